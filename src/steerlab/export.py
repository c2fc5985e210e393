"""ONNX export (`steerlab export`) and the ONNX Runtime model the Pilot runs on.

`model.onnx` holds the network for one frame: input `x` (1, C, H, W), standardised exactly as the torch Pilot
feeds it, plus `speeds` (1, N) for models with a speed history and `h`, `c` (layers, 1, hidden) for recurrent
models, whose next state comes back as outputs `h_out`, `c_out` (zeros start a segment, as the torch Pilot's
empty state). Outputs: `steering` (1,), `speed` (1,) or `command` (1, 3) where the model has them.

The file is self-contained: what the Pilot needs to feed it raw frames lives in the model's own metadata
(ONNX `metadata_props`), so a copied `model.onnx` runs on its own:

- `steerlab`: a JSON document with the preprocessing, standardisation statistics, steering convention, camera
  geometry, frame rate, input and output names, recurrent state shape, speed history and validation metrics;
- `steerlab_sha256`: the sha256 of everything else in the file: every top-level field of the ONNX model but
  the metadata (graph, weights, opset, producer: the bytes as stored), then each metadata entry but this one
  (key and value, in key order). `OnnxModel` recomputes it from the file's bytes before ONNX Runtime sees
  them, so a damaged model, or one whose metadata was edited, is refused instead of predicting nonsense.

Writing needs torch and the `onnx` package; reading needs neither (the top level of the protobuf is walked here,
and ONNX Runtime runs the graph), so the Pilot and the donkeycar part run on a car with onnxruntime alone.

An int8 export (`steerlab export --int8 --calib DATA`) is the same file quantized by ONNX Runtime, calibrated on
the inputs the fp32 graph receives in the Pilot on a recording's frames; its metadata adds `int8` (calibration
source, range, frames) and its sha256 is computed again, so the Pilot runs it unchanged.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import warnings
from pathlib import Path

import numpy as np

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError

FORMAT = "steerlab-onnx-2"  # 1: the metadata in a sidecar model.json beside the .onnx file (no longer read)
OPSET = 18
META_KEY, HASH_KEY = "steerlab", "steerlab_sha256"
_METADATA_PROPS = 14  # ModelProto field number of metadata_props (entries: key = 1, value = 2)
CALIB_FRAMES, CALIB_SAMPLES = 500, 300  # int8 calibration: default frames of the recording, inputs kept
QUANTIZED_OPS = ["Conv", "MatMul", "Gemm"]


def export_onnx(checkpoint: str | Path, out: str | Path, calib: str | Path | None = None,
                calib_range: str | None = None) -> Path:
    """Write `out` (.onnx) with its metadata inside; returns its path. With `calib`, a recording, the model is
    quantized to int8 (`quantize_int8`) on its frames `calib_range` (default: its first CALIB_FRAMES)."""
    out = Path(out)
    if out.suffix != ".onnx":
        raise SteerlabError(f"{out}: the export file must end in .onnx")
    if calib is not None:
        from steerlab.data.readers import open_recording

        calib_rec = open_recording(calib, calib_range)  # bad calibration data is refused before any work
    import torch

    from steerlab.checkpoint import load_checkpoint, model_from_checkpoint

    ckpt = load_checkpoint(checkpoint)
    model, pre, convention = model_from_checkpoint(ckpt)
    c = sum(pre.channels().values())
    x = torch.zeros(1, c, pre.height, pre.width)
    args, names = [x], ["x"]
    history = model.speed_history
    if history:
        args.append(torch.zeros(1, history))
        names.append("speeds")
    with torch.no_grad():
        probe = model(x[:, None]) if model.recurrent else model(*args)
    outputs = [k for k in ("steering", "speed", "command") if k in (probe[0] if isinstance(probe, tuple) else probe)]
    state = None
    if model.recurrent:
        h, _ = probe[1]
        state = list(h.shape)
        args += [torch.zeros(state), torch.zeros(state)]
        names += ["h", "c"]
    wrapper = _one_frame(model, outputs).eval()
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp-{os.getpid()}")
    try:
        with warnings.catch_warnings():  # the LSTM batch-size warning: the state is an explicit input here
            warnings.simplefilter("ignore")
            torch.onnx.export(wrapper, tuple(args), str(tmp), input_names=names,
                              output_names=outputs + (["h_out", "c_out"] if state else []), opset_version=OPSET,
                              dynamo=False)
        meta = {"format": FORMAT, "model": ckpt["model"], "preprocess": pre.as_dict(), "stats": ckpt["stats"],
                "convention": convention.as_dict(), "geometry": ckpt.get("geometry"),
                "frame_rate": ckpt.get("frame_rate"), "inputs": names, "outputs": outputs, "state_shape": state,
                "speed_history": history,
                "metrics": {k: v for k, v in ckpt.get("metrics", {}).items() if isinstance(v, (int, float))}}
        data = _with_metadata(tmp.read_bytes(), json.dumps(meta))
        if calib is not None:
            data, meta["int8"] = quantize_int8(data, calib_rec, calib_range)
            data = _with_metadata(data, json.dumps(meta))
        tmp.write_bytes(data)
        os.replace(tmp, out)  # a model without its metadata is never left at `out`
    finally:
        tmp.unlink(missing_ok=True)
    return out


def _one_frame(model, outputs: list[str]):
    """The model as ONNX sees it: one frame, tensors in and out, the recurrent state explicit."""
    from torch import nn

    class OneFrame(nn.Module):
        def __init__(self):
            super().__init__()
            self.model, self.outputs = model, outputs
            self.recurrent, self.speed_history = model.recurrent, model.speed_history

        def forward(self, x, *rest):
            rest = list(rest)
            kwargs = {"speeds": rest.pop(0)} if self.speed_history else {}
            if self.recurrent:
                h, c = rest
                out, (h, c) = self.model(x[:, None], state=(h, c), **kwargs)
                return (*(out[k][:, 0] for k in self.outputs), h, c)
            out = self.model(x, **kwargs)
            return tuple(out[k] for k in self.outputs)

    return OneFrame()


def quantize_int8(fp32: bytes, rec, calib_range: str | None) -> tuple[bytes, dict]:
    """The exported fp32 model (its bytes) quantized statically by ONNX Runtime (QDQ, int8 weights per channel,
    int8 activations; convolutions and matrix products only, so an LSTM stays fp32), and what it was calibrated
    on: the recording `rec`'s frames `calib_range` (default: its first CALIB_FRAMES)."""
    import tempfile

    import onnx
    from onnxruntime.quantization import (CalibrationDataReader, QuantFormat, QuantType, quant_pre_process,
                                          quantize_static)

    if not any(node.op_type in QUANTIZED_OPS for node in onnx.load_from_string(fp32).graph.node):
        raise SteerlabError("the model has no convolution or matrix product to quantize: export it without --int8")
    n = len(rec) if calib_range else min(len(rec), CALIB_FRAMES)
    with tempfile.TemporaryDirectory() as folder:
        fp32_path, pre, int8 = (Path(folder) / f"{k}.onnx" for k in ("fp32", "pre", "int8"))
        fp32_path.write_bytes(fp32)
        feeds = _calibration_inputs(fp32_path, rec, n)

        class Feeds(CalibrationDataReader):
            def __init__(self):
                self.feeds = iter(feeds)

            def get_next(self):
                return next(self.feeds, None)

        quant_pre_process(fp32_path, pre)
        quantize_static(pre, int8, Feeds(), quant_format=QuantFormat.QDQ, op_types_to_quantize=QUANTIZED_OPS,
                        per_channel=True, activation_type=QuantType.QInt8, weight_type=QuantType.QInt8)
        data = int8.read_bytes()
    return data, {"calibration": str(rec.source), "range": calib_range or f"0:{n}", "frames": len(feeds)}


