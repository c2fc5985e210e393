"""The one speed controller: the throttle that drives a measured speed to a target (the Udacity simulator
server's set speed, a donkeycar part's predicted speed), the one shaping of a part's throttle on its way to the
car (`Throttle`: a constant throttle, or a learned one scaled, capped and floored at rest), which the car's part
(`donkey.SteerlabPilot`) and every pilot of the simulated car (`sim.core.part.PartPilot`) apply alike, the one
lane controller (`lane_steering`), which steers by the lane a model's lane head sees, and the pace from that lane
(`lane_throttle`: the speed its curvature allows), on the car and in the simulated track world alike.

The lane controller's law is Stanley's (Thrun et al. 2006, "Stanley: the robot that won the DARPA Grand
Challenge"), with the lane's curvature as a feed-forward: road-wheel angle (rad, positive left) =

    atan(wheelbase x curvature) - K_HEADING x heading - atan(K_OFFSET x offset / (v + V0))

for the lateral offset of the rear axle (m, positive left), the heading to the lane (rad, positive turned left),
the lane's curvature (1/m, positive turning left) and the speed v (m/s), limited to the car's full lock by its
caller. The first term is the angle that follows the lane's curve (a kinematic car turns with curvature
tan(angle) / wheelbase), the second turns the wheels back along the lane, the third steers towards the centre line
over a distance that grows with the speed.

The pace from the lane slows for the curve as the track world's expert does (`sim/track/expert.py`), from the
curvature a lane head sees where the car is: the speed at which the lateral acceleration v^2 |curvature| is
`lat_acc`, at most the car's top speed,

    v* = min(top_speed, sqrt(lat_acc / |curvature|)),

is reached by the throttle v* / top_speed (what holds v* on a motor whose throttle u approaches u x top_speed)
plus LANE_KP x (v* - v), which brakes (a negative throttle) where the car is faster, limited to +-cap."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from steerlab.errors import SteerlabError

# Stanley's own heading term: the wheels turned back by the whole heading error point the car along the lane.
K_HEADING = 1.0
# 1/s: near the lane centre the car closes its offset at about K_OFFSET x offset m/s. On the donkeycar's 0.26 m
# wheelbase the offset then settles like a spring of damping sqrt(v / (4 K_OFFSET wheelbase)): 0.7 at 1 m/s, 1.2 at
# 3 m/s, never oscillating much at racing speeds, and back within a car's length at the speeds it races.
K_OFFSET = 2.0
# m/s: keeps the offset term finite at standstill (the start line) and gentle below a walking pace.
V0 = 0.5
AT_REST = 0.1  # m/s: slower than this, the car stands (or creeps) as far as a throttle floor is concerned
DEFAULT_THROTTLE = 0.3  # the constant throttle of a model that predicts none when none is given
# throttle per m/s of speed above or below the lane's: 1 m/s too fast takes 0.5 off the throttle that holds the
# speed, which brakes above 2.5 m/s on a 5 m/s car (on the track world's true lane: docs/results/racing.md, "Pace
# from the lane")
LANE_KP = 0.5
LAT_ACC = 3.5  # m/s^2: the lateral acceleration the pace from the lane allows by default, the track expert's
PACE_MAX = 20.0  # m/s^2 and m/s: the largest lat_acc and top_speed the pace from the lane takes


def number(name: str, value, low: float, high: float, low_open: bool = False) -> float:
    """`value` as a float when it is a real number (not a bool) in [low, high] ((low, high] with `low_open`); else
    one line naming `name`, the interval and what was given."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or not (low < value if low_open else low <= value) or value > high:
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}]"
        raise SteerlabError(f"{name} must be a number in {interval}, got {value!r}")
    return float(value)


def throttle_held(cap: float, floor: float) -> Iterator[tuple[str, str]]:
    """(option, what it must be) where a floor and a cap cannot shape one throttle: the floor lies within the cap
    (options' `related`, and `Throttle`'s own check: one message)."""
    if floor > cap:
        yield "throttle_floor", f"at most max_throttle ({cap:g}): the floor lies within the cap"


