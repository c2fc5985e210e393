"""Motion modalities between the previous and the current preprocessed frame.

- frame difference (paper 000 IV-B3): (x_t - x_{t-1}) / 2 + 128, uint8, per image channel;
- dense optical flow (paper 000 IV-B4): Farneback, or OpenCV's DIS as a faster option; two float channels
  (horizontal, vertical displacement in pixels of the 200x66 frame).

The first frame of a segment has no predecessor inside the segment. It is paired with itself, so its
difference is exactly 128 everywhere and its flow exactly zero: "no motion seen yet". Nothing from the
previous segment (another place, seconds earlier) ever enters.
"""

from __future__ import annotations

import threading

import cv2
import numpy as np


def frame_difference(prev: np.ndarray, cur: np.ndarray) -> np.ndarray:
    """floor((cur - prev) / 2) + 128, which always lies in [0, 255]."""
    d = (cur.astype(np.int16) - prev.astype(np.int16)) // 2 + 128
    return d.astype(np.uint8)


_dis = threading.local()


def optical_flow(prev_gray: np.ndarray, cur_gray: np.ndarray, method: str = "farneback") -> np.ndarray:
    """Dense flow from prev to cur: HxWx2 float32 (dx, dy) in pixels."""
    if prev_gray is cur_gray or np.array_equal(prev_gray, cur_gray):
        return np.zeros(cur_gray.shape + (2,), np.float32)
    if method == "farneback":
        return cv2.calcOpticalFlowFarneback(prev_gray, cur_gray, None, pyr_scale=0.5, levels=3, winsize=15,
                                            iterations=3, poly_n=5, poly_sigma=1.2, flags=0)
    if method == "dis":
        if not hasattr(_dis, "engine"):  # one DIS object per thread: it is not thread safe
            _dis.engine = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
        return _dis.engine.calc(prev_gray, cur_gray, None)
    raise ValueError(f"unknown flow method {method!r}")
