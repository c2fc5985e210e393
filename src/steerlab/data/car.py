"""The car a camera geometry belongs to: one home for its wheelbase, steering ratio, full lock, side cameras,
lane limit, plausible speeds and longitudinal dynamics, and for a small car its throttle model and body. Readers
give a recording its camera geometry, and everything that needs the car (training's recovery labels, the
synthetic worlds, replay, the simulator server, the donkeycar part) takes it from `CARS` by that name."""

from __future__ import annotations

import math
from dataclasses import dataclass

from steerlab.errors import SteerlabError


@dataclass(frozen=True)
class Motor:
    """How a small car's speed answers its throttle u in [-1, 1] (`sim/track/smallcar.py`, a brushed motor on an ESC):
    for u >= 0 the speed approaches u x `top_speed` (m/s) with `time_constant` (s) under power, or with
    `coast_time_constant` (s) while it is faster than that (the ESC's drag brake); `rolling` (m/s^2) is the
    rolling resistance while it moves. Braking (u < 0) and air drag are the car's `max_decel` and `drag`."""

    top_speed: float
    time_constant: float
    coast_time_constant: float
    rolling: float


@dataclass(frozen=True)
class Body:
    """A small car's outline and camera, in metres along the car from the rear axle: the body is `length` long
    and `width` wide and reaches `rear_overhang` behind the axle; the camera sits `camera_forward` ahead of it.
    Whether the body is inside the lane decides an off-track event in the track world."""

    length: float
    width: float
    rear_overhang: float
    camera_forward: float


@dataclass(frozen=True)
class Car:
    """wheelbase (m); steering_ratio: hand-wheel / road-wheel angle (for steering-wheel conventions);
    full_lock_deg: the largest road-wheel angle; side_camera_offset_m: left/right cameras this far beside the
    centre one (None: none); lane_limit_m: the lateral offset from the driven path that counts as leaving the
    lane (NVIDIA's 1 m for a car in a 3.7 m lane; for a donkeycar about the same share of its lane); speeds: the
    m/s it plausibly drives at (an estimate of its speed must fall in them); max_accel, max_decel (m/s^2 at full
    throttle and full brake, or throttle -1 of a small car) and drag (1/m: deceleration drag * v^2) for the
    synthetic worlds' dynamics; motor and body: a small car's throttle model and outline (the track world's
    car; None for the road world's)."""

    wheelbase: float
    steering_ratio: float
    full_lock_deg: float
    side_camera_offset_m: float | None
    lane_limit_m: float
    speeds: tuple[float, float]
    max_accel: float = 3.0
    max_decel: float = 8.0
    drag: float = 0.0004
    motor: Motor | None = None
    body: Body | None = None

    @property
    def full_lock(self) -> float:
        """The largest road-wheel angle, radians."""
        return math.radians(self.full_lock_deg)


# CH2's car, a Lincoln MKZ (steering ratio 14.8), is also the road world's; its left and right cameras sit
# 20 inches beside the centre one, as in paper 002 V-D. A donkeycar: a 1:10 RC car with a 25-degree servo lock,
# 0.26 m wheelbase, a 0.42 x 0.20 m body and its camera 0.22 m ahead of the rear axle; throttle 1 approaches
# 5 m/s with a 0.3 s lag (1.5 s when slowing to a lower throttle), braking at 6 m/s^2 at throttle -1.
CH2_CAR = Car(2.85, 14.8, math.degrees(0.55), 0.508, 1.0, (1.0, 45.0))
DONKEY_CAR = Car(0.26, 1.0, 25.0, None, 0.3, (0.3, 8.0), max_decel=6.0, drag=0.01,
                 motor=Motor(top_speed=5.0, time_constant=0.3, coast_time_constant=1.5, rolling=0.15),
                 body=Body(length=0.42, width=0.20, rear_overhang=0.07, camera_forward=0.22))
CARS = {"sim": CH2_CAR, "ch2": CH2_CAR, "donkey": DONKEY_CAR}


def car_of(geometry: str | None) -> Car:
    """The car of a camera geometry (the road world's for one steerlab does not know)."""
    if geometry is not None and geometry not in CARS:
        raise SteerlabError(f"unknown camera geometry {geometry!r}; choose one of {', '.join(CARS)}")
    return CARS[geometry or "sim"]
