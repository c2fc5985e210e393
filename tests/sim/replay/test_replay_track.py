"""Replay of small-car recordings (`sim/track/replay.py`): the fisheye warp, the speed from the throttle, the lane
criterion of the car's body, a round trip on a track-world tub and the shared real tubs."""

import csv
import json
import math

import numpy as np
import pytest
from conftest import SHARED, made

from steerlab.cli import main
from steerlab.data.car import CARS, VehicleState, speed_after, steady_speed, throttle_speeds
from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera, shift_view, view_maps
from steerlab.data.geometry import CAMERAS
from steerlab.data.readers import Source
from steerlab.pilot import Controls
from steerlab.data.path import human_path
from steerlab.sim.replay.run import replay_recording
from steerlab.sim.track.replay import TrackReplay

DONKEY = CARS["donkey"]
TUBS = SHARED / "donkeycar"
needs_tubs = pytest.mark.skipif(not (TUBS / "hall" / "manifest.json").exists(), reason="../shared/data absent")
# an ideal equidistant fisheye looking level: theta_d = theta, so that pixels can be worked out by hand
LEVEL = FisheyeCamera(fx=80.0, fy=80.0, cx=79.5, cy=59.5, d=(0.0, 0.0, 0.0, 0.0), pitch_deg=0.0)


def level_pixel(forward: float, left: float) -> tuple[float, float]:
    """Where LEVEL sees the floor point `forward` ahead and `left` to the left of it, 0.15 m below: camera axes
    (x right, y down, z ahead) = (-left, 0.15, forward), at angle theta = atan(r / forward) from the axis,
    r = hypot(left, 0.15), and theta_d = theta fx pixels from the centre along (x, y) / r."""
    r = math.hypot(left, 0.15)
    theta = math.atan(r / forward)
    return 79.5 + 80.0 * theta * -left / r, 59.5 + 80.0 * theta * 0.15 / r


def at(maps, u: float, v: float) -> tuple[float, float]:
    """A map pair read bilinearly at (u, v), as cv2.remap reads the frame."""
    (mx, my), i, j = maps, int(u), int(v)
    a, b = u - i, v - j

    def read(m):
        return ((1 - a) * (1 - b) * m[j, i] + a * (1 - b) * m[j, i + 1] + (1 - a) * b * m[j + 1, i]
                + a * b * m[j + 1, i + 1])
    return float(read(mx)), float(read(my))


class Scripted:
    """A pilot that answers tick k with the recorded steering of frame k - delay (None: straight ahead) and,
    given, a constant throttle."""

    name, geometry, source = "scripted", "donkey", "scripted"

    def __init__(self, rec, delay=0, throttle=None):
        self.rec, self.delay, self.throttle, self.k, self.convention = rec, delay, throttle, 0, rec.convention

    def reset(self):
        pass

    def step(self, frame, speed=None):
        self.k += 1
        steering = 0.0 if self.delay is None else float(self.rec.steering[max(self.k - 1 - self.delay, 0)])
        return Controls(steering, throttle=self.throttle)


def test_the_fisheye_warp_without_offset_and_heading_is_the_frame_itself():
    rng = np.random.default_rng(0)
    frame = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    for cam in (DONKEY_FISHEYE, LEVEL):
        mx, my = view_maps(cam, 0.0, 0.0)
        v, u = np.mgrid[0:120, 0:160]
        assert np.abs(mx - u).max() < 1e-3 and np.abs(my - v).max() < 1e-3
        assert np.abs(shift_view(frame, cam, 0.0, 0.0).astype(int) - frame).max() <= 1  # interpolation only


def test_a_known_offset_moves_a_floor_point_and_a_turn_the_horizon_where_the_maths_says():
    # moved 0.1 m to the left, the camera sees the floor point 1 m ahead and 0.3 m left at 0.2 m left; the view's
    # pixel there reads the frame where the point was
    maps = view_maps(LEVEL, 0.1, 0.0)
    u0, v0 = level_pixel(1.0, 0.3)  # r = 0.33541, theta = 0.32362: (79.5 - 23.156, 59.5 + 11.578)
    u1, v1 = level_pixel(1.0, 0.2)  # r = 0.25, theta = 0.24498: (79.5 - 15.679, 59.5 + 11.759)
    assert (u0, v0, u1, v1) == pytest.approx((56.344, 71.078, 63.821, 71.259), abs=1e-3)
    assert at(maps, u1, v1) == pytest.approx((u0, v0), abs=0.02)
    # a frame with a bright spot at the floor point shows it at the new pixel
    v, u = np.mgrid[0:120, 0:160]
    spot = 250 * np.exp(-((u - u0) ** 2 + (v - v0) ** 2) / (2 * 1.5 ** 2))
    moved = shift_view(np.repeat(spot[..., None], 3, 2).astype(np.uint8), LEVEL, 0.1, 0.0)[..., 0].astype(float)
    assert (np.sum(moved * u) / moved.sum(), np.sum(moved * v) / moved.sum()) == pytest.approx((u1, v1), abs=0.2)
    # turned 10 degrees left, the horizon straight ahead moves 10 degrees right: theta_d = theta, fx px a radian
    maps = view_maps(LEVEL, 0.0, 10.0)
    assert at(maps, 79.5 + 80.0 * math.radians(10), 59.5) == pytest.approx((79.5, 59.5), abs=0.02)
    # the default fisheye, pitched down: the same point through its own projection
    maps = view_maps(DONKEY_FISHEYE, 0.1, 0.0)
    h = DONKEY_FISHEYE.mount_height
    assert at(maps, *DONKEY_FISHEYE.project(1.0, 0.2, -h)) == pytest.approx(DONKEY_FISHEYE.project(1.0, 0.3, -h),
                                                                             abs=0.05)


