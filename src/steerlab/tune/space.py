"""The search space of `steerlab tune`: a config's `tune:` section, config keys (`train.lr`, `model.dropout`,
`preprocess.color`, ...) mapped to ranges,

    tune:
      train.lr: {low: 1.0e-6, high: 1.0e-3, log: true}     # float
      train.batch_size: {low: 4, high: 10, type: int}
      preprocess.color: [gray, yuv]                        # categorical

checked against the option schema of the training config before anything is created: a key that is not an
option, a range whose ends (or a choice) the option does not take, an empty or inverted range, or a log range
through zero is a one-line error."""

from __future__ import annotations

import math
from dataclasses import replace

from steerlab.data.preprocess import PreprocessOptions
from steerlab.errors import SteerlabError
from steerlab.models.registry import OPTION_CHECKS, model_option_types
from steerlab.options import as_dict, option_info, optional, value_of, words
from steerlab.train.config import TrainConfig, TrainOptions, parse_config


def _option(key: str, cfg: TrainConfig):
    """(type, check, expected) of the option `key` (section.option) of this config, or None."""
    section, _, name = key.partition(".")
    if section == "model":
        types = model_option_types(cfg.model.name)
        if name in types:
            return types[name], OPTION_CHECKS.get(name), None
        return None
    owner = {"train": TrainOptions, "preprocess": PreprocessOptions}.get(section)
    info = None if owner is None else option_info(owner, name)
    return None if info is None else (info.kind, info.check, info.expected)


def _takes(key: str, kind, check, expected, value) -> None:
    """`value` is one the option takes, or a one-line error that says so."""
    try:
        value_of(kind, value, key, check, expected)
    except SteerlabError:
        raise SteerlabError(f"tune: {key} takes {expected or words(kind, check)}, and the range or choices give "
                            f"{value!r}") from None


def search_space(spec, cfg: TrainConfig) -> dict:
    """The `tune:` section as Optuna distributions."""
    import optuna

    if not isinstance(spec, dict) or not spec:
        raise SteerlabError("the config has no tune: section (config key -> range) to search: add one, "
                            "e.g. tune: {train.lr: {low: 1.0e-5, high: 1.0e-3, log: true}}")
    space = {}
    for key, rng in spec.items():
        option = _option(key, cfg)
        if option is None:
            raise SteerlabError(f"tune: {key!r} is not a config key of this config (use section.option, e.g. "
                                f"train.lr, model.dropout, preprocess.color)")
        kind, check, expected = option
        if isinstance(rng, list):
            if len(rng) < 2:
                raise SteerlabError(f"tune: {key} needs at least two choices, got {rng}")
            for choice in rng:
                _takes(key, kind, check, expected, choice)
            space[key] = optuna.distributions.CategoricalDistribution(rng)
            continue
        if not isinstance(rng, dict) or "low" not in rng or "high" not in rng or set(rng) - {"low", "high", "log",
                                                                                              "type"}:
            raise SteerlabError(f"tune: {key} needs {{low: .., high: ..[, log: true][, type: int]}} or a list of "
                                f"choices, got {rng!r}")
        inner, _ = optional(kind)
        number = rng.get("type", "int" if inner is int else "float")
        if number not in ("int", "float") or (number == "int") != (inner is int):
            raise SteerlabError(f"tune: {key} is {words(kind)}: its range's type must be "
                                f"{'int' if inner is int else 'float'}, got {number!r}")
        low, high, log = rng["low"], rng["high"], rng.get("log", False)
        try:
            low, high = (value_of(int if number == "int" else float, v, key) for v in (low, high))
        except SteerlabError:
            raise SteerlabError(f"tune: {key} low/high must be numbers, got {rng['low']!r}/{rng['high']!r}") from None
        if not isinstance(log, bool):
            raise SteerlabError(f"tune: {key} log must be true or false, got {log!r}")
        if not low < high:
            raise SteerlabError(f"tune: {key} range {low}..{high} is empty or inverted (low must be below high)")
        if log and low <= 0:
            raise SteerlabError(f"tune: {key} has a log range, so low must be positive, got {low}")
        for end in (low, high):
            _takes(key, kind, check, expected, end)
        dist = optuna.distributions.IntDistribution if number == "int" else optuna.distributions.FloatDistribution
        space[key] = dist(low, high, log=log)
    with_params(cfg, {k: _sample(d) for k, d in space.items()})  # a combination of the options that cannot be
    return space                                                 # built (the input too small, say) fails here


def _sample(dist):
    """One value of a distribution (its low end, or first choice)."""
    return dist.choices[0] if hasattr(dist, "choices") else dist.low if not (
        isinstance(dist.low, float) and math.isinf(dist.low)) else dist.high


def with_params(cfg: TrainConfig, params: dict) -> TrainConfig:
    """The config with a trial's parameters (config key -> value) set, parsed again so that every value is
    checked and combinations too (a recurrent model's smoothness, an input that fits the model)."""
    raw = as_dict(replace(cfg, tune=None))
    for key, value in params.items():
        section, _, option = key.partition(".")
        raw[section] = {**(raw.get(section) or {}), option: value}
    return parse_config(raw)
