"""The learned throttle: models with a throttle output, the loss that weights it, training on a tub that varies
its throttle (and not on one that does not), its metrics in training and `steerlab evaluate`, the ONNX export
and the donkeycar part that drives with it."""

import json
import math

import cv2
import numpy as np
import pytest
import torch

from steerlab.data.writer import TubWriter
from steerlab.donkey import SteerlabPilot
from steerlab.errors import SteerlabError
from steerlab.models import create_model, list_models
from steerlab.models.registry import learns_throttle
from steerlab.train import loop
from steerlab.train.config import load_config

THROTTLE_MODELS = {"donkey-linear", "pilotnet", "pilotnet-diff", "pilotnet-flow", "cnn3d", "cg23", "lstm",
                   "multimodal-lstm", "flow-lstm"}


def test_models_with_a_throttle_output():
    assert {m for m in list_models() if learns_throttle(m)} == THROTTLE_MODELS
    for name in sorted(THROTTLE_MODELS):
        plain = create_model(name, in_channels=3)
        model = create_model(name, in_channels=3, throttle=True)
        # the steering's weights keep their names: checkpoints of models without the output still load
        assert set(model.state_dict()) == set(plain.state_dict())
        x = torch.randn((2, 4, 3, 66, 200) if model.recurrent else (2, 3, 66, 200))
        out = model.eval()(x)
        out = out[0] if model.recurrent else out
        assert set(out) == {"steering", "throttle"} and out["throttle"].shape == out["steering"].shape
        plain_out = plain.eval()(x)
        assert set(plain_out[0] if plain.recurrent else plain_out) == {"steering"}


def test_objective_adds_the_weighted_mae_of_the_throttle():
    net = create_model("cg23", throttle=True)
    out = {"steering": torch.tensor([0.0, 1.0]), "throttle": torch.tensor([0.5, 0.1])}
    y = {"steering": torch.tensor([1.0, 1.0]), "throttle": torch.tensor([0.3, 0.4])}
    # MSE of the steering (1 + 0) / 2, plus 2 x MAE of the throttle (0.2 + 0.3) / 2
    assert float(loop.objective(net, out, y, "mse", 0.0, 2.0)) == pytest.approx(0.5 + 2 * 0.25)
    assert float(loop.objective(net, out, y, "mae", 0.0, 0.0)) == pytest.approx(0.5)


def write_tub(folder, throttle, n=120):
    """A 160x120 tub at 20 Hz whose frames show the steering (a bar's position) and the throttle (the
    brightness of the floor), so that both can be learned from one frame."""
    w = TubWriter(folder, full_lock_deg=25)
    for i in range(n):
        angle, t = 0.8 * math.sin(i / 6), throttle(i)
        frame = np.full((120, 160, 3), int(60 + 150 * t), np.uint8)
        x = int(80 + 60 * angle)
        cv2.rectangle(frame, (x - 6, 40), (x + 6, 119), (20, 20, 230), -1)
        w.add(frame, i * 50_000_000, -angle * math.radians(25), t)
    return w.close()


def train_on(tub, tmp_path, **train):
    cfg = load_config(None, base={"data": str(tub), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
                                  "model": {"name": "cg23"}, "split": {"train": "0:90", "val": "90:120"},
                                  "preprocess": {"width": 100, "height": 33},  # half the default size: quicker
                                  "train": {"epochs": 12, "batch_size": 16, "lr": 1e-3, "patience": 12, **train}})
    return loop.train(cfg, progress=False), tmp_path / "run"


