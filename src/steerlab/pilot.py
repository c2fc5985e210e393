"""The Pilot: the one object that drives. Raw frames in, one steering command per frame out.

It applies exactly the preprocessing the model was trained with, keeps the previous frame for the frame
difference and optical flow, standardises with the checkpoint's statistics, runs the model and optionally
smooths the output (paper 002 Eq. 2). Offline evaluation and closed-loop driving both use it, so what is
measured is what runs.
"""

from __future__ import annotations

from collections import deque

import numpy as np
import torch

from steerlab.data.modalities import frame_difference, optical_flow
from steerlab.data.preprocess import preprocess
from steerlab.train.checkpoint import load_checkpoint, model_from_checkpoint
from steerlab.train.inputs import Standardizer, stack_modalities


class Pilot:
    def __init__(self, checkpoint: str | dict, smoothing: float | None = None):
        ckpt = load_checkpoint(checkpoint) if not isinstance(checkpoint, dict) else checkpoint
        self.model, self.config, self.convention = model_from_checkpoint(ckpt)
        self.name = ckpt["model"]
        self.standardize = Standardizer(ckpt["stats"])
        self.smoothing = smoothing
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next frame is treated as the first of a segment."""
        self._prev_img = self._prev_gray = None
        self._history: deque = deque(maxlen=self.config.stack)
        self._smoothed = None
        self._state = None

    @torch.inference_mode()
    def step(self, bgr: np.ndarray) -> float:
        """One raw BGR frame -> steering in the checkpoint's convention (radians)."""
        img, gray = preprocess(bgr, self.config)
        prev_img = img if self._prev_img is None else self._prev_img
        prev_gray = gray if self._prev_gray is None else self._prev_gray
        while len(self._history) < self.config.stack - 1:  # a segment's first frame stands in for its past
            self._history.append(img)
        self._history.append(img)
        arrays = {"image": np.concatenate(self._history, axis=-1)}
        if "diff" in self.config.modalities:
            arrays["diff"] = frame_difference(prev_img, img)
        if "flow" in self.config.modalities:
            arrays["flow"] = optical_flow(prev_gray, gray, self.config.flow).astype(np.float16)
        self._prev_img, self._prev_gray = img, gray
        x = self.standardize(stack_modalities(arrays, self.config)[None])
        if getattr(self.model, "recurrent", False):
            y_seq, self._state = self.model(x[None], self._state)
            y = float(y_seq[0, 0])
        else:
            y = float(self.model(x)[0])
        if self.smoothing is not None:
            self._smoothed = y if self._smoothed is None else self.smoothing * y + (1 - self.smoothing) * self._smoothed
            y = self._smoothed
        return y
