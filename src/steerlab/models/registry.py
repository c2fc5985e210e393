"""Every model is a `SteeringModel` registered by name; the class attributes declare what a model is.

A model is built from `in_channels` (set from the preprocessing config) and its own options; `create_model`
runs it once on an input of the configured height and width, which sizes its first fully connected layer
(`nn.LazyLinear`) and refuses an input too small for its layers. It maps standardised inputs to a dict of named
outputs:

- `forward(x)` with x (B, C, H, W) returns {"steering": (B,)} in the recording's units; multi-task models
  add "speed" (B,), the next frame's speed in m/s, or "command" (B, 3), logits of the speed command
  (decelerate, maintain, accelerate). A model built with `throttle=True` (training sets it when
  `train.throttle_weight` > 0 and the recording's throttle varies, a donkeycar tub's `user/throttle`) adds
  "throttle" (B,) from a second value of its last layer: the models with a `throttle` option can. A model built
  with `lane=True` (training sets it when `train.lane_weight` > 0) adds "lane" (B, 3), the lane the car is in
  over `data.labels.LANE`'s scales, from a linear head on its last hidden features (`heads`).
- `loss(out, targets)` is the model's training objective (targets: "steering", and "speed"/"command" where the
  recording has speed); without one, training minimises the MSE of the steering.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Callable, ClassVar, get_type_hints

import torch
import torch.nn as nn

from steerlab.data.preprocess import PreprocessConfig, PreprocessOptions
from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_0, Range, value_of


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
    learns_throttle: bool = False
    """True when built with `throttle=True`: the last layer has a second value, the throttle."""
    learns_lane: bool = False
    """True when built with `lane=True`: a linear head `lane` on the last hidden features gives the lane (3)."""

    def named(self, y: torch.Tensor) -> dict[str, torch.Tensor]:
        """The last layer's values (..., 1 or 2) as the model's outputs: the steering, and the throttle."""
        out = {"steering": y[..., 0]}
        if self.learns_throttle:
            out["throttle"] = y[..., 1]
        return out

    def heads(self, head: nn.Sequential, features: torch.Tensor) -> dict[str, torch.Tensor]:
        """The outputs of `head` (hidden layers, then the last linear layer) on `features` (`named`), and the lane
        head's on the last hidden features."""
        hidden = head[:-1](features)
        out = self.named(head[-1](hidden))
        if self.learns_lane:
            out["lane"] = self.lane(hidden)
        return out


def predicted(model) -> tuple[str, ...]:
    """What a model (or a Pilot's runtime model) predicts besides the steering: its `targets`, the throttle and
    the lane."""
    return (tuple(model.targets) + (("throttle",) if model.learns_throttle else ())
            + (("lane",) if getattr(model, "learns_lane", False) else ()))


def learns_throttle(name: str) -> bool:
    """Whether the model `name` can learn the throttle (its constructor has a `throttle` option)."""
    return "throttle" in model_option_types(name)


def learns_lane(name: str) -> bool:
    """Whether the model `name` has a lane head to learn the lane with (its constructor has a `lane` option)."""
    return "lane" in model_option_types(name)


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


def create_model(name: str, in_channels: int | None = None, height: int | None = None, width: int | None = None,
                 **options) -> SteeringModel:
    """The model `name` for inputs of `in_channels` x `height` x `width` (default: the model's own, else 66x200),
    its lazy layers sized by one run on such an input (a checkpoint's `model_cfg` holds exactly these
    arguments)."""
    cls = model_class(name)
    if in_channels is None:
        in_channels = inspect.signature(cls.__init__).parameters["in_channels"].default
    height, width = height or cls.inputs.get("height", 66), width or cls.inputs.get("width", 200)
    try:
        model = cls(in_channels=in_channels, **options)
    except TypeError as e:
        raise SteerlabError(f"bad options for model {name!r}: {e}; it takes "
                            f"{', '.join(model_option_types(name)) or 'none'}") from None
    x = torch.zeros((1, 1, in_channels, height, width) if model.recurrent else (1, in_channels, height, width))
    extra = {"speeds": torch.zeros(1, model.speed_history)} if model.speed_history else {}
    try:
        with torch.no_grad():
            model.eval()(x, **extra)
    except RuntimeError as e:
        if "size" not in str(e).lower():
            raise
        raise SteerlabError(f"model {name!r} cannot take a {width}x{height} input (preprocess.width x "
                            f"preprocess.height): it is too small for the model's layers") from None
    return model.train()


