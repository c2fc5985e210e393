"""Closed procedural tracks for small cars, like the taped or painted tracks donkeycar owners race on.

A track is a loop of 10-60 m drawn from a seed as a curvature profile: straights, and turns of 0.8-6 m radius
(tight hairpins and sweeping bends; some turn against the loop's direction, making chicanes and S-bends), each
turn an arc between two linear curvature ramps (clothoids), so that curvature is continuous everywhere. It is
closed by construction rather than by smoothing a random curve afterwards:

- heading: the turns' angles are scaled so that they add up to exactly one full turn;
- position: the end point moves linearly with the straights' lengths (lengthening the straight at heading psi
  moves everything after it by (cos psi, sin psi)), so the straights are adjusted by the smallest change that
  brings the end onto the start (a minimum-norm solve, repeated twice for the numerical integration);
- the start line lies in the middle of a straight, where curvature is zero on both sides.

A draw whose straights would become too short, whose lap is outside 10-60 m, or whose lane comes closer than
`CLEARANCE` to another part of itself (or crosses it) is thrown away and drawn again. The centre line is
sampled every ~2 cm by arc length s in [0, length): position, heading (unwrapped), curvature. Road
coordinates are (s, d), d the signed lateral distance from the centre line, positive left. The lane is
`lane_width` wide around the centre line; its style is "taped" (a tape line along each edge) or "centre"
(one painted centre line; the lane is then the width around it).
"""

from __future__ import annotations

import math

import numpy as np

from steerlab.errors import SteerlabError

DS = 0.02            # m, target sampling step along the centre line
LANE_WIDTH = 0.9     # m, default lane width
STYLES = ("taped", "centre")
LAP = (10.0, 60.0)   # m, lap lengths drawn
RADIUS = (0.8, 6.0)  # m, turn radii drawn (tight up to TIGHT, sweeping beyond)
TIGHT = 1.6          # m
CLEARANCE = 0.5      # m, least gap between the lane edges of two parts of the track that are not neighbours
MIN_STRAIGHT = 0.2   # m; the start straight is at least START_STRAIGHT
START_STRAIGHT = 1.5


def _psi_at(s, knots_s, knots_k, knots_psi):
    """Heading at s of a piecewise-linear curvature profile (the exact integral: quadratic within a piece)."""
    j = np.clip(np.searchsorted(knots_s, s, side="right") - 1, 0, len(knots_s) - 2)
    h = s - knots_s[j]
    length = knots_s[j + 1] - knots_s[j]
    slope = np.where(length > 0, (knots_k[j + 1] - knots_k[j]) / np.where(length > 0, length, 1), 0.0)
    return knots_psi[j] + knots_k[j] * h + slope * h * h / 2


def _integrate(pieces: list[tuple[float, float, float]], n: int):
    """Sample a curvature profile given as pieces (length, kappa at start, kappa at end) at n equal steps:
    s, kappa, psi (exact) and x, y (Simpson's rule); the end point (x, y) at s = total length too."""
    lengths = np.array([p[0] for p in pieces])
    knots_s = np.concatenate([[0.0], np.cumsum(lengths)])
    knots_k = np.array([pieces[0][1]] + [p[2] for p in pieces])
    knots_psi = np.concatenate([[0.0], np.cumsum(lengths * (np.array([p[1] for p in pieces]) + knots_k[1:]) / 2)])
    total = knots_s[-1]
    ds = total / n
    s = np.arange(n + 1) * ds
    psi = _psi_at(s, knots_s, knots_k, knots_psi)
    mid = _psi_at(s[:-1] + ds / 2, knots_s, knots_k, knots_psi)
    x = np.concatenate([[0.0], np.cumsum(ds / 6 * (np.cos(psi[:-1]) + 4 * np.cos(mid) + np.cos(psi[1:])))])
    y = np.concatenate([[0.0], np.cumsum(ds / 6 * (np.sin(psi[:-1]) + 4 * np.sin(mid) + np.sin(psi[1:])))])
    kappa = np.interp(s, knots_s, knots_k)
    return s, kappa, psi, x, y


def _pieces(straights: np.ndarray, turns: list[tuple[float, float, float]]) -> list[tuple[float, float, float]]:
    """Half the start straight, then turn i (ramp, arc, ramp) and straight i + 1, ..., the start straight's other
    half. turns: (curvature, arc length, ramp length)."""
    out = [(straights[0] / 2, 0.0, 0.0)]
    for i, (k, arc, ramp) in enumerate(turns):
        out += [(ramp, 0.0, k), (arc, k, k), (ramp, k, 0.0)]
        out.append((straights[(i + 1) % len(straights)] / (2 if i + 1 == len(turns) else 1), 0.0, 0.0))
    return out


