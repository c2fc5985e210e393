"""The track world for small cars: closed procedural tracks, their renderer, the small car, the racing expert and
the donkeycar tub writer (the donkeycar fisheye camera: tests/data/test_fisheye.py)."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from steerlab.data.fisheye import DONKEY_FISHEYE
from steerlab.errors import SteerlabError

# --- closed tracks -----------------------------------------------------------------------------------------------

from steerlab.sim.track.track import Track  # noqa: E402

SEEDS = (0, 1, 2, 3, 4)


@pytest.fixture(scope="module")
def tracks():
    return {seed: Track(seed) for seed in SEEDS}


def test_tracks_close_smoothly_and_keep_their_lane_clear(tracks):
    radii = []
    for tr in tracks.values():
        assert 10 <= tr.length <= 60 and tr.ds < 0.03
        assert abs(abs(tr.psi[-1] + tr.kappa[-1] * tr.ds - tr.psi[0]) - 2 * math.pi) < 1e-3  # one full turn
        # across the start line: position, heading and curvature continue
        for eps in (1e-3, 0.05):
            a, b = np.array(tr.pose(-eps)), np.array(tr.pose(eps))
            assert np.hypot(*(b[:2] - a[:2])) == pytest.approx(2 * eps, rel=1e-3, abs=1e-6)
            assert abs((b[2] - a[2] + math.pi) % (2 * math.pi) - math.pi) < 1e-9 + 2 * eps * abs(tr.curvature(0))
        assert tr.curvature(0.0) == 0 and tr.curvature(-tr.ds / 2) == 0
        assert np.abs(np.diff(tr.kappa)).max() < 0.1  # no curvature jumps between samples 2 cm apart
        # heading is the direction of travel, curvature its rate of change
        step = np.hypot(np.diff(tr.x), np.diff(tr.y))
        assert np.allclose(step, tr.ds, rtol=1e-3)
        travel = np.arctan2(np.diff(tr.y), np.diff(tr.x))
        assert np.abs((travel - (tr.psi[:-1] + tr.psi[1:]) / 2 + math.pi) % (2 * math.pi) - math.pi).max() < 1e-3
        radii.append(1 / np.abs(tr.kappa).max())
        # no two parts of the lane closer than the clearance (an independent check on the edges' points)
        left, right = (np.stack(tr.offset(d), 1)[::5] for d in (tr.lane_width / 2, -tr.lane_width / 2))
        edges = np.concatenate([left, right])
        s = np.concatenate([tr.s[::5], tr.s[::5]])
        dist = np.hypot(*(edges[:, None] - edges[None]).transpose(2, 0, 1))
        along = np.abs(s[:, None] - s[None])
        along = np.minimum(along, tr.length - along)
        assert dist[along > 2.5].min() > 0.4
    assert min(radii) < 1.6 and all(r >= 0.8 - 1e-9 for r in radii)  # tight turns, never tighter than 0.8 m
    assert len({round(tr.length) for tr in tracks.values()}) == len(tracks)  # each seed its own track
    assert Track(3).x.tobytes() == tracks[3].x.tobytes()


def test_track_project_pose_and_wrap(tracks):
    tr = tracks[1]
    for s, d in ((0.05, 0.2), (tr.length / 3, -0.3), (tr.length - 0.02, 0.1)):
        x, y, _ = tr.pose(s, d)
        s2, d2, heading = tr.project(float(x), float(y), s_hint=s + 0.5)
        assert abs(tr.delta(s, s2)) < 1e-3 and d2 == pytest.approx(d, abs=1e-3)
        assert abs((heading - tr.pose(s)[2] + math.pi) % (2 * math.pi) - math.pi) < 1e-3
    x, y, _ = tr.pose(0.05)  # just past the start line, found from a hint just before it
    s2, _, _ = tr.project(float(x), float(y), s_hint=tr.length - 0.1)
    assert s2 == pytest.approx(0.05, abs=1e-3)
    assert tr.project(float(x), float(y)) == pytest.approx((s2, *tr.project(float(x), float(y), 0.0)[1:]))
    assert tr.delta(tr.length - 0.1, 0.2) == pytest.approx(0.3)
    assert tr.delta(0.2, tr.length - 0.1) == pytest.approx(-0.3)
    assert tr.wrap(-0.5) == pytest.approx(tr.length - 0.5)
    assert tr.lines == (-tr.lane_width / 2, tr.lane_width / 2) and Track(1, style="centre").lines == (0.0,)
    xs, ys = np.array([tr.pose(3.0, 0.3)[:2], tr.pose(3.0, -0.2)[:2]]).T
    assert tr.overhang(xs, ys, 3.0) == pytest.approx(0.3 - tr.lane_width / 2, abs=1e-4)


@pytest.mark.parametrize("kwargs,message", [({"lane_width": 0.0}, "lane width must be positive, got 0.0 m"),
                                            ({"lane_width": -1}, "lane width must be positive"),
                                            ({"style": "dashed"}, "unknown track style 'dashed'")])
def test_track_bad_options(kwargs, message):
    with pytest.raises(SteerlabError, match=message):
        Track(0, **kwargs)


def test_speed_profile_respects_its_limits(tracks):
    tr = tracks[2]
    v = tr.speed_profile(5.0, lat_acc=3.5, decel=3.0)
    assert v.max() <= 5.0 and v.min() > 1.0
    assert np.all(v * v * np.abs(tr.kappa) <= 3.5 + 1e-9)
    nxt = np.roll(v, -1)  # braking within 3 m/s^2 before every turn, also across the start line
    assert np.all(v * v <= nxt * nxt + 2 * 3.0 * tr.ds + 1e-9)
    assert np.isclose(v, 5.0).any()  # straights long enough to reach the top speed
    with pytest.raises(SteerlabError, match="positive top speed"):
        tr.speed_profile(0.0)


# --- the small car -----------------------------------------------------------------------------------------------

from steerlab.data.car import CARS, VehicleState, speed_after, throttle_for  # noqa: E402
from steerlab.sim.track.smallcar import SmallCar  # noqa: E402


def test_small_car_throttle_lag_and_braking():
    real = CARS["donkey"]
    assert (real.wheelbase, real.full_lock_deg, real.motor.top_speed, real.max_decel) == (0.26, 25.0, 5.0, 6.0)
    p = replace(real, drag=0.0, motor=replace(real.motor, rolling=0.0))  # the first-order model alone
    v, dt = 0.0, 0.01
    for _ in range(30):  # one time constant at full throttle: 1 - 1/e of the top speed
        v = speed_after(v, 1.0, dt, p)
    assert v == pytest.approx(5.0 * (1 - math.exp(-1)), rel=1e-9)
    v1 = v
    for _ in range(300):  # faster than throttle 0.5 asks: slows towards it with the coasting time constant
        v = speed_after(v, 0.5, dt, p)
    assert v == pytest.approx(2.5 + (v1 - 2.5) * math.exp(-3.0 / p.motor.coast_time_constant), rel=1e-9)
    assert speed_after(2.5, -0.5, 0.1, p) == pytest.approx(2.5 * math.exp(-0.1 / p.motor.coast_time_constant) - 0.3)
    assert speed_after(0.1, -1.0, 0.5, p) == 0.0  # stops, never reverses
    for v0, accel in ((1.0, 2.0), (3.0, 0.0), (3.0, -1.0), (3.0, -5.0)):  # the feed-forward inverts the model
        u = throttle_for(v0, accel, real)
        assert (speed_after(v0, u, 1e-4, real) - v0) / 1e-4 == pytest.approx(accel, abs=0.02)
    v = 0.0
    for _ in range(300):
        v = speed_after(v, 1.0, dt, real)
    assert 4.5 < v < 5.0  # drag keeps it under the top speed


def test_small_car_turns_on_its_kinematic_circle():
    p = CARS["donkey"]
    car = SmallCar(VehicleState(0.0, 0.0, 0.0, 2.0))
    radius = p.wheelbase / math.tan(p.full_lock)
    steps = 2000
    dt = 2 * math.pi * radius / 2.0 / steps
    for _ in range(steps):
        car.vehicle.advance(1.0, 2.0, dt)  # asks for more than full lock: limited to 25 degrees
    assert car.state.x == pytest.approx(0.0, abs=1e-6) and car.state.y == pytest.approx(0.0, abs=1e-6)
    assert car.state.psi == pytest.approx(2 * math.pi)
    car.state = VehicleState(1.0, 2.0, math.pi / 2, 0.0)
    xs, ys = car.corners()
    assert np.allclose(xs, [0.9, 1.1, 1.1, 0.9]) and np.allclose(ys, [1.93, 1.93, 2.35, 2.35])
    assert np.allclose(car.camera_pose(), (1.0, 2.0 + p.body.camera_forward, math.pi / 2))
    assert np.allclose(car.camera_pose(0.1), (0.9, 2.0 + p.body.camera_forward, math.pi / 2))  # 0.1 m to its left
    with pytest.raises(SteerlabError, match="needs a throttle model and a body"):
        SmallCar(VehicleState(0.0, 0.0, 0.0, 0.0), CARS["sim"])


# --- the racing expert -------------------------------------------------------------------------------------------

from steerlab.sim.track.expert import Racer, expert_controls  # noqa: E402


def race(track, laps, drift_every_s, seed=0, dt=0.05):
    """The expert racing `laps` laps from standstill: (ticks, worst overhang of the body, episodes seen, time)."""
    p = CARS["donkey"]
    x, y, psi = track.pose(0.0)
    car = SmallCar(VehicleState(float(x), float(y), float(psi), 0.0))
    racer = Racer(track, p, seed, dt, drift_every_s=drift_every_s)
    s, progress, t, worst, episodes, ticks = 0.0, 0.0, 0.0, -1.0, set(), 0
    while progress < laps * track.length and t < 60 * laps:
        st = car.state
        s_new, d, _ = track.project(st.x, st.y, s)
        progress += float(track.delta(s, s_new))
        s = s_new
        worst = max(worst, track.overhang(*car.corners(), s))
        delta, throttle, episode = racer.act(st, s, d, t)
        assert abs(delta) <= p.full_lock + 1e-12 and -1 <= throttle <= 1
        episodes.add(episode)
        car.step(delta, throttle, dt)
        t += dt
        ticks += 1
    assert progress >= laps * track.length, f"seed {track.seed}: {progress / track.length:.2f} laps in {t:.0f} s"
    return worst, episodes, t


def test_expert_races_three_laps_inside_the_lane(tracks):
    for tr in tracks.values():
        worst, episodes, t = race(tr, 3, None)
        assert worst < -0.1 and episodes == {"normal"}
        assert t / 3 < tr.length / 2.0  # faster than 2 m/s on average
    pursuit, throttle = expert_controls(tracks[0], VehicleState(*map(float, tracks[0].pose(1.0, 0.1)), 1.0), 1.0,
                                        CARS["donkey"])
    assert pursuit < 0 and throttle > 0.2  # left of the centre: steer right; slow: speed up


def test_expert_drifts_and_recovers_without_leaving_the_lane(tracks):
    for seed, tr in tracks.items():
        worst, episodes, _ = race(tr, 2, 3.0, seed)
        assert worst < 0 and episodes == {"normal", "drift-out", "recover"}


# --- the renderer ------------------------------------------------------------------------------------------------

from steerlab.sim.track.render import TrackRenderer  # noqa: E402


@pytest.fixture(scope="module")
def renderers(tracks):
    return {seed: TrackRenderer(tracks[seed]) for seed in (1, 2)}


def test_rendered_frames_are_deterministic_and_differ_between_tracks(renderers, tracks):
    frames = {}
    for seed, r in renderers.items():
        x, y, psi = tracks[seed].pose(2.0)
        frames[seed] = r.render(float(x), float(y), float(psi), 2.0)
        assert frames[seed].shape == (120, 160, 3) and frames[seed].dtype == np.uint8
        assert frames[seed].std() > 10  # a scene, not a flat colour
    again = TrackRenderer(tracks[1])
    x, y, psi = tracks[1].pose(2.0)
    assert again.render(float(x), float(y), float(psi), 2.0).tobytes() == frames[1].tobytes()
    assert np.abs(frames[1].astype(int) - frames[2].astype(int)).mean() > 20
    # the clutter stands in the room beside the track: without it, frames differ mostly above the horizon, and
    # where they differ moves from frame to frame as the car drives
    bare = TrackRenderer(tracks[1])
    bare.face_start = bare.face_start[:0]
    masks = []
    for s in np.linspace(0, tracks[1].length, 12, endpoint=False):
        pose = [float(v) for v in tracks[1].pose(s)]
        with_it, without = again.render(*pose, s), bare.render(*pose, s)
        masks.append(np.abs(with_it.astype(int) - without.astype(int)).sum(-1) > 0)
    masks = np.array(masks)
    assert masks.any(axis=(1, 2)).sum() >= 6
    assert masks[:, 80:].sum() < 0.1 * masks.sum()
    assert all((a != b).any() for a, b in zip(masks, masks[1:]) if a.any() or b.any())


def test_track_worlds_of_one_track_share_its_renderer(renderers, tracks):
    """A renderer is built once per track and camera in a process (the suite and DAgger drive a track many
    times); it renders what a renderer of its own renders."""
    from steerlab.sim.track.world import TrackWorld

    a, b = TrackWorld(1), TrackWorld(1)
    assert a.renderer is b.renderer and a.track is a.renderer.track
    assert TrackWorld(1, style="centre").renderer is not a.renderer
    assert TrackWorld(1, camera=replace(DONKEY_FISHEYE, pitch_deg=10.0)).renderer is not a.renderer
    pose = [float(v) for v in tracks[1].pose(2.0)]
    assert a.renderer.render(*pose, 2.0).tobytes() == renderers[1].render(*pose, 2.0).tobytes()


def test_lane_lines_appear_where_the_camera_projects_them(renderers, tracks):
    cam = DONKEY_FISHEYE
    for seed, r in renderers.items():
        tr = tracks[seed]
        # the start straight: the camera on the centre line at its beginning, looking along it
        straight = np.flatnonzero(np.abs(tr.kappa) < 1e-12)
        first = -next(k for k in range(len(tr.s)) if (len(tr.s) - 1 - k) not in set(straight)) * tr.ds
        last = next(k for k in range(len(tr.s)) if k not in set(straight)) * tr.ds
        s_cam = first + 0.05
        x, y, psi = (float(v) for v in tr.pose(s_cam))
        frame = r.render(x, y, psi, s_cam).astype(float)
        light = r.room.brightness[tr.index(s_cam)] * r.room.tint[tr.index(s_cam)]
        tape = r.room.tape_bgr * light
        hits = 0
        points = [s for s in np.arange(s_cam + 0.45, min(last, s_cam + 1.6), 0.05)
                  if abs(s) > 0.12]  # off the start line
        for s in points:
            half = tr.lane_width / 2
            for d, inside in ((-half, -half + 0.12), (half, half - 0.12)):
                (u, v), (ui, vi) = ([int(round(float(c))) for c in cam.project_world(*tr.pose(s, e)[:2], 0.0,
                                                                                     (x, y, psi))]
                                    for e in (d, inside))
                on, off = frame[v, u], frame[vi, ui]
                hits += np.linalg.norm(on - tape) < np.linalg.norm(off - tape) and np.linalg.norm(on - off) > 30
        assert len(points) >= 8 and hits >= 0.9 * 2 * len(points), (seed, hits, 2 * len(points))


# --- the donkeycar tub writer ------------------------------------------------------------------------------------

from steerlab.data.readers import open_recording  # noqa: E402
from steerlab.data.recording import read_image  # noqa: E402
from steerlab.data.writer import TubWriter  # noqa: E402


def write_race_tub(folder, renderer, track, n=25, max_len=10):
    """n ticks of the expert racing on `track`, rendered and written as a tub; returns the written
    (servo angle, throttle, timestamp ns) per record."""
    p = CARS["donkey"]
    x, y, psi = track.pose(0.0)
    car = SmallCar(VehicleState(float(x), float(y), float(psi), 1.0))
    racer = Racer(track, p, 0, 0.05)
    writer = TubWriter(folder, full_lock_deg=p.full_lock_deg, max_len=max_len)
    s, rows = 0.0, []
    for i in range(n):
        st = car.state
        s, d, _ = track.project(st.x, st.y, s)
        delta, throttle, _ = racer.act(st, s, d, i * 0.05)
        frame = renderer.render(*car.camera_pose(), s)
        if i == 0:
            frame[:20, :20] = (0, 0, 255)  # a red corner (BGR) to check the colours of the JPEG bytes
        writer.add(frame, i * 50_000_000, delta, throttle)
        rows.append((writer.servo(delta), throttle, 1_577_836_800_000_000_000 + i * 50_000_000))
        car.step(delta, throttle, 0.05)
    writer.close()
    return rows


def test_tub_writer_is_read_back_exactly_by_steerlab(renderers, tracks, tmp_path):
    rows = write_race_tub(tmp_path / "tub", renderers[1], tracks[1])
    rec = open_recording(tmp_path / "tub")
    angle, throttle, ts = map(np.array, zip(*rows))
    assert len(rec) == 25 and rec.geometry == "donkey" and rec.convention.kind == "normalized"
    np.testing.assert_array_equal(rec.steering, angle)
    np.testing.assert_array_equal(rec.throttle, throttle)
    np.testing.assert_array_equal(rec.timestamps_ns, ts)
    assert np.ptp(angle) > 0 and np.all(np.abs(angle) <= 1)
    # the servo command: road-wheel angle / full lock, positive right
    writer = TubWriter(tmp_path / "other", full_lock_deg=25)
    assert writer.servo(math.radians(12.5)) == pytest.approx(-0.5) and writer.servo(-1.0) == 1.0
    first = read_image(rec.frames["center"][0])
    assert first.shape == (120, 160, 3) and tuple(first[5, 5]) == pytest.approx((0, 0, 255), abs=12)
    # catalogs of at most max_len records, their manifests counting the lines' lengths
    lines = (tmp_path / "tub" / "manifest.json").read_text().splitlines()
    assert len(lines) == 5 and json.loads(lines[0]) == ["cam/image_array", "user/angle", "user/throttle", "user/mode"]
    catalogs = json.loads(lines[4])
    assert catalogs == {"paths": ["catalog_0.catalog", "catalog_1.catalog", "catalog_2.catalog"],
                        "current_index": 25, "max_len": 10, "deleted_indexes": []}
    for n, start in enumerate((0, 10, 20)):
        meta = json.loads((tmp_path / "tub" / f"catalog_{n}.catalog_manifest").read_text())
        body = (tmp_path / "tub" / f"catalog_{n}.catalog").read_text()
        assert meta["start_index"] == start and meta["line_lengths"] == [len(x) + 1 for x in body.splitlines()]
    with pytest.raises(SteerlabError, match="not empty"):
        TubWriter(tmp_path / "tub", full_lock_deg=25)
    with pytest.raises(SteerlabError, match="full_lock_deg must lie in"):
        TubWriter(tmp_path / "x", full_lock_deg=0)


def test_tub_writer_is_read_by_donkeycar_as_its_own(donkeycar_tub, renderers, tracks, tmp_path, monkeypatch):
    from donkeycar.config import Config
    from donkeycar.pipeline.types import TubRecord

    rows = write_race_tub(tmp_path / "tub", renderers[1], tracks[1])
    tub = donkeycar_tub.Tub(str(tmp_path / "tub"), read_only=True)
    records = list(tub)
    assert len(tub) == len(records) == 25
    assert [r["_index"] for r in records] == list(range(25))
    assert [(r["user/angle"], r["user/throttle"], r["_timestamp_ms"] * 1_000_000) for r in records] == rows
    assert {r["user/mode"] for r in records} == {"user"} and records[0]["_session_id"] == "20-01-01_0"
    cfg = Config()
    cfg.IMAGE_W, cfg.IMAGE_H, cfg.IMAGE_DEPTH = 160, 120, 3
    rgb = TubRecord(cfg, tub.base_path, records[0]).image()
    assert rgb.shape == (120, 160, 3) and tuple(rgb[5, 5]) == pytest.approx((255, 0, 0), abs=12)  # red in RGB
    tub.close()
    # the manifest's lines and the records' keys as donkeycar's own writer makes them
    ticks = iter(1_700_000_000.0 + 0.05 * i for i in range(3))
    monkeypatch.setattr(donkeycar_tub, "time", type("Clock", (), {"time": staticmethod(lambda: next(ticks))}))
    theirs = donkeycar_tub.TubWriter(str(tmp_path / "theirs"), inputs=["cam/image_array", "user/angle", "user/throttle",
                                                                       "user/mode"],
                                     types=["image_array", "float", "float", "str"])
    for _ in range(3):
        theirs.run(np.zeros((120, 160, 3), np.uint8), 0.1, 0.2, "user")
    theirs.close()
    ours, them = ((tmp_path / t / "manifest.json").read_text().splitlines() for t in ("tub", "theirs"))
    assert ours[:3] == them[:3]
    for a, b in zip(ours[3:], them[3:]):
        assert list(json.loads(a)) == list(json.loads(b))
    assert list(json.loads(ours[3])["sessions"]) == list(json.loads(them[3])["sessions"])
    for name in ("catalog_0.catalog", "catalog_0.catalog_manifest"):
        ours, them = (json.loads((tmp_path / t / name).read_text().splitlines()[0]) for t in ("tub", "theirs"))
        assert list(ours) == list(them)