def test_the_warp_shows_the_floor_as_the_track_renderer_does_from_there():
    """The track world's frame warped to a pose 8 cm to the left and 4 degrees left of it looks, on the floor,
    like the frame rendered there, far more than the frame that is not warped (the sensor's noise and the lens's
    vignette, which stay where they are in the image, left out)."""
    from steerlab.sim.track.track import Track
    from steerlab.sim.track.render import TrackRenderer

    track = Track(5)
    renderer = TrackRenderer(track)
    renderer.noise[:], renderer.vignette[:] = 0, 1
    x, y, psi = (float(v) for v in track.pose(3.0))
    here = renderer.render(x, y, psi, 3.0)
    there = renderer.render(x - 0.08 * math.sin(psi), y + 0.08 * math.cos(psi), psi + math.radians(4), 3.0)
    floor = slice(60, 120)  # below the horizon: the floor only
    warped = shift_view(here, DONKEY_FISHEYE, 0.08, 4.0)
    error = np.abs(warped[floor].astype(int) - there[floor]).mean()
    assert error < 0.5 * np.abs(here[floor].astype(int) - there[floor]).mean()


def test_speed_from_a_constant_throttle_approaches_the_small_cars_steady_state():
    # throttle 0.5 pulls towards 2.5 m/s with tau 0.3 s; at 20 Hz the step keeps 1 - exp(-1/6) = 0.15352 of the
    # gap and loses (0.15 + 0.01 v^2) x 0.05 to rolling and drag: 0.15352 (2.5 - v) = 0.0075 + 0.0005 v^2,
    # v = 2.43188 m/s
    assert steady_speed(0.5, 0.05, DONKEY) == pytest.approx(2.43188, abs=1e-5)
    assert speed_after(2.43188, 0.5, 0.05, DONKEY) == pytest.approx(2.43188, abs=1e-5)
    assert steady_speed(0.0, 0.05, DONKEY) == 0.0 and steady_speed(-0.5, 0.05, DONKEY) == 0.0
    t = np.arange(200) * 0.05
    v = throttle_speeds(np.r_[0.0, np.full(199, 0.5)], t, DONKEY)  # from standstill (throttle 0 holds 0)
    assert v[0] == 0.0 and v[-1] == pytest.approx(2.43188, abs=1e-4)
    assert np.all(np.diff(v) >= 0) and v[7] == pytest.approx(2.5 * (1 - math.exp(-1)), rel=0.05)  # tau later: 63 %
    # a drive that starts at a steady throttle starts at its speed
    assert throttle_speeds(np.full(5, 0.5), t[:5], DONKEY) == pytest.approx(np.full(5, 2.43188), abs=1e-4)


def open_tub(path, frames=None):
    return Source(str(path), frames, None, {"full_lock_deg": 25}).open()


def test_the_body_leaving_the_lane_is_an_intervention_and_a_turn_alone_is_not(track_tub):
    """On a straight path in a 0.9 m lane, the 0.2 m wide body leaves it when the rear axle is more than
    0.45 - 0.1 = 0.35 m off; turned 20 degrees (twice the road's heading limit) 0.2 m off, its front corner is at
    0.2 + 0.35 sin 20 + 0.1 cos 20 = 0.41 m: inside."""
    replay = TrackReplay(CAMERAS["donkey"], DONKEY)
    t = np.arange(60) * 0.05
    world = replay.world(open_tub(track_tub), 0, human_path(np.zeros(60), np.full(60, 2.0), t, DONKEY))
    for y, psi, leaves in ((0.34, 0.0, False), (0.36, 0.0, True), (-0.36, 0.0, True), (0.2, 20.0, False),
                           (0.2, 35.0, True)):
        world.vehicle.state = VehicleState(1.0, y, math.radians(psi), 2.0)
        put_back, offset, _ = world.intervene(replay.limit)
        assert put_back == leaves, (y, psi)
        assert (offset, world.state.y) == ((0.0, 0.0) if leaves else (pytest.approx(y), y))
    world.overhang = lambda: 0.0  # a corner exactly on the lane's edge is still inside
    assert not world.leaves_lane(0.0, 0.0, replay.limit)
    # where the human stood still over the whole search there is no path to leave: never an intervention
    still = replay.world(open_tub(track_tub), 0, human_path(np.zeros(60), np.zeros(60), t, DONKEY))
    still.vehicle.state = VehicleState(0.0, 5.0, 0.0, 0.0)
    assert still.overhang() == -math.inf and still.intervene(replay.limit) == (False, 0.0, 0.0)


