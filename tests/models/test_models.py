import numpy as np
import pytest
import torch

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import create_model, list_models, model_class
from steerlab.models.multitask import weighted_mae
from steerlab.pilot import Pilot
from steerlab.checkpoint import load_checkpoint, save_checkpoint
from steerlab.data.inputs import stack_modalities
from steerlab.data.preprocess import PreprocessOptions
from steerlab.models.registry import ModelSpec
from steerlab.options import parse


def _model_config(name: str, **pre) -> PreprocessConfig:
    return ModelSpec(name, {}).preprocess(parse(PreprocessOptions, {"preset": "sim", **pre})).resolve()


def _inputs(name: str, channels: int, cfg: PreprocessConfig, batch: int = 4, steps: int = 2) -> dict:
    """Zero images of the model's size (with a time axis for recurrent models) and constant speeds."""
    model = model_class(name)
    shape = (batch, steps) if getattr(model, "recurrent", False) else (batch,)
    inputs = {"x": torch.zeros(*shape, channels, cfg.height, cfg.width)}
    if getattr(model, "speed_history", 0):
        inputs["speeds"] = torch.full((batch, model.speed_history), 8.0)
    return inputs


@pytest.mark.parametrize("name, color", [(n, c) for n in list_models() for c in ("gray", "yuv")
                                         if c == "gray" or "color" not in getattr(model_class(n), "inputs", {})])
def test_forward_shapes(name, color):
    cfg = _model_config(name, color=color)
    channels = sum(cfg.channels().values())
    model = create_model(name, in_channels=channels, height=cfg.height, width=cfg.width).eval()
    with torch.no_grad():
        out = model(**_inputs(name, channels, cfg))
    if getattr(model, "recurrent", False):
        out, (h, c) = out
        assert out["steering"].shape == (4, 2) and h.shape[:2] == (1, 4)
        if "command" in out:
            assert out["command"].shape == (4, 2, 3)
    else:
        assert out["steering"].shape == (4,)
        if "speed" in out:
            assert out["speed"].shape == (4,)


def test_cnn3d_keeps_temporal_size():
    m = create_model("cnn3d", in_channels=3)
    assert m.features(torch.zeros(1, 1, 3, 66, 200)).shape == (1, 64, 3, 1, 18)
    assert m.head[0].in_features == 3456


def test_two_stream_combined_loss_hand_computed():
    torch.manual_seed(0)
    m = create_model("two-stream-flow", in_channels=3, dropout=0.0).eval()
    x, y = torch.randn(5, 3, 66, 200), torch.randn(5)
    with torch.no_grad():
        out = m(x)
        loss = float(m.loss(out, {"steering": y}))
        y_img, y_flow = m.image(x[:, :1])["steering"], m.flow(x[:, 1:])["steering"]
    expected = sum(float((a - b) ** 2 + (c - b) ** 2) for a, b, c in zip(y_img, y, y_flow)) / 5
    assert loss == pytest.approx(expected, rel=1e-5)
    assert torch.allclose(out["steering"], (y_img + y_flow) / 2)


def test_weighted_mae_hand_computed():
    pred, y = torch.tensor([0.0, 0.0, 0.5]), torch.tensor([0.0, 0.2, 0.4])
    # mean |y| = 0.2 -> weights 1, 2, 3; errors 0, 0.2, 0.1 -> (0 + 0.4 + 0.3) / 6
    assert float(weighted_mae(pred, y)) == pytest.approx(0.7 / 6)
    assert float(weighted_mae(pred, y, gain=0.0)) == pytest.approx(0.1)  # plain MAE
    assert float(weighted_mae(torch.tensor([0.1, -0.1]), torch.zeros(2))) == pytest.approx(0.1)  # all straight


