"""The track world wired in: laps and off-track events, the pilot's throttle through the one driving loop, the
donkeycar part as the pilot, `sim record/drive/bench --world track`."""

import csv
import hashlib
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import assert_video, drawn_along, drawn_pixels, image_of, legend_of, made
from steerlab.cli import main
from steerlab.data.car import CARS
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls
from steerlab.sim.core.driving import Trajectory, drive_loop
from steerlab.sim.core.part import PartPilot, donkey_pilot
from steerlab.sim.track.look import Look
from steerlab.sim.track.smallcar import speed_after, steady_speed
from steerlab.sim.track.world import Laps, RacerPilot, TrackWorld
from steerlab.sim.core.vehicle import VehicleState
from steerlab.sim.road.world import World

DONKEY = CARS["donkey"]
IDEAL = replace(DONKEY, drag=0.0, motor=replace(DONKEY.motor, rolling=0.0))  # the first-order throttle model alone


class Scripted:
    """A pilot with a fixed road-wheel angle (rad, positive left) and throttle (None: gives none) that counts
    its resets."""

    name, geometry, source = "scripted", "donkey", "scripted"
    convention = SteeringConvention("road_wheel", "left")

    def __init__(self, road_wheel=0.0, throttle=None):
        self.road_wheel, self.throttle, self.resets = road_wheel, throttle, 0

    def step(self, frame, speed=None):
        return Controls(self.road_wheel, throttle=self.throttle)

    def reset(self):
        self.resets += 1


def at_speed(world, v):
    st = world.state
    world.smallcar.state = VehicleState(st.x, st.y, st.psi, v)
    return world


def test_laps_are_timed_where_the_progress_passes_the_line():
    laps = Laps(10.0)
    for k in range(1, 81):  # 3 m/s in ticks of 0.1 s, and 2 m back over the line at 4 s
        laps.advance(-2.0 if k == 40 else 0.3, k / 10)
        if k == 50:
            laps.off_track()
    r = laps.result()
    # 10 m is passed between 9.9 m at 3.3 s and 10.2 m at 3.4 s: at 3.3 + 0.1 / 3 s; back to 9.7 m at 4 s and
    # over the line again (no lap), then 20 m between 19.9 m at 7.4 s and 20.2 m at 7.5 s
    assert laps.crossings == pytest.approx([0.0, 3.3 + 0.1 / 3, 7.4 + 0.1 / 3])
    assert r["lap_times_s"] == pytest.approx([10 / 3, 4.1])
    assert r["laps"] == 2 and r["off_track_laps"] == [2] and r["clean_laps"] == 1
    assert r["best_lap_s"] == r["mean_lap_s"] == pytest.approx(10 / 3)
    assert laps.progress == pytest.approx(79 * 0.3 - 2.0)
    first = Laps(10.0)
    first.advance(12.0, 2.0)  # 12 m in the first 2 s from the start: the line passed at 10 / 12 of them
    assert first.crossings == pytest.approx([0.0, 5 / 3])
    assert Laps(5.0).result() == {"laps": 0, "clean_laps": 0, "best_lap_s": None, "mean_lap_s": None,
                                  "lap_times_s": [], "off_track_laps": []}


def test_lap_time_of_a_constant_speed_drive_is_the_lap_over_the_speed():
    """Throttle 0.4 of the 5 m/s motor without drag holds 2 m/s exactly; following the lane centre, a lap takes
    the track's length over 2 m/s (the rear axle cuts the turns by a few millimetres)."""
    world = at_speed(TrackWorld(5, camera=None, throttle=0.4, car=IDEAL), 2.0)
    pilot = Scripted()
    pilot.step = lambda frame, speed=None: Controls(world.expert_steering())
    t = drive_loop(world, pilot, int(round(20 * world.track.length)) + 20, 0.0, 20.0, progress=False)
    assert np.all(t.speed == 2.0) and t.interventions == 0
    r = world.laps.result()
    assert r["laps"] == r["clean_laps"] == 2
    assert r["lap_times_s"] == pytest.approx([world.track.length / 2.0] * 2, rel=5e-3)
    assert r["best_lap_s"] == min(r["lap_times_s"]) and r["mean_lap_s"] == pytest.approx(np.mean(r["lap_times_s"]))


def test_the_expert_races_laps_without_leaving_the_lane():
    for seed in (0, 9402):
        world = TrackWorld(seed, camera=None)
        t = drive_loop(world, RacerPilot(world, seed), 1200, 0.0, 20.0, progress=False)
        r = world.laps.result()
        assert t.interventions == 0 and r["laps"] >= 3 and r["clean_laps"] == r["laps"]
        assert 1.0 < world.track.length / r["mean_lap_s"] < 5.0  # racing speeds of a 1:10 car
        assert sum(r["lap_times_s"]) <= 60.0 and world.overhang() < 0


def test_the_expert_as_a_pilot_drifts_out_recovers_and_keeps_under_its_cap():
    """With drift episodes every 2 s, the expert drifts out by its offset and recovers (never leaving the lane);
    its throttle is capped at 0.5 and it brakes below zero into the turns."""
    world = TrackWorld(0, camera=None)
    pilot = RacerPilot(world, 0, drift_every_s=2.0, max_throttle=0.5)
    episodes, throttles = [], []

    def on_step(tick):
        episodes.append(pilot.episode)
        throttles.append(tick.throttle)

    t = drive_loop(world, pilot, 400, 0.0, 20.0, progress=False, on_step=on_step)
    assert t.interventions == 0 and {"normal", "drift-out", "recover"} == set(episodes)
    assert max(throttles) == 0.5 and min(throttles) < 0
    pilot.racer.act = lambda state, s, offset, t: (0.1, -0.9, "normal")  # a harder brake than the cap: capped too
    assert pilot.step(None) == Controls(0.1, throttle=-0.5)


