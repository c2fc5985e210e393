"""A run that stops and continues: after Ctrl-C (TensorBoard's events continuing too), moved to another
folder and cache, under more epochs, as an earlier version of steerlab wrote it, and not on data that changed."""

import csv
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from steerlab.data.car import CH2_CAR
from steerlab.data.readers import open_recording
from steerlab.errors import SteerlabError
from steerlab.train import loop
from steerlab.train.config import load_config, parse_config
from tests.train.runs import _cfg, _log


def _interrupt_the_second_epoch(monkeypatch):
    """Training that stops with Ctrl-C when its second epoch starts; returns the real epoch function."""
    real = loop.train_one_epoch
    calls = []

    def interrupted(*a, **k):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(loop, "train_one_epoch", interrupted)
    return real


def test_resume_after_interruption(tiny_recording, tmp_path, monkeypatch):
    """Also with TensorBoard logging: the resumed run's events continue the first one's, epoch for epoch."""
    cfg = _cfg(tiny_recording, tmp_path, epochs=3, tensorboard=True, split={"train": "0:100", "val": "100:140"})
    real = _interrupt_the_second_epoch(monkeypatch)
    with pytest.raises(KeyboardInterrupt):
        loop.train(cfg, progress=False)
    assert [r["epoch"] for r in _log(tmp_path)] == ["1"]
    monkeypatch.setattr(loop, "train_one_epoch", real)
    loop.train(cfg, progress=False)
    rows = _log(tmp_path)
    assert [r["epoch"] for r in rows] == ["1", "2", "3"]
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    board = EventAccumulator(str(tmp_path / "run" / "tensorboard"))
    board.Reload()
    assert {"train/loss", "val/rmse", "val/gamma_deg", "seconds"} <= set(board.Tags()["scalars"])
    rmse = board.Scalars("val/rmse")
    assert [e.step for e in rmse] == [1, 2, 3]
    np.testing.assert_allclose([e.value for e in rmse], [float(r["val_rmse"]) for r in rows], rtol=1e-6)
    other = _cfg(tiny_recording, tmp_path, epochs=3, lr=0.1, split={"train": "0:100", "val": "100:140"})
    with pytest.raises(SteerlabError, match=r"holds a run of another config \(train.lr: 0.001 -> 0.1\); choose a new "
                                            r"out directory"):
        loop.train(other, progress=False)


def test_a_moved_run_continues_with_another_cache_and_without_tensorboard(tiny_recording, tmp_path):
    """Where a run is written, where its cache is kept and TensorBoard's logging are not what its results depend on:
    a run folder moved elsewhere continues there with another cache root and TensorBoard off."""
    loop.train(_cfg(tiny_recording, tmp_path, epochs=1, batch_size=64, tensorboard=True), progress=False)
    first = _log(tmp_path)
    shutil.move(tmp_path / "run", tmp_path / "moved")
    cfg = _cfg(tiny_recording, tmp_path, epochs=2, patience=12, batch_size=64)
    cfg = replace(cfg, out=str(tmp_path / "moved"), cache=str(tmp_path / "another-cache"))
    loop.train(cfg, progress=False)
    rows = list(csv.DictReader(open(tmp_path / "moved" / "log.csv")))
    assert [r["epoch"] for r in rows] == ["1", "2"] and rows[0] == first[0]


def test_a_run_continues_under_more_epochs(tiny_recording, tmp_path):
    """More epochs (or patience) continue a run where it stopped; its epochs so far stay as they were."""
    loop.train(_cfg(tiny_recording, tmp_path, epochs=1, batch_size=64), progress=False)
    first = _log(tmp_path)
    loop.train(_cfg(tiny_recording, tmp_path, epochs=2, patience=12, batch_size=64), progress=False)
    rows = _log(tmp_path)
    assert [r["epoch"] for r in rows] == ["1", "2"] and rows[0] == first[0]


def test_a_run_of_an_earlier_version_loads_and_resumes(tiny_recording, tmp_path, monkeypatch):
    """tests/fixtures/run-0.1.0 is a run folder as steerlab 0.1.0 (commit 4e71608) wrote it after its first epoch of
    two: a config.json of raw values (the learning rate as text, the car's steering ratio and side-camera offset
    written out), a last.pt without the identity of its data, checkpoints of a model whose first fully connected
    layer was sized by hand. Its checkpoint drives, and the same config continues the run with epoch 2."""
    import json
    import shutil

    from steerlab.files import exponents_read
    from steerlab.pilot import Pilot

    old = Path(__file__).parents[1] / "fixtures" / "run-0.1.0"
    monkeypatch.chdir(tmp_path)
    shutil.copytree(old, tmp_path / "run")
    (tmp_path / "rec").symlink_to(tiny_recording)  # the recording it was trained on: the same seed, the same bytes
    first = Pilot(tmp_path / "run" / "best.pt").step(open_recording(tiny_recording).load_frame(0))
    assert np.isfinite(first.steering)
    user = {"data": "rec", "cache": "cache", "out": "run", "split": {"train": "0:240", "val": "240:300"},
            "model": {"name": "cg23", "dropout": 0.2}, "preprocess": {"width": 16, "height": 8},
            "train": {"epochs": 2, "batch_size": 32, "lr": 3e-4, "side_cameras": True}}
    stored = json.loads((old / "config.json").read_text())
    assert stored["train"]["lr"] == "3e-4"  # text: as YAML 1.1 read the 3e-4 of its config
    assert parse_config(exponents_read(stored)).identity() == load_config(
        None, base=user).for_car(CH2_CAR).identity()
    best = loop.train(load_config(None, base=user), progress=False)
    rows = _log(tmp_path)
    assert [r["epoch"] for r in rows] == ["1", "2"] and best["epoch"] in (1, 2)
    earlier = rows[0].pop("train_seconds")  # a column 0.1.0 did not write: left empty in its epoch
    assert rows[0] == next(csv.DictReader(open(old / "log.csv"))) and earlier == ""  # epoch 1 is the earlier version's
    assert float(rows[1]["train_seconds"]) > 0
    with pytest.raises(SteerlabError, match="another config"):
        loop.train(load_config(None, base={**user, "train": {**user["train"], "lr": 1e-3}}), progress=False)


def test_a_run_does_not_resume_on_changed_data(tiny_recording, tmp_path, monkeypatch):
    """Interrupted after epoch 1, then the labels change: the run records the identity of its data (the compiled
    cache's source hash) and refuses to continue on other labels rather than pick a best epoch across them."""
    import shutil

    data = tmp_path / "rec"
    shutil.copytree(tiny_recording, data)
    cfg = _cfg(data, tmp_path, epochs=2)
    real = _interrupt_the_second_epoch(monkeypatch)
    with pytest.raises(KeyboardInterrupt):
        loop.train(cfg, progress=False)
    log = (data / "log.csv").read_text().splitlines()
    header = log[0].split(",")
    column = header.index("steering")
    rows = [line.split(",") for line in log[1:]]
    for r in rows:
        r[column] = str(-float(r[column]))  # the labels negated
    (data / "log.csv").write_text("\n".join([log[0]] + [",".join(r) for r in rows]) + "\n")
    monkeypatch.setattr(loop, "train_one_epoch", real)
    with pytest.raises(SteerlabError, match="holds a run trained on other data"):
        loop.train(cfg, progress=False)
