"""Closed-loop replay on recordings: the rebuilt path, the replay world, the metrics, the command and its errors."""

import csv
import json
import math

import cv2
import numpy as np
import pytest
from conftest import SHARED, assert_video, drawn_pixels, image_of, legend_of, made

from steerlab.cli import main
from steerlab.data.car import CARS, CH2_CAR
from steerlab.data.geometry import CAMERAS
from steerlab.data.readers import open_recording
from steerlab.data.speed import estimate_speed
from steerlab.pilot import Controls, Pilot
from steerlab.sim.core.driving import Trajectory, drive_loop
from steerlab.data.path import human_path
from steerlab.sim.replay.plots import path_summary
from steerlab.sim.replay.run import RESULT_FIELDS, replay_recording
from steerlab.sim.replay.world import Replay, ReplayWorld
from steerlab.sim.road.world import RecordOptions

HALL = SHARED / "donkeycar" / "hall"
needs_donkey = pytest.mark.skipif(not (HALL / "manifest.json").exists(), reason="../shared/data absent")


@pytest.fixture(scope="module")
def twisty(tmp_path_factory):
    """15 s of the expert on a twisty road, centre camera only, no drift episodes."""
    from steerlab.sim.road.run import record

    out = tmp_path_factory.mktemp("twisty") / "rec"
    record(out, RecordOptions(seed=11, minutes=0.25, road="twisty", drift=False, side_cameras=False), progress=False)
    return open_recording(out)


class Scripted:
    """A stand-in for the Pilot: answers tick k with `steering(k)` and counts its resets."""

    name, geometry, source = "scripted", "sim", "scripted"

    def __init__(self, rec, steering):
        self.convention, self.steering, self.k, self.resets = rec.convention, steering, 0, 0

    def reset(self):
        self.resets += 1

    def step(self, frame, speed=None):
        self.k += 1
        return Controls(self.steering(self.k - 1))


def test_human_path_of_a_circle():
    """Constant steering and speed come back as a circle of radius wheelbase / tan(angle)."""
    p = CH2_CAR
    t = np.arange(400) * 0.05
    path = human_path(np.full(400, 0.1), np.full(400, 10.0), t, p)
    radius = p.wheelbase / math.tan(0.1)
    centre = np.array([0.0, radius])  # a left turn from the origin heading along x
    np.testing.assert_allclose(np.hypot(path.x - centre[0], path.y - centre[1]), radius, rtol=1e-3)
    np.testing.assert_allclose(path.s[-1], 10.0 * t[-1], rtol=1e-9)
    np.testing.assert_allclose(path.psi[-1], path.s[-1] / radius, rtol=1e-3)
    # in numbers: 200 m on a circle of 2 pi r = 125.7 m turn 573 degrees left, within a 2r x 2r box
    one = path_summary(path)
    assert one["m"] == pytest.approx(200 - 0.5, rel=1e-9) and one["turned_deg"] == pytest.approx(
        math.degrees(199.5 / radius), rel=1e-3)
    np.testing.assert_allclose(one["box_m"], [2 * radius, 2 * radius], rtol=1e-3)


def test_replaying_the_human_scores_100_and_zero_steering_does_not(twisty):
    human = Scripted(twisty, lambda k: twisty.steering[k])
    rows, traj = replay_recording(human, Replay(CAMERAS["sim"], CARS["sim"]), twisty)
    whole = rows[-1]
    assert whole["segment"] == "all" and whole["interventions"] == 0 and whole["autonomy"] == 100.0
    assert whole["max_offset_m"] < 1e-9 and len(traj) == len(twisty) - 1
    np.testing.assert_allclose(whole["km"], np.sum(twisty.speed[:-1]) * 0.05 / 1000, rtol=1e-6)
    zero = Scripted(twisty, lambda k: 0.0)
    rows, traj = replay_recording(zero, Replay(CAMERAS["sim"], CARS["sim"]), twisty)
    assert rows[-1]["interventions"] >= 1 and rows[-1]["autonomy"] < 100
    assert zero.resets == 1 + rows[-1]["interventions"]  # the pilot forgets its past at the start and at every intervention
    assert rows[-1]["interventions_per_km"] == pytest.approx(rows[-1]["interventions"] / rows[-1]["km"])
    assert traj.interventions == rows[-1]["interventions"]


