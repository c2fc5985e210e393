"""Checkpoints hold everything needed to run a model on raw frames: weights, model name and options,
preprocessing config, normalisation statistics, the steering convention and the metrics it reached.

A checkpoint holds tensors and plain values only (dicts, lists, text, numbers), so it is read with
`torch.load(weights_only=True)`: reading a checkpoint never runs code from it. Its file is sealed with the
sha256 of all its bytes, so a damaged file is refused instead of predicting nonsense. Files written before seals
carry inner hashes instead (of the weights, and of everything else stored), which are checked where they are.
Every checkpoint is read through `load_checkpoint`."""

from __future__ import annotations

import hashlib
import io
import os
import pickle
import secrets
import warnings
from pathlib import Path

import numpy as np
import torch

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import create_model, model_class
from steerlab.models.ensemble import Ensemble
from steerlab.paths import check_outputs, distinct, regular_file

# 2: always sealed; 1: sealed (with an inner content_sha256 until b827f9a, without since), or from before seals: with
# the sha256 of its weights inside (0.1.0) or with no hash at all (the first versions)
FORMAT = "steerlab-checkpoint-2"
FORMATS = ("steerlab-checkpoint-1", FORMAT)
REQUIRED = ("model", "model_cfg", "stats", "preprocess", "convention")  # what the Pilot reads of a checkpoint


def lacks(ckpt) -> str | None:
    """What makes a loaded `ckpt` (a dict given to the Python API) no steerlab checkpoint; None: nothing."""
    if not isinstance(ckpt, dict) or ckpt.get("format") not in FORMATS or not isinstance(ckpt.get("state_dict"), dict):
        return f"no 'format' of {' or '.join(FORMATS)} with a 'state_dict'"
    missing = [k for k in REQUIRED if k not in ckpt]
    return f"it lacks {', '.join(map(repr, missing))}" if missing else None


def _hash_into(h, value) -> None:
    """Feed a value (tensors, and dicts, lists and plain values holding them) into a hash, keys in order."""
    if isinstance(value, torch.Tensor):
        t = value.detach().cpu().contiguous()
        h.update(f"tensor|{t.dtype}|{tuple(t.shape)}\n".encode())
        h.update(t.reshape(-1).view(torch.uint8).numpy())
    elif isinstance(value, dict):
        h.update(f"dict|{len(value)}\n".encode())
        for k in sorted(value, key=repr):
            h.update(f"{k!r}:".encode())
            _hash_into(h, value[k])
    elif isinstance(value, (list, tuple)):
        h.update(f"{type(value).__name__}|{len(value)}\n".encode())
        for v in value:
            _hash_into(h, v)
    else:
        h.update(f"{value!r}\n".encode())


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


def content_hash(payload: dict) -> str:
    """sha256 of everything a checkpoint stores but this hash: the weights and everything the Pilot uses with
    them (model and options, preprocessing, statistics, convention, camera geometry) and what a resumed run
    reads (optimiser and RNG state, history)."""
    h = hashlib.sha256()
    _hash_into(h, {k: v for k, v in payload.items() if k != "content_sha256"})
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
    save_payload(path, {"format": FORMAT, "model": model.registry_name, "model_cfg": model_cfg,
                        "state_dict": model.state_dict(), "preprocess": pre.as_dict(), "stats": stats,
                        "convention": convention.as_dict(), "metrics": metrics, **extra})


SEAL = b"steerlab-sha256:"  # the zip comment of a checkpoint: this, then the hex sha256 of every byte before it
EOCD = b"PK\x05\x06"  # the zip's end-of-central-directory record (22 bytes and its comment close the file)


def save_payload(path: str | Path, payload: dict) -> None:
    """A checkpoint's contents written to `path` as torch.save writes them, sealed: the zip's comment is the sha256
    of all the bytes before it, so that every stored byte is covered (also the zip's own headers and padding, which
    reading does not check). Written to a temporary file first: never a half-written checkpoint."""
    buffer = io.BytesIO()
    torch.save(_plain({**payload, "format": FORMAT}), buffer)
    data = buffer.getbuffer()  # no copies of the bytes: a checkpoint with its optimiser state is tens of MB
    if data[-22:-18] != EOCD or data[-2:] != b"\0\0":
        raise SteerlabError("checkpoint: torch.save wrote an unexpected file layout (no plain zip end record): install "
                            "the torch version pyproject.toml names")
    comment = (len(SEAL) + 64).to_bytes(2, "little") + SEAL
    digest = hashlib.sha256(data[:-2])
    digest.update(comment)
    path = Path(path)
    tmp = path.with_name(f"{path.name}.tmp-{os.getpid()}-{secrets.token_hex(4)}")  # unique: never shared
    try:
        with open(tmp, "wb") as f:
            f.write(data[:-2])
            f.write(comment + digest.hexdigest().encode())
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def _seal_intact(data: bytes) -> bool | None:
    """Whether a sealed checkpoint's bytes match their sha256 (None: a file without a comment, as an earlier
    version or torch.save alone writes it)."""
    size = len(SEAL) + 64
    at = data.rfind(EOCD, max(0, len(data) - 22 - size - 64))  # the last end record
    if at < 0:
        return False
    comment = int.from_bytes(data[at + 20: at + 22], "little")
    if comment == 0 and at + 22 == len(data):
        return None
    if comment != size or len(data) != at + 22 + size or data[at + 22: at + 22 + len(SEAL)] != SEAL:
        return False
    return hashlib.sha256(memoryview(data)[:-64]).hexdigest().encode() == data[-64:]


