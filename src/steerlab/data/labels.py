"""Labels beyond the steering: those derived from the speed signal for the multi-task models of paper 002, and the
lane a model's auxiliary head learns (`LANE`)."""

from __future__ import annotations

import numpy as np

COMMANDS = ("decelerate", "maintain", "accelerate")

# The lane the car is in, as the track world records it (`Recording.extra`): the rear axle's lateral offset from the
# lane centre (m, positive left), the heading to the lane (rad, positive turned left) and the lane's curvature (1/m,
# positive turning left). A model learns each over a fixed scale, so that the three weigh alike in one MAE: in the
# 16 rooms tubs of configs/track_best.yaml (18,721 records) their standard deviations are 0.034 m, 0.044 rad and
# 0.41 /m (extremes 0.28 m, 0.34 rad, 1.25 /m), so 0.1 m, 0.1 rad and 1 /m give each a spread of about 0.4.
LANE = {"lateral_offset": 0.1, "heading_error": 0.1, "curvature": 1.0}


def lane_targets(labels: dict) -> np.ndarray | None:
    """The lane of every frame over its scale (N, 3), float32, in `LANE`'s order; None without lane values."""
    if not all(k in labels for k in LANE):
        return None
    return np.stack([np.asarray(labels[k], np.float64) / scale for k, scale in LANE.items()], 1).astype(np.float32)


def lane_values(scaled) -> tuple[float, float, float]:
    """A model's lane output (3,) back in metres, radians and 1/m: (offset, heading, curvature)."""
    return tuple(float(v) * scale for v, scale in zip(scaled, LANE.values()))


def speed_commands(speed: np.ndarray, timestamps_ns: np.ndarray, interval_s: float = 1.0,
                   threshold: float = 0.25) -> np.ndarray:
    """Paper 002 IV-B2: acceleration = (speed at the end - speed at the start of a 1 s interval) / interval;
    above +0.25 m/s^2 'accelerate' (2), below -0.25 'decelerate' (0), else 'maintain' (1).

    The interval starts at each frame and ends at the first frame at least `interval_s` later; the last
    frames, whose interval would run past the recording, use the shorter interval up to the last frame
    (the very last frame is "maintain")."""
    t = (np.asarray(timestamps_ns) - timestamps_ns[0]) / 1e9
    v = np.asarray(speed, float)
    end = np.minimum(np.searchsorted(t, t + interval_s - 1e-9), len(t) - 1)
    span = t[end] - t
    acc = np.where(span > 0, (v[end] - v) / np.where(span > 0, span, 1), 0.0)
    return np.where(acc > threshold, 2, np.where(acc < -threshold, 0, 1)).astype(np.int64)


def speed_targets(speed: np.ndarray, timestamps_ns: np.ndarray, segment: np.ndarray) -> dict[str, np.ndarray]:
    """Per frame, within its segment: "speed", the next frame's speed (the last frame of a segment keeps its
    own), and "command", the speed command of paper 002."""
    speed = np.asarray(speed, float)
    next_speed, command = speed.copy(), np.empty(len(speed), np.int64)
    bounds = np.flatnonzero(np.diff(segment)) + 1
    for a, b in zip(np.r_[0, bounds], np.r_[bounds, len(speed)]):
        next_speed[a: b - 1] = speed[a + 1: b]
        command[a:b] = speed_commands(speed[a:b], timestamps_ns[a:b])
    return {"speed": next_speed, "command": command}