def test_multitask_losses_hand_computed():
    out = {"steering": torch.tensor([0.0, 0.5]), "speed": torch.tensor([10.0, 12.0])}
    targets = {"steering": torch.tensor([0.0, 0.2]), "speed": torch.tensor([11.0, 12.5])}
    m = create_model("multitask-speed", speed_weight=0.5)
    # steering: weights 1, 3 (mean |y| 0.1) -> 3 * 0.3 / 4; speed MAE 0.75
    assert float(m.loss(out, targets)) == pytest.approx(0.9 / 4 + 0.5 * 0.75)
    logits = torch.tensor([[[2.0, 0.0, 0.0], [0.0, 0.0, 0.0]]])  # (B=1, T=2, 3)
    out = {"steering": torch.tensor([[0.1, 0.1]]), "command": logits}
    targets = {"steering": torch.tensor([[0.1, 0.1]]), "command": torch.tensor([[0, 2]])}
    ce = (-np.log(np.exp(2) / (np.exp(2) + 2)) - np.log(1 / 3)) / 2
    m = create_model("speed-command", command_weight=0.25)
    assert float(m.loss(out, targets)) == pytest.approx(0.25 * ce, rel=1e-5)


def test_multitask_speed_starts_from_the_current_speed():
    """The speed head predicts a change to the latest measured speed (the last of the history)."""
    m = create_model("multitask-speed").eval()
    with torch.no_grad():
        for p in m.speed_head[-1].parameters():
            p.zero_()
        speeds = torch.tensor([[5.0] * 9 + [7.0], [3.0] * 10])
        assert m(torch.zeros(2, 3, 96, 96), speeds)["speed"].tolist() == [7.0, 3.0]


def test_paper_002_input_is_square():
    for name in ("yang-base", "speed-command", "multitask-speed"):
        cfg = _model_config(name)
        assert cfg.width == cfg.height == 96


def test_model_inputs_fill_and_guard_the_config():
    assert _model_config("pilotnet-flow").modalities == ("image", "flow")
    with pytest.raises(SteerlabError, match="needs preprocess stack=3"):
        _model_config("cnn3d", stack=5)


def test_pilotnet_layers_as_in_paper():
    m = create_model("pilotnet", in_channels=1)
    convs = [l for l in m.features if isinstance(l, torch.nn.Conv2d)]
    assert [(c.out_channels, c.kernel_size, c.stride) for c in convs] == [
        (24, (5, 5), (2, 2)), (36, (5, 5), (2, 2)), (48, (5, 5), (2, 2)), (64, (3, 3), (1, 1)), (64, (3, 3), (1, 1))]
    fcs = [l for l in m.head if isinstance(l, torch.nn.Linear)]
    assert [(f.in_features, f.out_features) for f in fcs] == [(1152, 1164), (1164, 100), (100, 50), (50, 10), (10, 1)]


def test_lstm_layers_as_in_paper():
    m = create_model("lstm", in_channels=1)
    assert m.fc[0].in_features == 1152 and m.fc[0].out_features == 512
    assert (m.lstm.input_size, m.lstm.hidden_size) == (512, 100) and m.out.in_features == 100


def test_recurrent_state_carries_across_calls():
    torch.manual_seed(0)
    m = create_model("lstm", in_channels=1, dropout=0.0).eval()
    x = torch.randn(1, 6, 1, 66, 200)
    with torch.no_grad():
        whole, _ = m(x)
        first, state = m(x[:, :2])
        rest, _ = m(x[:, 2:], state)
    assert torch.allclose(whole["steering"], torch.cat([first["steering"], rest["steering"]], 1), atol=1e-6)


def test_unknown_model():
    with pytest.raises(SteerlabError, match="unknown model"):
        create_model("alexnet")


