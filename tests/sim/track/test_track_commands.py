"""`sim record/drive/bench --world track` and DAgger in the track world: the tub a recording writes and both
readers read, a drive of a tub checkpoint with its plots and video, a model that learned the throttle, the suite's
tables and kept drives, its tracks recorded only for evaluation, a rollout's labels and the DAgger rounds."""

import csv
import hashlib
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import assert_video, drawn_along, drawn_pixels, image_of, legend_of, made
from steerlab.cli import main
from steerlab.data.car import CARS, steady_speed
from steerlab.data.readers import open_recording
from steerlab.errors import SteerlabError
from steerlab.sim.core.driving import Trajectory
from steerlab.sim.track.world import TrackWorld
from tests.sim.track.pilots import DONKEY, Scripted


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
