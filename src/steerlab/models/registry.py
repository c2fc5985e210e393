"""Every model is a torch.nn.Module class registered by name.

A model is built from `in_channels` (set from the preprocessing config), `height`, `width` and its own
options. It maps a batch (B, C, H, W) of standardised inputs to steering (B,) in the recording's units.
Models whose output is not learned by gradient descent set `trainable = False` and implement `fit(y)`.
`inputs` names the preprocessing options a model needs (modalities, colour, stacked frames); a model with its
own training objective defines `loss(x, y)` (otherwise training minimises the MSE).
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
