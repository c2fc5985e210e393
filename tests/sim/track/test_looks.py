"""Rooms that cannot be memorised: the track world's varied looks (`sim/track/look.py`, `sim record --world track
--vary`). Without `vary` every frame and recording is the bytes it was; a varied look is drawn from its seed, within
its ranges, its tape standing out from its floor, its camera recorded, and its tub trains."""

import hashlib
import json
from dataclasses import asdict

import cv2
import numpy as np
import pytest

from steerlab.cli import main
from steerlab.data.fisheye import DONKEY_FISHEYE
from steerlab.data.readers import open_recording
from steerlab.sim.track.look import CONTRAST, CORNERS, LOOK, Look, stands_out, tape_colour
from steerlab.sim.track.render import TrackRenderer
from steerlab.sim.track.room import Room
from steerlab.sim.track.run import record
from steerlab.sim.track.track import Track
from steerlab.sim.track.world import TrackRecordOptions, TrackWorld

# sha256 of frames and of a tub as rendered and written before looks existed (see the test below)
FRAMES_SHA256 = "2b015d39621fdc010e38654523711a2139d33b1ef8de226e34d4ae672f92656f"
TUB_SHA256 = "d58300b496ed3dae7b96001c6e2603643bdbd3d73736a58764ef8e57904f4492"
DONKEYCAR_KEYS = ("_index", "_session_id", "_timestamp_ms", "cam/image_array", "user/angle", "user/mode",
                  "user/throttle")


def tub_sha256(folder) -> str:
    """Of a tub's images, the fields of its records that donkeycar's tubs have, and its manifest's metadata, sessions
    and catalogs (the lane values a track-world tub holds since are left out)."""
    h = hashlib.sha256()
    for p in sorted((folder / "images").iterdir()):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    for catalog in sorted(folder.glob("catalog_*.catalog")):
        for line in catalog.read_text().splitlines():
            rec = json.loads(line)
            h.update(json.dumps({k: rec[k] for k in DONKEYCAR_KEYS}, sort_keys=True).encode())
    h.update("\n".join((folder / "manifest.json").read_text().splitlines()[2:]).encode())
    return h.hexdigest()


def test_without_vary_frames_and_recordings_are_the_bytes_they_were(tmp_path):
    """Rooms of a tarp, epoxy, carpet and concrete floor (tracks 1, 5, 9506, 42; track 5 of the centre style) seen
    at three places of their lap, and a tub recorded on track 27: the sha256 of their bytes as computed on the
    renderer before looks existed."""
    h = hashlib.sha256()
    kinds = []
    for seed, style in ((1, "taped"), (5, "centre"), (9506, "taped"), (42, "taped")):
        tr = Track(seed, 0.9, style)
        r = TrackRenderer(tr)
        kinds.append(r.room.floor_kind)
        for s in (0.0, 3.0, 7.5):
            x, y, psi = tr.pose(s)
            h.update(r.render(float(x), float(y), float(psi), s).tobytes())
    assert kinds == ["tarp", "epoxy", "carpet", "concrete"]
    assert h.hexdigest() == FRAMES_SHA256
    o = TrackRecordOptions(seed=27, minutes=0.05)
    assert not o.vary and o.look() is LOOK and o.camera() == DONKEY_FISHEYE
    assert tub_sha256(record(tmp_path / "tub", o, progress=False)) == TUB_SHA256


def test_a_look_is_drawn_from_its_seed():
    """The same seed, the same look; other seeds, other looks (every one of 20 differs from every other in its floor,
    tape, light, noise and mount)."""
    assert Look.draw(5) == Look.draw(5) and Look.draw(5).varied and not LOOK.varied
    assert asdict(Look.draw(5)) == {  # seed 5's draws, as its tubs show them (exact: integer draws made floats)
        "floor": (36.4, 53.4, 73.5), "floor2": (88.0, 107.8, 44.6), "pattern": "checker", "tile_m": 0.8752008983577515,
        "marks": 2, "tape": (201.9, 244.2, 176.2), "tape_width": 0.04803524673176097, "light": 1.5514091350069408,
        "gradient": 0.2063675773280843, "light_from_deg": 314.16022958305786, "glare": 2.8284391465588308,
        "clutter": 0.09161203004200057, "people": 0, "noise": 5.188352290460025, "blur": 0.9728094014901241,
        "jpeg_quality": 69, "mount_dz": -0.01501595660946843, "pitch_ddeg": 0.01290877553271308}
    # a plain floor (seed 0): its tape stands out from the one floor colour, not from a second it does not show
    assert (Look.draw(0).pattern, Look.draw(0).floor2, Look.draw(0).tape) == ("plain", None, (68.2, 74.7, 108.8))
    looks = [Look.draw(seed) for seed in range(20)]
    for field in ("floor", "tape", "light", "noise", "mount_dz", "pitch_ddeg"):
        assert len({getattr(k, field) for k in looks}) == 20, field


