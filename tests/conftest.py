import math
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

if os.environ.get("PYTEST_XDIST_WORKER"):  # two test processes on two cores: one torch thread each
    import torch

    torch.set_num_threads(1)

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
CH2 = SHARED / "udacity-ch2"
SIM = SHARED / "udacity-sim-track1"

needs_ch2 = pytest.mark.skipif(not (CH2 / "CH2_final_evaluation.csv").exists(), reason="../shared/data absent")
needs_sim = pytest.mark.skipif(not (SIM / "driving_log.csv").exists(), reason="../shared/data absent")


def write_jpeg(path: Path, value: int = 128, size=(160, 320)) -> None:
    img = np.full((*size, 3), value, np.uint8)
    img[::7, ::5] = 255 - value  # some texture
    cv2.imwrite(str(path), img)


@pytest.fixture
def ch2_folder(tmp_path):
    """A tiny CH2-layout folder: 6 frames of 640x480, answer-file labels."""
    (tmp_path / "center").mkdir()
    ids = [1_000_000_000 + i * 50_000_000 for i in range(6)]
    for i, fid in enumerate(ids):
        write_jpeg(tmp_path / "center" / f"{fid}.jpg", 40 * i, (480, 640))
    lines = ["frame_id,steering_angle,public"] + [f"{fid},{0.01 * i},{i % 2}" for i, fid in enumerate(ids)]
    (tmp_path / "labels.csv").write_text("\n".join(lines) + "\n")
    return tmp_path


@pytest.fixture(scope="session")
def tiny_recording(tmp_path_factory):
    """A short synthetic recording with all three cameras (shared by several tests)."""
    from steerlab.sim.world import RecordOptions, record

    out = tmp_path_factory.mktemp("rec") / "rec"
    record(out, RecordOptions(seed=3, minutes=0.25), progress=False)
    return out


@pytest.fixture(scope="session")
def tiny_checkpoint(tiny_recording, tmp_path_factory):
    """PilotNet trained for one epoch on the tiny recording: a real checkpoint for the closed-loop tests."""
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    out = tmp_path_factory.mktemp("ckpt") / "run"
    train(load_config(None, base={"data": str(tiny_recording), "cache": str(out.parent / "cache"), "out": str(out),
                                  "split": {"train": "0:240", "val": "240:300"},
                                  "train": {"epochs": 1, "batch_size": 32}}), progress=False)
    return out / "best.pt"


@pytest.fixture
def donkeycar_tub():
    """donkeycar's tub module (its import prints a banner and sets the root logger to INFO: undone)."""
    import logging

    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    tub_v2 = pytest.importorskip("donkeycar.parts.tub_v2", reason="donkeycar is not installed")
    root.handlers[:] = handlers
    root.setLevel(level)
    return tub_v2


def made(tmp_path, kind="road_wheel", positive="right", geometry="sim", name="model.pt", full_lock_deg=None,
         model="pilotnet", seed=0, **options):
    """An untrained checkpoint of `model` (initialised with `seed`, built with `options`; per-modality statistics)
    with the steering convention and camera geometry of a kind of recording: road_wheel/right + sim (the
    simulator), normalized/right (donkeycar, with `full_lock_deg` if known), steering_wheel/left + ch2 (CH2)."""
    import torch

    from steerlab.checkpoint import save_checkpoint
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.recording import SteeringConvention
    from steerlab.models import create_model, model_class

    pre = PreprocessConfig.from_dict({"preset": geometry, **model_class(model).inputs})
    per = {"image": (100.0, 50.0), "diff": (128.0, 30.0), "flow": (0.0, 1.0)}
    stats = {"mean": [], "std": []}
    for modality, channels in pre.channels().items():
        stats["mean"] += [per[modality][0]] * channels
        stats["std"] += [per[modality][1]] * channels
    model_cfg = {"in_channels": len(stats["mean"]), "height": pre.height, "width": pre.width, **options}
    torch.manual_seed(seed)
    path = tmp_path / name
    save_checkpoint(path, create_model(model, **model_cfg), model_cfg, pre, stats,
                    SteeringConvention(kind, positive, full_lock_deg and math.radians(full_lock_deg)), {"rmse": 0.1},
                    geometry=geometry, frame_rate=20.0)
    return path


def resaved(path, ckpt) -> None:
    """A checkpoint edited on purpose (its statistics or convention changed by a test), saved as steerlab saves it."""
    from steerlab.checkpoint import save_payload

    save_payload(path, ckpt)
