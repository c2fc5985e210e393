"""studies/lane_drive.py: the lap's stretches and the frames kept before a put-back, on hand-made drives."""

from types import SimpleNamespace

import numpy as np
import pytest


def _row(place, offset, seen_offset, put_back=0):
    return {"place_m": place, "offset_m": offset, "seen_offset_m": seen_offset, "heading_rad": -0.1,
            "seen_heading_rad": 0.0, "curvature": 0.8, "seen_curvature": 0.5, "put_back": put_back}


def test_each_stretch_of_the_lap_gives_the_true_lane_beside_the_heads_errors():
    """0-2 m: offsets -0.04 and +0.02 (mean |.| 0.03), seen +0.01 and +0.02 (errors 0.05 and 0: 0.025); 2-4 m one
    frame put back; 4-5 m (the lap's end) none: no row."""
    from studies.lane_drive import stretch_rows

    lines = stretch_rows([_row(0.5, -0.04, 0.01), _row(1.9, 0.02, 0.02), _row(2.0, -0.2, 0.0, put_back=1)], 5.0)
    assert lines == ["| 0-2 | 2 | 0.030 | 0.025 | 0.100 | 0.100 | 0.800 | 0.300 | 0 |",
                     "| 2-4 | 1 | 0.200 | 0.200 | 0.100 | 0.100 | 0.800 | 0.300 | 1 |"]


def test_the_frames_of_the_last_second_before_each_put_back_are_kept():
    """At 4 frames/s a second is the last 4 frames: 6 steps, a put-back (reset), 2 steps, another; the lane the head
    saw is kept for every step."""
    from studies.lane_drive import Seeing

    inner = SimpleNamespace(part=SimpleNamespace(controls=None), reset=lambda: None, name="m", geometry="donkey",
                            source="m.pt")

    def step(frame, speed=None):
        inner.part.controls = SimpleNamespace(lane=(0.01 * frame[0, 0], 0.0, 0.5))
        return SimpleNamespace(steering=0.1)

    inner.step = step
    seeing, frame = Seeing(inner, fps=4), np.zeros((2, 2), np.uint8)  # one buffer, drawn over every frame
    for k in range(6):
        frame[:] = k
        seeing.step(frame)
    seeing.reset()
    for k in range(6, 8):
        frame[:] = k
        seeing.step(frame)
    seeing.reset()
    assert [[i for i, _ in before] for before in seeing.before] == [[2, 3, 4, 5], [6, 7]]
    assert [int(f[0, 0]) for _, f in seeing.before[0]] == [2, 3, 4, 5]  # each frame as it was, copied
    assert seeing.seen[7] == pytest.approx((0.07, 0.0, 0.5, 0.1))
