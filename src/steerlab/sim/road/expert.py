"""The expert driver: pure-pursuit steering with a human-like lag and noise, a speed profile that slows for
curves, and optional drift-and-recover episodes (paper 000 V-B) labelled frame by frame."""

from __future__ import annotations

import numpy as np

from steerlab.data.car import CH2_CAR, Car, VehicleState
from steerlab.sim.road.road import LANE_CENTER, Road

DRIFT_TARGET = 0.85   # m beside the lane centre the driver aims for while drifting out
DRIFT_TURN = 0.7      # m: the driver notices and starts to steer back
RECOVERED = 0.15      # m: back to normal driving


def pure_pursuit(road: Road, state: VehicleState, s: float, d_target: float, wheelbase: float) -> float:
    """Road-wheel angle (rad, positive left) that steers onto the line d = d_target."""
    lookahead = max(6.0, 0.9 * state.v)
    tx, ty, _ = road.pose(s + lookahead, d_target)
    alpha = np.arctan2(ty - state.y, tx - state.x) - state.psi
    alpha = (alpha + np.pi) % (2 * np.pi) - np.pi
    return float(np.arctan2(2 * wheelbase * np.sin(alpha), lookahead))


def cruise(road: Road, s: float, v: float, gain: float = 0.8) -> tuple[float, float]:
    """Throttle and brake that follow the road's speed profile (used by the expert and the closed loop)."""
    target = road.speed_limit[road.index(s + 2.0 * v)]
    acc = float(np.clip(gain * (target - v), -2.5, 1.5))
    return (acc / CH2_CAR.max_accel, 0.0) if acc >= 0 else (0.0, -acc / CH2_CAR.max_decel)


class ExpertDriver:
    def __init__(self, road: Road, seed: int, car: Car, dt: float, drift_every_s: float | None = 25.0,
                 lag_s: float = 0.2, noise_deg: float = 0.3):
        self.road, self.car, self.dt = road, car, dt
        self.rng = np.random.default_rng([seed, 4])
        self.drift_every = drift_every_s
        self.alpha = dt / (lag_s + dt)
        self.noise_deg = noise_deg
        self.delta = 0.0
        self.noise = 0.0
        self.episode, self.side = "normal", 0.0
        self.next_drift = self._draw_wait()

    def _draw_wait(self) -> float:
        return float(self.rng.exponential(self.drift_every)) + 5.0 if self.drift_every else np.inf

    def act(self, state: VehicleState, s: float, offset: float, t: float) -> tuple[float, float, float, str]:
        """(road-wheel angle, throttle, brake, episode label) for this tick. offset: from the lane centre."""
        if self.episode == "normal" and t >= self.next_drift:
            self.episode, self.side = "drift-out", float(self.rng.choice([-1.0, 1.0]))
        elif self.episode == "drift-out" and abs(offset) >= DRIFT_TURN:
            self.episode = "recover"
        elif self.episode == "recover" and abs(offset) <= RECOVERED:
            self.episode, self.next_drift = "normal", t + self._draw_wait()
        d_target = LANE_CENTER + (self.side * DRIFT_TARGET if self.episode == "drift-out" else 0.0)
        target = pure_pursuit(self.road, state, s, d_target, self.car.wheelbase)
        # Ornstein-Uhlenbeck noise on the hand wheel, then a first-order lag: a human, not a controller
        self.noise += -self.noise * self.dt / 1.0 + np.radians(self.noise_deg) * np.sqrt(self.dt) * self.rng.standard_normal()
        self.delta += self.alpha * (target + self.noise / self.car.steering_ratio - self.delta)
        throttle, brake = cruise(self.road, s, state.v)
        return self.delta, throttle, brake, self.episode
