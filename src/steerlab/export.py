"""ONNX export (`steerlab export`): one self-contained file that `runtime.OnnxModel` runs.

`model.onnx` holds the network for one frame: input `x` (1, C, H, W), standardised exactly as the torch Pilot
feeds it, plus `speeds` (1, N) for models with a speed history and `h`, `c` (layers, 1, hidden) for recurrent
models, whose next state comes back as outputs `h_out`, `c_out` (zeros start a segment, as the torch Pilot's
empty state). Outputs: `steering` (1,), `speed` (1,) or `command` (1, 3), `throttle` (1,) and `lane` (1, 3)
where the model has them.

The file is self-contained: what the Pilot needs to feed it raw frames lives in the model's own metadata
(ONNX `metadata_props`), so a copied `model.onnx` runs on its own:

- `steerlab`: a JSON document with the preprocessing, standardisation statistics, steering convention, camera
  geometry, frame rate, input and output names, recurrent state shape, speed history and validation metrics;
- `steerlab_sha256`: the sha256 of everything else in the file (`runtime.content_sha256`), checked when the
  file is loaded, so a damaged model, or one whose metadata was edited, is refused instead of predicting
  nonsense.

Writing needs torch and the `onnx` package; reading (`runtime.py`) needs neither.

An int8 export (`steerlab export --int8 --calib DATA`) is the same file quantized by ONNX Runtime (weights in 7
bits, `INT8_SCHEME`), calibrated on the inputs the fp32 graph receives in the Pilot on a recording's frames; its
metadata adds `int8` (calibration source, range, frames, the scheme and the CPUs it was checked on) and its sha256
is computed again, so the Pilot runs it unchanged.
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.paths import a_path, check_outputs
from steerlab.runtime import FORMAT, HASH_KEY, META_KEY, content_sha256

OPSET = 18
CALIB_FRAMES, CALIB_SAMPLES = 500, 300  # int8 calibration: default frames of the recording, inputs kept
QUANTIZED_OPS = ["Conv", "MatMul", "Gemm"]
# How an int8 model is quantized: QDQ, activations int8 per tensor, weights int8 per output channel in 7 bits
# (reduce_range). x86's int8 kernels without VNNI (AVX2, AVX-512 before VNNI) multiply unsigned 8-bit activations
# by signed 8-bit weights and add pairs of products in 16 bits, which saturate when both are near their ends; with
# weights in [-64, 64] a pair stays within 16 bits, so every CPU sums the same integers and the int8 model steers
# alike on all of them (docs/results/latency.md, "int8 on every CPU": the schemes measured on each).
INT8_SCHEMES = {  # name: (activation type, weight type, reduce_range)
    "s8s8": ("QInt8", "QInt8", False), "s8s8-7bit": ("QInt8", "QInt8", True), "u8u8": ("QUInt8", "QUInt8", False)}
INT8_SCHEME = "s8s8-7bit"
# the CPUs on whose kernels INT8_SCHEME was checked against fp32 (benchmarks/bench_int8.py: 16 models, two of the
# three CPUs emulated), written into an int8 model's metadata as `scheme_checked_on`
INT8_CHECKED_ON = ["x86-64 AVX2 without VNNI", "x86-64 AVX-512 with VNNI", "aarch64"]


def export_onnx(checkpoint: str | Path, out: str | Path, calib: str | Path | None = None,
                calib_range: str | None = None) -> Path:
    """Write `out` (.onnx) with its metadata inside; returns its path. With `calib`, a recording, the model is
    quantized to int8 (`quantize_int8`) on its frames `calib_range` (default: its first CALIB_FRAMES)."""
    out = a_path(out, "export_onnx: out")
    if out.suffix != ".onnx":
        raise SteerlabError(f"{out}: the export file must end in .onnx")
    check_outputs(files={"export": out}, inputs=[checkpoint, calib])
    if calib is not None:
        from steerlab.data.readers import open_recording

        from steerlab.data.rows import parse_range

        parse_range(calib_range, "--calib-range")  # the option named where the frames are given wrongly
        calib_rec = open_recording(calib, calib_range)  # bad calibration data is refused before any work
    import torch

    from steerlab.checkpoint import load_checkpoint, model_from_checkpoint

    ckpt = load_checkpoint(checkpoint)
    if calib is not None and ckpt.get("geometry") not in (None, calib_rec.geometry):
        raise SteerlabError(f"steerlab export --calib {calib}: the recording's camera geometry "
                            f"({calib_rec.geometry}) is not the model's ({ckpt['geometry']}): calibrate on frames of "
                            f"the camera {checkpoint} was trained on")
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
    outputs = [k for k in ("steering", "speed", "command", "throttle", "lane")
               if k in (probe[0] if isinstance(probe, tuple) else probe)]
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


def quantize_int8(fp32: bytes, rec, calib_range: str | None, scheme: str = INT8_SCHEME) -> tuple[bytes, dict]:
    """The exported fp32 model (its bytes) quantized statically by ONNX Runtime (QDQ, `scheme` of INT8_SCHEMES;
    convolutions and matrix products only, so an LSTM stays fp32), and what it was calibrated on: the recording
    `rec`'s frames `calib_range` (default: its first CALIB_FRAMES), with the scheme and the CPUs it was checked
    on."""
    import tempfile

    import onnx
    from onnxruntime.quantization import (CalibrationDataReader, QuantFormat, QuantType, quant_pre_process,
                                          quantize_static)

    if not any(node.op_type in QUANTIZED_OPS for node in onnx.load_from_string(fp32).graph.node):
        raise SteerlabError("the model has no convolution or matrix product to quantize: run steerlab export "
                            "without --int8")
    n = len(rec) if calib_range else min(len(rec), CALIB_FRAMES)
    with tempfile.TemporaryDirectory() as folder:
        fp32_path, pre, int8 = (Path(folder) / f"{k}.onnx" for k in ("fp32", "pre", "int8"))
        fp32_path.write_bytes(fp32)
        feeds = calibration_inputs(fp32_path, rec, n)

        class Feeds(CalibrationDataReader):
            def __init__(self):
                self.feeds = iter(feeds)

            def get_next(self):
                return next(self.feeds, None)

        quant_pre_process(fp32_path, pre)
        activations, weights, reduce_range = INT8_SCHEMES[scheme]
        quantize_static(pre, int8, Feeds(), quant_format=QuantFormat.QDQ, op_types_to_quantize=QUANTIZED_OPS,
                        per_channel=True, reduce_range=reduce_range, activation_type=QuantType[activations],
                        weight_type=QuantType[weights])
        data = int8.read_bytes()
    return data, {"calibration": str(rec.source), "range": calib_range or f"0:{n}", "frames": len(feeds),
                  "scheme": scheme, "scheme_checked_on": INT8_CHECKED_ON if scheme == INT8_SCHEME else []}


def calibration_inputs(fp32: Path, rec, n: int) -> list[dict[str, np.ndarray]]:
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
        raise SteerlabError("ONNX export: the model's bytes changed while its metadata was written: export "
                            "it again")
    return data


