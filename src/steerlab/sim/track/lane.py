"""Steering by the lane in the track world with the world's true lane: `LanePilot` drives a pilot's throttle and
steers by the lane controller (`control.lane_steering`, Stanley's law) on a lane it is given, as tests give it the
world's own (what a perfect lane head would see). A model's lane head drives through steerlab's donkeycar part
instead (`donkey.SteerlabPilot(steer_by="lane")`, `steerlab sim drive/bench --world track --steer-by lane`), the
same controller as on the car."""

from __future__ import annotations

import numpy as np

from steerlab.control import lane_steering
from steerlab.data.car import CARS, Car
from steerlab.data.recording import SteeringConvention
from steerlab.pilot import Controls


class LanePilot:
    """A pilot of `drive_loop` that steers by the lane: each step, `inner` (a pilot) answers for the frame, then
    `see()` gives the lane (offset, heading, curvature) the controller steers by, as road-wheel angles limited
    to `car`'s full lock; the throttle is `inner`'s. `see` reads what `inner` saw (a model's lane head) or, in
    tests, the world's true lane."""

    convention = SteeringConvention("road_wheel", "left")

    def __init__(self, inner, see, car: Car = CARS["donkey"]):
        self.inner, self.see, self.car = inner, see, car
        self.name, self.geometry, self.source = inner.name, inner.geometry, inner.source

    def step(self, frame: np.ndarray, speed: float | None = None) -> Controls:
        throttle = self.inner.step(frame, speed).throttle
        angle = lane_steering(*self.see(), speed or 0.0, self.car.wheelbase)
        return Controls(float(np.clip(angle, -self.car.full_lock, self.car.full_lock)), throttle=throttle)

    def reset(self) -> None:
        self.inner.reset()

    def close(self) -> None:
        close = getattr(self.inner, "close", None)
        if callable(close):
            close()
