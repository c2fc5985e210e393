"""Models that read the lane: the lane values of the track world's tubs, the auxiliary lane head (its targets, loss,
mirroring and errors), the Pilot's lane, steering by the lane (`--steer-by lane`) with a Stanley controller, and
the pace from the lane (`--throttle-by lane`)."""

import json
import math

import cv2
import numpy as np
import pytest
import torch

from steerlab.cli import main
from steerlab.data.car import CARS
from steerlab.data.labels import LANE, lane_targets, lane_values
from steerlab.data.readers import open_recording
from steerlab.data.writer import TubWriter
from steerlab.errors import DataError, SteerlabError
from steerlab.models import create_model, list_models
from steerlab.models.registry import learns_lane
from steerlab.pilot import Controls
from steerlab.sim.core.driving import drive_loop
from steerlab.control import K_OFFSET, LANE_KP, V0, lane_speed, lane_steering, lane_throttle
from steerlab.donkey import SteerlabPilot
from steerlab.sim.track.lane import LanePilot
from steerlab.sim.track.world import TrackDriveOptions, TrackWorld
from steerlab.train import loop
from steerlab.train.config import load_config

CAR = CARS["donkey"]


def lane_of(i: int) -> tuple[float, float, float]:
    """A frame's lane in the tubs below: offset (m), heading (rad), curvature (1/m)."""
    return 0.12 * math.sin(i / 5), 0.08 * math.cos(i / 7), 0.9 * math.sin(i / 11)


def write_tub(folder, n=80, lane=True):
    """A 160x120 tub whose frames show the lane offset (a bar's position) and the steering (its width)."""
    w = TubWriter(folder, full_lock_deg=25, lane=lane)
    for i in range(n):
        offset, heading, curvature = lane_of(i)
        frame = np.full((120, 160, 3), 90, np.uint8)
        x = int(80 + 400 * offset)
        cv2.rectangle(frame, (x - 6, 40), (x + 6, 119), (20, 20, 230), -1)
        w.add(frame, i * 50_000_000, -0.2 * math.sin(i / 5), 0.4, lane=(offset, heading, curvature) if lane else None)
    return w.close()


def test_a_tub_with_lane_values_declares_and_reads_them(tmp_path):
    tub = write_tub(tmp_path / "tub", n=5)
    keys, types = (json.loads(line) for line in (tub / "manifest.json").read_text().splitlines()[:2])
    assert keys[-3:] == ["lane/offset", "lane/heading", "lane/curvature"] and types[-3:] == ["float"] * 3
    rec = open_recording(tub)
    expected = np.array([lane_of(i) for i in range(5)])
    for k, name in enumerate(("lateral_offset", "heading_error", "curvature")):
        np.testing.assert_array_equal(rec.extra[name], expected[:, k])
    assert set(open_recording(write_tub(tmp_path / "plain", n=5, lane=False)).extra) == {"session"}
    # a record that lacks a declared value is named
    lines = (tub / "catalog_0.catalog").read_text().splitlines()
    rec3 = json.loads(lines[3])
    del rec3["lane/heading"]
    lines[3] = json.dumps(rec3)
    (tub / "catalog_0.catalog").write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"catalog_0.catalog, row 4: record 3: lane/heading is None; the manifest "
                                        r"declares it, so a finite number is expected"):
        open_recording(tub)
    w = TubWriter(tmp_path / "mixed", full_lock_deg=25)
    with pytest.raises(SteerlabError, match="lane values belong to every record of a tub made with lane=True"):
        w.add(np.zeros((120, 160, 3), np.uint8), 0, 0.0, 0.3, lane=(0.0, 0.0, 0.0))


def test_lane_targets_are_scaled_and_come_back_in_si_units():
    labels = {"lateral_offset": np.array([0.05, -0.2]), "heading_error": np.array([0.1, 0.0]),
              "curvature": np.array([-0.5, 1.0])}
    # over 0.1 m, 0.1 rad, 1 /m
    np.testing.assert_allclose(lane_targets(labels), [[0.5, 1.0, -0.5], [-2.0, 0.0, 1.0]], rtol=1e-6)
    assert lane_targets({"lateral_offset": labels["lateral_offset"]}) is None
    assert lane_values([0.5, 1.0, -0.5]) == pytest.approx((0.05, 0.1, -0.5))
    assert list(LANE) == ["lateral_offset", "heading_error", "curvature"]


