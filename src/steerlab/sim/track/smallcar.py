"""A 1:10 RC car as donkeycar owners build them, stepped in the track world: its pose by the kinematic bicycle
(`data.car.Vehicle.advance`, about the rear axle) and its speed by the car's motor model (`data.car.speed_after`:
a brushed motor on an ESC); its numbers are `data.car.CARS["donkey"]` (wheelbase, full lock, `Motor`, `Body`),
and `SmallCar` adds where its camera and its body's corners are.
"""

from __future__ import annotations

import math

import numpy as np

from steerlab.data.car import CARS, Car, Vehicle, VehicleState, speed_after
from steerlab.errors import SteerlabError


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
