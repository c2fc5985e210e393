"""Kinematic bicycle model with simple longitudinal dynamics, stepped at the camera frame rate."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from steerlab.data.geometry import STEERING_RATIO


@dataclass
class VehicleParams:
    wheelbase: float = 2.85          # m
    steering_ratio: float = STEERING_RATIO  # steering-wheel angle / road-wheel angle (CH2-like car)
    max_road_wheel: float = 0.55     # rad
    max_accel: float = 3.0           # m/s^2 at full throttle
    max_decel: float = 8.0           # m/s^2 at full brake
    drag: float = 0.0004             # 1/m, deceleration = drag * v^2


@dataclass
class VehicleState:
    x: float
    y: float
    psi: float
    v: float


class Vehicle:
    def __init__(self, state: VehicleState, params: VehicleParams | None = None):
        self.state, self.p = state, params or VehicleParams()

    def step(self, road_wheel: float, throttle: float, brake: float, dt: float) -> VehicleState:
        """Advance by dt with the road-wheel angle (rad, positive left), throttle and brake in [0, 1]."""
        p, v = self.p, self.state.v
        acc = np.clip(throttle, 0, 1) * p.max_accel - np.clip(brake, 0, 1) * p.max_decel - p.drag * v * v
        return self.advance(road_wheel, max(0.0, v + acc * dt), dt)

    def advance(self, road_wheel: float, v_new: float, dt: float) -> VehicleState:
        """Advance by dt with the road-wheel angle (rad, positive left, limited to the steering lock) while the
        speed changes linearly to `v_new` (m/s): the kinematic bicycle, integrated at the interval's midpoint."""
        p, s = self.p, self.state
        delta = float(np.clip(road_wheel, -p.max_road_wheel, p.max_road_wheel))
        v_mid = (s.v + v_new) / 2
        yaw_rate = v_mid * np.tan(delta) / p.wheelbase
        psi_mid = s.psi + yaw_rate * dt / 2
        self.state = VehicleState(s.x + v_mid * np.cos(psi_mid) * dt, s.y + v_mid * np.sin(psi_mid) * dt,
                                  s.psi + yaw_rate * dt, v_new)
        return self.state
