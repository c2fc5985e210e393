"""Every model is a torch.nn.Module class registered by name.

A model is built from `in_channels` (set from the preprocessing config), `height`, `width` and its own
options. It maps a batch (B, C, H, W) of standardised inputs to steering (B,) in the recording's units.
Models whose output is not learned by gradient descent set `trainable = False` and implement `fit(y)`.
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


def create_model(name: str, **cfg) -> nn.Module:
    if name not in _REGISTRY:
        raise SteerlabError(f"unknown model {name!r}; available: {', '.join(list_models())}")
    try:
        return _REGISTRY[name](**cfg)
    except TypeError as e:
        raise SteerlabError(f"bad options for model {name!r}: {e}") from None
