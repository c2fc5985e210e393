import numpy as np
import pytest
import torch

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import create_model, list_models
from steerlab.pilot import Pilot
from steerlab.train.checkpoint import load_checkpoint, save_checkpoint


@pytest.mark.parametrize("name", list_models())
@pytest.mark.parametrize("channels", [1, 3])
def test_forward_shapes(name, channels):
    model = create_model(name, in_channels=channels, height=66, width=200).eval()
    assert model(torch.zeros(4, channels, 66, 200)).shape == (4,)


def test_pilotnet_layers_as_in_paper():
    m = create_model("pilotnet", in_channels=1)
    convs = [l for l in m.features if isinstance(l, torch.nn.Conv2d)]
    assert [(c.out_channels, c.kernel_size, c.stride) for c in convs] == [
        (24, (5, 5), (2, 2)), (36, (5, 5), (2, 2)), (48, (5, 5), (2, 2)), (64, (3, 3), (1, 1)), (64, (3, 3), (1, 1))]
    fcs = [l for l in m.head if isinstance(l, torch.nn.Linear)]
    assert [(f.in_features, f.out_features) for f in fcs] == [(1152, 1164), (1164, 100), (100, 50), (50, 10), (10, 1)]


def test_unknown_model():
    with pytest.raises(SteerlabError, match="unknown model"):
        create_model("alexnet")


@pytest.mark.parametrize("name", list_models())
def test_checkpoint_round_trip_and_pilot(name, tmp_path):
    torch.manual_seed(0)
    cfg = PreprocessConfig.from_dict({"preset": "sim", "modalities": ["image", "diff", "flow"]})
    model_cfg = {"in_channels": 4, "height": 66, "width": 200}
    model = create_model(name, **model_cfg).eval()
    if name == "train-mean":
        model.fit(np.array([0.1, 0.3]))
    stats = {"mean": [100.0, 128.0, 0.0, 0.0], "std": [50.0, 10.0, 1.0, 1.0]}
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
    x = np.concatenate([img, np.full_like(img, 128), np.zeros(img.shape[:2] + (2,), np.uint8)], -1).astype(np.float32)
    x = (x - np.array(stats["mean"], np.float32)) / np.array(stats["std"], np.float32)
    with torch.no_grad():
        direct = float(model(torch.from_numpy(x).permute(2, 0, 1)[None])[0])
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
