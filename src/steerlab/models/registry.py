"""Every model is a torch.nn.Module class registered by name.

A model is built from `in_channels` (set from the preprocessing config), `height`, `width` and its own
options, and maps standardised inputs to a dict of named outputs:

- `forward(x)` with x (B, C, H, W) returns {"steering": (B,)} in the recording's units; multi-task models
  add "speed" (B,), the next frame's speed in m/s, or "command" (B, 3), logits of the speed command
  (decelerate, maintain, accelerate).
- A model with `speed_history = K > 0` is called `forward(x, speeds)` with the K most recent speeds (B, K),
  oldest first, in m/s.
- A recurrent model (`recurrent = True`) takes (B, T, C, H, W) and a state, `forward(x, state=None)`, and
  returns (outputs with a time axis (B, T, ...), state).
- `loss(out, targets)` is the model's training objective (targets: "steering", and "speed"/"command" where the
  recording has speed); without one, training minimises the MSE of the steering.
- `targets` names the labels a model trains on beyond the steering ("speed", "command"); such models need a
  recording with speed.
- `inputs` names the preprocessing options a model needs (modalities, colour, size, stacked frames).
- Models whose output is not learned by gradient descent set `trainable = False` and implement `fit(y)`.
"""

from __future__ import annotations

from typing import Callable

import torch.nn as nn

from steerlab.errors import SteerlabError

_REGISTRY: dict[str, Callable[..., nn.Module]] = {}


def register(name: str):
    def deco(cls):
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


def create_model(name: str, **cfg) -> nn.Module:
    cls = model_class(name)
    try:
        return cls(**cfg)
    except TypeError as e:
        raise SteerlabError(f"bad options for model {name!r}: {e}") from None