def test_full_lock_leaves_the_lane_when_the_body_corner_crosses_the_line_and_the_car_is_put_back():
    """From the start line at 1 m/s with full left lock the rear axle turns on a circle of radius
    wheelbase / tan(25 deg); the front left corner of the body (0.35 m ahead of the axle, 0.1 m left) crosses the
    lane's edge 0.45 m left of the centre at heading theta where R (1 - cos) + 0.35 sin + 0.1 cos = 0.45."""
    world = at_speed(TrackWorld(2, camera=None, throttle=0.2, car=IDEAL), 1.0)
    radius = DONKEY.wheelbase / math.tan(DONKEY.full_lock)
    lo, hi = 0.0, math.pi / 2
    for _ in range(60):
        theta = (lo + hi) / 2
        lateral = radius * (1 - math.cos(theta)) + 0.35 * math.sin(theta) + 0.1 * math.cos(theta)
        lo, hi = (theta, hi) if lateral < world.track.lane_width / 2 else (lo, theta)
    crossing = theta * radius / 1.0 * 20  # in ticks
    assert abs(crossing - round(crossing)) > 0.1  # not on a tick: the tick of the event is unambiguous
    pilot = Scripted(DONKEY.full_lock)
    t = drive_loop(world, pilot, 100, 0.0, 20.0, progress=False)
    events = np.flatnonzero(t.intervention)
    assert events[0] == math.ceil(crossing)
    assert np.abs(t.offset[events]).max() < 1e-3 and np.abs(t.heading[events]).max() < 1e-3  # on the centre line
    assert np.all(t.speed == 1.0)  # at its speed
    assert pilot.resets == t.interventions == len(events) >= 5
    assert world.laps.dirty == {1}
    # a bit more room: the body may overhang by 5 cm before it counts, so the first event comes later
    again = drive_loop(at_speed(TrackWorld(2, camera=None, throttle=0.2, car=IDEAL), 1.0), Scripted(DONKEY.full_lock),
                       100, 0.05, 20.0, progress=False)
    assert np.flatnonzero(again.intervention)[0] > events[0]


def test_a_pilot_that_steers_straight_leaves_the_lane_at_every_turn():
    world = TrackWorld(1, camera=None)
    pilot = Scripted(0.0)
    t = drive_loop(world, pilot, 1200, 0.0, 20.0, progress=False)
    hits = t.intervention
    assert t.interventions >= 10 and pilot.resets == t.interventions
    assert np.abs(t.offset[hits]).max() < 1e-3  # put back on the lane centre (to the sampling of the track)
    assert world.laps.progress > world.track.length  # put back where it left, it goes on round the track
    r = world.laps.result()
    assert r["laps"] >= 1 and r["clean_laps"] == 0 and set(r["off_track_laps"]) >= set(range(1, r["laps"] + 1))


def test_the_loop_passes_the_pilots_throttle_and_the_road_world_keeps_its_speeds():
    world = TrackWorld(3, camera=None, car=IDEAL)
    t = drive_loop(world, Scripted(0.0, throttle=0.6), 10, 0.0, 20.0, progress=False)
    # from standstill the speed approaches 0.6 x 5 m/s with the 0.3 s lag: 3 (1 - exp(-k 0.05 / 0.3))
    np.testing.assert_allclose(t.speed, 3.0 * (1 - np.exp(-np.arange(10) * 0.05 / 0.3)), atol=1e-12)
    v = world.state.v
    drive_loop(world, Scripted(0.0, throttle=-1.0), 1, 0.0, 20.0, progress=False)  # the ESC brakes
    assert world.state.v == pytest.approx(speed_after(v, -1.0, 0.05, IDEAL)) and world.applied == -1.0
    assert world.record_row(0)["brake"] == 1.0 and world.record_row(0)["throttle"] == 0.0
    # a pilot that gives no throttle drives at the world's constant one
    t = drive_loop(TrackWorld(3, camera=None, throttle=0.2, car=IDEAL), Scripted(0.0), 10, 0.0, 20.0, progress=False)
    np.testing.assert_allclose(t.speed, 1.0 * (1 - np.exp(-np.arange(10) * 0.05 / 0.3)), atol=1e-12)
    # the road world follows its road's speed profile whatever throttle a pilot gives
    pilot = Scripted(0.0)
    pilot.convention = SteeringConvention("steering_wheel", "left")
    runs = []
    for throttle in (None, 1.0, -1.0):
        pilot.throttle = throttle
        runs.append(drive_loop(World(4, "country", "sim", 5.0), pilot, 40, 1.0, 20.0, progress=False).speed)
    assert np.array_equal(runs[0], runs[1]) and np.array_equal(runs[0], runs[2])


class Part:
    """A donkeycar part: run(img_arr) -> (angle, throttle); it records what it was given."""

    def __init__(self, angle=0.5, throttle=0.25):
        self.out, self.frames = (angle, throttle), []

    def run(self, img_arr):
        self.frames.append(img_arr)
        return self.out