def test_leaving_the_path_or_turning_beyond_the_warp_is_an_intervention(twisty):
    """On a straight path along x with a 1 m limit: 1 m off is inside, beyond it (either side) the car is put back on
    the path; on the path, a heading error beyond the warp's 10 degrees is one too, 9 degrees is not; where the human
    stood still over the whole search there is no path to leave."""
    from steerlab.data.car import VehicleState

    replay, t = Replay(CAMERAS["sim"], CARS["sim"]), np.arange(60) * 0.05
    world = replay.world(twisty, 0, human_path(np.zeros(60), np.full(60, 10.0), t, CARS["sim"]))
    for y, deg, leaves in ((1.0, 0.0, False), (1.001, 0.0, True), (-1.001, 0.0, True), (0.0, 9.0, False),
                           (0.0, 11.0, True), (-0.5, -11.0, True)):
        world.vehicle.state = VehicleState(5.2, y, math.radians(deg), 10.0)
        put_back, offset, heading = world.intervene(1.0)
        assert put_back == leaves, (y, deg)
        if leaves:
            assert (offset, heading) == (0.0, 0.0) and (world.state.y, world.state.psi) == (0.0, 0.0)
        else:
            assert (offset, heading) == (pytest.approx(y), pytest.approx(math.radians(deg)))
    # exactly at the limits is inside: 1 m off, and the warp's 10 degrees either way
    assert not any(world.leaves_lane(o, h, 1.0) for o, h in ((1.0, 0.0), (-1.0, 0.0), (0.0, world.max_heading),
                                                              (0.0, -world.max_heading)))
    world.vehicle.state = VehicleState(5.2, 0.3, math.radians(340.0), 10.0)  # 5.2 m along, turned 20 deg right
    assert world.observe() == (pytest.approx(0.3), pytest.approx(math.radians(-20.0))) and world.s == pytest.approx(5.2)
    still = replay.world(twisty, 0, human_path(np.zeros(60), np.zeros(60), t, CARS["sim"]))
    still.vehicle.state = VehicleState(0.0, 5.0, 0.5, 0.0)
    assert still.observe() == (0.0, 0.0) and still.intervene(1.0) == (False, 0.0, 0.0)


def test_replay_world_matches_the_renderer_and_labels_point_back(twisty):
    """0.5 m right of the human's path the car sees what the renderer shows from there, and the label steers it
    back to the left of the human's steering."""
    wheel = twisty.convention.to_road_wheel_left(twisty.steering, CH2_CAR.steering_ratio)
    path = human_path(wheel, twisty.speed, twisty.timestamps_ns / 1e9, CH2_CAR)
    world = ReplayWorld(twisty, 0, path, CAMERAS["sim"], CH2_CAR)
    for _ in range(100):
        world.step(wheel[world.k])
    assert world.observe() == pytest.approx((0.0, 0.0), abs=1e-9)
    on_path = world.expert_steering()
    assert on_path == pytest.approx(wheel[100], abs=1e-9)  # on the path the label is the human's steering
    st = world.state
    world.vehicle.state = type(st)(st.x + 0.5 * math.sin(st.psi), st.y - 0.5 * math.cos(st.psi), st.psi, st.v)
    offset, heading = world.observe()
    assert offset == pytest.approx(-0.5, abs=0.02) and heading == pytest.approx(0.0, abs=0.005)
    assert world.expert_steering() > on_path + 0.01
    assert world.frame_index() == 100
    view = world.render()  # the recorded frame warped to the car's viewpoint (the warp is tested against the renderer)
    assert world.view == pytest.approx((-0.5, 0.0), abs=0.02) and view.shape == (160, 320, 3)
    assert not np.array_equal(view, twisty.load_frame(100))


def test_a_rollouts_side_cameras_look_like_the_recorded_ones(tiny_recording, tmp_path):
    """A rollout in replay of a recording with side cameras records them too, warped from the centre frame to
    0.508 m either side: on the path they match the recorded side cameras far better than the centre frame."""
    from steerlab.sim.replay.run import rollout_recording

    rec = open_recording(tiny_recording)
    out = tmp_path / "rollout"
    rollout_recording(Scripted(rec, lambda k: 0.0), Replay(CAMERAS["sim"], CARS["sim"]), rec, np.arange(100), out,
                      beta=1.0, seed=0)
    rollout = open_recording(out)
    assert rollout.cameras == ["center", "left", "right"]
    for k in (20, 60):  # the expert drives (beta 1): on the human's path
        for cam in ("left", "right"):
            truth = rec.load_frame(k, cam)[80:].astype(float)  # the road rows
            warped = np.abs(rollout.load_frame(k, cam)[80:] - truth).mean()
            assert warped < 0.7 * np.abs(rec.load_frame(k)[80:] - truth).mean(), (k, cam)