def test_models_with_a_lane_head():
    assert {m for m in list_models() if learns_lane(m)} == {"donkey-linear", "pilotnet", "pilotnet-diff",
                                                           "pilotnet-flow"}
    for name, hidden in (("donkey-linear", 50), ("pilotnet", 10)):
        plain = create_model(name, in_channels=3, height=120, width=160)
        model = create_model(name, in_channels=3, height=120, width=160, throttle=True, lane=True)
        # the other weights keep their names: checkpoints of models without the head still load
        assert set(model.state_dict()) - set(plain.state_dict()) >= {"lane.weight", "lane.bias"}
        assert model.lane.in_features == hidden
        out = model.eval()(torch.randn(2, 3, 120, 160))
        assert set(out) == {"steering", "throttle", "lane"} and out["lane"].shape == (2, 3)
        # the head reads the last hidden features, the same ones the steering's layer reads
        hidden_x = model.head[:-1](model.features(torch.ones(1, 3, 120, 160)).flatten(1))
        assert torch.allclose(model(torch.ones(1, 3, 120, 160))["lane"], model.lane(hidden_x))


def test_lane_weight_needs_a_model_with_the_head_and_is_not_set_by_hand(tmp_path):
    tub = write_tub(tmp_path / "tub", n=5)
    with pytest.raises(SteerlabError, match=r"^train.lane_weight: model 'cg23' has no lane head; these do: "
                                            r"donkey-linear, pilotnet, pilotnet-diff, pilotnet-flow; choose one"):
        load_config(None, base={"data": str(tub), "model": {"name": "cg23"}, "train": {"lane_weight": 0.5}})
    with pytest.raises(SteerlabError, match=r"model.lane is not set by hand"):
        load_config(None, base={"data": str(tub), "model": {"name": "pilotnet", "lane": True}})
    with pytest.raises(SteerlabError, match="train.lane_weight must be"):
        load_config(None, base={"data": str(tub), "train": {"lane_weight": -1}})


def test_objective_adds_the_weighted_mae_of_the_lane():
    net = create_model("pilotnet", lane=True)
    out = {"steering": torch.tensor([0.0, 1.0]), "lane": torch.tensor([[0.5, 0.0, 1.0], [0.0, 0.0, 0.0]])}
    y = {"steering": torch.tensor([1.0, 1.0]), "lane": torch.tensor([[0.0, 0.0, 1.0], [0.0, 1.5, 0.0]])}
    # MSE of the steering (1 + 0) / 2, plus 2 x MAE of the lane's six values (0.5 + 1.5) / 6
    assert float(loop.objective(net, out, y, "mse", 0.0, 0.0, 2.0)) == pytest.approx(0.5 + 2 * 2 / 6)
    assert float(loop.objective(net, out, y, "mse")) == pytest.approx(0.5)


def test_mirrored_samples_negate_the_lane_with_the_steering(tmp_path):
    from steerlab.data.inputs import channel_stats, segment_starts
    from steerlab.train.batches import Batch, FrameBatches
    from steerlab.train.sources import prepare_dataset

    tub = write_tub(tmp_path / "tub", n=10)
    cfg = load_config(None, base={"data": str(tub), "cache": str(tmp_path / "cache"), "model": {"name": "pilotnet"},
                                  "train": {"lane_weight": 1.0}})
    ds = prepare_dataset(cfg, progress=False)
    stats = channel_stats(ds.arrays, ds.config, np.arange(10), segment_starts(ds.labels["segment"]))
    data = FrameBatches([(ds, ds.steering)], stats, lane=True)
    _, targets, _ = data[Batch(np.array([3, 4]), flip=np.array([True, False]))]
    scaled = np.array([np.array(lane_of(i)) / list(LANE.values()) for i in (3, 4)])
    np.testing.assert_allclose(targets["lane"].numpy(), [-scaled[0], scaled[1]], rtol=1e-5)
    np.testing.assert_allclose(targets["steering"].numpy(), [-ds.steering[3], ds.steering[4]], rtol=1e-6)
    assert "lane" not in FrameBatches([(ds, ds.steering)], stats)[Batch(np.array([3]))][1]


