"""studies/lane_drive.py: the lap's stretches and the frames kept before a put-back, on hand-made drives; the
expert's steering beside the model's, frame by frame."""

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
    angles 0.1 and -0.3 (mean -0.1) against the expert's 0.3 and -0.5 (mean -0.1): off by 0.2 either way; 2-4 m one
    frame put back; 4-5 m (the lap's end) none: no row. A model without a lane head (NaN seen): "-" where its errors
    were."""
    from studies.lane_drive import stretch_rows

    rows = [_row(0.5, -0.04, 0.01), _row(1.9, 0.02, 0.02, -0.3, -0.5), _row(2.0, -0.2, 0.0, put_back=1)]
    assert stretch_rows(rows, 5.0) == [
        "| 0-2 | 2 | 0.030 | 0.025 | 0.100 | 0.100 | 0.800 | 0.300 | -0.100 | -0.100 | 0.200 | 0 |",
        "| 2-4 | 1 | 0.200 | 0.200 | 0.100 | 0.100 | 0.800 | 0.300 | 0.100 | 0.300 | 0.200 | 1 |"]
    blind = [_row(0.5, -0.04, math.nan, seen=math.nan)]
    assert stretch_rows(blind, 2.0) == ["| 0-2 | 1 | 0.040 | - | 0.100 | - | 0.800 | - | 0.100 | 0.300 | 0.200 | 0 |"]


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


def test_a_model_without_a_lane_head_drives_with_the_experts_steering_beside_its_own(tmp_path):
    """An untrained donkeycar-tub model on taped track 9505 for 3 s: every frame's road-wheel angle is its steering
    through its convention, the expert's is the driving world's own from the car's pose at that tick, the lane it
    would see is left empty and the stretch table says "-" there."""
    import csv

    from steerlab.cli import run_script
    from steerlab.data.recording import SteeringConvention
    from steerlab.sim.track.world import TrackWorld
    from studies import lane_drive
    from tests.inputs import made

    plain = made(tmp_path, "normalized", geometry="donkey", full_lock_deg=25.0)
    out = tmp_path / "drive"
    run_script(lane_drive.parser(), lane_drive.main, [str(plain), "--seed", "9505", "--minutes", "0.05", "--throttle",
                                                      "0.3", "--out", str(out)])
    rows = list(csv.DictReader(open(out / "frames.csv")))
    ticks = list(csv.DictReader(open(out / "trajectory.csv")))
    assert len(rows) == len(ticks) == 60 and rows[0]["seen_offset_m"] == rows[-1]["seen_curvature"] == ""
    convention = SteeringConvention("normalized", "right", full_lock=math.radians(25.0))
    world = TrackWorld(9505, camera=None, throttle=0.3)
    for k, (row, tick) in enumerate(zip(rows, ticks)):  # the drive again, as the drive loop steps it
        world.intervene(0.0)
        assert float(row["road_wheel"]) == pytest.approx(convention.to_road_wheel_left(float(row["steering"]), 1.0))
        assert float(row["expert_road_wheel"]) == pytest.approx(world.expert_steering(), abs=1e-9), k
        assert float(tick["x"]) == pytest.approx(world.state.x, abs=1e-4)
        world.step(float(row["road_wheel"]))
    table = (out / "lane_drive.md").read_text()
    assert "| 0-2 | " in table and " | - | " in table and sum(int(r["put_back"]) for r in rows) >= 1