def test_streaming_state_is_carried_across_replay_steps(tiny_checkpoint, twisty):
    """A car that drives the human's path sees the recorded frames in order: the pilot's commands, smoothing
    state included, equal a plain frame-by-frame run over the same frames."""
    wheel = twisty.convention.to_road_wheel_left(twisty.steering, CH2_CAR.steering_ratio)
    path = human_path(wheel, twisty.speed, twisty.timestamps_ns / 1e9, CH2_CAR)
    world = ReplayWorld(twisty, 0, path, CAMERAS["sim"], CH2_CAR)
    traj = drive_loop(world, Pilot(tiny_checkpoint, smoothing=0.2), 100, 1.0, 20.0,
                      choose=lambda t: (wheel[t.index], t.throttle), progress=False)
    plain = Pilot(tiny_checkpoint, smoothing=0.2)
    expected = [plain.step(twisty.load_frame(i), twisty.speed[i]).steering for i in range(100)]
    np.testing.assert_allclose(traj.command, expected, atol=1e-6)


def test_speed_estimated_from_the_frames(twisty):
    estimate = estimate_speed(twisty, CAMERAS["sim"], count=40)
    assert estimate == pytest.approx(float(np.median(twisty.speed)), rel=0.1)


def test_replay_command_writes_its_report(tiny_checkpoint, twisty, tmp_path, capsys, saved_figures):
    out = tmp_path / "replay"
    assert main(["replay", str(tiny_checkpoint), str(tiny_checkpoint.parent / "last.pt"), "--data", str(twisty.source),
                 "--range", "0:70", "--out", str(out), "--video", str(tmp_path / "r.mp4"), "--workers", "1"]) == 0
    printed = capsys.readouterr().out
    assert "| checkpoint | recording | km |" in printed and "(recorded)" in printed
    rows = list(csv.DictReader(open(out / "replay.csv")))
    assert list(rows[0]) == RESULT_FIELDS and len(rows) == 2
    for r in rows:
        assert r["recording"] == twisty.name and float(r["km"]) > 0 and r["speed_source"] == "recorded"
        assert float(r["interventions_per_km"]) == pytest.approx(int(r["interventions"]) / float(r["km"]), rel=1e-3)
    for name in ("replay.md", "segments.csv"):
        assert (out / name).exists()
    assert [r["checkpoint"] for r in rows] == ["best", "last"]
    traj = Trajectory.read(out / "best" / "trajectory.csv")
    assert len(traj) == 69 and traj.interventions == int(rows[0]["interventions"])
    # replay.png: 12 x 4 inches at 100 dpi, each checkpoint's offset from the human's path along the route as its
    # trajectory.csv has it, drawn; the legend names them with their interventions, and the limit
    img = image_of(out / "replay.png")
    assert img.shape[:2] == (400, 1200)
    ax = saved_figures[str(out / "replay.png")].axes[0]
    assert legend_of(ax) == [f"best ({rows[0]['interventions']} interventions)",
                             f"last ({rows[1]['interventions']} interventions)", "intervention limit (+-1 m)"]
    best, last = ax.get_lines()[0:4:2]  # each offset line is followed by its intervention marks
    for label, line in (("best", best), ("last", last)):
        np.testing.assert_allclose(line.get_ydata(), Trajectory.read(out / label / "trajectory.csv").offset, atol=1e-4)
    # one epoch of training: best.pt and last.pt hold the same weights, so the last line covers the first
    assert drawn_pixels(img, ax, last.get_color()) > 200
    # path.png: the human's path of the one segment seen from above, its numbers in the legend and replay.json, and
    # a mark where each checkpoint was put back
    (summary,) = json.loads((out / "replay.json").read_text())["paths"]
    ax = saved_figures[str(out / "path.png")].axes[0]
    line = ax.get_lines()[0]
    assert len(line.get_xdata()) == 70  # a point per frame of 0:70
    drawn = np.hypot(np.diff(line.get_xdata()), np.diff(line.get_ydata())).sum()
    assert summary["m"] == pytest.approx(drawn, rel=1e-6) and summary["m"] > 10
    assert legend_of(ax) == [f"segment 0: {summary['m']:.0f} m, turned {summary['turned_deg']:+.0f} deg, "
                             f"{summary['box_m'][0]:.1f} x {summary['box_m'][1]:.1f} m", "best: put back",
                             "last: put back"]
    assert [len(m.get_xdata()) for m in ax.get_lines()[2:]] == [int(r["interventions"]) for r in rows]
    # a video per checkpoint: a frame every tick, the warped 320x160 view scaled to 640 wide over the panel
    for label in ("best", "last"):
        assert_video(tmp_path / f"r-{label}.mp4", 69, (640, 470))
    assert traj.frame[0] == 0 and (traj.segment == 0).all()
    assert main(["replay", str(tiny_checkpoint), "--data", str(twisty.source), "--range", "0:70", "--speed", "9",
                 "--out", str(tmp_path / "given"), "--workers", "1"]) == 0
    given = next(csv.DictReader(open(tmp_path / "given" / "replay.csv")))
    assert given["speed_source"] == "given (--speed)" and float(given["speed_mps"]) == pytest.approx(9.0)
    # --smoothing smooths the commands as when driving: the first tick is the same command, the second the mix
    assert main(["replay", str(tiny_checkpoint), "--data", str(twisty.source), "--range", "0:70", "--smoothing",
                 "0.2", "--out", str(tmp_path / "smooth"), "--workers", "1"]) == 0
    smooth = Trajectory.read(next((tmp_path / "smooth").glob("*/trajectory.csv"))).command
    assert smooth[0] == pytest.approx(traj.command[0], abs=1e-4)
    assert smooth[1] == pytest.approx(0.2 * traj.command[1] + 0.8 * traj.command[0], abs=1e-4)
    assert json.loads((tmp_path / "smooth" / "replay.json").read_text())["smoothing"] == 0.2
    assert "The steering is smoothed exponentially, a = 0.2." in (tmp_path / "smooth" / "replay.md").read_text()


