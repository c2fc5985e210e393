"""Labels derived from the speed signal for the multi-task models of paper 002."""

from __future__ import annotations

import numpy as np

COMMANDS = ("decelerate", "maintain", "accelerate")


def speed_commands(speed: np.ndarray, timestamps_ns: np.ndarray, interval_s: float = 1.0,
                   threshold: float = 0.25) -> np.ndarray:
    """Paper 002 IV-B2: acceleration = (speed at the end - speed at the start of a 1 s interval) / interval;
    above +0.25 m/s^2 'accelerate' (2), below -0.25 'decelerate' (0), else 'maintain' (1).

    The interval starts at each frame and ends at the first frame at least `interval_s` later; the last
    frames, whose interval would run past the recording, use the shorter interval up to the last frame
    (the very last frame is "maintain")."""
    t = (np.asarray(timestamps_ns) - timestamps_ns[0]) / 1e9
    v = np.asarray(speed, float)
    end = np.minimum(np.searchsorted(t, t + interval_s - 1e-9), len(t) - 1)
    span = t[end] - t
    acc = np.where(span > 0, (v[end] - v) / np.where(span > 0, span, 1), 0.0)
    return np.where(acc > threshold, 2, np.where(acc < -threshold, 0, 1)).astype(np.int64)


def speed_targets(speed: np.ndarray, timestamps_ns: np.ndarray, segment: np.ndarray) -> dict[str, np.ndarray]:
    """Per frame, within its segment: "speed", the next frame's speed (the last frame of a segment keeps its
    own), and "command", the speed command of paper 002."""
    speed = np.asarray(speed, float)
    next_speed, command = speed.copy(), np.empty(len(speed), np.int64)
    bounds = np.flatnonzero(np.diff(segment)) + 1
    for a, b in zip(np.r_[0, bounds], np.r_[bounds, len(speed)]):
        next_speed[a: b - 1] = speed[a + 1: b]
        command[a:b] = speed_commands(speed[a:b], timestamps_ns[a:b])
    return {"speed": next_speed, "command": command}
