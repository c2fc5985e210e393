"""The track world's replay flavour: `steerlab replay --world track` on a recording of the donkey camera (donkeycar
tubs, the track world's), the generic replay (`replay/world.py`: a recording seen as a world) extended for small
cars.

- **The view**: the donkey camera is a fisheye. The recorded frame is warped by `fisheye.shift_view`: undistort,
  flat-floor homography, distort again, composed into one remap per offset and heading. The fisheye is the one
  the recording carries (the track world writes its camera into the tub), else the 160-degree Raspberry Pi
  camera's default (`fisheye.DONKEY_FISHEYE`); a calibration file replaces its K and D. The warp is from the
  car's camera (`Body.camera_forward` ahead of the rear axle) relative to the human's at that frame. A recording
  whose frames turn against its steering is refused unless read as mirrored (`sense.check_sense`).
- **The speed**: the recorded throttle through the small car's throttle model (`car.throttle_speeds`)
  gives the human's speed, which the replayed car follows; or the model's learned throttle drives the replayed
  car (`car.speed_after` every tick; the human's path keeps the recorded throttle's speeds); or a
  constant `--speed`.
- **The criterion**: the human is taken to have driven along the centre of a lane `lane_width` wide; a corner
  of the car's body (`Car.body`) outside it is an intervention, as an off-track event in the track world. No
  heading limit: a fisheye sees about 120 degrees across, and a body that turns far leaves the lane anyway.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Literal

import numpy as np

from steerlab.data.car import CARS, throttle_speeds
from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera, shift_view
from steerlab.data.geometry import CAMERAS
from steerlab.data.path import HumanPath
from steerlab.data.recording import Recording
from steerlab.data.sense import check_sense
from steerlab.data.views import lens_of
from steerlab.errors import DataError, SteerlabError
from steerlab.options import Options, SPEED, WORKERS, option
from steerlab.pilot import smoothing_option
from steerlab.sim.replay.world import MOUNT_HEIGHT, PITCH, Replay, ReplaySetup, ReplayWorld
from steerlab.sim.track.smallcar import SmallCar
from steerlab.sim.track.track import LANE_WIDTH
from steerlab.sim.track.world import lane_width_option


@dataclass(frozen=True)
class TrackReplayOptions(Options):
    """`steerlab replay --world track`'s options (the world of donkeycar tubs)."""

    speed: float | None = option(None, SPEED, help="a constant speed in m/s (default: "
                                 "from the throttle through the small car's throttle model)")
    throttle: Literal["recorded", "model"] = option("recorded", help="track: the throttle that sets the replayed "
                                                    "car's speed, the recorded one or the model's learned one")
    lane_width: float = lane_width_option("track: lane width in metres around the human's path (taken as the "
                                          "lane's centre); the car's body leaving it is an intervention")
    calibration: str | None = option(None, path="file", help="track: fisheye calibration of the recording's camera "
                                     "(JSON or YAML: image size 160x120, K, D; default: the one the recording "
                                     "carries, else a 160-degree Raspberry Pi camera)")
    mount_height: float | None = option(None, MOUNT_HEIGHT, help="camera height above the floor, m (default: the "
                                        "fisheye's, 0.15)")
    pitch: float | None = option(None, PITCH, help="camera pitch, degrees down (default: the fisheye's, 20)")
    workers: int = option(2, WORKERS, help="checkpoints replayed in parallel")
    smoothing: float | None = smoothing_option()

    @classmethod
    def related(cls, v):
        if v.speed is not None and v.throttle == "model":
            yield "speed", "left out when the throttle is the model's (it sets the speed)"

    def setup(self, rec: Recording) -> ReplaySetup:
        """The small cars' replay of `rec` (its fisheye, with these options' calibration and mount), or a one-line
        error for what cannot be replayed so."""
        car = CARS["donkey"]
        if rec.geometry != "donkey":
            raise SteerlabError(f"{rec.source}: the track replay is for the donkey camera (donkeycar tubs, the track "
                                f"world's recordings), not the {rec.geometry!r} camera: replay it with steerlab "
                                "replay --world road")
        if self.speed is None and rec.throttle is None:
            raise DataError(rec.source, "records no throttle to take the speed from: give one with steerlab replay "
                                        "--speed M/S")
        fisheye = lens_of(rec, self.calibration)
        check_sense(rec, fisheye.mirrored, "its replay")
        mount = {"mount_height": self.mount_height, "pitch_deg": self.pitch}
        fisheye = replace(fisheye, **{k: v for k, v in mount.items() if v is not None})
        source = ("given (--speed)" if self.speed is not None else
                  "the model's throttle" if self.throttle == "model" else "the recorded throttle")
        replay = TrackReplay(CAMERAS["donkey"], car, self.speed, fisheye=fisheye, lane_width=self.lane_width,
                             learned_throttle=self.throttle == "model")
        return ReplaySetup(replay, source, f"the car's body leaves the {self.lane_width:g} m lane around the human's "
                           "path", self.lane_width / 2 - car.body.width / 2,
                           "the body at the lane edge when parallel to the path (turned: sooner)",
                           {"fisheye": asdict(fisheye), "lane_width_m": self.lane_width})

    def check_pilot(self, pilot, checkpoint, rec: Recording) -> None:
        """A checkpoint that `--throttle model` cannot replay (it learned no throttle) is refused."""
        if self.throttle == "model" and "throttle" not in pilot.targets:
            raise SteerlabError(f"{checkpoint} predicts no throttle: steerlab replay --throttle model needs a model "
                                "that learned it (train.throttle_weight)")


