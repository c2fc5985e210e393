"""The cameras steerlab knows, each a name for three things that go together: the pinhole geometry that views are
warped through and the road world renders with (`geometry.CAMERAS`), the crop of its frames' preprocessing
(`preprocess.CROP_PRESETS`) and the car it sits on (`car.CARS`). The three of sim, ch2 and donkey are written where
each belongs; a camera of one's own is one call of `register_camera`, after which readers (a video's `geometry`
option), preprocessing presets, replay, views and `steerlab latency --geometry` take its name."""

from __future__ import annotations

import numbers
import re

from steerlab.data.car import CARS, Car
from steerlab.data.geometry import CAMERAS, Camera
from steerlab.data.preprocess import CROP_PRESETS
from steerlab.errors import SteerlabError
from steerlab.options import OneOf

GEOMETRY = OneOf(CAMERAS, "camera geometries")  # the check of an option that names a camera


def register_camera(name: str, camera: Camera, crop: tuple[int, int, int, int], car: Car) -> None:
    """`name` for frames of `camera` (its width and height those of the frames), cropped by `crop` (top, bottom,
    left, right, in pixels) before they are resized, on `car`."""
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_-]+", name):
        raise SteerlabError(f"a camera's name must be a word (letters, digits, - and _), got {name!r}")
    if name in CAMERAS:
        raise SteerlabError(f"camera {name!r} is registered already; choose another name")
    if not (isinstance(camera, Camera) and isinstance(car, Car)):
        raise SteerlabError(f"register_camera({name!r}): camera must be a geometry.Camera and car a car.Car")
    if (not isinstance(crop, (tuple, list)) or len(crop) != 4
            or not all(isinstance(c, numbers.Integral) and not isinstance(c, bool) and c >= 0 for c in crop)
            or crop[0] + crop[1] >= camera.height or crop[2] + crop[3] >= camera.width):
        raise SteerlabError(f"register_camera({name!r}): crop must be four non-negative integers (top, bottom, left, "
                            f"right) that leave some of the {camera.height}x{camera.width} frame, got {crop!r}")
    CAMERAS[name], CROP_PRESETS[name], CARS[name] = camera, tuple(int(c) for c in crop), car