def test_any_donkeycar_part_drives_through_the_adapter():
    part = Part(angle=0.5, throttle=0.25)
    pilot = PartPilot(part, 25.0)
    world = TrackWorld(1)
    frame = world.render()  # BGR; the part gets RGB, as donkeycar's cameras give it
    t = drive_loop(world, pilot, 3, 0.0, 20.0, progress=False)
    assert part.frames[0].shape == (120, 160, 3) and np.array_equal(part.frames[0], frame[..., ::-1])
    assert pilot.name == "Part" and pilot.geometry == "donkey"
    # angle 0.5, positive right: half of the 25-degree lock to the right; its throttle moves the car
    assert pilot.convention.to_road_wheel_left(0.5, 1.0) == pytest.approx(-math.radians(12.5))
    assert np.all(t.command == 0.5) and world.applied == 0.25 and world.state.v > 0
    assert pilot.step(frame).steering == 0.5
    part.out = (3.0, -2.0)  # beyond what the servo and the ESC take
    assert (pilot.step(frame).steering, pilot.step(frame).throttle) == (1.0, -1.0)
    for bad in (None, (0.1,), ("left", 0.2), (float("nan"), 0.1)):
        part.out = bad
        with pytest.raises(SteerlabError, match="run"):
            pilot.step(frame)
    with pytest.raises(SteerlabError, match="not a donkeycar part"):
        PartPilot(object(), 25.0)


def test_the_steerlab_part_as_pilot_gives_what_the_part_gives(tmp_path):
    from steerlab.donkey import SteerlabPilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    pilot = donkey_pilot(ckpt, throttle=0.35)
    part = SteerlabPilot(ckpt, 0.35, full_lock_deg=25.0, reset_after_s=None)
    world = TrackWorld(1)
    frames = [world.render()]
    for _ in range(3):
        world.step(0.0, 0.5)
        frames.append(world.render())
    for frame in frames:
        controls = pilot.step(frame, world.state.v)
        assert (controls.steering, controls.throttle) == part.run(frame[..., ::-1], world.state.v)
    assert controls.throttle == 0.35 and pilot.geometry == "donkey" and pilot.name == "pilotnet"


def test_sim_record_world_track_writes_a_tub_both_readers_read(tmp_path, donkeycar_tub_or_none):
    tub = tmp_path / "tub"
    assert main(["sim", "record", "--world", "track", "--seed", "27", "--minutes", "0.1", "--out", str(tub)]) == 0
    lines = (tub / "manifest.json").read_text().splitlines()
    deleted = json.loads(lines[4])["deleted_indexes"]
    records = [json.loads(line) for line in (tub / "catalog_0.catalog").read_text().splitlines()]
    assert len(records) == 120 and 0 < len(deleted) < 60  # the drift-outs (one here), marked deleted
    rec = open_recording(tub)
    assert len(rec) == 120 - len(deleted) and rec.geometry == "donkey" and rec.convention.kind == "normalized"
    kept = [r for r in records if r["_index"] not in deleted]
    np.testing.assert_array_equal(rec.steering, [r["user/angle"] for r in kept])
    assert np.abs(rec.steering).max() <= 1 and rec.throttle.max() > 0.3
    # every stretch kept after a cut is a session (a segment) of its own
    cuts = sum(1 for i in deleted if i + 1 not in deleted and i + 1 < 120)
    assert len(rec.segments()) == cuts + 1 == len(json.loads(lines[3])["sessions"]["all_full_ids"])
    # steerlab's own layout of the same drive keeps the drift-outs with their episode, in the same unit
    native = tmp_path / "native"
    assert main(["sim", "record", "--world", "track", "--seed", "27", "--minutes", "0.1", "--layout", "steerlab",
                 "--out", str(native)]) == 0
    full = open_recording(native)
    episodes = full.extra["episode"]
    assert len(full) == 120 and set(episodes) == {"normal", "drift-out", "recover"}
    assert list(np.flatnonzero(episodes == "drift-out")) == deleted
    np.testing.assert_allclose(full.steering[episodes != "drift-out"], rec.steering, atol=1e-6)
    assert full.convention.full_lock == pytest.approx(math.radians(25))
    # the tub's lane values are those of steerlab's layout (which writes 6 decimals), under the same names
    for name in ("lateral_offset", "heading_error", "curvature"):
        np.testing.assert_allclose(rec.extra[name], full.extra[name][episodes != "drift-out"], atol=1e-6)
    assert np.ptp(rec.extra["curvature"]) > 0.1 and np.abs(rec.extra["lateral_offset"]).max() > 0.01
    # the frames and the steering and throttle are those the build before the lane values wrote, byte for byte
    images = hashlib.sha256(b"".join((tub / "images" / r["cam/image_array"]).read_bytes() for r in records))
    controls = json.dumps([(r["user/angle"], r["user/throttle"]) for r in records]).encode()
    assert images.hexdigest() == "da2ae42dd854386e683487ab969bde4aca7a2cebd43d1f73b745952186c722d6"
    assert hashlib.sha256(controls).hexdigest() == "2da93b67a12e9d6abecedaf0727e9e3a6b951b8a24122fa4e52a8c88ab3b8817"
    if donkeycar_tub_or_none is not None:
        theirs = donkeycar_tub_or_none.Tub(str(tub), read_only=True)
        assert [(r["user/angle"], r["lane/offset"]) for r in theirs] == [(r["user/angle"], r["lane/offset"])
                                                                         for r in kept]
        theirs.close()


