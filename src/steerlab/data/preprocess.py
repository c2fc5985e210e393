"""Frame preprocessing (paper 000 IV-A): crop, resize to 200x66 with area interpolation, colour space.

Everything here works on one frame at a time and is used both by the compiler (offline) and by the Pilot
(streaming), so that what is trained on is exactly what is driven with.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, fields, replace
from typing import Literal

import cv2
import numpy as np

from steerlab.errors import SteerlabError
from steerlab.options import OneOf, Options, PIXELS, Range, as_dict, option

COLORS = {"gray": 1, "yuv": 3, "hsv": 3, "rgb": 3}
MODALITIES = ("image", "diff", "flow")
FLOW_METHODS = ("farneback", "dis")

# Rows/columns removed from the raw frame (top, bottom, left, right) per camera geometry.
#   ch2: Udacity CH2 640x480, paper 000 V-C drops the top 268 px -> 640x212.
#   sim: Udacity simulator 320x160: sky above row 60 and the bonnet below row 140 -> 320x80.
#   donkey: donkeycar 160x120: walls and sky above row 40 -> 160x80 (docs/img/geometry_donkey.png).
CROP_PRESETS = {"ch2": (268, 0, 0, 0), "sim": (60, 20, 0, 0), "donkey": (40, 0, 0, 0)}


@dataclass(frozen=True)
class PreprocessConfig:
    """How raw frames become network inputs. Saved with every compiled dataset and every checkpoint."""

    crop: tuple[int, int, int, int] = CROP_PRESETS["ch2"]
    width: int = 200
    height: int = 66
    color: str = "gray"
    modalities: tuple[str, ...] = ("image",)
    flow: str = "farneback"
    stack: int = 1  # consecutive frames stacked as image channels (oldest first)

    def __post_init__(self):
        object.__setattr__(self, "crop", tuple(int(c) for c in self.crop))
        object.__setattr__(self, "modalities", tuple(self.modalities))
        if self.color not in COLORS:
            raise SteerlabError(f"unknown colour space {self.color!r}; choose one of {sorted(COLORS)}")
        bad = [m for m in self.modalities if m not in MODALITIES]
        if bad or not self.modalities or self.modalities[0] != "image":
            raise SteerlabError(f"modalities must start with 'image' and use only {MODALITIES}, got {self.modalities}")
        if self.flow not in FLOW_METHODS:
            raise SteerlabError(f"unknown flow method {self.flow!r}; choose one of {FLOW_METHODS}")
        if int(self.stack) < 1:
            raise SteerlabError(f"stack must be at least 1 frame, got {self.stack}")
        if len(self.crop) != 4 or min(self.crop) < 0:
            raise SteerlabError(f"crop must be four non-negative numbers (top, bottom, left, right), got {self.crop}")

    @classmethod
    def from_dict(cls, d: dict) -> "PreprocessConfig":
        d = dict(d or {})
        preset = d.pop("preset", None)
        if preset is not None:
            if preset not in CROP_PRESETS:
                raise SteerlabError(f"unknown preprocessing preset {preset!r}; choose one of {sorted(CROP_PRESETS)}")
            d.setdefault("crop", CROP_PRESETS[preset])
        known = {f.name for f in fields(cls)}
        unknown = set(d) - known
        if unknown:
            raise SteerlabError(f"unknown preprocessing options {sorted(unknown)}; known: {sorted(known)}")
        return cls(**d)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["crop"], d["modalities"] = list(self.crop), list(self.modalities)
        return d

    def key(self) -> str:
        return hashlib.sha1(json.dumps(self.as_dict(), sort_keys=True).encode()).hexdigest()[:16]

    @property
    def image_channels(self) -> int:
        return COLORS[self.color]

    def channels(self) -> dict[str, int]:
        """Channels per modality, in input order."""
        per = {"image": self.image_channels * self.stack, "diff": self.image_channels, "flow": 2}
        return {m: per[m] for m in self.modalities}


@dataclass(frozen=True)
class PreprocessOptions(Options):
    """The preprocess: section of a training config: `PreprocessConfig`'s fields, None where the default is
    taken, and `preset`, the crop preset (default: the recording's camera geometry; an explicit crop wins)."""

    preset: str | None = option(None, OneOf(CROP_PRESETS, "crop presets"))
    crop: tuple[int, int, int, int] | None = option(None, lambda c: min(c) >= 0,
                                                    "four non-negative integers (top, bottom, left, right)")
    width: int | None = option(None, PIXELS)
    height: int | None = option(None, PIXELS)
    color: Literal[tuple(COLORS)] | None = None
    modalities: tuple[Literal[MODALITIES], ...] | None = option(
        None, lambda m: len(m) > 0 and m[0] == "image" and len(set(m)) == len(m),
        "a list of modalities starting with image, each once (image, diff, flow)")
    flow: Literal[FLOW_METHODS] | None = None
    stack: int | None = option(None, Range(1, 64))  # frames stacked as channels

    def resolve(self, geometry: str | None = None) -> PreprocessConfig:
        """The preprocessing of a recording of this camera `geometry` (its crop preset unless one is set)."""
        given = {k: v for k, v in as_dict(self).items() if v is not None and k != "preset"}
        preset = self.preset or (geometry if geometry in CROP_PRESETS else None)
        if "crop" not in given and preset is not None:
            given["crop"] = CROP_PRESETS[preset]
        return PreprocessConfig(**given)

    def merged(self, fixed: dict, owner: str) -> PreprocessOptions:
        """These options with `fixed` ones (what a model needs) filled in; a conflicting setting is an error."""
        for key, value in fixed.items():
            mine = getattr(self, key)
            if mine is not None and as_dict(mine) != as_dict(value):
                raise SteerlabError(f"{owner} needs preprocess {key}={value}, the config sets {as_dict(mine)}")
        return replace(self, **{k: tuple(v) if isinstance(v, list) else v for k, v in fixed.items()})


def crop_resize(bgr: np.ndarray, cfg: PreprocessConfig) -> np.ndarray:
    """Crop and resize (area interpolation) a BGR frame."""
    top, bottom, left, right = cfg.crop
    h, w = bgr.shape[:2]
    if top + bottom >= h or left + right >= w:
        raise SteerlabError(f"crop {cfg.crop} removes the whole {w}x{h} frame; use a preset that fits the camera")
    roi = bgr[top: h - bottom, left: w - right]
    return cv2.resize(roi, (cfg.width, cfg.height), interpolation=cv2.INTER_AREA)


def to_color(bgr_small: np.ndarray, color: str) -> np.ndarray:
    """Convert to the model's colour space; always returns HxWxC uint8."""
    if color == "gray":
        return cv2.cvtColor(bgr_small, cv2.COLOR_BGR2GRAY)[:, :, None]
    code = {"yuv": cv2.COLOR_BGR2YUV, "hsv": cv2.COLOR_BGR2HSV, "rgb": cv2.COLOR_BGR2RGB}[color]
    return cv2.cvtColor(bgr_small, code)


def preprocess(bgr: np.ndarray, cfg: PreprocessConfig) -> tuple[np.ndarray, np.ndarray]:
    """One raw BGR frame -> (image HxWxC uint8 in cfg.color, gray HxW uint8 for optical flow)."""
    small = crop_resize(bgr, cfg)
    image = to_color(small, cfg.color)
    gray = image[:, :, 0] if cfg.color == "gray" else cv2.cvtColor(small, cv2.COLOR_BGR2GRAY)
    return image, gray