def test_a_tub_that_varies_its_throttle_gets_a_throttle_model(tmp_path, capsys):
    from steerlab.checkpoint import load_checkpoint
    from steerlab.evaluate.offline import evaluate
    from steerlab.export import export_onnx
    from steerlab.data.readers import Source
    from steerlab.pilot import Pilot

    def throttle(i):
        return 0.2 + 0.5 * (i // 10 % 2)  # 0.2 and 0.7 in blocks of ten frames

    tub = write_tub(tmp_path / "tub", throttle)
    best, run = train_on(tub, tmp_path)
    assert "learns the steering alone" not in capsys.readouterr().out
    recorded = np.array([throttle(i) for i in range(90, 120)])
    assert best["throttle_mae"] < 0.5 * np.mean(np.abs(recorded - recorded.mean()))  # it sees the brightness
    assert load_checkpoint(run / "best.pt")["model_cfg"]["throttle"] is True
    assert "val_throttle_mae" in (run / "log.csv").read_text().splitlines()[0].split(",")
    assert (run / "val_predictions.csv").read_text().splitlines()[0].endswith("throttle")

    m = evaluate(run / "best.pt", Source(str(tub), "90:120"), tmp_path / "eval", progress=False)
    saved = json.loads((tmp_path / "eval" / "metrics.json").read_text())
    assert saved["throttle_mae"] == pytest.approx(m["throttle_mae"]) and "throttle_rmse" in saved
    pred = np.genfromtxt(tmp_path / "eval" / "predictions.csv", delimiter=",", names=True)
    assert np.mean(np.abs(pred["throttle"] - recorded)) == pytest.approx(m["throttle_mae"])

    onnx = export_onnx(run / "best.pt", tmp_path / "model.onnx")
    frame = cv2.imread(str(tub / "images" / "100_cam_image_array_.jpg"))
    for backend in (run / "best.pt", onnx):
        assert Pilot(backend).step(frame).throttle == pytest.approx(pred["throttle"][10], abs=1e-4)
    rgb = np.ascontiguousarray(frame[..., ::-1])
    learned = pred["throttle"][10]
    assert SteerlabPilot(onnx).run(rgb)[1] == pytest.approx(min(learned, 0.5), abs=1e-4)
    assert SteerlabPilot(onnx, throttle_scale=0.5, max_throttle=1.0).run(rgb)[1] == pytest.approx(
        0.5 * learned, abs=1e-4)
    assert SteerlabPilot(onnx, 0.25, learned_throttle=False).run(rgb)[1] == 0.25
    with pytest.raises(SteerlabError, match=r"model.onnx learned the throttle; throttle=0.25 would override it: "
                                            r"pass learned_throttle=False"):
        SteerlabPilot(onnx, 0.25)


def test_a_tub_of_constant_throttle_gets_no_throttle_output(tmp_path, capsys):
    from steerlab.checkpoint import load_checkpoint

    tub = write_tub(tmp_path / "tub", lambda i: 0.3, n=60)
    cfg = load_config(None, base={"data": str(tub), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
                                  "split": {"train": "0:40", "val": "40:60"}, "train": {"epochs": 1}})
    assert cfg.train.throttle_weight == 0.5  # the tub default
    best = loop.train(cfg, progress=False)
    assert f"{tub} has a constant throttle (0.3): the model learns the steering alone" in capsys.readouterr().out
    assert "throttle_mae" not in best and "throttle" not in load_checkpoint(tmp_path / "run" / "best.pt")["model_cfg"]
    assert SteerlabPilot(tmp_path / "run" / "best.pt").shaping.constant == 0.3  # the constant default


def test_pretraining_with_and_without_a_throttle_output_carries_the_steering(tmp_path, capsys):
    """train.init across tubs that differ in the throttle: the pretrained steering is kept; a throttle row is
    dropped for a tub of constant throttle, and added fresh for one that varies it."""
    from steerlab.checkpoint import load_checkpoint

    varying = write_tub(tmp_path / "varying", lambda i: 0.2 + 0.5 * (i // 10 % 2), n=40)
    constant = write_tub(tmp_path / "constant", lambda i: 0.3, n=40)

    def run(tub, name, **train):
        cfg = load_config(None, base={"data": str(tub), "cache": str(tmp_path / "cache"), "out": str(tmp_path / name),
                                      "model": {"name": "cg23"}, "split": {"train": "0:30", "val": "30:40"},
                                      "preprocess": {"width": 100, "height": 33},
                                      "train": {"epochs": 1, "batch_size": 16, "lr": 1e-12, **train}})
        loop.train(cfg, progress=False)  # Adam's steps of about lr: the weights stay as they start
        return load_checkpoint(tmp_path / name / "best.pt")["state_dict"]

    with_throttle = run(varying, "pre")
    last = next(k for k, w in with_throttle.items() if w.shape[0] == 2 and k.endswith("weight"))
    capsys.readouterr()
    without = run(constant, "fine", init=str(tmp_path / "pre" / "best.pt"))
    assert "pre/best.pt: train.init with its throttle output dropped" in capsys.readouterr().out
    same = lambda a, b: torch.allclose(a.float(), b.float(), rtol=0, atol=1e-9)  # noqa: E731
    assert without[last].shape == (1, *with_throttle[last].shape[1:]) and same(without[last][0], with_throttle[last][0])
    assert all(same(w, with_throttle[k]) for k, w in without.items() if w.shape == with_throttle[k].shape)
    again = run(varying, "back", init=str(tmp_path / "fine" / "best.pt"))
    assert "fine/best.pt: train.init with a new throttle output" in capsys.readouterr().out
    assert again[last].shape[0] == 2 and same(again[last][0], without[last][0])


def test_the_tub_default_learns_the_throttle_only_with_a_model_that_can(tmp_path):
    tub = write_tub(tmp_path / "tub", lambda i: 0.3, n=2)
    base = {"data": str(tub)}
    assert load_config(None, base=base).train.throttle_weight == 0.5
    assert load_config(None, base={**base, "model": {"name": "two-stream-flow"}}).train.throttle_weight == 0.0
    with pytest.raises(SteerlabError, match=r"train.throttle_weight: model 'two-stream-flow' does not learn a "
                                            r"throttle; these do: cg23, cnn3d, donkey-linear, flow-lstm"):
        load_config(None, base={**base, "model": {"name": "two-stream-flow"}}, overrides=["train.throttle_weight=1"])


def test_the_tub_defaults_train_on_views_where_the_reader_gives_the_full_lock(tmp_path, capsys):
    """Trained on a tub with no model named: donkey-linear with one view of every frame when the reader gives the
    full-lock angle; without it, no views, and training says why, once a process."""
    tub = write_tub(tmp_path / "tub", lambda i: 0.3, n=40)

    def run(name, reader):
        loop.train(load_config(None, base={"data": str(tub), "reader": reader, "cache": str(tmp_path / "cache"),
                                           "out": str(tmp_path / name), "split": {"train": "0:30", "val": "30:40"},
                                           "train": {"epochs": 1}}), progress=False)
        return json.loads((tmp_path / name / "config.json").read_text())

    capsys.readouterr()
    for name in ("a", "b"):
        cfg = run(name, {})
        assert (cfg["model"]["name"], cfg["train"]["views"]) == ("donkey-linear", [])
    err = capsys.readouterr().err
    assert err.count("tub: trains without the tub defaults' views") == 1 and "full_lock_deg=25" in err, err
    cfg = run("c", {"full_lock_deg": 25})
    assert (cfg["model"]["name"], len(cfg["train"]["views"])) == ("donkey-linear", 1)
    assert "views" not in capsys.readouterr().err


def test_the_simulated_car_and_the_real_one_get_the_same_controls_for_every_throttle_option(tmp_path):
    """One throttle (control.Throttle): `steerlab sim drive --world track`'s pilot (track.run.checkpoint_pilot,
    the part as the sim makes it) and `SteerlabPilot` on a car, given the same checkpoint, options and frames,
    answer the same (angle, throttle) for every combination of the constant throttle, the scale, the cap and the
    floor, on a model that learned the throttle and one that did not, at rest and moving, or both refuse (shaped
    twice, a constant throttle above the cap drives at the cap in the sim and above it on the car, and a floor on a
    model of a constant throttle is applied in the sim where the car refuses it)."""
    from itertools import product

    from conftest import made
    from steerlab.sim.track.run import checkpoint_pilot
    from steerlab.sim.track.world import TrackDriveOptions, TrackWorld, constant_throttle

    models = {"learned": made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True),
              "constant": made(tmp_path, "normalized", "right", "donkey", name="steering.pt", full_lock_deg=25)}
    world = TrackWorld(9401, 0.9, "taped", 20.0)
    frames = [world.render()]
    for _ in range(3):
        world.step(0.1, 0.4)
        frames.append(world.render())
    said, both = [], 0
    for (kind, ckpt), constant, scale, cap, floor in product(models.items(), (None, 0.3, 0.8), (1.0, 1.5), (0.5, 1.0),
                                                             (0.0, 0.2)):
        options = {"throttle_scale": scale, "max_throttle": cap, "throttle_floor": floor}
        try:
            sim = checkpoint_pilot(ckpt, TrackDriveOptions(throttle=constant, **options))
        except SteerlabError as e:
            sim = str(e)
        try:
            car = SteerlabPilot(ckpt, constant, full_lock_deg=25, reset_after_s=None, **options)
        except SteerlabError as e:
            car = str(e)
        case = (kind, constant, scale, cap, floor)
        assert isinstance(sim, str) == isinstance(car, str), (case, sim, car)
        if isinstance(sim, str):
            said.append(case)
            continue
        both += 1
        for frame, speed in zip(frames, (0.0, 0.05, 1.0, 2.0)):
            controls = sim.step(frame, speed)
            assert car.run(np.ascontiguousarray(frame[..., ::-1]), speed) == pytest.approx(
                (controls.steering, controls.throttle), abs=1e-6), case
            if kind == "constant":
                assert controls.throttle == constant_throttle(constant)  # never above the cap: refused there
    assert both == 13 and len(said) == 35  # hand-counted: 8 of the learned model's 24 cases, 5 of the other's
    # refused: a constant throttle forced on the model that learned one (16), and on the other a scale or a floor
    # (18 of 24) or a constant 0.8 above the cap 0.5 (1 more with scale 1 and no floor)
    assert sum(k == "learned" for k, *_ in said) == 16
    assert sorted(c for c in said if c[0] == "constant" and c[2] == 1.0 and c[4] == 0.0) == [
        ("constant", 0.8, 1.0, 0.5, 0.0)]


def test_a_floor_above_the_cap_is_refused_alike_by_the_sim_the_car_and_the_api(tmp_path):
    """The floor lies within the cap: a floor of 0.6 under a cap of 0.5 is refused in one message by the throttle
    itself, the track drive's and suite's options and the donkeycar part; a floor at the cap holds the car at it."""
    from conftest import made
    from steerlab.control import Throttle
    from steerlab.sim.track.suite import TrackSuiteOptions
    from steerlab.sim.track.world import TrackDriveOptions

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    expected = r"throttle_floor must be at most max_throttle \(0.5\): the floor lies within the cap, got 0.6"
    for make in (lambda: Throttle(cap=0.5, floor=0.6), lambda: TrackDriveOptions(max_throttle=0.5, throttle_floor=0.6),
                 lambda: TrackSuiteOptions(max_throttle=0.5, throttle_floor=0.6),
                 lambda: SteerlabPilot(ckpt, max_throttle=0.5, throttle_floor=0.6, full_lock_deg=25)):
        with pytest.raises(SteerlabError, match=expected):
            make()
    at_cap = Throttle(cap=0.5, floor=0.5)
    assert (at_cap.shaped(-1.0, 0.0), at_cap.shaped(-1.0, 1.0), at_cap.shaped(0.9, 0.0)) == (0.5, -0.5, 0.5)
    for options, says in (({"reset_after_s": 0}, r"reset_after_s must be a number in \(0, 1e\+09\], got 0"),
                          ({"smoothing": 0}, r"smoothing must be a number in \(0, 1\], got 0"),
                          ({"kp": -1}, r"kp must be a number in \[0, 10\], got -1")):  # each bound as declared
        with pytest.raises(SteerlabError, match=rf"^SteerlabPilot: {says}$"):
            SteerlabPilot(ckpt, full_lock_deg=25, **options)


def test_a_shaping_that_does_not_apply_to_the_model_is_refused_naming_the_option():
    """`Throttle.for_model` by hand: on a model of a constant throttle a floor or a scale is refused naming it, in
    the words of the throttle that drives; a constant throttle at the cap is taken, above it refused; `number`
    takes its lower bound unless told the interval is open there."""
    from steerlab.control import Throttle, number

    for shaping, field in ((Throttle(floor=0.2), "throttle_floor"), (Throttle(scale=1.5), "throttle_scale")):
        with pytest.raises(SteerlabError, match=rf"^{field} shapes a learned throttle; m.pt drives at a constant "
                                                rf"throttle: leave {field} out$"):
            shaping.for_model(False, "m.pt")
        assert shaping.for_model(True, "m.pt") is shaping
    with pytest.raises(SteerlabError, match="m.pt drives at a cruising throttle"):
        Throttle(floor=0.2).for_model(False, "m.pt", "cruising")
    at_cap = Throttle(constant=0.5, cap=0.5)
    assert at_cap.for_model(False, "m.pt") is at_cap
    with pytest.raises(SteerlabError, match=r"^the constant throttle 0.6 exceeds max_throttle 0.5"):
        Throttle(constant=0.6, cap=0.5).for_model(False, "m.pt")
    assert number("x", 0, 0.0, 1.0) == 0.0
    with pytest.raises(SteerlabError, match=r"^x must be a number in \(0, 1\], got 0$"):
        number("x", 0, 0.0, 1.0, low_open=True)