def train_on(tub, tmp_path, **train):
    cfg = load_config(None, base={"data": str(tub), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
                                  "model": {"name": "donkey-linear"}, "split": {"train": "0:60", "val": "60:80"},
                                  "reader": {"full_lock_deg": 25},
                                  "preprocess": {"crop": [0, 0, 0, 0], "width": 160, "height": 120, "color": "rgb"},
                                  "train": {"epochs": 3, "batch_size": 16, "lr": 1e-3, "loss": "mae", **train}})
    return loop.train(cfg, progress=False), tmp_path / "run"


def test_training_data_without_lane_values_is_refused(tmp_path):
    tub = write_tub(tmp_path / "tub", lane=False)
    with pytest.raises(SteerlabError, match=rf"^{tub} has no lane values \(lateral offset, heading error, curvature\) "
                                            r"for train.lane_weight to learn: record it with steerlab sim record "
                                            r"--world track, or set train.lane_weight to 0$"):
        train_on(tub, tmp_path, lane_weight=0.5)


@pytest.fixture(scope="module")
def lane_model(tmp_path_factory):
    """A donkey-linear with a lane head trained on `write_tub`'s frames: (training's best, run folder, its .onnx,
    a frame of the tub)."""
    from steerlab.export import export_onnx

    tmp_path = tmp_path_factory.mktemp("lane")
    tub = write_tub(tmp_path / "tub")
    best, run = train_on(tub, tmp_path, lane_weight=0.5)
    onnx = export_onnx(run / "best.pt", tmp_path / "model.onnx")  # the lane head is exported with the rest
    return best, run, onnx, cv2.imread(str(tub / "images" / "70_cam_image_array_.jpg"))


def test_a_lane_model_trains_and_its_pilot_sees_the_lane_but_drives_by_steering(lane_model):
    from steerlab.checkpoint import load_checkpoint
    from steerlab.pilot import Pilot

    best, run, onnx, frame = lane_model
    assert load_checkpoint(run / "best.pt")["model_cfg"]["lane"] is True
    header = (run / "log.csv").read_text().splitlines()[0].split(",")
    assert "val_lane_mae" in header and best["lane_mae"] > 0
    pilot = Pilot(run / "best.pt")
    controls = pilot.step(frame)
    assert "lane" in pilot.targets and len(controls.lane) == 3 and all(math.isfinite(v) for v in controls.lane)
    exported = Pilot(onnx)
    assert "lane" in exported.targets
    assert exported.step(frame).lane == pytest.approx(controls.lane, abs=1e-4)
    assert exported.step(frame).steering == pytest.approx(controls.steering, abs=1e-4)

    # steering by the lane, on the car: the controller's angle on the lane the model sees over the car's full lock
    # (servo units, positive right), its throttle the model's as usual
    rgb = np.ascontiguousarray(frame[..., ::-1])
    for model in (run / "best.pt", onnx):
        part = SteerlabPilot(model, steer_by="lane", full_lock_deg=25, reset_after_s=None)
        plain = SteerlabPilot(model, full_lock_deg=25, reset_after_s=None)
        (angle, throttle), (_, head_throttle) = part.run(rgb, 1.5), plain.run(rgb, 1.5)
        expected = -lane_steering(*part.controls.lane, 1.5, CAR.wheelbase) / CAR.full_lock
        assert angle == pytest.approx(float(np.clip(expected, -1, 1)), abs=1e-9) and throttle == head_throttle
        assert part.controls.lane == pytest.approx(controls.lane, abs=1e-4)
        with pytest.raises(SteerlabError, match="steer_by lane needs the measured speed"):
            part.run(rgb)
    for given, match in (({"smoothing": 0.5}, "smoothing shapes the steering head's output; steer_by lane"),
                         ({"steering_step": 0.1}, "steering_step shapes the steering head's output"),
                         ({"steer_by": "lanes"}, "steer_by must be 'steering' or 'lane', got 'lanes'")):
        with pytest.raises(SteerlabError, match=match):
            SteerlabPilot(onnx, **{"steer_by": "lane", **given})

    # in the track world the same part drives: the sim's angle is the car's
    from steerlab.sim.track.run import checkpoint_pilot

    world = TrackWorld(1)
    frame = world.render()
    for model in (run / "best.pt", onnx):
        lane = checkpoint_pilot(model, TrackDriveOptions(steer_by="lane"))
        car = SteerlabPilot(model, steer_by="lane", full_lock_deg=25, reset_after_s=None)
        got = lane.step(frame, 1.5)
        assert got.steering == car.run(np.ascontiguousarray(frame[..., ::-1]), 1.5)[0]
        assert lane.name == "donkey-linear" and lane.part.steer_by == "lane"