@pytest.fixture
def donkeycar_tub_or_none(request):
    try:
        return request.getfixturevalue("donkeycar_tub")
    except pytest.skip.Exception:
        return None


def test_sim_drive_world_track_with_a_tub_checkpoint(tmp_path, capsys, saved_figures):
    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    out = tmp_path / "drive"
    assert main(["sim", "drive", str(ckpt), "--world", "track", "--minutes", "0.025", "--throttle", "0.4",
                 "--out", str(out), "--video", str(out / "drive.mp4")]) == 0
    assert "off_track" in capsys.readouterr().out
    result = json.loads((out / "drive.json").read_text())
    with open(out / "trajectory.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 30 and result["label"] == "pilotnet" and result["style"] == "taped"
    assert result["off_track"] == sum(int(r["intervention"]) for r in rows)
    assert result["autonomy"] == pytest.approx((1 - result["off_track"] * 6 / 1.5) * 100)
    assert float(rows[-1]["speed"]) > 1.0  # throttle 0.4 for a steering model
    # track.png, 13 x 5.5 inches at 100 dpi: the driven line on the track and the speed over time as
    # trajectory.csv has them, both drawn, and the legend; frames.png: the first frame of the fisheye camera
    img = image_of(out / "track.png")
    assert img.shape[:2] == (550, 1300)
    the_track, speed = saved_figures[str(out / "track.png")].axes
    assert legend_of(the_track) == ["start line", f"pilotnet ({result['off_track']} off track)"]
    drive = Trajectory.read(out / "trajectory.csv")
    path, line = the_track.get_lines()[4], speed.get_lines()[0]
    np.testing.assert_allclose(path.get_xydata()[~drive.intervention.astype(bool)],
                               np.c_[drive.x, drive.y][~drive.intervention.astype(bool)], atol=1e-4)
    np.testing.assert_allclose(line.get_ydata(), drive.speed, atol=1e-4)
    assert drawn_along(img, the_track, path) > 0.9 and drawn_pixels(img, speed, line.get_color()) > 200
    strip = image_of(out / "frames.png")
    assert strip.shape[:2] == (120, 160) and strip.std() > 5
    # drive.mp4: a frame every tick, the 160x120 camera scaled to 640 wide over the panel of 150 rows
    assert_video(out / "drive.mp4", 30, (640, 630))


def test_a_model_that_learned_the_throttle_drives_the_track_with_its_own(tmp_path, capsys):
    """--throttle is the constant of a model that predicts none: refused for a throttle model (it would change
    nothing), in a drive and in a bench whose every model learned its own (`learns_throttle` tells them apart); a
    throttle model drives with its own."""
    from steerlab.sim.core.part import learns_throttle

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    steering = made(tmp_path, "normalized", "right", "donkey", name="steering.pt", full_lock_deg=25)
    assert learns_throttle(ckpt) and not learns_throttle(steering)
    for argv in (["drive", str(ckpt)], ["bench", str(ckpt)]):
        assert main(["sim", *argv, "--world", "track", "--minutes", "0.02", "--throttle", "0.6", "--out",
                     str(tmp_path / "refused")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "learned" in err and f"the throttle 0.6 (steerlab sim {argv[0]} --throttle) " \
            "is the constant throttle of a model that predicts none" in err and "leave it out" in err, err
    assert not (tmp_path / "refused").exists()
    out = tmp_path / "own"
    assert main(["sim", "drive", str(ckpt), "--world", "track", "--minutes", "0.02", "--out", str(out)]) == 0
    with open(out / "trajectory.csv") as f:
        speeds = [[float(r["speed"]) for r in csv.DictReader(f)]]
    assert max(speeds[0]) > 0
    out = tmp_path / "capped"  # --max-throttle caps the learned throttle: no faster than that throttle holds
    assert main(["sim", "drive", str(ckpt), "--world", "track", "--minutes", "0.02", "--max-throttle", "0.05",
                 "--out", str(out)]) == 0
    with open(out / "trajectory.csv") as f:
        capped = [float(r["speed"]) for r in csv.DictReader(f)]
    assert max(capped) <= steady_speed(0.05, 1 / 20, CARS["donkey"]) + 1e-4 < max(speeds[0])


def test_the_throttle_scale_multiplies_the_learned_throttle_before_the_cap(tmp_path):
    """--throttle-scale: the part's throttle is the model's times the scale, then capped (hand-computed products and
    caps); a scale of 0.1 under a cap of 1 drives at less than half the top speed of the model's own throttle."""
    from steerlab.pilot import Pilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    frame = TrackWorld(9401, 0.9, "taped", 20.0).render()
    learned = Pilot(ckpt).step(frame, 0.0).throttle
    assert learned > 0
    for scale, cap, expected in [(1.0, 1.0, learned), (0.5, 1.0, 0.5 * learned), (3.0, 1.0, min(3 * learned, 1.0)),
                                 (2.0, learned, learned)]:
        got = donkey_pilot(ckpt, 0.3, max_throttle=cap, throttle_scale=scale).step(frame, 0.0).throttle
        assert got == pytest.approx(expected, abs=1e-5)
    speeds = {}
    for scale in ("1", "0.1"):
        out = tmp_path / scale
        assert main(["sim", "drive", str(ckpt), "--world", "track", "--minutes", "0.02", "--max-throttle", "1",
                     "--throttle-scale", scale, "--out", str(out)]) == 0
        with open(out / "trajectory.csv") as f:
            speeds[scale] = max(float(r["speed"]) for r in csv.DictReader(f))
    assert 0 < speeds["0.1"] < speeds["1"] / 2


def test_the_learned_throttle_is_capped_both_ways_and_braking_is_scaled_too(tmp_path):
    """The part's throttle of a model that learned it, by hand: the learned value times the scale, then capped to
    +-max_throttle, forward and braking alike (the model's answers replaced by known ones)."""
    from steerlab.donkey import SteerlabPilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    frame = np.zeros((120, 160, 3), np.uint8)
    for learned, scale, cap, expected in [(0.4, 0.5, 0.3, 0.2), (0.4, 2.0, 0.5, 0.5), (-0.8, 0.5, 0.3, -0.3),
                                          (-0.8, 0.5, 0.5, -0.4), (-0.8, 2.0, 1.0, -1.0)]:
        part = SteerlabPilot(ckpt, throttle_scale=scale, max_throttle=cap)
        part.pilot.step = lambda image, speed=None, learned=learned: Controls(0.1, throttle=learned)
        assert part.run(frame) == pytest.approx((0.1, expected))
    # a speed-command model: the throttle steps by command_step up (2) or down (0) from 0.3, within [0, max_throttle]
    command = made(tmp_path, "normalized", "right", "donkey", name="command.pt", model="speed-command")
    part = SteerlabPilot(command, 0.3, command_step=0.1, max_throttle=0.5)
    for said, expected in [(2, 0.4), (2, 0.5), (2, 0.5), (0, 0.4), (0, 0.3), (0, 0.2), (0, 0.1), (0, 0.0), (0, 0.0)]:
        part.pilot.step = lambda image, speed=None, said=said: Controls(0.0, command=said)
        assert part.run(frame)[1] == pytest.approx(expected)
    # the part's numbers in their intervals: closed ends taken, open ones and booleans refused, the interval named
    steering = made(tmp_path, "normalized", "right", "donkey", name="steering.pt", full_lock_deg=25)
    SteerlabPilot(steering, throttle=0.0, kp=0.0, ki=0.0, command_step=0.0, max_throttle=1.0)
    for given, said in [({"throttle": True}, r"throttle must be a number in \[0, 1\], got True"),
                        ({"throttle": 1.5}, r"throttle must be a number in \[0, 1\], got 1.5"),
                        ({"max_throttle": 0.0}, r"max_throttle must be a number in \(0, 1\], got 0.0")]:
        with pytest.raises(SteerlabError, match=f"^SteerlabPilot: {said}$"):
            SteerlabPilot(steering, **given)


def test_the_parts_throttle_floor_holds_only_while_the_measured_speed_says_the_car_stands(tmp_path):
    """`SteerlabPilot(throttle_floor=)` on a car, by hand: a learned brake (-0.2, scaled 1.5 to -0.3) becomes the
    floor 0.25 below 0.1 m/s and stays a brake at 0.1 m/s and above; the floor within the cap; without the measured
    speed, or on a model of a constant throttle, the part refuses in one line."""
    from steerlab.donkey import SteerlabPilot
    from steerlab.sim.core.part import donkey_pilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    frame = np.zeros((120, 160, 3), np.uint8)
    for speed, cap, expected in [(0.0, 1.0, 0.25), (0.09, 1.0, 0.25), (0.1, 1.0, -0.3), (2.0, 1.0, -0.3),
                                 (0.0, 0.2, 0.2)]:
        part = SteerlabPilot(ckpt, throttle_scale=1.5, throttle_floor=0.25, max_throttle=cap)
        part.pilot.step = lambda image, speed=None: Controls(0.1, throttle=-0.2)
        assert part.run(frame, speed) == pytest.approx((0.1, expected))
    part = SteerlabPilot(ckpt, throttle_scale=1.5, throttle_floor=0.25, max_throttle=1.0)
    part.pilot.step = lambda image, speed=None: Controls(0.1, throttle=0.6)  # above the floor: as it is
    assert part.run(frame, 0.0) == pytest.approx((0.1, 0.9))
    # in the track world the part's cap bounds the floor too: x 1 at a cap of 0.15, a floor of 0.5 gives 0.15
    world_part = donkey_pilot(ckpt, 0.3, max_throttle=0.15, throttle_floor=0.5)
    world_part.part.pilot.step = lambda image, speed=None: Controls(0.1, throttle=-0.2)
    assert world_part.step(frame, 0.0).throttle == pytest.approx(0.15)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: the throttle floor needs the measured speed \(m/s\) "
                                            r"with every frame: add the car's odometry \(HAVE_ODOM = True\)"):
        part.run(frame)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: throttle_floor must be a number in \[0, 1\], got 1.5$"):
        SteerlabPilot(ckpt, throttle_floor=1.5)
    steering = made(tmp_path, "normalized", "right", "donkey", name="steering.pt", full_lock_deg=25)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: throttle_floor shapes a learned throttle; steering.pt "
                                            r"drives at a constant throttle"):
        SteerlabPilot(steering, throttle_floor=0.2)


def test_sim_bench_world_track_writes_its_tables_and_reuses_drives(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    ckpt = made(tmp_path / "a", "normalized", "right", "donkey", name="best.pt", full_lock_deg=25)
    out = tmp_path / "bench"
    argv = ["sim", "bench", str(ckpt), "--world", "track", "--styles", "centre", "--minutes", "0.02",
            "--workers", "1", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "| a | centre | 0 of 2 |" in printed and "| a | all | 0 of 2 |" in printed
    assert "| checkpoint | centre-9451 | centre-9452 |" in printed
    with open(out / "suite.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["style"], r["seed"]) for r in rows] == [("centre", "9451"), ("centre", "9452")]
    assert {"laps", "clean_laps", "best_lap_s", "expert_mean_lap_s", "off_track_per_lap", "autonomy"} <= set(rows[0])
    with open(out / "summary.csv") as f:
        summary = list(csv.DictReader(f))
    assert [s["style"] for s in summary] == ["centre", "all"]
    assert int(summary[1]["off_track"]) == sum(int(r["off_track"]) for r in rows)
    expert = json.loads((out / "expert-max0.5" / "centre-9451" / "drive.json").read_text())
    assert expert["off_track"] == 0 and expert["cache_key"] == {"suite": "t1", "minutes": 0.02, "max_throttle": 0.5}
    assert sorted(p.name for p in (out / "tracks").glob("*.png")) == ["centre-9451.png", "centre-9452.png"]
    key = json.loads((out / "a" / "centre-9451" / "drive.json").read_text())["cache_key"]
    assert key["throttle"] == 0.3 and key["camera"] is None and key["suite"] == "t1"
    stamp = (out / "a" / "centre-9451" / "drive.json").stat().st_mtime_ns
    assert main(argv) == 0  # reused
    assert (out / "a" / "centre-9451" / "drive.json").stat().st_mtime_ns == stamp
    assert main([*argv, "--throttle", "0.4"]) == 0  # another throttle: driven anew
    assert (out / "a" / "centre-9451" / "drive.json").stat().st_mtime_ns != stamp
    assert "throttle_scale" not in key  # at its default: drives kept before the option existed stay reusable
    # a scale shapes a learned throttle: on this model of a constant one it is refused, as the car's part refuses it
    assert main([*argv, "--throttle-scale", "1.5"]) == 2
    assert capsys.readouterr().err == (f"error: throttle_scale shapes a learned throttle; {ckpt} drives at a constant "
                                       "throttle: leave throttle_scale out\n")  # before any drive
    (tmp_path / "b").mkdir()  # a model that learned the throttle races scaled
    learned = made(tmp_path / "b", "normalized", "right", "donkey", name="best.pt", full_lock_deg=25, throttle=True)
    assert main(["sim", "bench", str(learned), *argv[3:-1], str(tmp_path / "scaled"), "--throttle-scale", "1.5"]) == 0
    key = json.loads((tmp_path / "scaled" / "b" / "centre-9451" / "drive.json").read_text())["cache_key"]
    assert key["throttle_scale"] == 1.5
    assert "(the learned one times 1.5 first)" in (tmp_path / "scaled" / "suite.md").read_text()


def test_the_suites_tracks_are_recorded_only_for_evaluation(tmp_path):
    from steerlab.sim.track.track import Track
    from steerlab.sim.track.suite import TRACK_SUITES, TrackSuiteOptions
    from steerlab.sim.track.run import record

    o = replace(TrackSuiteOptions(minutes=0.01).record_options("taped", 9401), layout="steerlab")
    assert o.lane_width == TRACK_SUITES["t1"]["lane_width"] and not o.drift
    with pytest.raises(SteerlabError, match="reserved for the track suites"):
        record(tmp_path / "refused", o, progress=False)
    meta = json.loads((record(tmp_path / "eval", o, progress=False, suite_ok=True) / "recording.json").read_text())
    assert meta["seed"] == 9401 and meta["lap_m"] == pytest.approx(Track(9401, o.lane_width, "taped").length)


def test_a_track_rollout_labels_every_visited_frame_with_the_experts_steering_and_throttle(tmp_path):
    """DAgger's data collection in the track world: whoever drives a tick (the model with beta 0, the expert with
    beta 1), every visited frame is written to a tub labelled with the expert's steering and throttle in that state
    (the stateless `expert_controls`), and the car moves by the driver's commands: driving the same commands again
    visits the same states."""
    from steerlab.data.fisheye import DONKEY_FISHEYE
    from steerlab.sim.track.run import rollout

    results = {}
    for beta in (0.0, 1.0):
        out = tmp_path / f"beta-{beta:g}"
        results[beta] = rollout(Scripted(0.08, throttle=0.5), out, 7, 0.05, "centre", beta)
        world, labels = TrackWorld(7, style="centre", camera=None), []
        for _ in range(60):
            world.intervene(0.0)
            labels.append(world.expert_controls())
            world.step(*(labels[-1] if beta else (0.08, 0.5)))
        wheel, throttle = np.array(labels).T
        rec = open_recording(out)
        assert len(rec) == 60 and rec.geometry == "donkey" and rec.fisheye == DONKEY_FISHEYE
        np.testing.assert_allclose(rec.steering, np.clip(-wheel / DONKEY.full_lock, -1, 1), atol=1e-9)
        np.testing.assert_allclose(rec.throttle, np.clip(throttle, -1, 1), atol=1e-9)
        assert np.ptp(rec.throttle) > 0.1 and np.ptp(rec.steering) > 0.05  # not the model's constant commands
    assert results[0.0].off_track > 0 == results[1.0].off_track  # the model circles off; the expert races on
    assert results[0.0].seed == 7 and results[0.0].style == "centre"


def test_dagger_in_the_track_world(tmp_path):
    """One DAgger round on a tiny tub: the model, through the donkeycar part, races a fresh track of each style
    with the expert labelling, the rollouts are tubs of the expert's labels added to round 1's training data,
    and every round drives the track suite into dagger.csv's track columns."""
    from steerlab.dagger import run_dagger
    from steerlab.sim.track.run import record
    from steerlab.sim.track.world import TrackRecordOptions
    from steerlab.train.config import load_config, parse_config
    from steerlab.train.sources import prepare_dataset, training_sources

    record(tmp_path / "tub", TrackRecordOptions(seed=1, minutes=0.05, drift=False), progress=False)
    out = tmp_path / "dagger"
    cfg = load_config(None, base={
        "data": str(tmp_path / "tub"), "cache": str(tmp_path / "cache"), "out": str(out),
        "preprocess": {"preset": "donkey", "color": "gray"}, "model": {"name": "pilotnet"},
        "split": {"train": "0:40", "val": "40:60"}, "train": {"epochs": 1, "batch_size": 16, "throttle_weight": 0.5},
        "dagger": {"world": "track", "iterations": 1, "minutes": 0.05, "epochs": 1, "suite": "t1",
                   "suite_minutes": 0.01, "suite_styles": "centre", "workers": 1}})
    assert run_dagger(cfg, progress=False) == out / "best.pt"
    with open(out / "dagger.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["round"] for r in rows] == ["0", "1"] and rows[1]["recordings"] == "3" and float(rows[1]["beta"]) == 0.5
    assert all(r["off_track_per_lap"] != "" for r in rows)  # the track world's columns, none of another place's
    assert list(rows[0])[5:] == ["clean_laps_pct", "lap_ratio", "off_track_per_lap"]
    assert rows[1]["rollout_autonomy"] != ""
    for r in (0, 1):  # the suite of every round: the centre-line tracks
        with open(out / f"round{r}" / "suite" / "suite.csv") as f:
            assert [d["seed"] for d in csv.DictReader(f)] == ["9451", "9452"]
    rollouts = [out / "round1" / "rollouts" / "taped-5100", out / "round1" / "rollouts" / "centre-5101"]
    for folder in rollouts:  # 0.05 minutes shared by the two styles, labelled with the expert's throttle too
        rec = open_recording(folder)
        assert len(rec) == 30 and rec.throttle is not None and np.ptp(rec.throttle) > 0
    round0, round1 = (parse_config(json.loads((out / f"round{r}" / "config.json").read_text())) for r in (0, 1))
    assert round1.extra_data == tuple(str(p) for p in rollouts) and round1.train.init == str(out / "round0" / "best.pt")
    ds = prepare_dataset(round1, progress=False)
    trained_on = [len(training_sources(c, ds, np.arange(40), progress=False)[1]) for c in (round0, round1)]
    assert trained_on == [40, 100]


def timed_laps(length: float, crossings: list[float], dirty: list[int]) -> dict:
    """`Laps.result()` of a car that passes the start line at `crossings` (s) and leaves the lane in the laps
    `dirty` (1-based): the progress of each lap added in one step that ends on the line."""
    laps = Laps(length)
    for k, t in enumerate(crossings, start=1):
        if k in dirty:
            laps.off_track()
        laps.advance(length, t)
    return laps.result()


def test_the_pace_of_a_track_and_of_the_suite_is_over_the_same_tracks():
    """Three tracks (expert laps 10, 8 and 9 s); X laps A in 12 s and C in 9.9 s but never B cleanly, Y laps A in
    11 s and B in 10 s but never C cleanly. The headline pace of each is over A alone, the one track both finished."""
    from steerlab.sim.track.run import TrackDrive
    from steerlab.sim.track.suite import drive_row, round_columns, summarize

    def drive(label, style, seed, crossings, dirty=()):
        r = timed_laps(40.0, crossings, list(dirty))
        return TrackDrive(label, seed, style, 0.9, 40.0, 1.0, float(len(crossings)), **r, off_track=len(dirty),
                          off_track_per_lap=len(dirty) / len(crossings), off_track_per_km=0.0, autonomy=100.0,
                          distance_km=0.04 * len(crossings), mean_speed=3.0, mean_abs_offset_m=0.1,
                          max_abs_offset_m=0.2, command_gamma_deg=float(seed))

    expert = {1: drive("expert", "taped", 1, [10, 20, 30]), 2: drive("expert", "taped", 2, [8, 16, 24]),
              3: drive("expert", "centre", 3, [9, 18, 27])}
    laps = {("X", 1): ([13, 24, 36, 48], [1]), ("X", 2): ([10, 21], [1, 2]), ("X", 3): ([9.9, 19.8], []),
            ("Y", 1): ([11, 22], []), ("Y", 2): ([10, 20, 30], [2]), ("Y", 3): ([9, 18], [1, 2])}
    style = {1: "taped", 2: "taped", 3: "centre"}
    rows = [drive_row(drive(label, style[seed], seed, *laps[label, seed]), expert[seed], label, f"{label}.pt",
                      style[seed], seed) for label in "XY" for seed in (1, 2, 3)]
    pace = {(r.label, r.seed): r.pace for r in rows}
    # X on A: clean laps 2-4 of 11, 12 and 12 s; on B none; on C 9.9 s twice. Y on B: laps 1 and 3, 10 s each.
    assert pace == pytest.approx({("X", 1): (35 / 3) / 10, ("X", 2): None, ("X", 3): 1.1, ("Y", 1): 1.1,
                                  ("Y", 2): 10 / 8, ("Y", 3): None})
    summary = {(s.label, s.style): s for s in summarize(rows)}
    x, y = summary["X", "all"], summary["Y", "all"]
    assert (x.laps, x.clean_laps, x.finished, x.tracks, x.off_track) == (8, 5, 2, 3, 3)
    assert (y.laps, y.clean_laps, y.finished, y.tracks, y.off_track) == (7, 4, 2, 3, 3)
    assert x.clean_pct == pytest.approx(62.5) and y.clean_pct == pytest.approx(400 / 7)
    assert (x.pace, x.pace_tracks, y.pace, y.pace_tracks) == (pytest.approx(35 / 30), 1, pytest.approx(1.1), 1)
    assert summary["X", "taped"].pace == pytest.approx(35 / 30) and summary["X", "centre"].pace is None
    assert summary["X", "centre"].finished == 1 and summary["Y", "centre"].finished == 0
    # a row carries its drive and the expert's laps: X on A laps in 13, 11, 12 and 12 s, the first not clean
    assert vars(rows[0]) == pytest.approx(
        {"label": "X", "checkpoint": "X.pt", "style": "taped", "seed": 1, "lap_m": 40.0, "minutes": 1.0,
         "laps_driven": 4.0, "laps": 4, "clean_laps": 3, "best_lap_s": 11.0, "mean_lap_s": 35 / 3,
         "expert_best_lap_s": 10.0, "expert_mean_lap_s": 10.0, "pace": 35 / 30, "off_track": 1,
         "off_track_per_lap": 0.25, "off_track_per_km": 0.0, "autonomy": 100.0, "distance_km": 0.16,
         "mean_speed": 3.0, "mean_abs_offset_m": 0.1, "command_gamma_deg": 1.0})
    # X drove 3 minutes and 0.32 km (8 laps of 40 m) with 3 events: autonomy 1 - 3 x 6 s / 180 s; gamma 1, 2, 3
    assert (x.minutes, x.distance_km, x.off_track_per_lap, x.off_track_per_km, x.autonomy, x.command_gamma_deg) == \
        pytest.approx((3.0, 0.32, 3 / 8, 3 / 0.32, 90.0, 2.0))
    assert (y.off_track_per_lap, y.off_track_per_km) == pytest.approx((3 / 7, 3 / 0.28))
    taped = summary["X", "taped"]
    assert (taped.minutes, taped.distance_km, taped.autonomy, taped.command_gamma_deg) == \
        pytest.approx((2.0, 0.24, (1 - 3 * 6 / 120) * 100, 1.5))
    x_only = [s for s in summarize(rows) if s.label == "X"]
    assert round_columns(x_only) == pytest.approx({"clean_laps_pct": 62.5, "lap_ratio": 35 / 30,
                                                   "off_track_per_lap": 0.375})
    # a label that completes no lap: half a lap driven (0.16 km) with one event; its DAgger columns are empty
    (z,) = [s for s in summarize([replace(rows[0], label="Z", laps=0, clean_laps=0, laps_driven=0.5, pace=None)])
            if s.style == "all"]
    assert (z.clean_pct, z.pace, z.off_track_per_lap, z.off_track_per_km) == (None, None, 2.0, pytest.approx(6.25))
    assert round_columns([z]) == {"clean_laps_pct": "", "lap_ratio": "", "off_track_per_lap": 2.0}


def test_the_experts_reference_laps_are_driven_under_the_models_cap(tmp_path):
    from steerlab.sim.track.run import drive_expert
    from steerlab.sim.track.suite import TrackSuiteOptions

    laps = {}
    for cap in (0.5, 1.0):
        o = TrackSuiteOptions(minutes=0.5, max_throttle=cap)
        r = drive_expert(tmp_path / f"cap{cap}", o.drive_options("taped", 9406))
        laps[cap] = r
        assert r.off_track == 0 and r.clean_laps == r.laps >= 2
        rows = (tmp_path / f"cap{cap}" / "trajectory.csv").read_text().split()[1:]
        speeds = [float(row.split(",")[6]) for row in rows]
        assert max(speeds) <= steady_speed(cap, 1 / 20, CARS["donkey"]) + 1e-3  # never faster than the cap holds
    assert laps[0.5].mean_lap_s > 1.1 * laps[1.0].mean_lap_s


def test_another_light_scales_the_rooms_frames_and_leaves_the_room_as_drawn():
    """A look's light level replaces the room's drawn one and nothing else: at its own level the frame is the same bytes;
    at half of it the frame's mean is half (within the rounding to 8 bits); the floor, the tape and the track are
    the ones drawn."""
    own = TrackWorld(9506, 0.9, "taped", 20.0)
    level = own.renderer.room.light
    same, half = (TrackWorld(9506, 0.9, "taped", 20.0, look=Look(light=v)) for v in (level, level / 2))
    assert np.array_equal(same.render(), own.render())
    assert half.renderer.room.tape_name == own.renderer.room.tape_name and half.track.length == own.track.length
    assert half.render().mean() / own.render().mean() == pytest.approx(0.5, abs=0.01)
