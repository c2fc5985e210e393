"""A 1:10 RC car as donkeycar owners build them: a kinematic bicycle for its pose and a first-order throttle
model for its speed.

The pose follows `Vehicle.advance` (the kinematic bicycle about the rear axle, integrated at the interval's
midpoint) with a 0.26 m wheelbase and 25 degrees of full lock. The speed answers the throttle as a brushed
motor on an ESC does: with throttle u >= 0 it approaches u x `top_speed` with time constant `time_constant`
(the motor's back EMF limits speed, so its lag is first order), or, when it is faster than that, slows towards
it more gently (`coast_time_constant`: the ESC's drag brake), less a little rolling resistance and air drag; a
negative throttle adds braking at -u x `brake_decel`. The car never reverses (an ESC needs a second pull for
that).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from steerlab.data.car import CARS
from steerlab.sim.vehicle import Vehicle, VehicleState


@dataclass(frozen=True)
class SmallCarParams:
    wheelbase: float = 0.26       # m
    full_lock_deg: float = 25.0   # road-wheel angle of servo command +-1
    top_speed: float = 5.0        # m/s that throttle 1 approaches (less drag)
    time_constant: float = 0.3    # s, the speed's first-order lag under power
    coast_time_constant: float = 1.5  # s, the same while the throttle asks for less than the speed (ESC drag brake)
    brake_decel: float = 6.0      # m/s^2 at throttle -1
    rolling: float = 0.15         # m/s^2, rolling resistance while moving
    drag: float = 0.01            # 1/m, air drag deceleration = drag v^2
    length: float = 0.42          # m, body
    width: float = 0.20           # m, body
    rear_overhang: float = 0.07   # m, body behind the rear axle
    camera_forward: float = 0.22  # m, the camera ahead of the rear axle

    @property
    def full_lock(self) -> float:
        """Full lock in radians."""
        return math.radians(self.full_lock_deg)


def speed_after(v: float, throttle: float, dt: float, p: SmallCarParams) -> float:
    """Speed (m/s) after dt seconds at a throttle in [-1, 1], starting at v."""
    u = float(np.clip(throttle, -1.0, 1.0))
    target = max(u, 0.0) * p.top_speed
    tau = p.time_constant if target >= v else p.coast_time_constant
    v_new = target + (v - target) * math.exp(-dt / tau)
    if u < 0:
        v_new += u * p.brake_decel * dt
    if v > 0:
        v_new -= (p.rolling + p.drag * v * v) * dt
    return max(0.0, v_new)


def throttle_for(v: float, accel: float, p: SmallCarParams) -> float:
    """The throttle in [-1, 1] that gives acceleration `accel` (m/s^2) at speed v: the inverse of
    `speed_after` over a short step (the feed-forward of a speed controller)."""
    want = accel + (p.rolling + p.drag * v * v if v > 0 else 0.0)
    if want >= 0:
        u = (v + p.time_constant * want) / p.top_speed
    elif want >= -v / p.coast_time_constant:
        u = (v + p.coast_time_constant * want) / p.top_speed
    else:
        u = (want + v / p.coast_time_constant) / p.brake_decel
    return float(np.clip(u, -1.0, 1.0))


class SmallCar:
    """The car's state (x, y at the rear axle, heading psi, speed v) stepped by servo-free controls: the
    road-wheel angle (rad, positive left, limited to full lock) and the throttle in [-1, 1]."""

    def __init__(self, state: VehicleState, params: SmallCarParams | None = None):
        self.p = params or SmallCarParams()
        self.vehicle = Vehicle(state, replace(CARS["donkey"], wheelbase=self.p.wheelbase,
                                              full_lock_deg=self.p.full_lock_deg))

    @property
    def state(self) -> VehicleState:
        return self.vehicle.state

    @state.setter
    def state(self, value: VehicleState) -> None:
        self.vehicle.state = value

    def step(self, road_wheel: float, throttle: float, dt: float) -> VehicleState:
        return self.vehicle.advance(road_wheel, speed_after(self.state.v, throttle, dt, self.p), dt)

    def camera_pose(self) -> tuple[float, float, float]:
        """World (x, y, heading) of the camera."""
        s = self.state
        return (s.x + self.p.camera_forward * math.cos(s.psi), s.y + self.p.camera_forward * math.sin(s.psi), s.psi)

    def corners(self) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of the body's four corners (rear left, rear right, front right, front left)."""
        s, p = self.state, self.p
        f = np.array([-p.rear_overhang, -p.rear_overhang, p.length - p.rear_overhang, p.length - p.rear_overhang])
        left = np.array([1, -1, -1, 1]) * p.width / 2
        c, sn = math.cos(s.psi), math.sin(s.psi)
        return s.x + f * c - left * sn, s.y + f * sn + left * c
