"""The closed-loop suite, DAgger rollouts, viewpoint shifts against the renderer, and drive videos."""

import csv
import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from conftest import assert_video, drawn_pixels, image_of, legend_of, resaved
from steerlab.cli import main
from steerlab.data.car import CH2_CAR
from steerlab.data.geometry import CAMERAS, shift_view
from steerlab.data.readers import Source, open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls
from steerlab.sim.core.driving import Trajectory
from steerlab.sim.road.render import Renderer
from steerlab.sim.road.road import LANE_CENTER, Road
from steerlab.sim.road.run import drive, record, rollout
from steerlab.sim.road.suite import SUITES, SuiteDrive, summarize
from steerlab.sim.road.world import DriveOptions, RecordOptions, World
from steerlab.video import MODEL, REFERENCE


class ConstantPilot:
    """A stand-in for the Pilot that always steers the same (steering-wheel angle, positive left)."""

    name, geometry, source, convention = "constant", "sim", "constant", SteeringConvention("steering_wheel", "left")

    def __init__(self, steering: float):
        self.steering = steering

    def step(self, frame, speed=None) -> Controls:
        return Controls(self.steering)

    def reset(self) -> None:
        pass


def test_drive_metrics_hand_computed():
    # one minute at 20 Hz and 20 m/s: 1.2 km; two interventions
    n, dt = 1200, 0.05
    offset = np.full(n, 0.3)
    offset[::2] = -0.3
    offset[100] = 0.9
    command = np.where(np.arange(n) % 2 == 0, 0.01, -0.01)  # successive differences +-0.02 rad
    hits = np.zeros(n, bool)
    hits[[10, 500]] = True
    zeros = np.zeros(n)
    m = Trajectory(zeros, zeros, zeros, zeros, offset, command, np.full(n, 20.0), zeros, hits).metrics(dt)
    assert m.autonomy == pytest.approx((1 - 2 * 6 / 60) * 100)  # 80 %
    assert m.distance_km == pytest.approx(1.2)
    assert m.interventions_per_km == pytest.approx(2 / 1.2)
    assert m.mean_abs_offset_m == pytest.approx((1199 * 0.3 + 0.9) / 1200)
    assert m.max_abs_offset_m == pytest.approx(0.9)
    assert m.command_gamma_deg == pytest.approx(np.degrees(0.02))
    # a road type's autonomy counts the interventions over the summed time of its drives
    drives = [SuiteDrive("a", "a.pt", "twisty", 9301, 1.0, **vars(m)),
              SuiteDrive("a", "a.pt", "twisty", 9302, 1.0, **{**vars(m), "interventions": 0})]
    twisty, overall = summarize(drives)
    assert twisty.autonomy == pytest.approx(90.0) and twisty.distance_km == pytest.approx(2.4)
    assert twisty.interventions_per_km == pytest.approx(2 / 2.4) and overall.road_type == "all"
    # a drive of one tick has no change of command: its gamma is 0, not a standard deviation of nothing
    one = Trajectory(*[np.zeros(1)] * 4, np.full(1, 0.2), np.full(1, 0.1), np.full(1, 20.0), np.zeros(1),
                     np.zeros(1, bool)).metrics(dt)
    assert one.command_gamma_deg == 0.0 and one.distance_km == pytest.approx(0.001)


def test_suite_roads_are_never_recorded(tmp_path):
    seeds = [s for seeds in SUITES["v1"]["roads"].values() for s in seeds]
    assert len(seeds) == 11 and len(SUITES["v1"]["roads"]["twisty"]) >= 3
    with pytest.raises(SteerlabError, match="reserved for the road suites"):
        record(tmp_path / "r", RecordOptions(seed=seeds[0], minutes=0.01), progress=False)