def _calibration_inputs(fp32: Path, rec, n: int) -> list[dict[str, np.ndarray]]:
    """What the graph sees in the Pilot: the fp32 model drives the recording's first `n` frames, reset at every
    segment start, and the inputs (standardised frame, speeds, recurrent state) of up to CALIB_SAMPLES frames
    spread evenly over them are kept."""
    from steerlab.pilot import Pilot

    keep = set(np.linspace(0, n - 1, min(n, CALIB_SAMPLES)).round().astype(int).tolist())
    pilot = Pilot(fp32)
    session, feeds = pilot.net.session, []

    class Recorder:  # the session as the Pilot calls it, keeping the last input
        def run(self, outputs, feed):
            self.feed = feed
            return session.run(outputs, feed)

    pilot.net.session = recorder = Recorder()
    for start, stop in rec.segments():
        pilot.reset()
        for i in range(start, min(stop, n)):
            pilot.step(rec.load_frame(i), None if rec.speed is None else float(rec.speed[i]))
            if i in keep:
                feeds.append(recorder.feed)
    return feeds


def _with_metadata(data: bytes, meta_json: str) -> bytes:
    """The ONNX model `data` with the steerlab metadata and its sha256 in its metadata_props."""
    import onnx

    proto = onnx.load_from_string(data)
    keep = [(p.key, p.value) for p in proto.metadata_props if p.key not in (META_KEY, HASH_KEY)]
    del proto.metadata_props[:]
    for key, value in [*keep, (META_KEY, meta_json)]:
        proto.metadata_props.add(key=key, value=value)
    digest, _ = content_sha256(proto.SerializeToString())
    proto.metadata_props.add(key=HASH_KEY, value=digest)
    data = proto.SerializeToString()
    if content_sha256(data)[0] != digest:  # the serialiser wrote the rest of the model differently: never expected
        raise SteerlabError("ONNX export: the model's bytes changed while its metadata was written")
    return data


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