@dataclass(frozen=True)
class Throttle:
    """What shapes a part's throttle on its way to the car, checked once when made (`number`'s one message):

    - `constant`: the throttle of a model that predicts none, and the cruising throttle of the speed controllers
      (a model that predicts its speed or a speed command);
    - `scale`, `cap` (donkeycar's max_throttle) and `floor`: a learned throttle (a model's, or any donkeycar
      part's) reaches the car times `scale`, limited to +-`cap`, and at least `floor` (within the cap) while the car
      stands (`shaped`).

    `for_model(learned)` checks the shaping against the throttle that drives: a floor or a scale shapes a learned
    throttle only, and a constant or cruising throttle above the cap is refused (it would drive above it)."""

    constant: float = DEFAULT_THROTTLE
    scale: float = 1.0
    cap: float = 0.5
    floor: float = 0.0

    def __post_init__(self):
        for name, field, low, high, low_open in (("throttle", "constant", 0.0, 1.0, False),
                                                 ("throttle_scale", "scale", 0.0, 10.0, True),
                                                 ("max_throttle", "cap", 0.0, 1.0, True),
                                                 ("throttle_floor", "floor", 0.0, 1.0, False)):
            object.__setattr__(self, field, number(name, getattr(self, field), low, high, low_open))
        for name, expected in throttle_held(self.cap, self.floor):
            raise SteerlabError(f"{name} must be {expected}, got {self.floor:g}")

    def for_model(self, learned: bool, name: str, kind: str = "constant") -> Throttle:
        """This shaping for model `name` (what messages call it): `learned`, its own throttle drives; else its
        `kind` ("constant", "cruising" or "lane-paced": `lane_throttle`) throttle. Returns itself; refuses a shaping
        that would not apply."""
        if learned:
            return self
        for field, value, default in (("throttle_floor", self.floor, 0.0), ("throttle_scale", self.scale, 1.0)):
            if value != default:
                raise SteerlabError(f"{field} shapes a learned throttle; {name} drives at a {kind} throttle: "
                                    f"leave {field} out")
        if kind != "lane-paced" and self.constant > self.cap:
            raise SteerlabError(f"the {kind} throttle {self.constant:g} exceeds max_throttle {self.cap:g}: lower "
                                "the throttle or raise max_throttle")
        return self

    def shaped(self, throttle: float, speed: float | None = None) -> float:
        """A learned throttle as it reaches the car: times `scale`, limited to +-`cap`, and at least `floor` (within
        the cap) while the car stands (`speed` below AT_REST; without a measured speed, no floor): a throttle
        learned from the image alone brakes at rest where the expert braked at speed, and would leave the car
        standing for good."""
        shaped = float(np.clip(self.scale * throttle, -self.cap, self.cap))
        if self.floor and speed is not None and speed < AT_REST:
            return max(shaped, self.floor)  # within the cap: made so
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


def lane_steering(offset: float, heading: float, curvature: float, speed: float, wheelbase: float) -> float:
    """The road-wheel angle (rad, positive left) of the lane controller (see the module's docstring), unlimited."""
    return (math.atan(wheelbase * curvature) - K_HEADING * heading
            - math.atan(K_OFFSET * offset / (max(speed, 0.0) + V0)))


def lane_speed(curvature: float, lat_acc: float, top_speed: float) -> float:
    """The speed (m/s) a lane of `curvature` (1/m) allows: lateral acceleration `lat_acc` (m/s^2), at most
    `top_speed`."""
    return min(top_speed, math.sqrt(lat_acc / max(abs(curvature), 1e-9)))


def lane_throttle(curvature: float, speed: float, lat_acc: float, top_speed: float, cap: float) -> float:
    """The throttle of the pace from the lane (see the module's docstring) at the measured `speed` (m/s) on a car
    whose throttle 1 approaches `top_speed` (m/s), limited to +-`cap`."""
    target = lane_speed(curvature, lat_acc, top_speed)
    return float(np.clip(target / top_speed + LANE_KP * (target - speed), -cap, cap))