def test_suite_on_the_command_line(tiny_checkpoint, tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["sim", "bench", str(tiny_checkpoint), "--minutes", "0.01", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| run | twisty | 3 |" in printed and "| run | all | 11 |" in printed
    with open(out / "suite.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 11 and {"road_type", "seed", "minutes", "autonomy", "interventions"} <= set(rows[0])
    assert sorted({r["road_type"] for r in rows}) == ["country", "highway", "twisty"]
    assert len(list((out / "roads").glob("*.png"))) == 11
    # a second run reuses the finished drives (of the road type with the fewest roads: the fewest figures redrawn)
    drive_json = out / "run" / "highway-9201" / "drive.json"
    stamp = drive_json.stat().st_mtime_ns
    assert main(["sim", "bench", str(tiny_checkpoint), "--minutes", "0.01", "--out", str(out),
                 "--roads", "highway"]) == 0
    assert drive_json.stat().st_mtime_ns == stamp
    assert "| run | country |" not in capsys.readouterr().out


def test_suite_cache_key_covers_checkpoint_smoothing_and_minutes(tiny_checkpoint, tmp_path):
    import shutil

    import torch

    ckpt = tmp_path / "run" / "best.pt"
    ckpt.parent.mkdir()
    shutil.copy(tiny_checkpoint, ckpt)
    out, drive_json = tmp_path / "bench", tmp_path / "bench" / "run" / "highway-9201" / "drive.json"

    def bench(*options):
        before = drive_json.stat().st_mtime_ns if drive_json.exists() else None
        minutes = [] if "--minutes" in options else ["--minutes", "0.01"]
        assert main(["sim", "bench", str(ckpt), *minutes, "--roads", "highway", "--workers", "1",
                     "--out", str(out), *options]) == 0
        return drive_json.stat().st_mtime_ns != before  # driven anew

    assert bench()
    key = json.loads(drive_json.read_text())["cache_key"]
    assert key == {"checkpoint_sha256": key["checkpoint_sha256"], "suite": "v1", "minutes": 0.01, "smoothing": None}
    assert not bench()  # the same inputs: reused
    assert bench("--smoothing", "0.5") and json.loads(drive_json.read_text())["cache_key"]["smoothing"] == 0.5
    assert not bench("--smoothing", "0.5")
    retrained = torch.load(ckpt, weights_only=True)  # another checkpoint at the same path
    retrained["metrics"]["rmse"] = 0.123
    resaved(ckpt, retrained)
    assert bench("--smoothing", "0.5")
    assert json.loads(drive_json.read_text())["cache_key"]["checkpoint_sha256"] != key["checkpoint_sha256"]
    assert bench("--smoothing", "0.5", "--minutes", "0.02")
    drive_json.write_text(drive_json.read_text()[:40])  # a torn drive.json is driven anew, not a traceback
    assert bench("--smoothing", "0.5", "--minutes", "0.02")


def test_suite_bad_input(tiny_checkpoint, tmp_path, capsys):
    assert main(["sim", "bench", str(tmp_path / "missing.pt")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing.pt: checkpoint not found" in err
    assert main(["sim", "bench", str(tiny_checkpoint), "--roads", ""]) == 2
    assert "--roads must be a comma list of road types of country, highway, twisty, each once" in capsys.readouterr().err


def test_rollout_labels_are_the_experts(tmp_path):
    """A pilot that always steers left drifts off; every frame it visits is labelled with what the expert
    would steer in that state, which an independent replay of the same world reproduces."""
    pilot = ConstantPilot(0.15)
    out = rollout(pilot, tmp_path / "r", seed=21, minutes=0.1, road="country", beta=0.0)
    rec = open_recording(tmp_path / "r")
    assert len(rec) == 120 and rec.cameras == ["center", "left", "right"] and out.interventions > 0
    world = World(21, "country", "sim", 120 / 20)
    ratio = world.car.steering_ratio
    labels, resets = [], 0
    for _ in range(120):
        offset, _ = world.observe()
        if abs(offset) > 1.0:
            world.put_back()
            resets += 1
        labels.append(world.expert_steering() * ratio)  # steering-wheel angle, positive left
        world.step(0.15 / ratio)
    np.testing.assert_allclose(rec.steering, labels, atol=1e-5)
    assert resets == out.interventions
    drifted = np.abs(rec.extra["lateral_offset"]) > 0.5
    assert drifted.any() and (rec.steering[drifted] < 0).all()  # steering back to the right
    assert set(rec.extra["episode"]) == {"rollout"}


def test_dagger_aggregates_rollouts(tiny_recording, tmp_path, saved_figures):
    from steerlab.dagger import run_dagger
    from steerlab.train.config import load_config
    from steerlab.sim.road.suite import SuiteOptions
    from steerlab.train.batches import FrameBatches
    from steerlab.train.config import parse_config
    from steerlab.train.sources import prepare_dataset, training_sources

    cfg = load_config(None, base={
        "data": str(tiny_recording), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "dagger"),
        "split": {"train": "0:60", "val": "240:300"}, "model": {"name": "pilotnet", "dropout": 0.0},
        "train": {"epochs": 1, "batch_size": 32, "side_cameras": True},
        "dagger": {"iterations": 1, "minutes": 0.02, "roads": "country,twisty", "epochs": 1, "suite_minutes": 0.01,
                   "suite_roads": "twisty", "workers": 1}})
    final = run_dagger(cfg, progress=False)
    assert final.exists()
    with open(tmp_path / "dagger" / "dagger.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["round"] for r in rows] == ["0", "1"] and rows[1]["recordings"] == "3"
    assert float(rows[1]["beta"]) == 0.5 and rows[1]["autonomy_twisty"] != "" and rows[1]["autonomy_country"] == ""
    # dagger.png: 7 x 4 inches at 100 dpi; the suite's twisty roads (the only ones driven) and all of them, and
    # the validation RMSE, per round as dagger.csv has them, drawn, the legend naming the three
    png = tmp_path / "dagger" / "dagger.png"
    img = image_of(png)
    assert img.shape[:2] == (400, 700)
    autonomy, rmse = saved_figures[str(png)].axes
    assert legend_of(autonomy) == ["twisty", "all", "val RMSE"]
    twisty, everywhere = autonomy.get_lines()
    assert list(twisty.get_xdata()) == [0, 1]
    for line, key in [(twisty, "autonomy_twisty"), (everywhere, "autonomy_all"), (rmse.get_lines()[0], "val_rmse")]:
        np.testing.assert_allclose(line.get_ydata(), [float(r[key]) for r in rows])
    assert drawn_pixels(img, autonomy, twisty.get_color()) > 100 and drawn_pixels(img, autonomy, "black") > 100
    # a second run into the folder may resume the same config (other workers allowed), not another one
    from steerlab.dagger import _claim

    from steerlab.dagger import dagger_options

    def claim(folder, **more):
        changed = replace(cfg, dagger={**cfg.dagger, **more})
        _claim(folder, changed.for_car(CH2_CAR), dagger_options(changed), CH2_CAR)

    for more in ({"workers": 2}, {"iterations": 2}):
        claim(tmp_path / "dagger", **more)
    with pytest.raises(SteerlabError, match=r"holds a DAgger run of another config \(dagger.minutes: 0.02 -> 0.2\); "
                                            r"choose a new out"):
        claim(tmp_path / "dagger", minutes=0.2)
    claim(tmp_path / "fresh")  # a start that failed before its first round does not hold the folder
    claim(tmp_path / "fresh", minutes=0.2)
    # an experiment's closed-loop column reuses the last round's drives of the same suite, and drives anew otherwise
    from steerlab.experiment import suite_checkpoint
    from steerlab.sim.road.suite import closed_loop_metrics

    run = tmp_path / "dagger"
    drives = sorted((run / "round1" / "suite").rglob("drive.json"))
    stamps = [d.stat().st_mtime_ns for d in drives]
    same = SuiteOptions("v1", 0.01, 1, roads="twisty")
    assert suite_checkpoint(run, cfg, same) == run / "round1" / "best.pt"
    metrics = closed_loop_metrics(suite_checkpoint(run, cfg, same), same, False, plots=False)
    assert [d.stat().st_mtime_ns for d in drives] == stamps and not (run / "suite").exists()
    assert metrics["autonomy_twisty"] == pytest.approx(float(rows[1]["autonomy_twisty"]))
    assert suite_checkpoint(run, cfg, replace(same, minutes=0.02)) == run / "best.pt"
    round1 = parse_config(json.loads((tmp_path / "dagger" / "round1" / "config.json").read_text()))
    assert round1.train.init.endswith("round0/best.pt") and len(round1.extra_data) == 2
    # round 1 trains on the main recording's training frames and every rollout frame, with their side cameras
    ds = prepare_dataset(round1, progress=False)
    sources, codes = training_sources(round1, ds, np.arange(60), progress=False)
    rollouts = [open_recording(p) for p in round1.extra_data]
    assert len(sources) == 9 and len(codes) == 3 * (60 + sum(len(r) for r in rollouts))
    batches = FrameBatches(sources, {"mean": [0.0], "std": [1.0]})
    first_rollout = batches.offsets[3]
    np.testing.assert_allclose(batches.steering(np.array([first_rollout])), rollouts[0].steering[:1])


@pytest.mark.parametrize("geometry", ["sim", "ch2"])
def test_viewpoint_shift_matches_the_renderer(geometry):
    """A frame rendered with the car moved sideways (and turned) and the centre frame warped by the same
    amount agree on the road; the unwarped frame does not."""
    road = Road(3, "country", 3000)
    r = Renderer(road, geometry)
    x, y, psi = road.pose(300.0, LANE_CENTER)
    centre = r.render(x, y, psi, 300.0)
    rows = slice(int(r.horizon) + r.cam.height // 7, r.cam.height)  # the road, below the far haze
    gray = lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(int)[rows]  # noqa: E731
    for shift, yaw in [(0.5, 0.0), (-0.8, 0.0), (0.4, 3.0)]:
        truth = r.render(x, y, psi + np.radians(yaw), 300.0, shift=shift)
        warped = shift_view(centre, CAMERAS[geometry], shift, yaw)
        moved = np.abs(gray(truth) - gray(centre)) > 40  # markings and verges that moved
        agree = np.abs(gray(truth) - gray(warped)) <= 40
        assert moved.mean() > 0.05
        assert agree.mean() > 0.97 and agree[moved].mean() > 0.85


def test_viewpoint_shift_identity_and_frame_size():
    img = np.random.default_rng(0).integers(0, 255, (160, 320, 3), np.uint8)
    np.testing.assert_array_equal(shift_view(img, CAMERAS["sim"], 0.0, 0.0), img)
    with pytest.raises(SteerlabError, match="does not fit"):
        shift_view(img, CAMERAS["ch2"], 0.5)


def test_viewpoint_views_on_ch2_layout(ch2_folder, tmp_path):
    """Centre-only recordings without speed (like CH2) get virtual views once a return distance is set."""
    from steerlab.train import loop, sources
    from steerlab.train.config import load_config

    cfg = load_config(None, base={"data": str(ch2_folder), "labels": str(ch2_folder / "labels.csv"),
                                  "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
                                  "split": {"train": "0:4", "val": "4:6"},
                                  "train": {"epochs": 1, "batch_size": 4, "views": [[0.5, 0.0], [-0.5, 2.0]]}})
    with pytest.raises(SteerlabError, match="recovery_distance_m"):
        loop.train(cfg, progress=False)
    cfg = replace(cfg, train=replace(cfg.train, recovery_distance_m=20.0)).for_car(CH2_CAR)
    ds = sources.prepare_dataset(cfg, progress=False)
    sources, codes = sources.training_sources(cfg, ds, np.arange(4), progress=False)
    assert len(sources) == 3 and len(codes) == 12
    # 0.5 m to the right: steer left by arctan(0.5 / 20 m); turned 2 deg left: steer 2 deg right; x 14.8 at the
    # steering wheel
    np.testing.assert_allclose(sources[2][1], ds.steering + 14.8 * (np.arctan(0.5 / 20.0) - np.radians(2.0)))
    assert sources[1][0].arrays["image"].shape == (6, 66, 200, 1)


def test_drive_and_evaluate_videos(tiny_checkpoint, tiny_recording, tmp_path):
    from steerlab.evaluate.offline import evaluate
    from steerlab.pilot import Pilot

    r = drive(Pilot(tiny_checkpoint), tmp_path / "d", DriveOptions(seed=101, minutes=0.025), video=tmp_path / "d.mp4",
              progress=False)
    assert r.distance_km > 0
    # every tick a frame: the 320x160 camera scaled to 640 wide over a panel of 150 rows, the road moving
    evaluate(tiny_checkpoint, Source(str(tiny_recording), "0:20"), tmp_path / "e", video=tmp_path / "e.mp4",
             progress=False)
    for path, count in ((tmp_path / "d.mp4", 30), (tmp_path / "e.mp4", 20)):
        frames = assert_video(path, count, (640, 470))
        for color in (MODEL, REFERENCE):  # the model's wheel (amber) and the expert's or recorded one (green)
            assert (np.abs(frames[0][320:].astype(int) - color).max(axis=2) < 40).sum() > 200, (path, color)


def test_another_camera_is_refused_unless_asked_for(tiny_checkpoint, ch2_folder, tmp_path, capsys):
    from steerlab.evaluate.offline import evaluate
    from steerlab.pilot import Pilot

    with pytest.raises(SteerlabError, match="trained on the 'sim' camera and takes no 'ch2' frames"):
        drive(Pilot(tiny_checkpoint), None, DriveOptions(seed=101, minutes=0.01, geometry="ch2"), progress=False)
    drive(Pilot(tiny_checkpoint, other_camera=True), None, DriveOptions(seed=101, minutes=0.01, geometry="ch2"),
          progress=False)
    assert "trained on the 'sim' camera geometry" in capsys.readouterr().err
    source = Source(str(ch2_folder), labels=str(ch2_folder / "labels.csv"))
    with pytest.raises(SteerlabError, match="run steerlab evaluate with --allow-other-camera"):
        evaluate(tiny_checkpoint, source, tmp_path / "e", progress=False)
    evaluate(tiny_checkpoint, source, tmp_path / "e", progress=False, other_camera=True)
    assert "has the 'ch2' geometry" in capsys.readouterr().err
