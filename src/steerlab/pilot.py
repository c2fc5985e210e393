"""The Pilot: the one object that drives. Raw frames in, one set of controls per frame out.

It applies exactly the preprocessing the model was trained with, keeps the previous frame for the frame
difference and optical flow, the last frames for stacked input, the last speeds for models with a speed
history and the recurrent state, standardises with the checkpoint's statistics, runs the model and optionally
smooths the steering (paper 002 Eq. 2). Offline evaluation and closed-loop driving both use it, so what is
measured is what runs.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
import torch

from steerlab.data.modalities import frame_difference, optical_flow
from steerlab.data.preprocess import preprocess
from steerlab.errors import SteerlabError
from steerlab.checkpoint import load_checkpoint, model_from_checkpoint
from steerlab.data.inputs import Standardizer, stack_modalities


@dataclass(frozen=True)
class Controls:
    """One frame's output: steering in the checkpoint's convention (radians); for speed models also the next
    frame's speed (m/s) or the speed command (0 decelerate, 1 maintain, 2 accelerate)."""

    steering: float
    speed: float | None = None
    command: int | None = None


class Pilot:
    def __init__(self, checkpoint: str | dict, smoothing: float | None = None):
        ckpt = load_checkpoint(checkpoint) if not isinstance(checkpoint, dict) else checkpoint
        self.model, self.config, self.convention = model_from_checkpoint(ckpt)
        self.name = ckpt["model"]
        self.preset = ckpt.get("preset")  # the camera geometry it was trained on (ch2, sim)
        self.standardize = Standardizer(ckpt["stats"])
        self.smoothing = smoothing
        self.recurrent = getattr(self.model, "recurrent", False)
        self.speed_history = getattr(self.model, "speed_history", 0)
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next frame is treated as the first of a segment."""
        self._prev_img = self._prev_gray = None
        self._frames: deque = deque(maxlen=self.config.stack)
        self._speeds: deque = deque(maxlen=self.speed_history)
        self._smoothed = None
        self._state = None

    @staticmethod
    def _push(history: deque, item) -> None:
        """Append to a history; a segment's first item stands in for the past before it."""
        while len(history) < history.maxlen - 1:
            history.append(item)
        history.append(item)

    @torch.inference_mode()
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
        inputs = {"x": self.standardize(stack_modalities(arrays, self.config)[None])}
        if self.speed_history:
            if speed is None:
                raise SteerlabError(f"model {self.name!r} needs the measured speed with every frame")
            self._push(self._speeds, float(speed))
            inputs["speeds"] = torch.tensor([list(self._speeds)], dtype=torch.float32)
        if self.recurrent:
            out, self._state = self.model(**{k: v[None] for k, v in inputs.items()}, state=self._state)
            out = {k: v[0] for k, v in out.items()}
        else:
            out = self.model(**inputs)
        y = float(out["steering"][0])
        if self.smoothing is not None:
            self._smoothed = y if self._smoothed is None else self.smoothing * y + (1 - self.smoothing) * self._smoothed
            y = self._smoothed
        return Controls(y, float(out["speed"][0]) if "speed" in out else None,
                        int(out["command"][0].argmax()) if "command" in out else None)
