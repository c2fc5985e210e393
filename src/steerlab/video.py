"""Drive videos: the camera view with the model's and the reference (expert or recorded) steering drawn as two
steering wheels, and the lateral offset from the lane centre as a bar, written with OpenCV's VideoWriter."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from steerlab.errors import SteerlabError

MODEL, REFERENCE = (60, 200, 255), (90, 230, 90)  # BGR: amber for the model, green for the reference
WIDTH = 640  # frames are scaled to this width so that the drawings stay legible


class DriveVideo:
    """`add(frame, model, reference, offset)` once per frame, then `close()`. Angles are steering-wheel
    angles in radians, positive left (counter-clockwise), as the wheels on screen turn."""

    def __init__(self, path: str | Path, fps: float, reference: str = "expert"):
        self.path, self.fps, self.reference = Path(path), fps, reference
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.writer = None
        self.frames = 0

    def add(self, bgr: np.ndarray, model: float, reference: float | None = None, offset: float | None = None,
            text: str = "", limit: float = 1.0) -> None:
        """`limit`: the offset (m) the bar marks as leaving the lane."""
        h, w = bgr.shape[:2]
        img = cv2.resize(bgr, (WIDTH, int(round(h * WIDTH / w))), interpolation=cv2.INTER_LINEAR)
        panel = np.full((150, WIDTH, 3), 30, np.uint8)
        _wheel(panel, (85, 75), model, MODEL, "model")
        if reference is not None:
            _wheel(panel, (235, 75), reference, REFERENCE, self.reference)
        if offset is not None:
            _offset_bar(panel, offset, limit)
        if text:
            cv2.putText(panel, text, (335, 140), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (200, 200, 200), 1, cv2.LINE_AA)
        out = np.vstack([img, panel])
        if self.writer is None:
            self.writer = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*"mp4v"), self.fps,
                                          (out.shape[1], out.shape[0]))
            if not self.writer.isOpened():
                raise SteerlabError(f"{self.path}: OpenCV cannot write an MP4 video here: choose another "
                                    "path")
        self.writer.write(out)
        self.frames += 1

    def close(self) -> None:
        if self.writer is not None:
            self.writer.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _wheel(img: np.ndarray, centre: tuple[int, int], angle: float, color, label: str) -> None:
    """A steering wheel turned by `angle` (rad, positive counter-clockwise) with its angle in degrees."""
    r = 45

    def rim(a: float) -> tuple[int, int]:  # the rim point at angle a (counter-clockwise from the right)
        return int(round(centre[0] + r * math.cos(a + angle))), int(round(centre[1] - r * math.sin(a + angle)))

    cv2.circle(img, centre, r, color, 4, cv2.LINE_AA)
    for spoke in (-math.pi / 2, math.pi / 6, 5 * math.pi / 6):
        cv2.line(img, centre, rim(spoke), color, 3, cv2.LINE_AA)
    cv2.circle(img, rim(math.pi / 2), 6, color, -1, cv2.LINE_AA)  # the top of the wheel
    cv2.putText(img, f"{label} {math.degrees(angle):+.1f} deg", (centre[0] - 70, centre[1] + r + 22),
                cv2.FONT_HERSHEY_SIMPLEX, 0.45, color, 1, cv2.LINE_AA)


def _offset_bar(img: np.ndarray, offset: float, limit: float = 1.0) -> None:
    """Lateral offset from the lane centre (m, positive left) on a bar that spans +-1.5 x limit."""
    x0, x1, y = 335, WIDTH - 25, 70
    span = 1.5 * limit
    px = lambda d: int(round((x0 + x1) / 2 - d / span * (x1 - x0) / 2))  # left of the lane is left on screen
    cv2.rectangle(img, (x0, y - 10), (x1, y + 10), (80, 80, 80), -1)
    for d in (-limit, limit):
        cv2.line(img, (px(d), y - 16), (px(d), y + 16), (60, 60, 230), 2)
    cv2.line(img, (px(0), y - 12), (px(0), y + 12), (200, 200, 200), 1)
    color = (60, 60, 230) if abs(offset) > limit else (230, 230, 230)
    cv2.circle(img, (px(float(np.clip(offset, -span, span))), y), 9, color, -1, cv2.LINE_AA)
    cv2.putText(img, f"offset {offset:+.2f} m (left +)", (x0, y - 22), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                (200, 200, 200), 1, cv2.LINE_AA)
