"""studies/lane_drive.py: the lap's stretches and the frames kept before a put-back, on hand-made drives; the
expert's steering read back from a drive's poses."""

import math
from types import SimpleNamespace

import numpy as np
import pytest


def _row(place, offset, seen_offset, road_wheel=0.1, expert=0.3, put_back=0, seen=0.0):
    return {"place_m": place, "offset_m": offset, "seen_offset_m": seen_offset, "heading_rad": -0.1,
            "seen_heading_rad": seen, "curvature": 0.8, "seen_curvature": 0.5 + seen, "road_wheel": road_wheel,
            "expert_road_wheel": expert, "put_back": put_back}


def test_each_stretch_of_the_lap_gives_the_true_lane_beside_the_heads_errors_and_the_experts_steering():
    """0-2 m: offsets -0.04 and +0.02 (mean |.| 0.03), seen +0.01 and +0.02 (errors 0.05 and 0: 0.025); road-wheel
    angles 0.1 and -0.3 (mean -0.1) against the expert's 0.3 and -0.5 (mean -0.1): off by 0.2 either way; 2-4 m one frame put
    back; 4-5 m (the lap's end) none: no row. A model without a lane head (NaN seen): "-" where its errors were."""
    from studies.lane_drive import stretch_rows

    rows = [_row(0.5, -0.04, 0.01), _row(1.9, 0.02, 0.02, -0.3, -0.5), _row(2.0, -0.2, 0.0, put_back=1)]
    assert stretch_rows(rows, 5.0) == [
        "| 0-2 | 2 | 0.030 | 0.025 | 0.100 | 0.100 | 0.800 | 0.300 | -0.100 | -0.100 | 0.200 | 0 |",
        "| 2-4 | 1 | 0.200 | 0.200 | 0.100 | 0.100 | 0.800 | 0.300 | 0.100 | 0.300 | 0.200 | 1 |"]
    blind = [_row(0.5, -0.04, math.nan, seen=math.nan)]
    assert stretch_rows(blind, 2.0) == ["| 0-2 | 1 | 0.040 | - | 0.100 | - | 0.800 | - | 0.100 | 0.300 | 0.200 | 0 |"]


def test_the_experts_steering_is_read_back_from_a_ticks_pose_as_trajectory_csv_rounds_it():
    """A car driven off the centre line of taped track 9505, turned against its lane: the expert's road-wheel angle
    from its pose, read back in another world of the track from the pose's numbers rounded to trajectory.csv's four
    decimals, equals the driving world's own; without the heading error it would not."""
    from steerlab.sim.track.world import TrackWorld
    from studies.lane_drive import expert_road_wheel

    world = TrackWorld(9505, camera=None)
    for k in range(20):  # a second: 0.31 m left of the centre, turned 0.26 rad left of the lane
        world.step(0.05 * math.sin(k / 6), 0.6)
    offset, heading = world.observe()
    st, want = world.state, world.expert_steering()
    assert abs(offset) > 0.02 and abs(heading) > 0.05 and abs(want) > 0.05
    pose = [round(v, 4) for v in (st.x, st.y, world.s)]
    other = TrackWorld(9505, camera=None)
    assert expert_road_wheel(other, *pose, round(heading, 4), round(st.v, 4)) == pytest.approx(want, abs=2e-3)
    assert abs(expert_road_wheel(other, *pose, 0.0, round(st.v, 4)) - want) > 0.02


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
