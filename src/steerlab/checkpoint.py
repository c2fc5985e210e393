"""Checkpoints hold everything needed to run a model on raw frames: weights, model name and options,
preprocessing config, normalisation statistics, the steering convention and the metrics it reached.

A checkpoint holds tensors and plain values only (dicts, lists, text, numbers), so it is read with
`torch.load(weights_only=True)`: reading a checkpoint never runs code from it. It carries the sha256 of its
weights, checked when it is read, so a damaged file is refused instead of predicting nonsense. Every
checkpoint is read through `load_checkpoint`."""

from __future__ import annotations

import hashlib
import os
import pickle
import secrets
from pathlib import Path

import numpy as np
import torch

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import create_model, model_class
from steerlab.models.ensemble import Ensemble

FORMAT = "steerlab-checkpoint-1"


def weights_hash(state_dict: dict) -> str:
    """sha256 of the weights: the name, dtype, shape and bytes of every tensor."""
    h = hashlib.sha256()
    for name, t in sorted(state_dict.items()):
        if isinstance(t, torch.Tensor):
            t = t.detach().cpu().contiguous()
            h.update(f"{name}|{t.dtype}|{tuple(t.shape)}\n".encode())
            h.update(t.reshape(-1).view(torch.uint8).numpy())
        else:
            h.update(f"{name}|{t!r}\n".encode())
    return h.hexdigest()


def _plain(value):
    """numpy values as plain Python ones, which `weights_only` loading accepts (tensors stay tensors)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(v) for v in value)
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    return value


def save_checkpoint(path: str | Path, model, model_cfg: dict, pre: PreprocessConfig, stats: dict,
                    convention: SteeringConvention, metrics: dict, **extra) -> None:
    state = model.state_dict()
    payload = _plain({
        "format": FORMAT, "model": model.registry_name, "model_cfg": model_cfg, "state_dict": state,
        "sha256": weights_hash(state), "preprocess": pre.as_dict(), "stats": stats,
        "convention": convention.as_dict(), "metrics": metrics, **extra,
    })
    path = Path(path)
    tmp = path.with_name(f"{path.name}.tmp-{os.getpid()}-{secrets.token_hex(4)}")  # unique: never shared
    try:
        torch.save(payload, tmp)
        tmp.replace(path)  # never leave a half-written checkpoint
    finally:
        tmp.unlink(missing_ok=True)


def load_checkpoint(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise SteerlabError(f"{path}: checkpoint not found")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as e:
        if "weights only" not in str(e).lower():
            raise SteerlabError(f"{path}: not a readable checkpoint (UnpicklingError)") from None
        try:
            names = ", ".join(torch.serialization.get_unsafe_globals_in_checkpoint(path)) or "unknown objects"
        except Exception:  # noqa: BLE001 - only used to name them
            names = "unknown objects"
        raise SteerlabError(f"{path}: the checkpoint holds objects other than tensors and plain values ({names}); "
                            "steerlab does not load them, as loading could run code from the file") from None
    except Exception as e:  # noqa: BLE001 - any reading failure means the same thing to the user
        raise SteerlabError(f"{path}: not a readable checkpoint ({e.__class__.__name__})") from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != FORMAT or not isinstance(ckpt.get("state_dict"), dict):
        raise SteerlabError(f"{path}: not a steerlab checkpoint")
    # checkpoints written before the hash existed have none
    if "sha256" in ckpt and weights_hash(ckpt["state_dict"]) != ckpt["sha256"]:
        raise SteerlabError(f"{path}: the weights do not match the checkpoint's sha256: the file is damaged")
    if "preset" in ckpt:  # the camera geometry's earlier name
        ckpt.setdefault("geometry", ckpt.pop("preset"))
    return ckpt


def model_from_checkpoint(ckpt: dict):
    pre = PreprocessConfig.from_dict(ckpt["preprocess"])
    name, options = ckpt["model"], ckpt["model_cfg"]
    model = Ensemble(**options) if name == "ensemble" else create_model(name, **options)
    model.load_state_dict(ckpt["state_dict"])
    model.eval()
    return model, pre, SteeringConvention(**ckpt["convention"])


def save_ensemble(checkpoints: list[str | Path], out: str | Path) -> Path:
    """One checkpoint that runs the mean of several (`steerlab ensemble`). They must agree on everything the
    Pilot does around the model: preprocessing, camera geometry, steering convention, speed history, outputs
    and recurrence; a one-line error names the first that differs."""
    if len(checkpoints) < 2:
        raise SteerlabError("an ensemble needs at least two checkpoints")
    ckpts = [load_checkpoint(c) for c in checkpoints]
    models = [Ensemble if c["model"] == "ensemble" else model_class(c["model"]) for c in ckpts]
    first, path0 = ckpts[0], checkpoints[0]
    for path, ckpt, model in zip(checkpoints, ckpts, models):
        if ckpt["model"] == "ensemble":
            raise SteerlabError(f"{path} is an ensemble already: name its members instead")
        for what, key in (("steering convention", "convention"), ("camera geometry", "geometry"),
                          ("preprocessing", "preprocess")):
            if ckpt.get(key) != first.get(key):
                raise SteerlabError(f"{path} and {path0} differ in {what} ({ckpt.get(key)} and {first.get(key)}): "
                                    f"an ensemble averages models of one {what}")
        for what in ("recurrent", "speed_history", "targets"):
            if getattr(model, what) != getattr(models[0], what):
                raise SteerlabError(f"{path} ({ckpt['model']}) and {path0} ({first['model']}) differ in "
                                    f"{what.replace('_', ' ')}: an ensemble averages models that run alike")
    members = [{"model": c["model"], "model_cfg": c["model_cfg"], "stats": c["stats"]} for c in ckpts]
    ensemble = Ensemble(members)
    ensemble.nets.load_state_dict({f"{k}.{name}": t for k, c in enumerate(ckpts)
                                   for name, t in c["state_dict"].items()})
    channels = len(first["stats"]["mean"])
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    save_checkpoint(out, ensemble, {"members": members}, PreprocessConfig.from_dict(first["preprocess"]),
                    {"mean": [0.0] * channels, "std": [1.0] * channels},
                    SteeringConvention(**first["convention"]), {}, geometry=first.get("geometry"),
                    frame_rate=first.get("frame_rate"), members=[str(c) for c in checkpoints])
    return Path(out)
