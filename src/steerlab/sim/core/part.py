"""A donkeycar part as the pilot of steerlab's closed loop.

donkeycar's vehicle loop drives with parts: each loop a pilot part's `run(img_arr)` gets the camera frame (H x W x
3 uint8 RGB) and returns `(angle, throttle)`, the servo command in [-1, 1] (positive right) and the throttle in
[-1, 1]. `PartPilot` puts any object with that interface where `core.driving.drive_loop` expects a pilot: steerlab's
own part (`donkey.SteerlabPilot`, made for the track world's car by `donkey_pilot`) or another (donkeycar's
KerasLinear, say, behind a part of the same interface). The world renders BGR frames, as OpenCV does; the part
gets them as RGB, as donkeycar's cameras deliver them. Its angle is steering in the convention normalized,
positive right, with the car's full lock: angle 1 turns the car's road wheels to full lock to the right.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from steerlab.control import Throttle
from steerlab.data.car import CARS, Car
from steerlab.data.recording import SteeringConvention
from steerlab.donkey import SteerlabPilot
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls, Pilot


class PartPilot:
    """`part`: anything with `run(img_arr) -> (angle, throttle)`, or `run(img_arr, speed)` with `with_speed`
    (the measured speed in m/s as the part's second input, as donkeycar's `enc/speed`); `full_lock_deg`: the
    road-wheel angle of the driven car at angle +-1. The part's throttle reaches the car shaped by `throttle`
    (`control.Throttle.shaped`, as steerlab's own part shapes a learned throttle on the car: times its scale, then
    limited to +-its cap, at least its floor at rest; donkeycar's AI_THROTTLE_MULT scales after its cap instead);
    `throttle=None` (the default) for a part that shapes its own (steerlab's, `donkey_pilot`), whose throttle passes
    as it is, within the ESC's [-1, 1]. `reset()` calls the part's own `reset` if it has one (after an off-track
    event the pilot forgets its past), `close()` its `close` (a part behind a pipe), `on_track(drive)` its
    `on_track` (told the track before a suite's drive). `name`, `geometry` (the camera
    the part expects; "donkey" for donkeycar's 160x120 camera) and `source` (what messages name) describe it to
    the loop."""

    def __init__(self, part, full_lock_deg: float, name: str | None = None, geometry: str | None = "donkey",
                 source: str | None = None, with_speed: bool = False, throttle: Throttle | None = None):
        if not callable(getattr(part, "run", None)):
            raise SteerlabError(f"{type(part).__name__} is not a donkeycar part: it has no run(img_arr); "
                                "give a part that has one")
        if not 0 < full_lock_deg < 90:
            raise SteerlabError(f"full_lock_deg must lie in (0, 90) degrees, got {full_lock_deg}")
        if throttle is not None and not isinstance(throttle, Throttle):
            raise SteerlabError(f"throttle must be a steerlab.control.Throttle or None, got {throttle!r}")
        self.part, self.with_speed, self.throttle = part, with_speed, throttle
        self.convention = SteeringConvention("normalized", "right", math.radians(full_lock_deg))
        self.name = name or type(part).__name__
        self.geometry = geometry
        self.source = source or self.name

    def step(self, frame: np.ndarray, speed: float | None = None) -> Controls:
        """One BGR frame (and the car's speed) -> the part's angle as steering, limited to [-1, 1] as the servo
        limits it, and its throttle shaped by `throttle` (or as it is, within [-1, 1])."""
        rgb = np.ascontiguousarray(frame[..., ::-1])
        out = self.part.run(rgb, speed) if self.with_speed else self.part.run(rgb)
        try:
            angle, throttle = (float(v) for v in out)
        except (TypeError, ValueError):
            raise SteerlabError(f"{self.source}: run() must return (angle, throttle), two numbers; got {out!r}") \
                from None
        if not (math.isfinite(angle) and math.isfinite(throttle)):
            raise SteerlabError(f"{self.source}: run() returned ({angle}, {throttle}); finite numbers are expected")
        throttle = (float(np.clip(throttle, -1.0, 1.0)) if self.throttle is None
                    else self.throttle.shaped(throttle, speed))
        return Controls(float(np.clip(angle, -1.0, 1.0)), throttle=throttle)

    def reset(self) -> None:
        reset = getattr(self.part, "reset", None)
        if callable(reset):
            reset()

    def close(self) -> None:
        close = getattr(self.part, "close", None)
        if callable(close):
            close()

    def on_track(self, drive) -> None:
        """Before a suite's drive: the part's own `on_track(drive)` if it has one (`drive`: the world's drive
        options), for a part its owner sets up for each track, as a line follower for its tape's colour."""
        on_track = getattr(self.part, "on_track", None)
        if callable(on_track):
            on_track(drive)


def learns_throttle(checkpoint: str | Path) -> bool:
    """Whether the model of `checkpoint` learned the throttle (the donkeycar part drives with it)."""
    return "throttle" in Pilot(checkpoint).targets


def donkey_pilot(checkpoint: str | Path, throttle: float, smoothing: float | None = None, max_throttle: float = 0.5,
                 car: Car = CARS["donkey"], steering_step: float | None = None,
                 throttle_scale: float = 1.0, throttle_floor: float = 0.0, steer_by: str = "steering",
                 throttle_by: str = "model", lat_acc: float | None = None) -> PartPilot:
    """steerlab's donkeycar part on `checkpoint` driving `car`, made as on the car (`donkey.SteerlabPilot`, which
    shapes its own throttle: the sim and the car drive alike): its full lock turns the angles of models trained
    on angles into servo commands, `throttle` is the part's constant throttle for models that predict none (a
    model that learned the throttle drives with its own times `throttle_scale`, capped at `max_throttle`, at least
    `throttle_floor` at rest; a scale or a floor on a model of a constant throttle is refused, as on the car),
    `smoothing` and `steering_step` shape its steering as the Pilot's do (`steer_by` lane: it steers by the lane
    its model's lane head sees instead; `throttle_by` lane: it drives at that lane's pace, `lat_acc`), the measured
    speed is its second input (speed models and the lane controller need it), and it forgets the past when the
    world puts the car back, not after a gap in wall-clock time (a simulation keeps no wall-clock pace)."""
    # the learned throttle of a model that learned one, or the lane's pace: no constant throttle
    constant = None if throttle_by == "lane" or learns_throttle(checkpoint) else throttle
    part = SteerlabPilot(checkpoint, constant, full_lock_deg=car.full_lock_deg, smoothing=smoothing,
                         steering_step=steering_step, max_throttle=max_throttle, reset_after_s=None,
                         throttle_scale=throttle_scale, throttle_floor=throttle_floor, steer_by=steer_by,
                         throttle_by=throttle_by, lat_acc=lat_acc)
    return PartPilot(part, car.full_lock_deg, name=part.pilot.name, geometry=part.pilot.geometry,
                     source=str(checkpoint), with_speed=True, throttle=None)