def test_the_pace_from_the_lane_against_hand_computed_throttles():
    # lateral acceleration 3.5 m/s^2 on a curve of 0.875 /m: 2 m/s; on a 5 m/s car the throttle 0.4 holds it
    assert lane_speed(0.875, 3.5, 5.0) == pytest.approx(2.0) and lane_speed(-0.875, 3.5, 5.0) == pytest.approx(2.0)
    assert lane_speed(0.0, 3.5, 5.0) == 5.0 and lane_speed(0.01, 3.5, 5.0) == 5.0  # a straight: the top speed
    assert LANE_KP == 0.5
    assert lane_throttle(0.875, 2.0, 3.5, 5.0, 1.0) == pytest.approx(0.4)
    assert lane_throttle(0.875, 3.0, 3.5, 5.0, 1.0) == pytest.approx(-0.1)  # 1 m/s too fast: it brakes
    assert lane_throttle(0.875, 1.0, 3.5, 5.0, 1.0) == pytest.approx(0.9)
    assert lane_throttle(0.875, 0.0, 3.5, 5.0, 0.5) == 0.5 and lane_throttle(2.0, 5.0, 3.5, 5.0, 0.5) == -0.5


class TrueLanePace:
    """A pilot at the pace of the world's true lane (what a perfect lane head would give the part)."""

    name, geometry, source, convention = "true-lane-pace", None, "the world's lane", None

    def reset(self):
        pass

    def __init__(self, world, lat_acc):
        self.world, self.lat_acc = world, lat_acc

    def step(self, frame, speed=None):
        return Controls(0.0, throttle=lane_throttle(self.world.lane_curvature(), speed or 0.0, self.lat_acc,
                                                    CAR.motor.top_speed, 1.0))


def test_the_pace_from_the_true_lane_laps_cleanly_faster_than_the_expert_and_slows_for_the_curves(tmp_path):
    from steerlab.sim.track.run import drive_expert

    times, in_bends = {}, {}
    for lat_acc in (2.0, 3.5):
        world = TrackWorld(3, camera=None)
        pilot = LanePilot(TrueLanePace(world, lat_acc), lambda: (*world.observe(), world.lane_curvature()))
        t = drive_loop(world, pilot, 900, 0.0, 20.0, progress=False)  # 45 s
        laps = world.laps.result()
        assert laps["laps"] >= 2 and laps["clean_laps"] == laps["laps"] and not t.intervention.any()
        times[lat_acc] = laps["mean_lap_s"]
        bends = np.abs(world.track.curvature(t.s)) > 1.0
        in_bends[lat_acc] = t.speed[bends].mean()
        # slower in the bends than on the straights: it reads the curvature where the car is, so it slows within a
        # bend, not before it
        assert in_bends[lat_acc] < t.speed[~bends].mean() - 0.5
    expert = drive_expert(tmp_path, TrackDriveOptions(seed=3, minutes=0.75, max_throttle=1.0))
    assert in_bends[2.0] < in_bends[3.5] - 0.3 and times[3.5] < times[2.0] and times[3.5] < expert.mean_lap_s


