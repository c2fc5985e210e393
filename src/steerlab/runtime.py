"""The two backends a Pilot runs a model on: PyTorch (a `.pt` checkpoint, `TorchModel`) and ONNX Runtime (an
exported `.onnx` file, `OnnxModel`). Both take the standardised-to-be NHWC frame (and speeds) and return numpy
outputs, keeping a recurrent model's state between calls; `load_model` picks one by the file.

An exported file carries its metadata in the model's `metadata_props`: `steerlab` (a JSON document) and
`steerlab_sha256`, the sha256 of every other top-level field of the model as stored (graph, weights, opset)
and of the other metadata entries. The hash is checked on the file's bytes before ONNX Runtime sees them, so
the top level of the protobuf is walked here (ONNX Runtime's `custom_metadata_map` gives the metadata but not
the bytes the hash covers); neither torch nor the `onnx` package is needed, so a car runs an export with
numpy, OpenCV and onnxruntime alone. torch is imported for `.pt` checkpoints only.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

from steerlab.data.inputs import Standardizer
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError

FORMAT = "steerlab-onnx-2"  # 1: the metadata in a sidecar model.json beside the .onnx file (no longer read)
META_KEY, HASH_KEY = "steerlab", "steerlab_sha256"
_METADATA_PROPS = 14  # ModelProto field number of metadata_props (entries: key = 1, value = 2)


def load_model(checkpoint: str | Path | dict, threads: int | None = None):
    """The model of a .pt checkpoint (path or loaded dict) on PyTorch, or of an exported .onnx file on ONNX
    Runtime; `threads`: the runtime's intra-op threads (for PyTorch the process's, `torch.set_num_threads`)."""
    if isinstance(checkpoint, dict):
        from steerlab.checkpoint import lacks

        if why := lacks(checkpoint):
            raise SteerlabError(f"the checkpoint given as a dict is not a steerlab checkpoint ({why}): load it with "
                                "steerlab.checkpoint.load_checkpoint(path), or give the path")
    elif not isinstance(checkpoint, (str, os.PathLike)) or not str(checkpoint):
        raise SteerlabError(f"checkpoint must be the path of a .pt checkpoint or an .onnx file (or a loaded "
                            f"checkpoint), got {checkpoint!r}")
    if not isinstance(checkpoint, dict) and Path(checkpoint).suffix == ".onnx":
        return OnnxModel(checkpoint, threads)
    if not isinstance(checkpoint, dict):
        from steerlab.checkpoint import load_checkpoint

        checkpoint = load_checkpoint(checkpoint)
    return TorchModel(checkpoint, threads)


class TorchModel:
    """A checkpoint's model: standardised NHWC frame (and speeds) in, numpy outputs out; keeps the recurrent
    state between calls. `OnnxModel` is the same on ONNX Runtime. `threads` sets torch's (process-wide)."""

    def __init__(self, ckpt: dict, threads: int | None = None):
        import torch

        if threads is not None:
            torch.set_num_threads(threads)

        from steerlab.checkpoint import model_from_checkpoint
        from steerlab.models.registry import predicted

        self.torch = torch
        self.model, self.config, self.convention = model_from_checkpoint(ckpt)
        self.name = ckpt["model"]
        self.geometry = ckpt.get("geometry")  # the camera geometry it was trained on (ch2, sim, donkey)
        self.standardize = Standardizer(ckpt["stats"])
        self.recurrent = self.model.recurrent
        self.speed_history = self.model.speed_history
        self.targets = predicted(self.model)  # what it predicts besides steering: speed or command, throttle
        self.reset()

    def reset(self) -> None:
        self.state = None

    def __call__(self, x_nhwc: np.ndarray, speeds: list[float] | None = None) -> dict[str, np.ndarray]:
        torch = self.torch
        with torch.inference_mode():
            inputs = {"x": self.standardize(x_nhwc)}
            if self.speed_history:
                inputs["speeds"] = torch.tensor([speeds], dtype=torch.float32)
            if self.recurrent:
                out, self.state = self.model(**{k: v[None] for k, v in inputs.items()}, state=self.state)
                out = {k: v[0] for k, v in out.items()}
            else:
                out = self.model(**inputs)
            return {k: v[0].numpy() for k, v in out.items()}