def test_replay_without_speed_needs_one(tiny_checkpoint, twisty, tmp_path, capsys):
    """A recording without speed whose frames give no estimate is refused (tests/bad_input/test_recordings.py); with --speed
    it replays. A missing checkpoint is named."""
    assert main(["replay", str(tmp_path / "none.pt"), "--data", str(twisty.source), "--out", str(tmp_path / "x")]) == 2
    assert "none.pt: checkpoint not found" in capsys.readouterr().err
    flat = tmp_path / "flat"
    (flat / "center").mkdir(parents=True)
    ids = [1_000_000_000 + i * 50_000_000 for i in range(70)]
    for fid in ids:
        cv2.imwrite(str(flat / "center" / f"{fid}.jpg"), np.full((480, 640, 3), 90, np.uint8))
    (flat / "labels.csv").write_text("frame_id,steering_angle,public\n" + "".join(f"{f},0.0,1\n" for f in ids))
    ch2 = made(tmp_path, "steering_wheel", "left", "ch2", "ch2.pt")
    argv = ["replay", str(ch2), "--data", str(flat), "--labels", str(flat / "labels.csv"), "--workers", "1"]
    assert main([*argv, "--out", str(tmp_path / "x")]) == 2
    assert "cannot estimate the speed" in capsys.readouterr().err and not (tmp_path / "x").exists()
    assert main([*argv, "--speed", "10", "--out", str(tmp_path / "given")]) == 0
    row = next(csv.DictReader(open(tmp_path / "given" / "replay.csv")))
    assert row["speed_source"] == "given (--speed)" and float(row["km"]) == pytest.approx(10 * 69 * 0.05 / 1000)