def test_a_lane_model_drives_at_the_pace_of_the_lane_it_sees(lane_model):
    from steerlab.sim.track.run import checkpoint_pilot

    _, run, onnx, frame = lane_model
    rgb = np.ascontiguousarray(frame[..., ::-1])
    for model in (run / "best.pt", onnx):
        for given, lat_acc in (({}, 3.5), ({"lat_acc": 0.01}, 0.01)):
            part = SteerlabPilot(model, throttle_by="lane", full_lock_deg=25, max_throttle=1.0, reset_after_s=None,
                                 **given)
            for speed in (0.0, 1.5, 4.0):
                _, throttle = part.run(rgb, speed)
                assert throttle == lane_throttle(part.controls.lane[2], speed, lat_acc, 5.0, 1.0)
        assert lane_speed(part.controls.lane[2], 0.01, 5.0) < 5.0  # the curvature it sees sets the pace
        with pytest.raises(SteerlabError, match="throttle_by lane needs the measured speed"):
            part.run(rgb)
        sim = checkpoint_pilot(model, TrackDriveOptions(throttle_by="lane", lat_acc=2.0, max_throttle=1.0))
        world_frame = TrackWorld(1).render()
        car = SteerlabPilot(model, throttle_by="lane", lat_acc=2.0, full_lock_deg=25, max_throttle=1.0,
                            reset_after_s=None)
        assert sim.step(world_frame, 1.5).throttle == car.run(np.ascontiguousarray(world_frame[..., ::-1]), 1.5)[1]
    for given, match in (({"throttle_by": "speed"}, r"throttle_by must be 'model' or 'lane', got 'speed'"),
                         ({"lat_acc": 3.0}, r"lat_acc shapes the pace from the lane: leave it out, or set "
                                            r"throttle_by to lane"),
                         ({"throttle_by": "lane", "lat_acc": 0}, r"lat_acc must be a number in \(0, 20\], got 0"),
                         ({"throttle_by": "lane", "top_speed": -1.0}, r"top_speed must be a number in \(0, 20\]"),
                         ({"throttle_by": "lane", "throttle": 0.3}, r"throttle is the constant throttle of a model "
                                                                    r"that predicts none; throttle_by lane"),
                         ({"throttle_by": "lane", "throttle_scale": 1.2},
                          r"throttle_scale shapes a learned throttle; model.onnx drives at a lane-paced throttle"),
                         ({"throttle_by": "lane", "throttle_floor": 0.2}, r"throttle_floor shapes a learned throttle")):
        with pytest.raises(SteerlabError, match=r"^SteerlabPilot: " + match):
            SteerlabPilot(onnx, **given)


def test_the_pace_from_the_lane_needs_a_lane_head_and_is_refused_beside_a_learned_throttles_shaping(tmp_path,
                                                                                                      capsys):
    from conftest import made

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    with pytest.raises(SteerlabError, match=rf"^{ckpt}: throttle_by lane drives at the pace of the lane a model's "
                                            r"lane head sees; model 'pilotnet' has none"):
        SteerlabPilot(ckpt, throttle_by="lane")
    for args, message in ((["--throttle-by", "lane", "--throttle-floor", "0.2"], "--throttle-floor must be 0 with "
                           "throttle_by lane (--throttle-by lane: the lane sets the pace; it shapes a learned "
                           "throttle), got 0.2"),
                          (["--lat-acc", "2"], "--lat-acc must be given only with throttle_by lane (--throttle-by "
                           "lane: it shapes the pace from the lane), got 2"),
                          (["--throttle-by", "lane", "--throttle", "0.3"], "--throttle must be left out with "
                           "throttle_by lane (--throttle-by lane: the lane sets the pace), got 0.3")):
        for command in (["drive", "--minutes", "0.01", "--out", str(tmp_path / "drive")],
                        ["bench", "--suite", "s1", "--out", str(tmp_path / "bench")]):
            assert main(["sim", command[0], str(ckpt), "--world", "track", *command[1:], *args]) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert err == [f"error: {message}"]


