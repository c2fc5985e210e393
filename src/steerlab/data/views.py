"""Virtual views of a recording's frames (`train.views`, NVIDIA PilotNet's augmentation): every frame as a camera
moved sideways and turned would have seen it, and the lens it is warped through.

A view is [shift_m, yaw_deg]: the camera moved `shift_m` to the left and turned `yaw_deg` to the left, each a
number or a range [lo, hi] drawn uniformly for every frame (`View.offsets`: the same draws every time, and another
draw for every view of the list, so that a list of N equal ranges gives N views of every frame). Below the horizon
everything is taken to lie on the flat floor or road; above it, infinitely far away (it only turns): walls, cars
and trees beside the road are warped as if they were at the horizon: a turn moves them as it should, a shift not
at all. A view shifts at most MAX_SHIFT_M and turns at most MAX_YAW_DEG either way.

The warp: a pinhole camera's frames by `geometry.shift_view`; the donkey camera's by `fisheye.shift_view` through
its fisheye (`lens_of`: the one a recording carries, the track world's, else the 160-degree Raspberry Pi camera's
default, or a calibration file's K and D)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.data import fisheye, geometry
from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera, camera_fields, load_calibration
from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_0, value_of

FISHEYE_GEOMETRY = "donkey"  # the camera geometry whose lens is a fisheye
EXPECTED = "a list of [shift_m, yaw_deg] pairs, each a number or a range [lo, hi]"
MAX_SHIFT_M = 2.0   # half a full-size car's lane: a view farther off shows mostly what the frame does not hold
MAX_YAW_DEG = 45.0  # a camera turned further sees mostly what the frame does not show


@dataclass(frozen=True)
class View:
    """One view of every frame: the shift (m, left positive) and turn (degrees, left positive) ranges, equal ends
    for a fixed value, and which draw of them it is (its place in the list)."""

    shift_m: tuple[float, float]
    yaw_deg: tuple[float, float]
    draw: int = 0

    def __post_init__(self):
        value_of(int, self.draw, "a view's draw", AT_LEAST_0)
        for name, limit, unit in (("shift_m", MAX_SHIFT_M, "m"), ("yaw_deg", MAX_YAW_DEG, "degrees")):
            r = getattr(self, name)
            if (not isinstance(r, tuple) or len(r) != 2
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in r)):
                raise SteerlabError(f"a view's {name} must be a range (lo, hi) of two numbers, got {r!r}")
            if not -limit <= r[0] <= r[1] <= limit:
                raise SteerlabError(f"a view's {name} must be a range [lo, hi] with lo <= hi within +-{limit:g} "
                                    f"{unit}, got {list(r)}")

    @classmethod
    def parse_option(cls, value, where: str) -> View:
        if isinstance(value, View):
            return value
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            raise SteerlabError(f"{where} must be a [shift_m, yaw_deg] pair, each a number or a range [lo, hi], got "
                                f"{value!r}")
        ranges = []
        for name, v in zip(("shift_m", "yaw_deg"), value):
            if isinstance(v, (list, tuple)) and len(v) != 2:
                raise SteerlabError(f"{where}.{name} must be a number or a range [lo, hi] of two numbers, got {v!r}")
            lo, hi = (v, v) if not isinstance(v, (list, tuple)) else v
            lo, hi = (value_of(float, x, f"{where}.{name}", expected=f"a number or a range [lo, hi] ({EXPECTED})")
                      for x in (lo, hi))
            if lo > hi:
                raise SteerlabError(f"{where}.{name} must be a range [lo, hi] with lo <= hi, got {v!r}")
            ranges.append((lo, hi))
        if ranges == [(0, 0), (0, 0)]:
            raise SteerlabError(f"{where}: a view of [0, 0] (no shift, no turn) is the frame itself, which training "
                                "has already: leave it out")
        try:
            return cls(*ranges)
        except SteerlabError as e:
            raise SteerlabError(f"{where}: {e}") from None

    def as_dict(self) -> list:
        return [lo if lo == hi else [lo, hi] for lo, hi in (self.shift_m, self.yaw_deg)]

    @property
    def name(self) -> str:
        """The view in a cache entry's name."""
        (a, b), (c, d) = self.shift_m, self.yaw_deg
        if (a, c) == (b, d):
            return f"{a:+g}m{c:+g}deg"
        return f"{a:+g}..{b:+g}m{c:+g}..{d:+g}deg#{self.draw}"

    def describe(self) -> str:
        """In words: "+0.5 m +0 deg", "-0.1..+0.1 m -10..+10 deg"."""
        return " ".join(f"{lo:+g} {unit}" if lo == hi else f"{lo:+g}..{hi:+g} {unit}"
                        for (lo, hi), unit in ((self.shift_m, "m"), (self.yaw_deg, "deg")))

    def offsets(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(shift m, yaw degrees) of each of n frames."""
        value_of(int, n, "View.offsets(n)", AT_LEAST_0)
        rng = np.random.default_rng([self.draw, 71])
        return rng.uniform(*self.shift_m, n), rng.uniform(*self.yaw_deg, n)


def lens_of(rec, calibration: str | Path | None = None) -> FisheyeCamera | None:
    """The fisheye a recording's views are warped through (None: a pinhole camera's recording): the one it carries,
    else the donkey camera's default, with a calibration file's K and D where given."""
    if rec.geometry != FISHEYE_GEOMETRY:
        if calibration is not None:
            raise SteerlabError(f"{calibration}: a fisheye calibration is for recordings of the {FISHEYE_GEOMETRY!r} "
                                f"camera; {rec.source} is of the {rec.geometry!r} camera: leave it out")
        return None
    lens = rec.fisheye or DONKEY_FISHEYE
    return lens if calibration is None else load_calibration(calibration, lens)


def lens_name(lens: FisheyeCamera) -> str:
    """A short digest of a lens (K, D, mount; `mirrored` only where true), for cache entries' names."""
    return hashlib.sha1(json.dumps(camera_fields(lens), sort_keys=True).encode()).hexdigest()[:8]


def warp(frame: np.ndarray, geometry_name: str, lens: FisheyeCamera | None, shift_m: float,
         yaw_deg: float) -> np.ndarray:
    """`frame` as the camera moved `shift_m` to the left and turned `yaw_deg` to the left sees it."""
    if lens is not None:
        return fisheye.shift_view(frame, lens, shift_m, yaw_deg)
    return geometry.shift_view(frame, geometry.camera(geometry_name), shift_m, yaw_deg)