@pytest.mark.parametrize("name", list_models())
def test_checkpoint_round_trip_and_pilot(name, tmp_path):
    torch.manual_seed(0)
    pre = {} if getattr(model_class(name), "inputs", {}) else {"modalities": ["image", "diff", "flow"]}
    cfg = _model_config(name, **pre)
    channels = cfg.channels()
    model_cfg = {"in_channels": sum(channels.values()), "height": cfg.height, "width": cfg.width}
    model = create_model(name, **model_cfg).eval()
    if name == "train-mean":
        model.fit(np.array([0.1, 0.3]))
    means = {"image": 100.0, "diff": 128.0, "flow": 0.0}
    stats = {"mean": [means[m] for m, c in channels.items() for _ in range(c)],
             "std": [50.0 if m == "image" else 2.0 for m, c in channels.items() for _ in range(c)]}
    path = tmp_path / "m.pt"
    save_checkpoint(path, model, model_cfg, cfg, stats, SteeringConvention(), {"rmse": 0.1})
    frames = [np.random.default_rng(i).integers(0, 255, (160, 320, 3), dtype=np.uint8) for i in range(3)]
    p1, p2 = Pilot(path), Pilot(load_checkpoint(path))
    out1 = [p1.step(f, speed=8.0) for f in frames]
    out2 = [p2.step(f, speed=8.0) for f in frames]
    assert out1 == out2
    if name == "train-mean":
        assert out1[0].steering == pytest.approx(0.2)
    # the pilot gives what the model gives on the same standardised input of the first frame
    from steerlab.data.preprocess import preprocess
    img, _ = preprocess(frames[0], cfg)
    first = {"image": np.concatenate([img] * cfg.stack, -1), "diff": np.full_like(img, 128),
             "flow": np.zeros(img.shape[:2] + (2,), np.float32)}  # a segment's first frame
    x = stack_modalities(first, cfg)
    x = (x - np.array(stats["mean"], np.float32)) / np.array(stats["std"], np.float32)
    inputs = _inputs(name, model_cfg["in_channels"], cfg, batch=1, steps=1)
    xt = torch.from_numpy(x).permute(2, 0, 1)
    inputs["x"] = xt.expand_as(inputs["x"])
    with torch.no_grad():
        out = model(**inputs)
    out = out[0] if getattr(model, "recurrent", False) else out
    assert out1[0].steering == pytest.approx(float(out["steering"].flatten()[0]), abs=1e-5)
    if "speed" in out:
        assert out1[0].speed == pytest.approx(float(out["speed"][0]), abs=1e-5)
    if "command" in out:
        assert out1[0].command == int(out["command"].flatten(0, -2)[0].argmax())


def test_pilot_smoothing(tmp_path):
    model_cfg = {"in_channels": 1, "height": 66, "width": 200}
    model = create_model("train-mean", **model_cfg)
    model.fit(np.array([1.0]))
    path = tmp_path / "m.pt"
    save_checkpoint(path, model, model_cfg, PreprocessConfig.from_dict({"preset": "sim"}),
                    {"mean": [0.0], "std": [1.0]}, SteeringConvention(), {})
    pilot = Pilot(path, smoothing=0.2)
    frame = np.zeros((160, 320, 3), np.uint8)
    assert [pilot.step(frame).steering for _ in range(2)] == pytest.approx([1.0, 1.0])


def test_missing_and_bad_checkpoint(tmp_path):
    with pytest.raises(SteerlabError, match="checkpoint not found"):
        Pilot(tmp_path / "none.pt")
    bad = tmp_path / "bad.pt"
    bad.write_text("hello")
    with pytest.raises(SteerlabError, match="not a readable checkpoint"):
        Pilot(bad)


def test_pilot_needs_speed_for_speed_models(tmp_path):
    cfg = _model_config("multitask-speed")
    model_cfg = {"in_channels": 1, "height": cfg.height, "width": cfg.width}
    save_checkpoint(tmp_path / "m.pt", create_model("multitask-speed", **model_cfg), model_cfg, cfg,
                    {"mean": [0.0], "std": [1.0]}, SteeringConvention(), {})
    with pytest.raises(SteerlabError, match="needs the measured speed"):
        Pilot(tmp_path / "m.pt").step(np.zeros((160, 320, 3), np.uint8))
