"""The racing expert of the track world: pure pursuit of the lane centre, the track's speed profile through the
car's throttle model, a human's lag and noise, and drift-and-recover episodes labelled tick by tick.

Steering: pure pursuit of a point on the lane centre `lookahead` metres ahead along the track (0.3 s of travel,
at least 0.3 m), from the rear axle: the road-wheel angle whose circle passes through it. Speed: the track's
speed profile (lateral acceleration within `lat_acc`, braking within `decel`, the car's top speed) read one
throttle time constant ahead, times a pace that wanders slowly around 0.9 (a human does not drive the limit),
reached by a feed-forward throttle (`car.throttle_for`) with a proportional-integral correction. The hand
on the controls lags by `lag_s` (first order) and wanders (Ornstein-Uhlenbeck noise on the road wheel).

Drift episodes, as the road expert has them (`road/expert.py`): about every `drift_every_s` seconds the driver lets
the car drift towards one lane line (`drift-out`, aiming DRIFT_TARGET of the room the body has beside the lane
centre), notices at DRIFT_TURN of it and steers back (`recover`), and drives `normal` again within RECOVERED;
the room is half the lane width less half the car's width, so the body stays in the lane while drifting.
"""

from __future__ import annotations

import math

import numpy as np

from steerlab.control import LAT_ACC  # m/s^2, a small car's lateral acceleration limit on a hall floor
from steerlab.data.car import Car, VehicleState, throttle_for
from steerlab.sim.track.track import Track

DRIFT_TARGET = 0.6   # of the room beside the lane centre: where a drift aims
DRIFT_TURN = 0.45    # the driver notices and steers back
RECOVERED = 0.15     # normal driving again
DECEL = 3.0          # m/s^2, the braking the speed profile plans with (the car brakes up to 6)
PREVIEW_S = 0.3      # s of travel: the pursuit point's distance and how far ahead the speed profile is read


def pursuit(track: Track, state: VehicleState, s: float, d_target: float, wheelbase: float) -> float:
    """Road-wheel angle (rad, positive left) that steers the rear axle onto the line d = d_target: pure pursuit
    of the point `PREVIEW_S` of travel (at least 0.3 m) ahead along the track."""
    lookahead = max(0.3, PREVIEW_S * state.v)
    tx, ty, _ = track.pose(s + lookahead, d_target)
    dx, dy = float(tx) - state.x, float(ty) - state.y
    alpha = (math.atan2(dy, dx) - state.psi + math.pi) % (2 * math.pi) - math.pi
    return math.atan2(2 * wheelbase * math.sin(alpha), math.hypot(dx, dy))


def target_speed(track: Track, s: float, v: float, car: Car, lat_acc: float = LAT_ACC,
                 decel: float = DECEL) -> float:
    """The speed profile's value (m/s) one throttle time constant ahead: where the car will be when a change
    of throttle has taken effect."""
    profile = track.speed_profile(car.motor.top_speed, lat_acc, decel)
    return float(profile[track.index(s + v * car.motor.time_constant)])


def expert_controls(track: Track, state: VehicleState, s: float, car: Car) -> tuple[float, float]:
    """The expert's (road-wheel angle, throttle) in this state without lag, noise or memory: pure pursuit of the
    lane centre and the feed-forward throttle to the full speed profile (labels for any state, as DAgger needs)."""
    v_target = target_speed(track, s, state.v, car)
    accel = float(np.clip((v_target - state.v) / 0.25, -car.max_decel, 4.0))
    return pursuit(track, state, s, 0.0, car.wheelbase), throttle_for(state.v, accel, car)


class Racer:
    """The expert on one track: `act` gives each tick's controls and episode label."""

    def __init__(self, track: Track, car: Car, seed: int, dt: float, drift_every_s: float | None = 12.0,
                 lag_s: float = 0.08, noise_deg: float = 0.8, pace: float = 0.9):
        self.track, self.car, self.dt = track, car, dt
        self.rng = np.random.default_rng([seed, 14])
        self.drift_every = drift_every_s
        self.alpha = dt / (lag_s + dt)
        self.noise_deg, self.pace = noise_deg, pace
        self.room = track.lane_width / 2 - car.body.width / 2
        self.delta = self.noise = self.wander = self.integral = 0.0
        self.episode, self.side = "normal", 0.0
        self.next_drift = self._draw_wait()

    def _draw_wait(self) -> float:
        return float(self.rng.exponential(self.drift_every)) + 3.0 if self.drift_every else math.inf

    def act(self, state: VehicleState, s: float, offset: float, t: float) -> tuple[float, float, str]:
        """(road-wheel angle [rad, positive left], throttle [-1, 1], episode) for this tick at time t (s).
        s: the rear axle's arc length; offset: its lateral offset from the lane centre (m, left positive)."""
        if self.episode == "normal" and t >= self.next_drift:
            self.episode, self.side = "drift-out", float(self.rng.choice([-1.0, 1.0]))
        elif self.episode == "drift-out" and abs(offset) >= DRIFT_TURN * self.room:
            self.episode = "recover"
        elif self.episode == "recover" and abs(offset) <= RECOVERED * self.room:
            self.episode, self.next_drift = "normal", t + self._draw_wait()
        d_target = self.side * DRIFT_TARGET * self.room if self.episode == "drift-out" else 0.0
        target = pursuit(self.track, state, s, d_target, self.car.wheelbase)
        # Ornstein-Uhlenbeck noise on the road wheel, then a first-order lag: a human, not a controller
        dt = self.dt
        self.noise += -self.noise * dt / 0.5 + math.radians(self.noise_deg) * math.sqrt(dt) * self.rng.standard_normal()
        self.delta += self.alpha * (target + self.noise - self.delta)
        self.delta = float(np.clip(self.delta, -self.car.full_lock, self.car.full_lock))
        # the pace wanders slowly within about +-5 %
        self.wander += -self.wander * dt / 4.0 + 0.05 * math.sqrt(dt / 2.0) * self.rng.standard_normal()
        v_target = (self.pace + self.wander) * target_speed(self.track, s, state.v, self.car)
        err = v_target - state.v
        self.integral = float(np.clip(self.integral + err * dt, -1.0, 1.0))
        accel = float(np.clip(err / 0.25, -self.car.max_decel, 4.0))
        throttle = throttle_for(state.v, accel, self.car) + 0.05 * self.integral
        return self.delta, float(np.clip(throttle, -1.0, 1.0)), self.episode
