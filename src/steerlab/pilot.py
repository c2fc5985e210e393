"""The Pilot: the one object that drives. Raw frames in, one set of controls per frame out.

It applies exactly the preprocessing the model was trained with, keeps the previous frame for the frame
difference and optical flow, the last frames for stacked input, the last speeds for models with a speed
history and the recurrent state, standardises with the checkpoint's statistics, runs the model and optionally
smooths the steering (paper 002 Eq. 2). Offline evaluation and closed-loop driving both use it, so what is
measured is what runs. The model runs on PyTorch (a .pt checkpoint) or on ONNX Runtime (an exported .onnx
file); everything around the model is the same code. torch is imported only for a .pt checkpoint: the Pilot
on an exported .onnx file needs numpy, OpenCV and ONNX Runtime alone (what a car's computer has).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.data.inputs import Standardizer, stack_modalities
from steerlab.data.modalities import frame_difference, optical_flow
from steerlab.data.preprocess import preprocess
from steerlab.errors import SteerlabError


@dataclass(frozen=True)
class Controls:
    """One frame's output: steering in the checkpoint's convention (radians); for speed models also the next
    frame's speed (m/s) or the speed command (0 decelerate, 1 maintain, 2 accelerate)."""

    steering: float
    speed: float | None = None
    command: int | None = None


class TorchModel:
    """A checkpoint's model: standardised NHWC frame (and speeds) in, numpy outputs out; keeps the recurrent
    state between calls. `export.OnnxModel` is the same on ONNX Runtime."""

    def __init__(self, ckpt: dict):
        import torch

        from steerlab.checkpoint import model_from_checkpoint

        self.torch = torch
        self.model, self.config, self.convention = model_from_checkpoint(ckpt)
        self.name = ckpt["model"]
        self.preset = ckpt.get("preset")  # the camera geometry it was trained on (ch2, sim, donkey)
        self.standardize = Standardizer(ckpt["stats"])
        self.recurrent = self.model.recurrent
        self.speed_history = self.model.speed_history
        self.targets = tuple(self.model.targets)  # what it predicts besides steering: ("speed",), ("command",)
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


class Pilot:
    def __init__(self, checkpoint: str | Path | dict, smoothing: float | None = None):
        """`checkpoint`: a .pt checkpoint (path or loaded dict) or an exported .onnx file (self-contained: its
        preprocessing, statistics and convention are in its metadata)."""
        if not isinstance(checkpoint, dict) and Path(checkpoint).suffix == ".onnx":
            from steerlab.export import OnnxModel

            self.net = OnnxModel(checkpoint)
        else:
            if not isinstance(checkpoint, dict):
                from steerlab.checkpoint import load_checkpoint

                checkpoint = load_checkpoint(checkpoint)
            self.net = TorchModel(checkpoint)
        self.name, self.config, self.convention = self.net.name, self.net.config, self.net.convention
        self.preset, self.speed_history, self.targets = self.net.preset, self.net.speed_history, self.net.targets
        self.smoothing = smoothing
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next frame is treated as the first of a segment."""
        self._prev_img = self._prev_gray = None
        self._frames: deque = deque(maxlen=self.config.stack)
        self._speeds: deque = deque(maxlen=self.speed_history)
        self._smoothed = None
        self.net.reset()

    @staticmethod
    def _push(history: deque, item) -> None:
        """Append to a history; a segment's first item stands in for the past before it."""
        while len(history) < history.maxlen - 1:
            history.append(item)
        history.append(item)

    def step(self, bgr: np.ndarray, speed: float | None = None) -> Controls:
        """One raw BGR frame (and the measured speed in m/s, for models that use it) -> controls."""
        img, gray = preprocess(bgr, self.config)
        prev_img = img if self._prev_img is None else self._prev_img
        prev_gray = gray if self._prev_gray is None else self._prev_gray
        self._push(self._frames, img)
        arrays = {"image": np.concatenate(self._frames, axis=-1)}
        if "diff" in self.config.modalities:
            arrays["diff"] = frame_difference(prev_img, img)
        if "flow" in self.config.modalities:
            arrays["flow"] = optical_flow(prev_gray, gray, self.config.flow).astype(np.float16)
        self._prev_img, self._prev_gray = img, gray
        speeds = None
        if self.speed_history:
            if speed is None:
                raise SteerlabError(f"model {self.name!r} needs the measured speed with every frame")
            self._push(self._speeds, float(speed))
            speeds = list(self._speeds)
        out = self.net(stack_modalities(arrays, self.config)[None], speeds)
        y = float(out["steering"])
        if self.smoothing is not None:
            self._smoothed = y if self._smoothed is None else self.smoothing * y + (1 - self.smoothing) * self._smoothed
            y = self._smoothed
        return Controls(y, float(out["speed"]) if "speed" in out else None,
                        int(out["command"].argmax()) if "command" in out else None)