def file_sha256(path: Path) -> str:
    """sha256 of a file's bytes (the closed-loop suite keys its cached drives with it)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def read_metadata(path: str | Path) -> tuple[dict, bytes]:
    """The steerlab metadata of an exported model and the file's bytes, its sha256 checked."""
    path = Path(path)
    if not path.is_file():
        raise SteerlabError(f"{path}: ONNX file not found")
    data = path.read_bytes()
    try:
        digest, props = content_sha256(data)
    except (ValueError, UnicodeDecodeError):
        raise SteerlabError(f"{path}: not an ONNX model (damaged or truncated?)") from None
    if META_KEY not in props:
        raise SteerlabError(f"{path}: no steerlab metadata in the model: not written by steerlab export, or by a "
                            "version that kept it in a .json sidecar (export the checkpoint again)")
    if props.get(HASH_KEY) != digest:
        raise SteerlabError(f"{path}: the model does not match the sha256 in its metadata: the file is damaged or "
                            "was changed after export (export the checkpoint again)")
    try:
        meta = json.loads(props[META_KEY])
    except json.JSONDecodeError as e:
        raise SteerlabError(f"{path}: its steerlab metadata is not valid JSON ({e.msg})") from None
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
            raise SteerlabError(f"{path}: not a loadable ONNX model ({e.__class__.__name__})") from None
        self.name = meta["model"]
        self.config = PreprocessConfig.from_dict(meta["preprocess"])
        self.convention = SteeringConvention(**meta["convention"])
        self.geometry = meta.get("geometry")
        self.frame_rate = meta.get("frame_rate")
        self.recurrent = meta["state_shape"] is not None
        self.speed_history = int(meta["speed_history"])
        self.outputs = meta["outputs"] + (["h_out", "c_out"] if self.recurrent else [])
        self.targets = tuple(k for k in meta["outputs"] if k != "steering")
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
