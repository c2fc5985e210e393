"""ONNX export (`steerlab export`) and the ONNX Runtime model the Pilot runs on.

`model.onnx` holds the network for one frame: input `x` (1, C, H, W), standardised exactly as the torch Pilot
feeds it, plus `speeds` (1, N) for models with a speed history and `h`, `c` (layers, 1, hidden) for recurrent
models, whose next state comes back as outputs `h_out`, `c_out` (zeros start a segment, as the torch Pilot's
empty state). Outputs: `steering` (1,), `speed` (1,) or `command` (1, 3) where the model has them.
`model.json` beside it is the sidecar the Pilot needs to feed raw frames: preprocessing, standardisation
statistics, steering convention, camera preset, input and output names, and the sha256 of the .onnx file,
which `OnnxModel` checks, so that a damaged model is refused instead of predicting nonsense.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path

import numpy as np
import torch
from torch import nn

from steerlab.checkpoint import load_checkpoint, model_from_checkpoint
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError

FORMAT = "steerlab-onnx-1"
OPSET = 18


class _OneFrame(nn.Module):
    """The model as ONNX sees it: one frame, tensors in and out, the recurrent state explicit."""

    def __init__(self, model: nn.Module, outputs: list[str]):
        super().__init__()
        self.model, self.outputs = model, outputs
        self.recurrent = model.recurrent
        self.speed_history = model.speed_history

    def forward(self, x, *rest):
        rest = list(rest)
        kwargs = {"speeds": rest.pop(0)} if self.speed_history else {}
        if self.recurrent:
            h, c = rest
            out, (h, c) = self.model(x[:, None], state=(h, c), **kwargs)
            return (*(out[k][:, 0] for k in self.outputs), h, c)
        out = self.model(x, **kwargs)
        return tuple(out[k] for k in self.outputs)


def sidecar_path(onnx_path: str | Path) -> Path:
    return Path(onnx_path).with_suffix(".json")


def export_onnx(checkpoint: str | Path, out: str | Path) -> Path:
    """Write `out` (.onnx) and its sidecar `.json`; returns the ONNX path."""
    out = Path(out)
    if out.suffix != ".onnx":
        raise SteerlabError(f"{out}: the export file must end in .onnx")
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
    wrapper = _OneFrame(model, outputs).eval()
    out.parent.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():  # the LSTM batch-size warning: the state is an explicit input here
        warnings.simplefilter("ignore")
        torch.onnx.export(wrapper, tuple(args), str(out), input_names=names,
                          output_names=outputs + (["h_out", "c_out"] if state else []), opset_version=OPSET,
                          dynamo=False)
    meta = {"format": FORMAT, "model": ckpt["model"], "preprocess": pre.as_dict(), "stats": ckpt["stats"],
            "convention": convention.as_dict(), "preset": ckpt.get("preset"), "frame_rate": ckpt.get("frame_rate"),
            "inputs": names, "outputs": outputs, "state_shape": state, "speed_history": history,
            "metrics": {k: v for k, v in ckpt.get("metrics", {}).items() if isinstance(v, (int, float))},
            "sha256": file_sha256(out)}
    sidecar_path(out).write_text(json.dumps(meta, indent=1))
    return out


def file_sha256(path: Path) -> str:
    """sha256 of a file's bytes: for an .onnx file (graph and weights) it is kept in the sidecar and checked when
    the model is loaded; the closed-loop suite keys its cached drives with it."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class OnnxModel:
    """The Pilot's model on ONNX Runtime: standardised NHWC frame (and speeds) in, numpy outputs out; keeps
    the recurrent state between calls."""

    def __init__(self, path: str | Path):
        path = Path(path)
        side = sidecar_path(path)
        if not path.is_file():
            raise SteerlabError(f"{path}: ONNX file not found")
        if not side.is_file():
            raise SteerlabError(f"{path}: its metadata {side.name} is missing (write both with steerlab export)")
        try:
            meta = json.loads(side.read_text())
        except json.JSONDecodeError as e:
            raise SteerlabError(f"{side}: not valid JSON ({e.msg}, line {e.lineno})") from None
        if meta.get("format") != FORMAT:
            raise SteerlabError(f"{side}: not steerlab ONNX metadata (format {meta.get('format')!r})")
        # exports written before the hash existed have none
        if "sha256" in meta and file_sha256(path) != meta["sha256"]:
            raise SteerlabError(f"{path}: the model does not match the sha256 in {side.name}: the file is damaged "
                                "or is not the export this metadata belongs to (export it again)")
        try:
            import onnxruntime as ort
        except ImportError:
            raise SteerlabError("running .onnx models needs onnxruntime: pip install onnxruntime") from None
        options = ort.SessionOptions()
        options.intra_op_num_threads = torch.get_num_threads()
        try:
            self.session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        except Exception as e:  # noqa: BLE001 - onnxruntime raises its own exception types for bad files
            raise SteerlabError(f"{path}: not a loadable ONNX model ({e.__class__.__name__})") from None
        self.name = meta["model"]
        self.config = PreprocessConfig.from_dict(meta["preprocess"])
        self.convention = SteeringConvention(**meta["convention"])
        self.preset = meta.get("preset")
        self.recurrent = meta["state_shape"] is not None
        self.speed_history = int(meta["speed_history"])
        self.outputs = meta["outputs"] + (["h_out", "c_out"] if self.recurrent else [])
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
