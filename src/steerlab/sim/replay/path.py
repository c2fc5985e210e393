"""Replay's share of the human's path (`data.path`): the speed to replay at (recorded, given or estimated from
the frames: `replay_speed`), the recorded steering as road-wheel angles (`human_road_wheel`) and the stretches of a recording that are replayed (`replay_segments`)."""

from __future__ import annotations

import numpy as np

from steerlab.data.car import Car
from steerlab.data.geometry import Camera
from steerlab.data.recording import Recording
from steerlab.data.speed import estimate_speed
from steerlab.errors import DataError, SteerlabError

MIN_SECONDS = 3.0       # shorter segments are not replayed


def replay_speed(rec: Recording, cam: Camera, car: Car, speed: float | None) -> tuple[float | None, str]:
    """The speed to replay `rec` at (None: the recorded one) and where it comes from: given, recorded, or
    estimated from the frames (printed; refused when it is not a speed the car drives at)."""
    low, high = car.speeds
    if speed is not None:  # checked where it enters (options.SPEED), and here against the recording's car
        if speed > high:
            raise DataError(rec.source, f"the speed {speed:g} m/s (steerlab replay --speed) is beyond what this "
                                        f"recording's car drives ({low:g}-{high:g} m/s): km/h or mph where m/s is "
                                        "expected? give it in m/s")
        return speed, "given (--speed)"
    if rec.speed is not None:
        return None, "recorded"
    speed = estimate_speed(rec, cam)
    if not low <= speed <= high:
        raise DataError(rec.source, f"no speed recorded, and the one estimated from the frames, {speed:.2f} m/s, is "
                                    f"not one this car drives at ({low:g}-{high:g} m/s): the camera geometry may not "
                                    "fit (the camera's mount height, pitch, field of view); give the speed (M/S)")
    print(f"{rec.source} has no speed signal; estimated from the frames: {speed:.2f} m/s ({speed * 3.6:.0f} km/h); "
          "give the speed to override it")
    return speed, "estimated from the frames"


def human_road_wheel(rec: Recording, car: Car) -> np.ndarray:
    """The recorded steering as road-wheel angles (rad, positive left), which rebuild the driven path."""
    try:
        return rec.convention.to_road_wheel_left(rec.steering, car.steering_ratio)
    except SteerlabError as e:
        raise DataError(rec.source, f"{e}: it is needed to rebuild the driven path") from None


def replay_segments(rec: Recording, frames: np.ndarray | None = None) -> list[tuple[int, int]]:
    """The half-open frame ranges to replay: the recording's segments (or the runs of consecutive `frames`
    within them, e.g. a validation split) that last at least MIN_SECONDS."""
    idx = np.arange(len(rec)) if frames is None else np.asarray(frames)
    seg = rec.segment_ids()[idx]
    breaks = np.flatnonzero((np.diff(idx) != 1) | (np.diff(seg) != 0)) + 1
    times = rec.timestamps_ns / 1e9
    runs = [(int(r[0]), int(r[-1]) + 1) for r in np.split(idx, breaks) if len(r)]
    out = [(a, b) for a, b in runs if times[b - 1] - times[a] >= MIN_SECONDS]
    if not out:
        raise DataError(rec.source, f"too short to replay: no segment lasts {MIN_SECONDS:g} s ({len(idx)} frames): "
                                    "give a longer recording")
    return out