def _varint(data, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        if i >= len(data) or shift > 63:
            raise ValueError("truncated or overlong varint")
        b = data[i]
        i += 1
        value |= (b & 0x7F) << shift
        if b < 0x80:
            return value, i
        shift += 7


def _fields(data) -> list[tuple[int, int, int, int]]:
    """The top-level fields of a protobuf message: (field number, start, start of a length-delimited value, end)."""
    out, i = [], 0
    while i < len(data):
        start = i
        key, i = _varint(data, i)
        number, wire = key >> 3, key & 7
        value = i
        if wire == 0:
            _, i = _varint(data, i)
        elif wire == 1:
            i += 8
        elif wire == 2:
            length, value = _varint(data, i)
            i = value + length
        elif wire == 5:
            i += 4
        else:
            raise ValueError(f"wire type {wire}")
        if number == 0 or i > len(data):
            raise ValueError("not a protobuf message")
        out.append((number, start, value, i))
    return out


def content_sha256(data: bytes) -> tuple[str, dict[str, str]]:
    """(sha256 of an ONNX model's content, its metadata_props): the hash covers every top-level field but the
    metadata, byte for byte as stored, then every metadata entry but the hash itself (key, value, in key order).
    Raises ValueError when `data` is not a protobuf message."""
    view, h, meta = memoryview(data), hashlib.sha256(), {}
    for number, start, value, end in _fields(view):
        if number != _METADATA_PROPS:
            h.update(view[start:end])
            continue
        sub = view[value:end]
        entry = {n: bytes(sub[v:e]).decode("utf-8") for n, _, v, e in _fields(sub) if n in (1, 2)}
        meta[entry.get(1, "")] = entry.get(2, "")
    for key in sorted(meta):
        if key != HASH_KEY:
            h.update(key.encode() + b"\0" + meta[key].encode() + b"\0")
    return h.hexdigest(), meta


def read_metadata(path: str | Path) -> tuple[dict, bytes]:
    """The steerlab metadata of an exported model and the file's bytes, its sha256 checked."""
    path = Path(path)
    if not path.is_file():
        raise SteerlabError(f"{path}: ONNX file not found: check the path")
    data = path.read_bytes()
    try:
        digest, props = content_sha256(data)
    except (ValueError, UnicodeDecodeError):
        raise SteerlabError(f"{path}: not an ONNX model (damaged or truncated?): export the checkpoint again") from None
    if META_KEY not in props:
        raise SteerlabError(f"{path}: no steerlab metadata in the model: not written by steerlab export, or by a "
                            "version that kept it in a .json sidecar (export the checkpoint again)")
    if props.get(HASH_KEY) != digest:
        raise SteerlabError(f"{path}: the model does not match the sha256 in its metadata: the file is damaged or "
                            "was changed after export (export the checkpoint again)")
    try:
        meta = json.loads(props[META_KEY])
    except json.JSONDecodeError as e:
        raise SteerlabError(f"{path}: its steerlab metadata is not valid JSON ({e.msg}): export the "
                            "checkpoint again") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise SteerlabError(f"{path}: unknown steerlab metadata format "
                            f"{meta.get('format') if isinstance(meta, dict) else meta!r} (expected {FORMAT})")
    return meta, data


class OnnxModel:
    """The Pilot's model on ONNX Runtime: standardised NHWC frame (and speeds) in, numpy outputs out; keeps
    the recurrent state between calls. `threads`: ONNX Runtime's intra-op threads (default: torch's thread
    count when torch is loaded, else ONNX Runtime's own choice)."""

    def __init__(self, path: str | Path, threads: int | None = None):
        path = Path(path)
        meta, data = read_metadata(path)
        try:
            import onnxruntime as ort
        except ImportError:
            raise SteerlabError("running .onnx models needs onnxruntime: pip install onnxruntime") from None
        options = ort.SessionOptions()
        if threads is not None:
            options.intra_op_num_threads = threads
        elif "torch" in sys.modules:  # share the cores as torch was told to (one thread per test worker, say)
            options.intra_op_num_threads = sys.modules["torch"].get_num_threads()
        try:
            self.session = ort.InferenceSession(data, options, providers=["CPUExecutionProvider"])
        except Exception as e:  # noqa: BLE001 - onnxruntime raises its own exception types for bad files
            raise SteerlabError(f"{path}: not a loadable ONNX model ({e.__class__.__name__}): export the "
                                "checkpoint again") from None
        self.name = meta["model"]
        self.config = PreprocessConfig.from_dict(meta["preprocess"])
        self.convention = SteeringConvention(**meta["convention"])
        self.geometry = meta.get("geometry")
        self.frame_rate = meta.get("frame_rate")
        self.recurrent = meta["state_shape"] is not None
        self.speed_history = int(meta["speed_history"])
        self.outputs = meta["outputs"] + (["h_out", "c_out"] if self.recurrent else [])
        self.targets = tuple(k for k in meta["outputs"] if k != "steering")  # as TorchModel's
        self.state_shape = meta["state_shape"]
        self.inputs = {i.name for i in self.session.get_inputs()}  # a constant baseline's graph takes none
        self.mean = np.asarray(meta["stats"]["mean"], np.float32)
        self.std = np.asarray(meta["stats"]["std"], np.float32)
        self.reset()

    def reset(self) -> None:
        self.state = None if not self.recurrent else [np.zeros(self.state_shape, np.float32)] * 2

    def __call__(self, x_nhwc: np.ndarray, speeds: list[float] | None = None) -> dict[str, np.ndarray]:
        feed = {"x": np.ascontiguousarray(((x_nhwc - self.mean) / self.std).transpose(0, 3, 1, 2), np.float32)}
        if self.speed_history:
            feed["speeds"] = np.asarray([speeds], np.float32)
        if self.recurrent:
            feed["h"], feed["c"] = self.state
        feed = {k: v for k, v in feed.items() if k in self.inputs}
        result = dict(zip(self.outputs, self.session.run(self.outputs, feed)))
        if self.recurrent:
            self.state = [result.pop("h_out"), result.pop("c_out")]
        return {k: v[0] for k, v in result.items()}