def test_a_track_world_tub_carries_its_camera_and_replays(track_tub):
    rec = open_tub(track_tub)
    assert rec.fisheye == DONKEY_FISHEYE and rec.throttle is not None
    human, _ = replay_recording(Scripted(rec), TrackReplay(CAMERAS["donkey"], DONKEY, fisheye=rec.fisheye), rec)
    assert human[-1]["interventions"] == 0 and human[-1]["max_offset_m"] < 1e-9
    # the speed is the recorded throttle's through the car's throttle model
    expected = throttle_speeds(rec.throttle, rec.timestamps_ns / 1e9, DONKEY)
    assert human[-1]["km"] * 1000 == pytest.approx(np.sum(expected[:-1]) / rec.frame_rate(), rel=1e-6)
    straight, _ = replay_recording(Scripted(rec, None), TrackReplay(CAMERAS["donkey"], DONKEY), rec)
    assert straight[-1]["interventions"] >= 1
    # with the model's throttle the car goes as fast as the pilot's throttle takes it
    slow, traj = replay_recording(Scripted(rec, throttle=0.2),
                                  TrackReplay(CAMERAS["donkey"], DONKEY, learned_throttle=True), rec)
    assert traj.speed[-1] == pytest.approx(steady_speed(0.2, 0.05, DONKEY), rel=0.02)
    assert slow[-1]["km"] < human[-1]["km"]


def test_both_layouts_of_the_track_world_carry_the_calibrated_camera(tmp_path):
    from steerlab.data.fisheye import load_calibration

    calib = tmp_path / "calib.json"
    calib.write_text(json.dumps({"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0, 0, 1]],
                                 "D": [-0.02, -0.01, 0.0, 0.005]}))
    for layout in ("tub", "steerlab"):
        out = tmp_path / layout
        assert main(["sim", "record", "--world", "track", "--minutes", "0.01", "--layout", layout, "--calibration",
                     str(calib), "--out", str(out)]) == 0
        assert Source(str(out)).open().fisheye == load_calibration(calib)


def test_steerlab_replay_on_a_track_world_tub(track_tub, tmp_path, capsys):
    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    argv = ["replay", str(ckpt), "--data", str(track_tub), "--reader", "full_lock_deg=25", "--workers", "1"]
    assert main([*argv, "--out", str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    assert "an intervention when the car's body leaves the 0.9 m lane around the human's path" in out
    row = next(csv.DictReader(open(tmp_path / "r" / "replay.csv")))
    assert row["speed_source"] == "the recorded throttle" and float(row["km"]) > 0
    report = json.loads((tmp_path / "r" / "replay.json").read_text())
    assert report["lane_width_m"] == 0.9 and report["fisheye"]["fx"] == DONKEY_FISHEYE.fx
    assert main([*argv, "--throttle", "model", "--lane-width", "0.6", "--pitch", "24", "--out",
                 str(tmp_path / "m")]) == 0
    row = next(csv.DictReader(open(tmp_path / "m" / "replay.csv")))
    assert row["speed_source"] == "the model's throttle"
    assert json.loads((tmp_path / "m" / "replay.json").read_text())["fisheye"]["pitch_deg"] == 24
    assert main([*argv, "--speed", "1.5", "--world", "road", "--out", str(tmp_path / "road")]) == 0
    assert "turned more than 10 deg" in capsys.readouterr().out  # the road replay, on request


@needs_tubs
@pytest.mark.parametrize("tub, frames", [("hall", "4012:4300"), ("taped-track", "2460:2700"),
                                         ("wood-tape", "7000:7300")])
def test_the_shared_real_tubs_replay_the_humans_steering_without_intervention(tub, frames):
    """Real tubs get the default fisheye and the speed of their recorded throttle; the human's own steering
    needs no intervention, driving straight does."""
    rec = Source(str(TUBS / tub), frames, None, {"full_lock_deg": 25, "skip_missing": True}).open()
    assert rec.fisheye is None and rec.throttle is not None
    human, _ = replay_recording(Scripted(rec), TrackReplay(CAMERAS["donkey"], DONKEY), rec)
    straight, _ = replay_recording(Scripted(rec, None), TrackReplay(CAMERAS["donkey"], DONKEY), rec)
    assert human[-1]["interventions"] == 0 and straight[-1]["interventions"] >= 1
    assert 0.3 < human[-1]["speed_mps"] < 5.0
