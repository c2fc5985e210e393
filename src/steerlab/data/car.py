"""The car a camera geometry belongs to: one home for its wheelbase, steering ratio, full lock, side cameras,
lane limit, plausible speeds and longitudinal dynamics. Readers give a recording its camera geometry, and
everything that needs the car (training's recovery labels, the synthetic world, replay, the simulator server,
the donkeycar part) takes it from `CARS` by that name."""

from __future__ import annotations

import math
from dataclasses import dataclass

from steerlab.errors import SteerlabError


@dataclass(frozen=True)
class Car:
    """wheelbase (m); steering_ratio: hand-wheel / road-wheel angle (for steering-wheel conventions);
    full_lock_deg: the largest road-wheel angle; side_camera_offset_m: left/right cameras this far beside the
    centre one (None: none); lane_limit_m: the lateral offset from the driven path that counts as leaving the
    lane (NVIDIA's 1 m for a car in a 3.7 m lane; for a donkeycar about the same share of its lane); speeds: the
    m/s it plausibly drives at (an estimate of its speed must fall in them); max_accel, max_decel (m/s^2 at full
    throttle and full brake) and drag (1/m: deceleration drag * v^2) for the synthetic world's dynamics."""

    wheelbase: float
    steering_ratio: float
    full_lock_deg: float
    side_camera_offset_m: float | None
    lane_limit_m: float
    speeds: tuple[float, float]
    max_accel: float = 3.0
    max_decel: float = 8.0
    drag: float = 0.0004

    @property
    def full_lock(self) -> float:
        """The largest road-wheel angle, radians."""
        return math.radians(self.full_lock_deg)


# CH2's car, a Lincoln MKZ (steering ratio 14.8), is also the synthetic world's; its left and right cameras sit
# 20 inches beside the centre one, as in paper 002 V-D. A donkeycar: a 1:10 RC car with a 25-degree servo lock.
CH2_CAR = Car(2.85, 14.8, math.degrees(0.55), 0.508, 1.0, (1.0, 45.0))
CARS = {"sim": CH2_CAR, "ch2": CH2_CAR, "donkey": Car(0.26, 1.0, 25.0, None, 0.3, (0.3, 8.0))}


def car_of(geometry: str | None) -> Car:
    """The car of a camera geometry (the synthetic world's for one steerlab does not know)."""
    if geometry is not None and geometry not in CARS:
        raise SteerlabError(f"unknown camera geometry {geometry!r}; choose one of {', '.join(CARS)}")
    return CARS[geometry or "sim"]
