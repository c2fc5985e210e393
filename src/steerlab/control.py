"""The one speed controller: the throttle that drives a measured speed to a target (the Udacity simulator
server's set speed, a donkeycar part's predicted speed), and the one throttle floor at rest."""

from __future__ import annotations

import numpy as np

AT_REST = 0.1  # m/s: slower than this, the car stands (or creeps) as far as a throttle floor is concerned


def shaped_throttle(throttle: float, scale: float, cap: float, floor: float = 0.0,
                    speed: float | None = None) -> float:
    """A part's throttle as it reaches the car: times `scale`, limited to +-`cap`, and at least `floor` (within the
    cap) while the car stands (`speed` below AT_REST; without a measured speed, no floor): a throttle learned from
    the image alone brakes at rest where the expert braked at speed, and would leave the car standing for good."""
    shaped = float(np.clip(scale * throttle, -cap, cap))
    if floor and speed is not None and speed < AT_REST:
        return max(shaped, min(floor, cap))
    return shaped


class SpeedControl:
    """PI control of the throttle: `cruise + kp e + ki sum(e)`, e = target - measured (m/s), the sum bounded to
    +-`limit` (no wind-up) and the throttle to [`low`, `high`] (a negative throttle brakes where the car takes
    one; a donkeycar's ESC treats it as brake or reverse, so its part keeps `low` at 0)."""

    def __init__(self, kp: float = 0.2, ki: float = 0.01, cruise: float = 0.0, low: float = -1.0,
                 high: float = 1.0, limit: float = 20.0):
        self.kp, self.ki, self.cruise, self.low, self.high, self.limit = kp, ki, cruise, low, high, limit
        self.reset()

    def reset(self) -> None:
        self.integral = 0.0

    def update(self, target: float, measured: float) -> float:
        error = target - measured
        self.integral = min(max(self.integral + error, -self.limit), self.limit)
        return float(np.clip(self.cruise + self.kp * error + self.ki * self.integral, self.low, self.high))
