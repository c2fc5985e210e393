"""Every model is a `SteeringModel` registered by name; the class attributes declare what a model is.

A model is built from `in_channels` (set from the preprocessing config), `height`, `width` and its own
options, and maps standardised inputs to a dict of named outputs:

- `forward(x)` with x (B, C, H, W) returns {"steering": (B,)} in the recording's units; multi-task models
  add "speed" (B,), the next frame's speed in m/s, or "command" (B, 3), logits of the speed command
  (decelerate, maintain, accelerate).
- `loss(out, targets)` is the model's training objective (targets: "steering", and "speed"/"command" where the
  recording has speed); without one, training minimises the MSE of the steering.
"""

from __future__ import annotations

from typing import Callable, ClassVar

import torch.nn as nn

from steerlab.errors import SteerlabError


class SteeringModel(nn.Module):
    """The capabilities every model declares (class attributes; the defaults describe a plain image CNN)."""

    trainable: ClassVar[bool] = True
    """False for models not learned by gradient descent; they implement `fit(steering)`."""
    recurrent: ClassVar[bool] = False
    """True: `forward(x, state=None)` takes (B, T, C, H, W) and returns (outputs with a time axis, state)."""
    speed_history: ClassVar[int] = 0
    """K > 0: `forward(x, speeds)` also takes the K most recent speeds (B, K) in m/s, oldest first."""
    targets: ClassVar[tuple[str, ...]] = ()
    """Labels trained beyond the steering ("speed", "command"); such models need a recording with speed."""
    inputs: ClassVar[dict] = {}
    """Preprocessing options the model needs (modalities, colour, size, stacked frames)."""


_REGISTRY: dict[str, Callable[..., SteeringModel]] = {}


def register(name: str):
    def deco(cls):
        if not issubclass(cls, SteeringModel):
            raise TypeError(f"model {name!r} must subclass SteeringModel")
        _REGISTRY[name] = cls
        cls.registry_name = name
        return cls
    return deco


def list_models() -> list[str]:
    return sorted(_REGISTRY)


def model_class(name: str):
    if name not in _REGISTRY:
        raise SteerlabError(f"unknown model {name!r}; available: {', '.join(list_models())}")
    return _REGISTRY[name]


def create_model(name: str, **cfg) -> SteeringModel:
    cls = model_class(name)
    try:
        return cls(**cfg)
    except TypeError as e:
        raise SteerlabError(f"bad options for model {name!r}: {e}") from None
