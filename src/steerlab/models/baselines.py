"""Baselines every model must beat: always straight, and always the training split's mean steering."""

from __future__ import annotations

import numpy as np
import torch

from steerlab.models.registry import SteeringModel, register


class _Constant(SteeringModel):
    trainable = False

    def __init__(self, in_channels: int = 1):
        super().__init__()
        self.register_buffer("value", torch.zeros(()))

    def fit(self, steering: np.ndarray) -> None:
        pass

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return {"steering": self.value.expand(x.shape[0]).clone()}


@register("zero")
class Zero(_Constant):
    """Predicts 0 rad (straight ahead) for every frame."""


@register("train-mean")
class TrainMean(_Constant):
    """Predicts the mean steering of the training split for every frame."""

    def fit(self, steering: np.ndarray) -> None:
        self.value.fill_(float(np.mean(steering)))
