"""Data-parallel training: two CPU ranks with a global batch B take the steps one process takes with batch B."""

import functools
import os
import subprocess

import pytest
import torch
import yaml

from steerlab.cli import main
from steerlab.errors import SteerlabError
from steerlab.train.config import load_config
from steerlab.train.distributed import device_of
from steerlab.train.loop import train


def config(tmp_path, recording, out, model="pilotnet"):
    cfg = {"data": str(recording), "cache": str(tmp_path / "cache"), "out": str(tmp_path / out),
           "split": {"train": "0:96", "val": "240:270"}, "model": {"name": model, "dropout": 0.0},
           "preprocess": {"width": 64, "height": 64},  # small frames (PilotNet's layers need 61 or more)
           "train": {"epochs": 2, "batch_size": 16, "flip": True, "lr": 1e-3}}
    path = tmp_path / f"{out}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="--nproc 2 needs two cores")
def test_two_ranks_match_one_process(tmp_path, tiny_recording, monkeypatch):
    model = "lstm"  # a recurrent model: windows of frames sharded over the ranks, flipped
    train(load_config(config(tmp_path, tiny_recording, "one", model)), progress=False)
    # the command runs here (no interpreter of its own to start); the ranks it starts with torchrun get 5 minutes
    monkeypatch.setattr(subprocess, "run", functools.partial(subprocess.run, timeout=300))
    assert main(["train", str(config(tmp_path, tiny_recording, "two", model)), "--nproc", "2"]) == 0
    one = torch.load(tmp_path / "one" / "last.pt", weights_only=False)
    two = torch.load(tmp_path / "two" / "last.pt", weights_only=False)
    assert one["epoch"] == two["epoch"] == 2  # 2 epochs of 96 / 16 = 6 steps (lstm: windows of 10 frames)
    for k, v in one["state_dict"].items():
        assert torch.allclose(v, two["state_dict"][k], atol=2e-5), k
    assert two["history"][-1]["train_loss"] == pytest.approx(one["history"][-1]["train_loss"], rel=1e-4)
    assert not list((tmp_path / "two").glob("*.tmp"))  # rank 1 wrote nothing half-done


def test_device_option():
    assert device_of("cpu") == torch.device("cpu")
    assert device_of("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    with pytest.raises(SteerlabError, match="train.device must be auto, cpu or cuda"):
        device_of("tpu")
    if not torch.cuda.is_available():
        with pytest.raises(SteerlabError, match="no CUDA device"):
            device_of("cuda")
