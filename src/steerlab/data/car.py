"""The car a camera geometry belongs to: one home for its wheelbase, steering ratio, full lock, side cameras,
lane limit, plausible speeds and longitudinal dynamics, and for a small car its throttle model and body. Readers
give a recording its camera geometry, and everything that needs the car (training's recovery labels, the
synthetic worlds, replay, the simulator server, the donkeycar part) takes it from `CARS` by that name."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.options import SPEED, Range, value_of

FULL_LOCK_DEG = (5.0, 60.0)  # a road wheel's largest angle: no car steers less or more (0.44: radians)


@dataclass(frozen=True)
class Motor:
    """How a small car's speed answers its throttle u in [-1, 1] (a brushed motor on an ESC: `speed_after` below):
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

    def __post_init__(self):  # each field of its kind and plausible, named: a car is given in the Python API too
        metres = Range(0, 10, lo_open=True, unit="m")
        value_of(float, self.wheelbase, "car.wheelbase", metres)
        value_of(float, self.steering_ratio, "car.steering_ratio", Range(0, 50, lo_open=True))
        value_of(float, self.full_lock_deg, "car.full_lock_deg", Range(*FULL_LOCK_DEG),
                 expected=f"a road-wheel angle in [{FULL_LOCK_DEG[0]:g}, {FULL_LOCK_DEG[1]:g}] degrees (not radians)")
        if self.side_camera_offset_m is not None:
            value_of(float, self.side_camera_offset_m, "car.side_camera_offset_m", metres)
        value_of(float, self.lane_limit_m, "car.lane_limit_m", metres)
        value_of(tuple[float, float], self.speeds, "car.speeds")
        if not 0 <= self.speeds[0] < self.speeds[1] <= SPEED.hi:
            raise SteerlabError(f"car.speeds must be (lowest, highest) m/s with 0 <= lowest < highest <= "
                                f"{SPEED.hi:g}, got {self.speeds}")
        for name in ("max_accel", "max_decel"):
            value_of(float, getattr(self, name), f"car.{name}", Range(0, 100, lo_open=True, unit="m/s^2"))
        value_of(float, self.drag, "car.drag", Range(0, 1, unit="1/m"))

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


# --- the motor: how a small car's speed answers its throttle ------------------------------------------------------

def speed_after(v: float, throttle: float, dt: float, car: Car) -> float:
    """Speed (m/s) after dt seconds at a throttle in [-1, 1], starting at v."""
    m = car.motor
    u = float(np.clip(throttle, -1.0, 1.0))
    target = max(u, 0.0) * m.top_speed
    tau = m.time_constant if target >= v else m.coast_time_constant
    v_new = target + (v - target) * math.exp(-dt / tau)
    if u < 0:
        v_new += u * car.max_decel * dt
    if v > 0:
        v_new -= (m.rolling + car.drag * v * v) * dt
    return max(0.0, v_new)


def steady_speed(throttle: float, dt: float, car: Car) -> float:
    """The speed (m/s) that a throttle holds in steps of dt seconds (`speed_after(v, throttle, dt) == v`): where
    the motor's pull towards u x `top_speed` balances rolling resistance and drag; 0 for u <= 0."""
    m = car.motor
    target = max(float(np.clip(throttle, -1.0, 1.0)), 0.0) * m.top_speed
    # target + (v - target) e - (rolling + drag v^2) dt = v, with e = exp(-dt / tau): a quadratic in v
    pull = 1 - math.exp(-dt / m.time_constant)
    a, b, c = car.drag * dt, pull, m.rolling * dt - pull * target
    if c >= 0:
        return 0.0
    return (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a) if a > 0 else -c / b


def throttle_speeds(throttle: np.ndarray, times_s: np.ndarray, car: Car) -> np.ndarray:
    """The speed (m/s) at every frame of a drive with the recorded throttle: frame i's throttle for the time to
    frame i + 1 (`speed_after`), from the speed the first frame's throttle holds (a recording starts mid-drive
    as often as at standstill)."""
    dt = np.diff(np.asarray(times_s, float))
    v = [steady_speed(float(throttle[0]), float(np.median(dt)) if len(dt) else 0.05, car)]
    for u, step in zip(throttle[:-1], dt):
        v.append(speed_after(v[-1], float(u), float(step), car))
    return np.array(v)


def throttle_for(v: float, accel: float, car: Car) -> float:
    """The throttle in [-1, 1] that gives acceleration `accel` (m/s^2) at speed v: the inverse of
    `speed_after` over a short step (the feed-forward of a speed controller)."""
    m = car.motor
    want = accel + (m.rolling + car.drag * v * v if v > 0 else 0.0)
    if want >= 0:
        u = (v + m.time_constant * want) / m.top_speed
    elif want >= -v / m.coast_time_constant:
        u = (v + m.coast_time_constant * want) / m.top_speed
    else:
        u = (want + v / m.coast_time_constant) / car.max_decel
    return float(np.clip(u, -1.0, 1.0))


# --- the kinematic bicycle with simple longitudinal dynamics, stepped at the camera frame rate -------------------

@dataclass
class VehicleState:
    x: float
    y: float
    psi: float
    v: float


class Vehicle:
    def __init__(self, state: VehicleState, car: Car = CH2_CAR):
        self.state, self.car = state, car

    def step(self, road_wheel: float, throttle: float, brake: float, dt: float) -> VehicleState:
        """Advance by dt with the road-wheel angle (rad, positive left), throttle and brake in [0, 1]."""
        c, v = self.car, self.state.v
        acc = np.clip(throttle, 0, 1) * c.max_accel - np.clip(brake, 0, 1) * c.max_decel - c.drag * v * v
        return self.advance(road_wheel, max(0.0, v + acc * dt), dt)

    def advance(self, road_wheel: float, v_new: float, dt: float) -> VehicleState:
        """Advance by dt with the road-wheel angle (rad, positive left, limited to the steering lock) while the
        speed changes linearly to `v_new` (m/s): the kinematic bicycle, integrated at the interval's midpoint."""
        c, s = self.car, self.state
        delta = float(np.clip(road_wheel, -c.full_lock, c.full_lock))
        v_mid = (s.v + v_new) / 2
        yaw_rate = v_mid * np.tan(delta) / c.wheelbase
        psi_mid = s.psi + yaw_rate * dt / 2
        self.state = VehicleState(s.x + v_mid * np.cos(psi_mid) * dt, s.y + v_mid * np.sin(psi_mid) * dt,
                                  s.psi + yaw_rate * dt, v_new)
        return self.state