class Track:
    """A closed track made from `seed`; see the module's docstring."""

    def __init__(self, seed: int, lane_width: float = LANE_WIDTH, style: str = "taped"):
        if not lane_width > 0:
            raise SteerlabError(f"lane width must be positive, got {lane_width} m")
        if lane_width > 2.0:
            raise SteerlabError(f"lane width must be at most 2 m for a small car's track, got {lane_width} m")
        if style not in STYLES:
            raise SteerlabError(f"unknown track style {style!r}; choose one of {', '.join(STYLES)}")
        self.seed, self.lane_width, self.style = int(seed), float(lane_width), style
        self.min_radius = max(RADIUS[0], lane_width / 2 + 0.3)
        rng = np.random.default_rng([self.seed, 11])
        for _ in range(5000):
            if self._draw(rng):
                break
        else:  # pragma: no cover - seeds 0-59 close within 112 draws, with lanes of 0.3 to 2 m
            raise SteerlabError(f"no track could be drawn from seed {seed} with a {lane_width} m lane: "
                            "choose another seed")
        self._speed_cache: dict = {}

    # --- drawing ---------------------------------------------------------------------------------------------

    def _draw(self, rng: np.random.Generator) -> bool:
        n = int(rng.integers(4, 12))
        sign = np.where(rng.random(n) < 0.3, -1.0, 1.0)
        if sign.sum() < 2:
            return False
        radius = np.where(rng.random(n) < 0.45, rng.uniform(self.min_radius, TIGHT, n),
                          rng.uniform(TIGHT, RADIUS[1], n))
        angle = np.radians(rng.uniform(30, 180, n))
        pos, neg = angle[sign > 0].sum(), angle[sign < 0].sum()
        angle[sign > 0] *= (2 * math.pi + neg) / pos  # the signed angles add up to one full turn
        if angle.max() > math.radians(240):
            return False
        ramp = np.minimum(rng.uniform(0.2, 0.8, n), angle * radius / 2)
        turns = [(s / r, a * r - l, l) for s, r, a, l in zip(sign, radius, angle, ramp)]
        straights = np.concatenate([[rng.uniform(2.0, 5.0)], rng.uniform(0.3, 5.0, n - 1)])
        psi_straight = np.concatenate([[0.0], np.cumsum(sign * angle)[:-1]])
        u = np.stack([np.cos(psi_straight), np.sin(psi_straight)])
        for _ in range(3):  # close the loop: least change of the straights' lengths that removes the gap
            length = straights.sum() + sum(a + 2 * r for _, a, r in turns)
            s, kappa, psi, x, y = _integrate(_pieces(straights, turns), int(math.ceil(length / DS)))
            straights = straights - u.T @ np.linalg.solve(u @ u.T, np.array([x[-1], y[-1]]))
            if straights[0] < START_STRAIGHT or straights[1:].min() < MIN_STRAIGHT:
                return False
        length = straights.sum() + sum(a + 2 * r for _, a, r in turns)
        if not LAP[0] <= length <= LAP[1]:
            return False
        s, kappa, psi, x, y = _integrate(_pieces(straights, turns), int(math.ceil(length / DS)))
        gap = np.array([x[-1], y[-1]])
        if np.hypot(*gap) > 1e-6:
            return False
        if rng.random() < 0.5:  # clockwise as often as counter-clockwise
            y, psi, kappa = -y, -psi, -kappa
        self.s, self.kappa, self.psi, self.x, self.y = s[:-1], kappa[:-1], psi[:-1], x[:-1], y[:-1]
        self.length = float(s[-1])
        self.ds = self.length / len(self.s)
        self.turn = float(psi[-1])  # +-2 pi: counter-clockwise or clockwise
        return self._clear()

    def _clear(self) -> bool:
        """No two parts of the lane come closer than CLEARANCE unless they are neighbours along the track: any
        two points further apart along it than half a circle of the keep-out diameter must be that far apart."""
        keep = self.lane_width + CLEARANCE
        step = max(1, int(round(0.1 / self.ds)))
        px, py, ps = self.x[::step], self.y[::step], self.s[::step]
        dist = np.hypot(px[:, None] - px[None], py[:, None] - py[None])
        along = np.abs(ps[:, None] - ps[None])
        along = np.minimum(along, self.length - along)
        return not np.any((along > math.pi * keep / 2) & (dist < keep))

    # --- coordinates -------------------------------------------------------------------------------------------

    def wrap(self, s):
        """Arc length folded into [0, length)."""
        return np.mod(s, self.length)

    def delta(self, s0, s1):
        """Signed arc length from s0 to s1 the short way round (progress between two nearby positions)."""
        return np.mod(np.asarray(s1) - s0 + self.length / 2, self.length) - self.length / 2

    def index(self, s) -> np.ndarray | int:
        """Nearest sample of arc length s (any value; wraps)."""
        i = np.mod(np.rint(np.asarray(s) / self.ds).astype(np.int64), len(self.s))
        return int(i) if np.ndim(i) == 0 else i

    def _interp(self, s):
        s = self.wrap(np.asarray(s, float)) / self.ds
        i = np.floor(s).astype(np.int64)
        return i % len(self.s), (i + 1) % len(self.s), s - i

    def pose(self, s, d=0.0) -> tuple:
        """World (x, y, heading) of road coordinates (s, d), interpolated between samples."""
        i, j, w = self._interp(s)
        dpsi = np.mod(self.psi[j] - self.psi[i] + math.pi, 2 * math.pi) - math.pi
        psi = self.psi[i] + w * dpsi
        x = self.x[i] + w * (self.x[j] - self.x[i]) - np.asarray(d) * np.sin(psi)
        y = self.y[i] + w * (self.y[j] - self.y[i]) + np.asarray(d) * np.cos(psi)
        return x, y, psi

    def curvature(self, s):
        i, j, w = self._interp(s)
        return self.kappa[i] + w * (self.kappa[j] - self.kappa[i])

    def project(self, x: float, y: float, s_hint: float | None = None,
                window: float = 3.0) -> tuple[float, float, float]:
        """Road coordinates (s in [0, length), d) and the centre line's heading at s of a world point: the
        nearest centre-line point within `window` m of `s_hint` along the track (the whole track without a
        hint). Keep the hint within a car's move of the last answer so that a nearby part of the loop is never
        taken for this one."""
        if s_hint is None:
            idx = np.arange(len(self.s))
        else:
            k = int(math.ceil(window / self.ds))
            idx = (self.index(s_hint) + np.arange(-k, k + 1)) % len(self.s)
        dx, dy = x - self.x[idx], y - self.y[idx]
        i = int(idx[int(np.argmin(dx * dx + dy * dy))])
        c, sn = math.cos(self.psi[i]), math.sin(self.psi[i])
        ex, ey = x - self.x[i], y - self.y[i]
        along = ex * c + ey * sn
        return float(self.wrap(self.s[i] + along)), -ex * sn + ey * c, float(self.psi[i] + self.kappa[i] * along)

    def overhang(self, xs, ys, s_hint: float) -> float:
        """How far (m) the farthest of the points (a car's corners, say) lies outside the lane; negative while
        all are inside."""
        return max(abs(self.project(x, y, s_hint)[1]) for x, y in zip(xs, ys)) - self.lane_width / 2

    @property
    def lines(self) -> tuple[float, ...]:
        """Lateral offsets (m) of the painted or taped lines: the lane edges, or the centre line."""
        return (-self.lane_width / 2, self.lane_width / 2) if self.style == "taped" else (0.0,)

    def offset(self, d: float) -> tuple[np.ndarray, np.ndarray]:
        """The curve at lateral offset d from the centre line, as (x, y) at every sample."""
        return self.x - d * np.sin(self.psi), self.y + d * np.cos(self.psi)

    # --- speed -------------------------------------------------------------------------------------------------

    def speed_profile(self, top_speed: float, lat_acc: float = 3.5, decel: float = 3.0) -> np.ndarray:
        """The fastest speed (m/s) at each sample: at most `top_speed`, lateral acceleration v^2 kappa within
        `lat_acc` (m/s^2), and slowing down for what comes within `decel` (m/s^2) of braking (a backward pass,
        twice round the loop so that the turns after the start line slow the car before it)."""
        if not (top_speed > 0 and lat_acc > 0 and decel > 0):
            raise SteerlabError(f"a speed profile needs positive top speed, lateral acceleration and deceleration, "
                                f"got {top_speed}, {lat_acc}, {decel}")
        key = (top_speed, lat_acc, decel)
        if key not in self._speed_cache:
            v = np.minimum(top_speed, np.sqrt(lat_acc / np.maximum(np.abs(self.kappa), 1e-9)))
            n, step = len(v), 2 * decel * self.ds
            for k in range(2 * n - 1, -1, -1):
                i = k % n
                v[i] = min(v[i], math.sqrt(v[(i + 1) % n] ** 2 + step))
            self._speed_cache[key] = v
        return self._speed_cache[key]
