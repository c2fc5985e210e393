import csv

import numpy as np
import pytest

from steerlab.errors import SteerlabError
from steerlab.models import list_models, model_class
from steerlab.evaluate.offline import evaluate
from steerlab.train import loop
from steerlab.train.config import load_config


def _cfg(rec, tmp_path, **train):
    return load_config(None, base={
        "data": str(rec), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
        "split": {"train": "0:240", "val": "240:300"},
        "model": {"name": "pilotnet", "dropout": 0.0},
        "train": {"epochs": 4, "lr": 1e-3, "batch_size": 32, "patience": 10, **train},
    })


def _log(tmp_path):
    with open(tmp_path / "run" / "log.csv") as f:
        return list(csv.DictReader(f))


def test_training_lowers_loss_and_checkpoint_reproduces(tiny_recording, tmp_path):
    best = loop.train(_cfg(tiny_recording, tmp_path), progress=False)
    rows = _log(tmp_path)
    assert len(rows) == 4
    assert float(rows[-1]["train_loss"]) < float(rows[0]["train_loss"])
    # the streaming evaluation of the best checkpoint reproduces its validation predictions in batch
    m = evaluate(tmp_path / "run" / "best.pt", tiny_recording, "240:300", tmp_path / "eval", progress=False)
    assert m["frames"] == 60
    assert m["rmse"] == pytest.approx(best["rmse"], rel=1e-3)
    assert (tmp_path / "eval" / "steering.png").stat().st_size > 10_000
    with open(tmp_path / "eval" / "predictions.csv") as f:
        assert next(csv.reader(f)) == ["frame_id", "steering_angle"]


@pytest.mark.parametrize("name", [n for n in list_models() if n != "pilotnet" and model_class(n).trainable])
def test_every_trainable_model_learns(name, tiny_recording, tmp_path):
    cfg = _cfg(tiny_recording, tmp_path, epochs=3, batch_size=8)  # recurrent: 8 windows of 10 frames
    cfg["model"] = {"name": name, "dropout": 0.0}
    loop.train(cfg, progress=False)
    rows = _log(tmp_path)
    assert float(rows[-1]["train_loss"]) < float(rows[0]["train_loss"])


def test_side_cameras_and_episode_filter(tiny_recording, tmp_path):
    cfg = _cfg(tiny_recording, tmp_path, epochs=1, side_cameras=True, exclude_episodes=["drift-out"])
    loop.train(cfg, progress=False)
    assert len(_log(tmp_path)) == 1


def test_side_camera_labels_hand_computed(tiny_recording, tmp_path):
    ds = loop.prepare_dataset(_cfg(tiny_recording, tmp_path), progress=False, camera="left")
    y = loop.side_camera_labels(ds, 0.5, 1.0, 10.0)
    v = ds.labels["speed"][0]
    # left camera: steer right by arctan(0.5 / v) at the road wheel = 10x that at the steering wheel
    assert y[0] == pytest.approx(ds.steering[0] - 10 * np.arctan(0.5 / v))


def test_resume_after_interruption(tiny_recording, tmp_path, monkeypatch):
    cfg = _cfg(tiny_recording, tmp_path, epochs=3)
    real = loop.train_one_epoch
    calls = []

    def interrupted(*a, **k):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(loop, "train_one_epoch", interrupted)
    with pytest.raises(KeyboardInterrupt):
        loop.train(cfg, progress=False)
    assert [r["epoch"] for r in _log(tmp_path)] == ["1"]
    monkeypatch.setattr(loop, "train_one_epoch", real)
    loop.train(cfg, progress=False)
    assert [r["epoch"] for r in _log(tmp_path)] == ["1", "2", "3"]
    other = _cfg(tiny_recording, tmp_path, epochs=3, lr=0.1)
    with pytest.raises(SteerlabError, match="another config"):
        loop.train(other, progress=False)


def test_baselines(tiny_recording, tmp_path):
    cfg = _cfg(tiny_recording, tmp_path)
    cfg["model"] = {"name": "train-mean"}
    m = loop.train(cfg, progress=False)
    ds = loop.prepare_dataset(cfg, progress=False)
    mean = ds.steering[:240].mean()
    assert m["rmse"] == pytest.approx(np.sqrt(np.mean((ds.steering[240:300] - mean) ** 2)))


def test_config_errors(tmp_path):
    with pytest.raises(SteerlabError, match="config file not found"):
        load_config(tmp_path / "x.yaml")
    with pytest.raises(SteerlabError, match="names no data"):
        load_config(None)
    with pytest.raises(SteerlabError, match="unknown train options"):
        load_config(None, ["data=x", "train.epoch=3"])
    cfg = load_config(None, ["data=x", "train.epochs=3", "split.train=0:10"])
    assert cfg["train"]["epochs"] == 3 and cfg["train"]["batch_size"] == 100
    assert cfg["split"]["train"] == "0:10"
    (tmp_path / "c.yaml").write_text("data: x\nsplit: {train: 10:20, val: 20:30}\n")
    from steerlab.data.splits import make_split
    with pytest.raises(SteerlabError, match="quote it"):
        make_split(load_config(tmp_path / "c.yaml")["split"], 2400)


@pytest.mark.parametrize("model, pre", [
    ("pilotnet", {"modalities": ["image", "diff", "flow"], "stack": 3, "color": "yuv"}),
    ("multimodal-lstm", {}),
])
def test_streaming_equals_batch(model, pre, tiny_recording, tmp_path):
    """Stacked frames, difference, flow and LSTM state: the Pilot, fed the raw frames of the whole recording
    one by one, reproduces the batch path (which runs recurrent models statefully through the range)."""
    from steerlab.train.checkpoint import load_checkpoint, model_from_checkpoint

    cfg = _cfg(tiny_recording, tmp_path, epochs=1, batch_size=4)
    cfg["model"] = {"name": model}
    cfg["preprocess"] = pre
    loop.train(cfg, progress=False)
    evaluate(tmp_path / "run" / "best.pt", tiny_recording, None, tmp_path / "eval", progress=False)
    streamed = np.loadtxt(tmp_path / "eval" / "predictions.csv", delimiter=",", skiprows=1)[:, 1]
    ckpt = load_checkpoint(tmp_path / "run" / "best.pt")
    ds = loop.prepare_dataset({**cfg, "preprocess": loop.model_preprocess(model, pre)}, progress=False)
    batches = loop.Batches([(ds, ds.steering)], ckpt["stats"])
    batch = loop.predict(model_from_checkpoint(ckpt)[0], batches, np.arange(len(ds)), batch_size=64)
    np.testing.assert_allclose(streamed, batch, atol=1e-4)
