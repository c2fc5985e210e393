"""Steering by the lane (`steerlab sim drive/bench --world track --steer-by lane`): a model with a lane head
(`train.lane_weight`) says where the car is in its lane, and a small controller steers from that instead of the
model's steering head; the model's learned throttle drives as usual.

The law is Stanley's (Thrun et al. 2006, "Stanley: the robot that won the DARPA Grand Challenge"), with the lane's
curvature as a feed-forward: road-wheel angle (rad, positive left) =

    atan(wheelbase x curvature) - K_HEADING x heading - atan(K_OFFSET x offset / (v + V0))

for the lateral offset of the rear axle (m, positive left), the heading to the lane (rad, positive turned left),
the lane's curvature (1/m, positive turning left) and the speed v (m/s), limited to the car's full lock. The first
term is the angle that follows the lane's curve (a kinematic car turns with curvature tan(angle) / wheelbase), the
second turns the wheels back along the lane, the third steers towards the centre line over a distance that grows
with the speed."""

from __future__ import annotations

import math

import numpy as np

from steerlab.data.car import CARS, Car
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls

# Stanley's own heading term: the wheels turned back by the whole heading error point the car along the lane.
K_HEADING = 1.0
# 1/s: near the lane centre the car closes its offset at about K_OFFSET x offset m/s. On the donkeycar's 0.26 m
# wheelbase the offset then settles like a spring of damping sqrt(v / (4 K_OFFSET wheelbase)): 0.7 at 1 m/s, 1.2 at
# 3 m/s, never oscillating much at racing speeds, and back within a car's length at the speeds it races.
K_OFFSET = 2.0
# m/s: keeps the offset term finite at standstill (the start line) and gentle below a walking pace.
V0 = 0.5


def lane_steering(offset: float, heading: float, curvature: float, speed: float, wheelbase: float) -> float:
    """The road-wheel angle (rad, positive left) of the lane controller (see the module's docstring), unlimited."""
    return (math.atan(wheelbase * curvature) - K_HEADING * heading
            - math.atan(K_OFFSET * offset / (max(speed, 0.0) + V0)))


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


def lane_pilot(part_pilot, checkpoint) -> LanePilot:
    """steerlab's donkeycar part on `checkpoint` (a `core.part.PartPilot` of `donkey_pilot`) steering by the lane its
    model sees; a model without a lane head is refused."""
    part = part_pilot.part
    if "lane" not in part.pilot.targets:
        raise SteerlabError(f"{checkpoint}: steer_by lane steers by the lane a model's lane head sees; model "
                            f"{part.pilot.name!r} has none: train it with train.lane_weight > 0 on tubs with lane "
                            "values (steerlab sim record --world track), or set steer_by to steering")
    return LanePilot(part_pilot, lambda: part.controls.lane)
