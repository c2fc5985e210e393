"""Checkpoints hold everything needed to run a model on raw frames: weights, model name and options,
preprocessing config, normalisation statistics, the steering convention and the metrics it reached."""

from __future__ import annotations

from pathlib import Path

import torch

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import create_model


def save_checkpoint(path: str | Path, model, model_cfg: dict, pre: PreprocessConfig, stats: dict,
                    convention: SteeringConvention, metrics: dict, **extra) -> None:
    payload = {
        "format": "steerlab-checkpoint-1",
        "model": model.registry_name, "model_cfg": model_cfg, "state_dict": model.state_dict(),
        "preprocess": pre.as_dict(), "stats": stats, "convention": convention.as_dict(), "metrics": metrics,
        **extra,
    }
    tmp = Path(str(path) + ".tmp")
    torch.save(payload, tmp)
    tmp.replace(path)  # never leave a half-written checkpoint


def load_checkpoint(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise SteerlabError(f"{path}: checkpoint not found")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # noqa: BLE001 - any unpickling failure means the same thing to the user
        raise SteerlabError(f"{path}: not a readable checkpoint ({e.__class__.__name__})") from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != "steerlab-checkpoint-1":
        raise SteerlabError(f"{path}: not a steerlab checkpoint")
    return ckpt


def model_from_checkpoint(ckpt: dict):
    pre = PreprocessConfig.from_dict(ckpt["preprocess"])
    model = create_model(ckpt["model"], **ckpt["model_cfg"])
    model.load_state_dict(ckpt["state_dict"])
    model.eval()
    return model, pre, SteeringConvention(**ckpt["convention"])