def test_steering_by_the_lane_is_refused_for_a_model_without_the_head(tmp_path, capsys):
    from conftest import made

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    assert main(["sim", "drive", str(ckpt), "--world", "track", "--minutes", "0.01", "--steer-by", "lane",
                 "--out", str(tmp_path / "drive")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{ckpt}: steer_by lane steers by the lane a model's lane head sees; model " \
        "'pilotnet' has none" in err[0]


def test_the_lane_controller_against_hand_computed_angles():
    L = CAR.wheelbase  # 0.26 m
    assert lane_steering(0.0, 0.0, 0.0, 2.0, L) == 0.0
    assert lane_steering(0.0, 0.0, 0.5, 2.0, L) == pytest.approx(math.atan(0.13))  # follows the curve, to the left
    assert lane_steering(0.0, 0.2, 0.0, 2.0, L) == pytest.approx(-0.2)  # turned left: back to the right
    # 0.1 m left of the centre at 1.5 m/s: atan(2 x 0.1 / (1.5 + 0.5)) to the right
    assert (K_OFFSET, V0) == (2.0, 0.5)
    assert lane_steering(0.1, 0.0, 0.0, 1.5, L) == pytest.approx(-math.atan(0.1))
    assert lane_steering(-0.1, -0.05, -1.0, 0.0, L) == pytest.approx(-math.atan(0.26) + 0.05 + math.atan(0.4))


class Throttle:
    """A pilot that gives a constant throttle (and steers straight): the throttle of a lane pilot."""

    name, geometry, source, convention = "throttle", None, "a constant throttle", None

    def step(self, frame, speed=None):
        return Controls(0.0, throttle=0.5)

    def reset(self):
        pass


@pytest.mark.parametrize("style", ["taped", "centre"])
def test_the_lane_controller_on_the_true_lane_laps_a_track_cleanly(style):
    world = TrackWorld(3, style=style, camera=None)
    pilot = LanePilot(Throttle(), lambda: (*world.observe(), world.lane_curvature()))
    t = drive_loop(world, pilot, 900, 0.0, 20.0, progress=False)  # 45 s at about 2.4 m/s
    laps = world.laps.result()
    assert laps["laps"] >= 2 and laps["clean_laps"] == laps["laps"] and not t.intervention.any()
    assert np.max(np.abs(t.offset)) < 0.1  # within 10 cm of the centre line, 0.45 m from the lane's edge


def test_a_donkeycar_part_in_the_suite_cannot_steer_by_the_lane():
    from steerlab.sim.track.suite import TrackSuiteOptions, race_part

    with pytest.raises(SteerlabError, match=r"^model.h5: steer_by lane steers by a steerlab checkpoint's lane head; "
                                            r"a donkeycar part steers by its own angle: set steer_by to steering$"):
        race_part(Throttle, "theirs", "model.h5", TrackSuiteOptions(steer_by="lane"))
    with pytest.raises(SteerlabError, match=r"^model.h5: throttle_by lane paces by a steerlab checkpoint's lane head; "
                                            r"a donkeycar part drives at its own throttle: set throttle_by to model$"):
        race_part(Throttle, "theirs", "model.h5", TrackSuiteOptions(throttle_by="lane"))


def test_the_lane_pilot_steers_by_what_it_sees_within_the_full_lock_and_keeps_its_inner_pilots_throttle():
    """By hand: the inner pilot answers the frame and the speed it is given, its throttle drives; the angle is the
    lane controller's at the measured speed (0 without one), limited to the car's full lock both ways."""
    from steerlab.pilot import Controls

    class Inner:
        name, geometry, source = "inner", "donkey", "inner"

        def __init__(self):
            self.calls = []

        def step(self, frame, speed=None):
            self.calls.append((frame, speed))
            return Controls(0.0, throttle=0.37)

    frame, seen = np.zeros((2, 2, 3), np.uint8), [(0.1, 0.05, 0.5)]
    inner = Inner()
    pilot = LanePilot(inner, lambda: seen[0], CAR)
    for speed, at in ((None, 0.0), (2.0, 2.0)):
        controls = pilot.step(frame, speed)
        assert inner.calls[-1][0] is frame and inner.calls[-1][1] == speed and controls.throttle == 0.37
        assert controls.steering == pytest.approx(lane_steering(0.1, 0.05, 0.5, at, CAR.wheelbase))
    for offset, lock in ((10.0, -CAR.full_lock), (-10.0, CAR.full_lock)):  # far off: atan nears 90 degrees
        seen[0] = (offset, 0.0, 0.0)
        assert pilot.step(frame, 1.0).steering == pytest.approx(lock)