def test_drawn_looks_stay_within_their_ranges():
    """Over 500 seeds every drawn value lies in its range, and the draws reach near both ends of it."""
    looks = [Look.draw(seed) for seed in range(500)]

    def values(field):
        return np.array([getattr(k, field) for k in looks], float)

    for field, lo, hi in (("tile_m", 0.3, 1.0), ("tape_width", 0.02, 0.10), ("light", 0.4, 1.6), ("gradient", 0, 0.5),
                          ("light_from_deg", 0, 360), ("glare", 1, 3), ("clutter", 0.05, 0.3), ("noise", 1, 10),
                          ("blur", 0, 1), ("mount_dz", -0.03, 0.03), ("pitch_ddeg", -4, 4), ("marks", 0, 12),
                          ("people", 0, 6), ("jpeg_quality", 40, 95)):
        v = values(field)
        assert lo <= v.min() < lo + 0.05 * (hi - lo) and hi - 0.05 * (hi - lo) < v.max() <= hi, field
        if field in ("marks", "people", "jpeg_quality"):  # whole numbers: both ends are drawn
            assert (v.min(), v.max()) == (lo, hi), field
    assert {k.pattern for k in looks} == {"plain", "checker", "tiles"}
    assert all((k.floor2 is None) == (k.pattern == "plain") for k in looks)
    # floors: value 0.2-0.95 (the brightest channel 51-242.25), saturation up to 0.6 (the darkest channel at least
    # 0.4 of the brightest); tapes: value at least 0.1 (25.5)
    floors = np.array([k.floor for k in looks] + [k.floor2 for k in looks if k.floor2])
    assert 51 <= floors.max(1).min() and floors.max(1).max() <= 242.25
    assert (floors.min(1) >= 0.4 * floors.max(1) - 0.1).all()
    assert np.array([k.tape for k in looks]).max(1).min() >= 25.5 - 0.1


def test_the_tape_stands_out_from_every_floor_colour():
    """The rule: a tape's colour lies over CONTRAST (120) from each of its floor's colours (B, G, R). The named
    tapes as the rooms choose them: white on a tarp (235, 232, 230) does not (distance 17), blue does; over 200
    varied looks every tape stands out from both colours of its floor; without a candidate that does, the corner
    of the colour cube farthest from the floor colours."""
    assert CONTRAST == 120
    assert not stands_out((240, 240, 240), (235, 232, 230)) and stands_out((170, 90, 30), (235, 232, 230))
    assert not stands_out((120, 0, 0), (0, 0, 0)) and stands_out((121, 0, 0), (0, 0, 0))
    for seed in range(200):
        k = Look.draw(seed)
        for floor in (k.floor, k.floor2 or k.floor):
            assert np.linalg.norm(np.subtract(k.tape, floor)) > 120, seed
    grey = (128.0, 128.0, 128.0)
    assert tape_colour([grey], [(100, 100, 100), (10, 10, 250)]) == (10, 10, 250)
    assert tape_colour([grey], [(100, 100, 100)]) == (0.0, 0.0, 0.0)  # black, 221.7 away, the farthest corner
    # black and white floors: every other corner is 255 from both
    assert tape_colour([(0, 0, 0), (255, 255, 255)], []) == (0.0, 0.0, 255.0) == CORNERS[1]


def test_a_room_takes_the_looks_floor_tape_and_light_and_keeps_its_own_draws():
    tr = Track(3, 0.9, "taped")
    own = Room(tr)
    look = Look(floor=(40.0, 50.0, 60.0), tape=(250.0, 250.0, 10.0), tape_width=0.08, light=1.5)
    room = Room(tr, look=look)
    np.testing.assert_array_equal(room.floor_bgr, [40, 50, 60])
    np.testing.assert_array_equal(room.tape_bgr, [250, 250, 10])
    assert room.tape_width == 0.08 and room.light == 1.5 and room.tape_name == "varied"
    assert (room.floor_kind, room.height, room.x0, room.gloss) == (own.floor_kind, own.height, own.x0, own.gloss)
    np.testing.assert_allclose(room.brightness / 1.5, own.brightness / own.light, rtol=1e-6)


