"""The path a recording's driver drove, and the steering that returns a car to it: one home for what replay
drives along (`sim/replay`) and what training labels views with (`train.views` of a small car's recording).

`human_path` integrates the recorded road-wheel angles and speeds through the kinematic bicycle (`car.Vehicle`).
`return_steering` is the label of a car off that path: the driver's own steering at the car's place on it plus
the correction of pure pursuit (pure pursuit of the path from the car's pose minus pure pursuit from the path's
own pose there), so that on the path it is exactly the driver's steering and off it the generalisation of paper
002's side-camera label (Eq. 3) to a car with a wheelbase, at the speed it drives."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from steerlab.data.car import Car, Vehicle, VehicleState


@dataclass
class HumanPath:
    """The path the human drove, one point per frame: time (s), pose (m, rad) and arc length (m), speed (m/s)
    and the human's road-wheel angle (rad, positive left)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    psi: np.ndarray
    s: np.ndarray
    v: np.ndarray
    wheel: np.ndarray

    def pose(self, s: float) -> tuple[float, float, float]:
        """(x, y, heading) of the path at arc length `s` (m), interpolated; before its start and beyond its end,
        straight on along its first or last heading (where a pursued point lies beyond the last frame)."""
        end = min(max(s, self.s[0]), self.s[-1])
        x, y, psi = (float(np.interp(end, self.s, a)) for a in (self.x, self.y, self.psi))
        return x + (s - end) * math.cos(psi), y + (s - end) * math.sin(psi), psi


def human_path(road_wheel: np.ndarray, speed: np.ndarray, times_s: np.ndarray, car: Car) -> HumanPath:
    """Integrate the recorded road-wheel angles (rad, positive left) and speeds through the vehicle model: frame
    i's steering and frame i+1's speed take the car from frame i to frame i+1."""
    vehicle = Vehicle(VehicleState(0.0, 0.0, 0.0, float(speed[0])), car)
    pose = [(0.0, 0.0, 0.0)]
    for i in range(1, len(times_s)):
        st = vehicle.advance(float(road_wheel[i - 1]), float(speed[i]), float(times_s[i] - times_s[i - 1]))
        pose.append((st.x, st.y, st.psi))
    x, y, psi = np.array(pose).T
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    return HumanPath(np.asarray(times_s, float), x, y, psi, s, np.asarray(speed, float), np.asarray(road_wheel, float))


REPLAY_PREVIEW_S = 0.9  # s of travel to the pursued point: replay's return to the path


def pursuit(path: HumanPath, s: float, x: float, y: float, psi: float, v: float, car: Car,
            preview_s: float = REPLAY_PREVIEW_S) -> float:
    """Pure pursuit of the path from a pose: the road-wheel angle towards the path point one lookahead
    (`preview_s` of travel at speed v, at least three wheelbases) ahead of arc length `s`."""
    lookahead = max(preview_s * v, 3.0 * car.wheelbase)
    tx, ty, _ = path.pose(s + lookahead)
    alpha = (math.atan2(ty - y, tx - x) - psi + math.pi) % (2 * math.pi) - math.pi
    return math.atan2(2 * car.wheelbase * math.sin(alpha), math.hypot(tx - x, ty - y))


def return_steering(path: HumanPath, j: int, s: float, x: float, y: float, psi: float, v: float, car: Car,
                    preview_s: float = REPLAY_PREVIEW_S) -> float:
    """The road-wheel angle (rad, positive left) that brings a car at pose (x, y, psi), speed v, arc length `s`
    along the path, back to it: the human's steering at frame j plus pure pursuit from the car's pose minus pure
    pursuit from the path's pose at `s` (see the module's docstring), pursuing the point `preview_s` ahead."""
    px, py, ppsi = path.pose(s)
    return (float(path.wheel[j]) + pursuit(path, s, x, y, psi, v, car, preview_s)
            - pursuit(path, s, px, py, ppsi, v, car, preview_s))


def moved_car(x: float, y: float, psi: float, shift_m: float, yaw_deg: float, ahead: float) -> tuple[float, float, float]:
    """The rear axle's pose (x, y, heading) of a car whose camera, `ahead` m in front of the axle, sits `shift_m` to
    the left of the camera of the car at (x, y, psi) and is turned `yaw_deg` to the left of it."""
    c, s = math.cos(psi), math.sin(psi)
    turned = psi + math.radians(yaw_deg)
    cam_x, cam_y = x + ahead * c - shift_m * s, y + ahead * s + shift_m * c
    return cam_x - ahead * math.cos(turned), cam_y - ahead * math.sin(turned), turned


def view_steering(path: HumanPath, shift_m: np.ndarray, yaw_deg: np.ndarray, car: Car,
                  preview_s: float = REPLAY_PREVIEW_S) -> np.ndarray:
    """The label of every frame of `path` seen from a camera moved `shift_m[j]` to the left and turned
    `yaw_deg[j]` to the left of the human's camera (which sits `car.body.camera_forward` ahead of the rear axle;
    at it for a car without a body): `return_steering` of the car whose camera that is (`moved_car`), at the arc
    length of its rear axle along the path's tangent. The inverse of replay's `relative_view`."""
    ahead = car.body.camera_forward if car.body is not None else 0.0
    out = np.empty(len(path.t))
    for j in range(len(path.t)):
        x, y, psi = float(path.x[j]), float(path.y[j]), float(path.psi[j])
        car_x, car_y, turned = moved_car(x, y, psi, float(shift_m[j]), float(yaw_deg[j]), ahead)
        along = float(path.s[j]) + (car_x - x) * math.cos(psi) + (car_y - y) * math.sin(psi)
        out[j] = return_steering(path, j, along, car_x, car_y, turned, float(path.v[j]), car, preview_s)
    return out