class TrackReplayWorld(ReplayWorld):
    """One segment of a small-car recording as a world (see the module's docstring): the road replay's world
    with the fisheye's view, the body's lane criterion and, with `learned_throttle`, the pilot's throttle."""

    def __init__(self, replay: TrackReplay, rec: Recording, start: int, path: HumanPath):
        super().__init__(rec, start, path, replay.cam, replay.car)
        self.fisheye, self.lane_width = replay.fisheye, replay.lane_width
        self.learned_throttle = replay.learned_throttle
        self.smallcar = SmallCar(self.vehicle.state, replay.car)
        self.vehicle = self.smallcar.vehicle
        self.camera_forward = replay.car.body.camera_forward

    def overhang(self) -> float:
        """How far (m) the body's farthest corner lies outside the lane (negative while all are inside)."""
        nearest = self.project(*self.smallcar.corners())
        return -math.inf if nearest is None else float(np.max(np.abs(nearest[2]))) - self.lane_width / 2

    def leaves_lane(self, offset: float, heading: float, limit_m: float) -> bool:
        """Whether the body overhangs the lane edge by more than `limit_m`."""
        return self.overhang() > limit_m

    def warp(self, frame: np.ndarray, shift_m: float, yaw_deg: float) -> np.ndarray:
        return shift_view(frame, self.fisheye, shift_m, yaw_deg)

    def step(self, road_wheel: float, throttle: float | None = None) -> None:
        """One frame at the human's speed or, with `learned_throttle`, at the speed the pilot's throttle gives."""
        if not self.learned_throttle:
            return super().step(road_wheel, throttle)
        if throttle is None:
            raise SteerlabError("the pilot gives no throttle; replaying with the model's throttle needs a model "
                                "that learned it")
        self.smallcar.step(road_wheel, throttle, float(self.path.t[self.k + 1] - self.path.t[self.k]))
        self.k += 1


@dataclass(frozen=True)
class TrackReplay(Replay):
    """A small-car recording as worlds to drive: the `Replay` with its fisheye, the lane width and whether the
    model's throttle drives (`learned_throttle`). `speed` None: from the recorded throttle."""

    fisheye: FisheyeCamera = DONKEY_FISHEYE
    lane_width: float = LANE_WIDTH
    learned_throttle: bool = False

    @property
    def limit(self) -> float:
        return 0.0  # no part of the body may overhang the lane edge

    def speeds(self, rec: Recording, a: int, b: int) -> np.ndarray:
        if self.speed is not None:
            return np.full(b - a, self.speed)
        return throttle_speeds(rec.throttle[a:b], rec.timestamps_ns[a:b] / 1e9, self.car)

    def world(self, rec: Recording, start: int, path: HumanPath) -> TrackReplayWorld:
        return TrackReplayWorld(self, rec, start, path)
