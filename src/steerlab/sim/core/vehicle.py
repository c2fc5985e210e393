"""Kinematic bicycle model with simple longitudinal dynamics, stepped at the camera frame rate; the car's
dimensions and dynamics are its `data.car.Car`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from steerlab.data.car import CH2_CAR, Car


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
