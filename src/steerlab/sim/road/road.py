"""Procedural roads from a seed: straights, circular arcs and clothoid transitions between them.

A road is a two-lane carriageway described along its centre line (the dashed line) by arc length s:
position, heading and curvature every `DS` metres. The road frame coordinate d is the signed lateral
distance from the centre line, positive to the left. Cars drive on the right lane, centred at d = -LANE/2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from steerlab.errors import SteerlabError

DS = 0.5          # sampling step along the road [m]
LANE = 3.6        # lane width [m]
EDGE = LANE       # solid edge lines: outer border at |d| = LANE
LINE_WIDTH = 0.15  # m, painted lines
VERGE = LANE + 1.5
LANE_CENTER = -LANE / 2


@dataclass(frozen=True)
class RoadType:
    radius: tuple[float, float]        # arc radius range [m]
    straight: tuple[float, float]      # straight length range [m]
    transition: tuple[float, float]    # clothoid length range [m]
    turn_deg: tuple[float, float]      # heading change of an arc [deg]
    speed: float                       # cruise speed on straights [m/s]


ROAD_TYPES = {
    "highway": RoadType((450, 1200), (150, 500), (80, 160), (10, 40), 27.0),
    "country": RoadType((90, 400), (40, 250), (30, 80), (20, 90), 19.0),
    "twisty": RoadType((35, 120), (15, 90), (15, 40), (30, 120), 13.0),
}


class Road:
    def __init__(self, seed: int, kind: str = "country", length_m: float = 5000.0):
        if kind not in ROAD_TYPES:
            raise SteerlabError(f"unknown road type {kind!r}; choose one of {', '.join(ROAD_TYPES)}")
        self.seed, self.kind, self.params = int(seed), kind, ROAD_TYPES[kind]
        rng = np.random.default_rng([self.seed, 1])
        p = self.params
        kappa = [np.zeros(int(60 / DS))]  # every road starts straight
        total = len(kappa[0]) * DS
        while total < length_m + 300:
            ls = rng.uniform(*p.straight)
            lt = rng.uniform(*p.transition)
            k = rng.choice([-1, 1]) / rng.uniform(*p.radius)
            arc = max(np.radians(rng.uniform(*p.turn_deg)) / abs(k) - lt, 5.0)
            parts = [np.zeros(int(ls / DS)), np.linspace(0, k, int(lt / DS)), np.full(int(arc / DS), k),
                     np.linspace(k, 0, int(lt / DS))]
            kappa += parts
            total += sum(len(a) for a in parts) * DS
        self.kappa = np.concatenate(kappa)
        n = len(self.kappa)
        self.s = np.arange(n) * DS
        self.psi = np.concatenate([[0.0], np.cumsum((self.kappa[1:] + self.kappa[:-1]) / 2 * DS)])
        mid = self.psi[:-1] + np.diff(self.psi) / 2
        self.x = np.concatenate([[0.0], np.cumsum(np.cos(mid) * DS)])
        self.y = np.concatenate([[0.0], np.cumsum(np.sin(mid) * DS)])
        self.length = float(self.s[-1])
        self._speed_limit()

    def _speed_limit(self, lat_acc: float = 2.0, decel: float = 1.2) -> None:
        """Speed the expert aims for at each s: slower in curves, braking early enough before them."""
        rng = np.random.default_rng([self.seed, 2])
        # the cruise speed wanders by +-15% every ~300 m, so there are stretches of speeding up and slowing down
        knots = rng.uniform(0.85, 1.15, int(self.length / 300) + 2) * self.params.speed
        cruise = np.interp(self.s, np.arange(len(knots)) * 300.0, knots)
        v = np.minimum(cruise, np.sqrt(lat_acc / np.maximum(np.abs(self.kappa), 1e-6)))
        for i in range(len(v) - 2, -1, -1):  # backward pass: reachable with a gentle deceleration
            v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + 2 * decel * DS))
        self.speed_limit = v

    def index(self, s: float) -> int:
        return int(np.clip(round(s / DS), 0, len(self.s) - 1))

    def pose(self, s: float, d: float = LANE_CENTER) -> tuple[float, float, float]:
        """World (x, y, heading) of road coordinate (s, d)."""
        i = self.index(s)
        return (self.x[i] - d * np.sin(self.psi[i]), self.y[i] + d * np.cos(self.psi[i]), self.psi[i])

    def project(self, x: float, y: float, s_hint: float, window: float = 30.0) -> tuple[float, float, float]:
        """Road coordinates (s, d) and road heading of a world point near s_hint."""
        a, b = self.index(s_hint - window), self.index(s_hint + window) + 1
        dx, dy = x - self.x[a:b], y - self.y[a:b]
        i = a + int(np.argmin(dx * dx + dy * dy))
        c, sn = np.cos(self.psi[i]), np.sin(self.psi[i])
        ex, ey = x - self.x[i], y - self.y[i]
        along = ex * c + ey * sn
        return self.s[i] + along, -ex * sn + ey * c, self.psi[i] + self.kappa[i] * along