def test_the_floors_pattern_and_the_light_across_it():
    """A checker of 2-texel squares and tiles of 4 texels with 2-texel joints, texel by texel; the light from
    +x (0 degrees) rises from 0.6 to 1.4 along x, from 180 degrees it falls, from 90 degrees it rises along y."""
    a, b = (10.0, 20.0, 30.0), (200.0, 210.0, 220.0)
    checker = Look(floor=a, floor2=b, pattern="checker", tile_m=0.02).floor_colours(6, 6, 0.01)
    second = np.kron([[0, 1, 0], [1, 0, 1], [0, 1, 0]], np.ones((2, 2), int))  # squares of 2 texels
    np.testing.assert_array_equal(checker, np.where(second[..., None] == 1, b, a))
    tiles = Look(floor=a, floor2=b, pattern="tiles", tile_m=0.04).floor_colours(5, 5, 0.01)
    joint = np.array([1, 1, 0, 0, 1], bool)
    np.testing.assert_array_equal(tiles, np.where((joint[:, None] | joint[None])[..., None], b, a))
    ramp = [0.6, 0.8, 1.0, 1.2, 1.4]
    assert Look(gradient=0.4).light_across(3, 5).dtype == np.float32 == checker.dtype
    np.testing.assert_allclose(Look(gradient=0.4).light_across(3, 5), [ramp] * 3, atol=1e-6)
    np.testing.assert_allclose(Look(gradient=0.4, light_from_deg=180).light_across(3, 5), [ramp[::-1]] * 3, atol=1e-6)
    np.testing.assert_allclose(Look(gradient=0.4, light_from_deg=90).light_across(5, 3), np.c_[ramp, ramp, ramp],
                               atol=1e-6)


def test_marks_lie_outside_the_lane_and_people_stand_beside_it():
    """A look's floor marks change the floor only away from the lane (placed 0.1 m beside its margin of 0.1 m,
    on the clearance map's 5 cm cells, less the half width of the widest mark: at least 5 cm beyond its edge); its
    people stand 0.45-0.9 m beside the lane's edge, 1.5-1.9 m tall; the room's own clutter stays as drawn, more
    is added."""
    tr = Track(3, 0.9, "taped")
    own, marked = Room(tr), Room(tr, look=Look(marks=12, people=6, clutter=0.3))
    h, w = marked.wall_row - 16, int(np.ceil((marked.x1 - marked.x0) / 0.01))  # the floor's texels
    changed = np.argwhere((marked.atlas[0][:h, :w] != own.atlas[0][:h, :w]).any(2))
    assert len(changed) > 500  # texels
    y, x = marked.y0 + changed[::7, 0] * 0.01, marked.x0 + changed[::7, 1] * 0.01
    beside = np.array([abs(tr.project(a, b)[1]) for a, b in zip(x, y)]) - 0.45  # m beyond the lane's edge
    assert beside.min() >= 0.05
    people = [o for o in marked.objects if o["kind"] == "person"]
    assert 3 <= len(people) <= 6
    for p in people:
        top = max(face[:, 2].max() for face, _ in p["faces"])
        assert 1.5 <= top <= 1.9
        _, d, _ = tr.project(p["x"], p["y"])
        assert 0.45 - 0.01 <= abs(d) - 0.45 <= 0.9 + 0.01
    rng = np.random.default_rng(0)
    tops = [max(face[:, 2].max() for face, _ in marked._solid("person", 0.0, 0.0, 0.0, 1.0, rng)["faces"])
            for _ in range(200)]
    assert 1.5 <= min(tops) < 1.52 and 1.88 < max(tops) <= 1.9
    kinds = [o["kind"] for o in own.objects]
    assert [o["kind"] for o in marked.objects[: len(kinds)]] == kinds
    assert len(marked.objects) - len(people) > len(own.objects)


