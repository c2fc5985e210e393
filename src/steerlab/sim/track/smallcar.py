"""A 1:10 RC car as donkeycar owners build them: a kinematic bicycle for its pose and a first-order throttle
model for its speed. Its numbers are `data.car.CARS["donkey"]` (wheelbase, full lock, `Motor`, `Body`).

The pose follows `Vehicle.advance` (the kinematic bicycle about the rear axle, integrated at the interval's
midpoint). The speed answers the throttle as a brushed motor on an ESC does: with throttle u >= 0 it approaches
u x `top_speed` with time constant `time_constant` (the motor's back EMF limits speed, so its lag is first
order), or, when it is faster than that, slows towards it more gently (`coast_time_constant`: the ESC's drag
brake), less a little rolling resistance and air drag; a negative throttle adds braking at -u x the car's
`max_decel`. The car never reverses (an ESC needs a second pull for that).
"""

from __future__ import annotations

import math

import numpy as np

from steerlab.data.car import CARS, Car
from steerlab.errors import SteerlabError
from steerlab.sim.core.vehicle import Vehicle, VehicleState


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


class SmallCar:
    """The car's state (x, y at the rear axle, heading psi, speed v) stepped by servo-free controls: the
    road-wheel angle (rad, positive left, limited to full lock) and the throttle in [-1, 1]."""

    def __init__(self, state: VehicleState, car: Car = CARS["donkey"]):
        if car.motor is None or car.body is None:
            raise SteerlabError("a small car needs a throttle model and a body (data.car.Motor, Body); "
                                "CARS['donkey'] has both")
        self.car = car
        self.vehicle = Vehicle(state, car)

    @property
    def state(self) -> VehicleState:
        return self.vehicle.state

    @state.setter
    def state(self, value: VehicleState) -> None:
        self.vehicle.state = value

    def step(self, road_wheel: float, throttle: float, dt: float) -> VehicleState:
        return self.vehicle.advance(road_wheel, speed_after(self.state.v, throttle, dt, self.car), dt)

    def camera_pose(self, lateral: float = 0.0) -> tuple[float, float, float]:
        """World (x, y, heading) of the camera; `lateral`: of a camera that far to the left of it."""
        s, forward = self.state, self.car.body.camera_forward
        c, sn = math.cos(s.psi), math.sin(s.psi)
        return s.x + forward * c - lateral * sn, s.y + forward * sn + lateral * c, s.psi

    def corners(self) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of the body's four corners (rear left, rear right, front right, front left)."""
        s, b = self.state, self.car.body
        f = np.array([-b.rear_overhang, -b.rear_overhang, b.length - b.rear_overhang, b.length - b.rear_overhang])
        left = np.array([1, -1, -1, 1]) * b.width / 2
        c, sn = math.cos(s.psi), math.sin(s.psi)
        return s.x + f * c - left * sn, s.y + f * sn + left * c