# The range of a model option, by its name, for every model that has it.
OPTION_CHECKS = {"dropout": Range(0, 1, hi_open=True), "hidden": Range(1, 4096), "seq_len": Range(1, 1000),
                 "speed_history": Range(1, 1000), "weight_gain": AT_LEAST_0, "command_weight": AT_LEAST_0,
                 "speed_weight": AT_LEAST_0}


def model_option_types(name: str) -> dict[str, type]:
    """The options a model's constructor takes (following `**kw` up to the base classes) and their types."""
    types: dict[str, type] = {}
    for cls in model_class(name).__mro__:
        init = cls.__init__
        params = inspect.signature(init).parameters
        hints = get_type_hints(init)
        types.update({n: hints.get(n, object) for n, p in params.items()
                      if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL) and n not in ("self", "in_channels")
                      and n not in types})
        if not any(p.kind == p.VAR_KEYWORD for p in params.values()):
            break
    return types


@dataclass(frozen=True)
class ModelSpec:
    """The model: section of a config: a registered model's name and its own options, typed and range-checked
    (`OPTION_CHECKS`); `{name: pilotnet, dropout: 0.3}` in YAML."""

    name: str = "pilotnet"
    options: Mapping = field(default_factory=lambda: {"dropout": 0.5})

    @classmethod
    def parse_option(cls, value, where: str) -> "ModelSpec":
        if not isinstance(value, Mapping) or not isinstance(value.get("name"), str):
            raise SteerlabError(f"{where} needs a model name, e.g. {{name: pilotnet}}; got {value!r}")
        name = value["name"]
        types = model_option_types(name)
        options = {k: v for k, v in value.items() if k != "name"}
        if "throttle" in options:
            raise SteerlabError(f"{where}.throttle is not set by hand: training adds the throttle output when "
                                "train.throttle_weight > 0 and the recording's throttle varies: remove it")
        if "lane" in options:
            raise SteerlabError(f"{where}.lane is not set by hand: training adds the lane head when "
                                "train.lane_weight > 0: remove it")
        unknown = sorted(set(options) - set(types))
        if unknown:
            raise SteerlabError(f"unknown {where} options {unknown} for model {name!r}; it takes {sorted(types)}")
        return cls(name, {k: value_of(types[k], v, f"{where}.{k}", OPTION_CHECKS.get(k)) for k, v in options.items()})

    def as_dict(self) -> dict:
        return {"name": self.name, **self.options}

    @property
    def cls(self):
        return model_class(self.name)

    def preprocess(self, options: PreprocessOptions) -> PreprocessOptions:
        """The config's preprocessing with what this model needs (its `inputs`) filled in."""
        return options.merged(self.cls.inputs, f"model {self.name!r}")

    def arguments(self, pre: PreprocessConfig) -> dict:
        """The model's options completed with the input its preprocessing gives (channels, height, width): what
        `create_model` takes and a checkpoint keeps as `model_cfg`."""
        return {**self.options, "in_channels": sum(pre.channels().values()), "height": pre.height,
                "width": pre.width}

    def build(self, pre: PreprocessConfig) -> SteeringModel:
        return create_model(self.name, **self.arguments(pre))

    def check(self, pre: PreprocessConfig) -> None:
        """Refuse options the model does not take or an input too small for its layers (`create_model`'s
        errors), on torch's meta device (shapes without memory: a 4096-unit LSTM is checked in milliseconds); a
        configuration checked once in a process is not built again."""
        arguments = self.arguments(pre)
        key = repr((self.name, sorted(arguments.items())))
        if key not in _CHECKED:
            with torch.device("meta"):
                create_model(self.name, **arguments)
            _CHECKED.add(key)


_CHECKED: set[str] = set()  # ModelSpec.check's configurations that passed