def test_the_cameras_noise_blur_and_glare():
    """The sensor's noise scales with the look's (twice the noise: the frames differ by the noise once, sd 3);
    a blurred frame is the sharp one blurred; the lamps' glare on a glossy (epoxy) floor only brightens it."""
    tr = Track(5, 0.9, "taped")
    x, y, psi = (float(v) for v in tr.pose(0.0))
    sharp, blurred, noisier, glary = (TrackRenderer(tr, look=k).render(x, y, psi, 0.0) for k in
                                      (LOOK, Look(blur=1.0), Look(noise=6.0), Look(glare=3.0)))
    np.testing.assert_array_equal(blurred, cv2.GaussianBlur(sharp, (0, 0), 1.0))
    diff = noisier.astype(float) - sharp
    unclipped = (sharp > 20) & (sharp < 235) & (noisier > 0) & (noisier < 255)
    assert diff[unclipped].std() == pytest.approx(3.0, abs=0.3)
    more = glary.astype(int) - sharp
    assert more.min() >= 0 and more.max() > 30


def test_a_varied_recording_keeps_its_look_and_its_jittered_camera(tmp_path):
    """`sim record --world track --vary`: the tub's manifest holds the look drawn from the track's seed and the
    fisheye at the given mount jittered by it (what replay and the readers read); its frames are the renderer's at
    the look's JPEG quality. The same options give the same bytes."""
    tub = tmp_path / "tub"
    args = ["sim", "record", "--world", "track", "--seed", "27", "--minutes", "0.01", "--vary", "--mount-height",
            "0.2", "--pitch", "15"]
    assert main([*args, "--out", str(tub)]) == 0
    look = Look.draw(27)
    meta = json.loads((tub / "manifest.json").read_text().splitlines()[2])
    assert meta["look"] == json.loads(json.dumps(asdict(look)))
    assert meta["fisheye"]["mount_height"] == 0.2 + look.mount_dz != 0.2
    assert meta["fisheye"]["pitch_deg"] == 15 + look.pitch_ddeg != 15
    assert abs(look.mount_dz) <= 0.03 and abs(look.pitch_ddeg) <= 4
    cam = open_recording(tub).fisheye
    assert (cam.mount_height, cam.pitch_deg) == (0.2 + look.mount_dz, 15 + look.pitch_ddeg)
    world = TrackWorld(27, camera=cam, look=look)
    ok, jpeg = cv2.imencode(".jpg", world.render(), [cv2.IMWRITE_JPEG_QUALITY, look.jpeg_quality])
    assert (tub / "images" / "0_cam_image_array_.jpg").read_bytes() == jpeg.tobytes()
    assert main([*args, "--out", str(tmp_path / "again")]) == 0
    assert tub_sha256(tmp_path / "again") == tub_sha256(tub)
    # steerlab's layout keeps the same look in recording.json
    native = record(tmp_path / "native", TrackRecordOptions(seed=27, minutes=0.01, vary=True, layout="steerlab"),
                    progress=False)
    assert json.loads((native / "recording.json").read_text())["look"] == meta["look"]


def test_a_varied_tub_trains(tmp_path):
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    tub = record(tmp_path / "tub", TrackRecordOptions(seed=4, minutes=0.05, drift=False, vary=True), progress=False)
    best = train(load_config(None, base={
        "data": str(tub), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
        "preprocess": {"preset": "donkey"}, "model": {"name": "pilotnet"},
        "split": {"train": "0:45", "val": "45:60"}, "train": {"epochs": 1, "batch_size": 16}}), progress=False)
    assert best["frames"] == 15 and np.isfinite(best["mae"]) and (tmp_path / "run" / "best.pt").exists()


def test_a_looks_mount_jitters_the_cameras_height_and_pitch_and_a_varied_look_is_kept():
    """By hand: the mount adds its dz and its pitch to the camera (each alone too); the room's own look keeps the
    camera as it is and writes nothing beside it, a varied look its every draw."""
    cam = DONKEY_FISHEYE
    both = Look(mount_dz=0.01, pitch_ddeg=2.0).mount(cam)
    assert (both.mount_height, both.pitch_deg) == pytest.approx((cam.mount_height + 0.01, cam.pitch_deg + 2.0))
    assert Look(mount_dz=-0.02).mount(cam).mount_height == pytest.approx(cam.mount_height - 0.02)
    assert Look(pitch_ddeg=-3.0).mount(cam).pitch_deg == pytest.approx(cam.pitch_deg - 3.0)
    assert LOOK.mount(cam) is cam and LOOK.metadata() == {}
    assert Look.draw(5).metadata() == {"look": asdict(Look.draw(5))}
