import numpy as np
import pytest
import torch

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import create_model, list_models, model_class
from steerlab.pilot import Pilot
from steerlab.train.checkpoint import load_checkpoint, save_checkpoint
from steerlab.train.inputs import stack_modalities
from steerlab.train.loop import model_preprocess


def _model_config(name: str, **pre) -> PreprocessConfig:
    return PreprocessConfig.from_dict(model_preprocess(name, {"preset": "sim", **pre}))


@pytest.mark.parametrize("name, color", [(n, c) for n in list_models() for c in ("gray", "yuv")
                                         if c == "gray" or "color" not in getattr(model_class(n), "inputs", {})])
def test_forward_shapes(name, color):
    channels = sum(_model_config(name, color=color).channels().values())
    model = create_model(name, in_channels=channels, height=66, width=200).eval()
    if getattr(model, "recurrent", False):
        y, (h, c) = model(torch.zeros(4, 2, channels, 66, 200))
        assert y.shape == (4, 2) and h.shape == (1, 4, 100)
    else:
        assert model(torch.zeros(4, channels, 66, 200)).shape == (4,)


def test_cnn3d_keeps_temporal_size():
    m = create_model("cnn3d", in_channels=3)
    assert m.features(torch.zeros(1, 1, 3, 66, 200)).shape == (1, 64, 3, 1, 18)
    assert m.head[0].in_features == 3456


def test_two_stream_combined_loss_hand_computed():
    torch.manual_seed(0)
    m = create_model("two-stream-flow", in_channels=3, dropout=0.0).eval()
    x, y = torch.randn(5, 3, 66, 200), torch.randn(5)
    with torch.no_grad():
        loss = float(m.loss(x, y))
        y_img, y_flow = m.image(x[:, :1]), m.flow(x[:, 1:])
        mean = m(x)
    expected = sum(float((a - b) ** 2 + (c - b) ** 2) for a, b, c in zip(y_img, y, y_flow)) / 5
    assert loss == pytest.approx(expected, rel=1e-5)
    assert torch.allclose(mean, (y_img + y_flow) / 2)


def test_model_inputs_fill_and_guard_the_config():
    assert model_preprocess("pilotnet-flow", {"preset": "sim"})["modalities"] == ["image", "flow"]
    with pytest.raises(SteerlabError, match="needs preprocess stack=3"):
        model_preprocess("cnn3d", {"stack": 5})


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
    assert torch.allclose(whole, torch.cat([first, rest], 1), atol=1e-6)


def test_unknown_model():
    with pytest.raises(SteerlabError, match="unknown model"):
        create_model("alexnet")


@pytest.mark.parametrize("name", list_models())
def test_checkpoint_round_trip_and_pilot(name, tmp_path):
    torch.manual_seed(0)
    pre = {} if getattr(model_class(name), "inputs", {}) else {"modalities": ["image", "diff", "flow"]}
    cfg = _model_config(name, **pre)
    channels = cfg.channels()
    model_cfg = {"in_channels": sum(channels.values()), "height": 66, "width": 200}
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
    out1 = [p1.step(f) for f in frames]
    out2 = [p2.step(f) for f in frames]
    assert out1 == out2
    if name == "train-mean":
        assert out1[0] == pytest.approx(0.2)
    # the pilot gives what the model gives on the same standardised input of the first frame
    from steerlab.data.preprocess import preprocess
    img, _ = preprocess(frames[0], cfg)
    first = {"image": np.concatenate([img] * cfg.stack, -1), "diff": np.full_like(img, 128),
             "flow": np.zeros(img.shape[:2] + (2,), np.float32)}  # a segment's first frame
    x = stack_modalities(first, cfg)
    x = (x - np.array(stats["mean"], np.float32)) / np.array(stats["std"], np.float32)
    with torch.no_grad():
        xt = torch.from_numpy(x).permute(2, 0, 1)[None]
        direct = float(model(xt[None])[0][0, 0] if getattr(model, "recurrent", False) else model(xt)[0])
    assert out1[0] == pytest.approx(direct, abs=1e-5)


def test_pilot_smoothing(tmp_path):
    model_cfg = {"in_channels": 1, "height": 66, "width": 200}
    model = create_model("train-mean", **model_cfg)
    model.fit(np.array([1.0]))
    path = tmp_path / "m.pt"
    save_checkpoint(path, model, model_cfg, PreprocessConfig.from_dict({"preset": "sim"}),
                    {"mean": [0.0], "std": [1.0]}, SteeringConvention(), {})
    pilot = Pilot(path, smoothing=0.2)
    frame = np.zeros((160, 320, 3), np.uint8)
    assert [pilot.step(frame) for _ in range(2)] == pytest.approx([1.0, 1.0])


def test_missing_and_bad_checkpoint(tmp_path):
    with pytest.raises(SteerlabError, match="checkpoint not found"):
        Pilot(tmp_path / "none.pt")
    bad = tmp_path / "bad.pt"
    bad.write_text("hello")
    with pytest.raises(SteerlabError, match="not a readable checkpoint"):
        Pilot(bad)
