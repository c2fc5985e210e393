"""Derived labels."""

from __future__ import annotations

import numpy as np

def speed_commands(speed: np.ndarray, timestamps_ns: np.ndarray, interval_s: float = 1.0,
                   threshold: float = 0.25) -> np.ndarray:
    """Paper 002 IV-B2: acceleration = (speed at the end - speed at the start of a 1 s interval) / interval;
    above +0.25 m/s^2 'accelerating' (2), below -0.25 'decelerating' (0), else 'maintaining' (1).

    The interval starts at each frame and ends at the first frame at least `interval_s` later; the last
    frames, whose interval would run past the recording, use the shorter interval up to the last frame
    (the very last frame is "maintaining")."""
    t = (np.asarray(timestamps_ns) - timestamps_ns[0]) / 1e9
    v = np.asarray(speed, float)
    end = np.minimum(np.searchsorted(t, t + interval_s - 1e-9), len(t) - 1)
    span = t[end] - t
    acc = np.where(span > 0, (v[end] - v) / np.where(span > 0, span, 1), 0.0)
    return np.where(acc > threshold, 2, np.where(acc < -threshold, 0, 1)).astype(np.int64)