@needs_donkey
def test_replay_a_donkeycar_tub_as_a_road(tmp_path, capsys):
    """With --world road a tub replays as a road car's recording (`test_replay_track.py` has its own replay)
    with the donkeycar geometry and its full-lock angle; the speed estimated from the hall's plain floor is no
    speed a donkeycar drives at, so it asks for --speed."""
    ckpt = made(tmp_path, "normalized", "right", "donkey", "donkey.pt", full_lock_deg=25)
    argv = ["replay", str(ckpt), "--data", str(HALL), "--reader", "full_lock_deg=25", "--range", "0:200",
            "--world", "road", "--workers", "1", "--out", str(tmp_path / "r")]
    assert main(argv) == 2
    assert "is not one this car drives at (0.3-8 m/s)" in capsys.readouterr().err
    assert main([*argv, "--speed", "2"]) == 0
    row = next(csv.DictReader(open(tmp_path / "r" / "replay.csv")))
    assert float(row["speed_mps"]) == 2.0 and row["recording"] == "hall"
    assert main(["replay", str(ckpt), "--data", str(HALL), "--range", "0:200", "--speed", "2", "--world", "road",
                 "--workers", "1", "--out", str(tmp_path / "y")]) == 2
    assert "full-lock angle" in capsys.readouterr().err  # a tub without full_lock_deg has no angles


def test_dagger_in_replay(twisty, tmp_path):
    """world: replay rolls the model out over the training frames, labels every visited view with the way back
    to the human's path in the recording's own convention, and replays the validation frames every round."""
    from steerlab.dagger import run_dagger
    from steerlab.train.config import load_config

    cfg = load_config(None, base={
        "data": str(twisty.source), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "dagger"),
        "split": {"train": "0:70", "val": "70:140"}, "train": {"epochs": 1, "batch_size": 32},
        "dagger": {"world": "replay", "iterations": 1, "beta": 0.0, "epochs": 1, "workers": 1}})
    run_dagger(cfg, progress=False)
    rows = list(csv.DictReader(open(tmp_path / "dagger" / "dagger.csv")))
    assert [r["round"] for r in rows] == ["0", "1"] and all(r["replay_interventions_per_km"] != "" for r in rows)
    assert list(rows[0])[5:] == ["replay_autonomy", "replay_interventions_per_km"] and rows[1]["recordings"] == "2"
    rollout = open_recording(tmp_path / "dagger" / "round1" / "rollouts" / "replay")
    assert rollout.convention == twisty.convention and rollout.geometry == "sim" and len(rollout) == 69
    assert set(rollout.extra["episode"]) == {"rollout"}
    np.testing.assert_array_equal(rollout.timestamps_ns, twisty.timestamps_ns[:69])
    # off the path, the label steers back towards it: left of the human's steering when the car is right of it
    human = twisty.steering[:69]
    off = np.abs(rollout.extra["lateral_offset"]) > 0.2
    assert off.any()
    back = np.sign(rollout.steering[off] - human[off]) == -np.sign(rollout.extra["lateral_offset"][off])
    assert back.mean() > 0.9
    replayed = list(csv.DictReader(open(tmp_path / "dagger" / "round1" / "replay" / "replay.csv")))
    assert float(replayed[0]["km"]) == pytest.approx(np.sum(twisty.speed[70:139]) * 0.05 / 1000, rel=0.05)


def test_record_suite_roads_only_when_asked(tmp_path):
    """record refuses the suite's reserved seeds unless asked for an evaluation recording, which then shows
    the suite's own road: as long as `drive` makes it, so the same frames."""
    from steerlab.errors import SteerlabError
    from steerlab.sim.road.run import record
    from steerlab.sim.road.suite import SuiteOptions
    from steerlab.sim.road.world import World

    with pytest.raises(SteerlabError, match="reserved"):
        record(tmp_path / "refused", RecordOptions(seed=9101, minutes=0.01), progress=False)
    assert not (tmp_path / "refused").exists() or not any((tmp_path / "refused").iterdir())
    out = record(tmp_path / "suite", SuiteOptions(minutes=0.1).record_options("country", 9101), progress=False,
                 suite_ok=True)
    rec = open_recording(out)
    assert len(rec) == 120
    first = World(9101, "country", "sim", 120 / 20).render()  # the suite's road for these minutes, as `drive` makes it
    assert np.abs(rec.load_frame(0).astype(int) - first).mean() < 4  # JPEG only
    longer = World(9101, "country", "sim", 240 / 20).render()  # a longer road from the same seed has other scenery
    assert np.abs(rec.load_frame(0).astype(int) - longer).mean() > 4
