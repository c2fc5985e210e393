"""What the drives of every world write besides their plots: a strip of the camera's frames."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def write_strip(path: Path, frames: list[np.ndarray]) -> None:
    """frames.png: the frames a drive kept (one every 5 s), four to a row."""
    rows = [np.hstack(frames[k:k + 4]) for k in range(0, len(frames) - 3, 4)] or [np.hstack(frames)]
    cv2.imwrite(str(path), np.vstack(rows))