def load_checkpoint(path: str | Path) -> dict:
    path = regular_file(path, "checkpoint")
    if path.suffix == ".onnx":
        raise SteerlabError(f"{path}: an exported .onnx model, not a steerlab checkpoint (.pt): name the checkpoint "
                            "it was exported from")
    data = path.read_bytes()
    if not data.startswith(b"PK\x03\x04"):  # what torch.save writes, and so every checkpoint: a zip file
        raise SteerlabError(f"{path}: not a readable checkpoint (not the zip file torch.save writes): give a steerlab "
                            "checkpoint (best.pt of a training run)")
    try:
        with warnings.catch_warnings():  # a plain pickle's protocol: refused below, not worth a warning
            warnings.simplefilter("ignore")
            ckpt = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as e:
        if "weights only" not in str(e).lower():
            raise SteerlabError(f"{path}: not a readable checkpoint (UnpicklingError): give a steerlab "
                                "checkpoint (best.pt of a training run)") from None
        try:
            names = ", ".join(torch.serialization.get_unsafe_globals_in_checkpoint(path)) or "unknown objects"
        except Exception:  # noqa: BLE001 - only used to name them
            names = "unknown objects"
        raise SteerlabError(f"{path}: the checkpoint holds objects other than tensors and plain values ({names}): not "
                            "a steerlab checkpoint; steerlab does not load them, as loading could run code from the "
                            "file; give a checkpoint that steerlab wrote (best.pt of a training run)") from None
    except Exception as e:  # noqa: BLE001 - any reading failure means the same thing to the user
        raise SteerlabError(f"{path}: not a readable checkpoint ({e.__class__.__name__}): give a steerlab checkpoint "
                            "(best.pt of a training run)") from None
    if not isinstance(ckpt, dict) or ckpt.get("format") not in FORMATS or not isinstance(ckpt.get("state_dict"), dict):
        raise SteerlabError(f"{path}: not a steerlab checkpoint: give best.pt or last.pt of a training run")
    seal = _seal_intact(data)
    if not seal:  # damaged, or written before seals: those carry inner hashes (the earliest: the weights' or none)
        if "sha256" in ckpt and weights_hash(ckpt["state_dict"]) != ckpt["sha256"]:
            raise SteerlabError(f"{path}: the weights do not match the checkpoint's sha256: the file is damaged; "
                                "copy it again, or train it again")
        if "content_sha256" in ckpt and content_hash(ckpt) != ckpt["content_sha256"]:
            raise SteerlabError(f"{path}: the checkpoint's settings (statistics, preprocessing, convention, "
                                "training state) do not match its sha256: the file is damaged; copy it again, or train "
                                "it again")
        if seal is False:
            raise SteerlabError(f"{path}: the file's bytes do not match the sha256 stored with them: the file is "
                                "damaged; copy it again, or train it again")
        if ckpt["format"] == FORMAT or "content_sha256" in ckpt:  # steerlab sealed every file of these when it wrote it
            raise SteerlabError(f"{path}: a checkpoint that steerlab sealed, without its seal: it was written again "
                                "by another tool (torch.save?), which may have changed anything in it; steerlab does "
                                "not load it (save with steerlab.checkpoint.save_payload, or use the original file)")
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
    if isinstance(checkpoints, (str, os.PathLike)) or not isinstance(checkpoints, (list, tuple)):
        raise SteerlabError(f"save_ensemble: checkpoints must be a list of checkpoint paths, got {checkpoints!r}")
    if len(checkpoints) < 2:
        raise SteerlabError("an ensemble needs at least two checkpoints")
    check_outputs(files={"ensemble": out}, inputs=distinct(checkpoints, "checkpoint"))
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
                                    f"an ensemble averages models of one {what}: choose members that share it")
        for what in ("recurrent", "speed_history", "targets", "throttle"):
            value, value0 = ((c["model_cfg"].get("throttle", False) for c in (ckpt, first)) if what == "throttle"
                             else (getattr(m, what) for m in (model, models[0])))
            if value != value0:
                raise SteerlabError(f"{path} ({ckpt['model']}) and {path0} ({first['model']}) differ in "
                                    f"{what.replace('_', ' ')}: an ensemble averages models that run alike: "
                                    "choose members that do")
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
