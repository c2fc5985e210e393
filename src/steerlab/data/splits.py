"""Splits of a recording into training and validation frames: contiguous time blocks, sessions, or paper 000's
protocol. A random choice of frames (`{random: 0.2}`, as donkeycar's trainer splits a tub) is there to compare with
it: neighbouring frames are near-duplicates, so its validation frames have twins in training and its error
says little about unseen driving; early stopping on it stops late."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from steerlab.data.rows import parse_range
from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_1, Range, value_of


def block(text: str, n: int, name: str) -> np.ndarray:
    """Frame indices of one "a:b" range, checked against the dataset length n."""
    start, stop = parse_range(text, f"split.{name}")
    start = 0 if start is None else start
    stop = n if stop is None else stop
    if not (0 <= start < stop <= n):
        raise SteerlabError(f"split.{name} range {text!r} is empty or outside the recording's {n} frames: give a "
                            f"range START:STOP within 0:{n}")
    return np.arange(start, stop)


def paper_protocol(n: int, k: int = 3, length: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    """Paper 000 V-C: k validation segments of `length` consecutive frames, spread evenly; the rest trains."""
    if k < 1 or length < 1 or k * length >= n:
        raise SteerlabError(f"cannot take {k} validation segments of {length} frames from {n} frames")
    val = []
    for i in range(k):
        start = int(round((i + 0.5) * n / k - length / 2))
        start = min(max(start, 0), n - length)
        val.append(np.arange(start, start + length))
    val_idx = np.unique(np.concatenate(val))
    if len(val_idx) != k * length:
        raise SteerlabError(f"{k} validation segments of {length} frames overlap in {n} frames: lower k or length")
    train_idx = np.setdiff1d(np.arange(n), val_idx)
    return train_idx, val_idx


def by_sessions(part: dict, sessions: np.ndarray | None, name: str) -> np.ndarray:
    """Frame indices of the sessions listed in {"sessions": [...]} (donkeycar tubs record one per drive)."""
    wanted = part.get("sessions")
    if sessions is None:
        raise SteerlabError(f"the {name} split names sessions, but this recording has no sessions: give "
                            "frame ranges instead")
    if not isinstance(wanted, list) or not wanted:
        raise SteerlabError(f"the {name} split needs a non-empty list of sessions, e.g. {{sessions: [{sessions[0]}]}}")
    unknown = sorted(set(map(str, wanted)) - set(sessions))
    if unknown:
        raise SteerlabError(f"{name} sessions {unknown} are not in the recording; it has "
                            f"{', '.join(dict.fromkeys(sessions))}: choose among them")
    return np.flatnonzero(np.isin(sessions, [str(w) for w in wanted]))


@dataclass(frozen=True)
class Split:
    """The split: section of a config: `{train: "a:b", val: "c:d"}`, `{train: {sessions: [...]}, val:
    {sessions: [...]}}`, `{random: 0.2[, seed: 0]}` (that fraction of the frames, drawn at random, validates) or
    `{protocol: paper, k: 3, length: 1000}` (the default)."""

    protocol: str | None = "paper"
    k: int = 3
    length: int = 1000
    train: str | dict | None = None
    val: str | dict | None = None
    random: float | None = None
    seed: int = 0

    @classmethod
    def parse_option(cls, value, where: str) -> Split:
        if not isinstance(value, Mapping):
            raise SteerlabError(f"{where} must be a mapping, e.g. {{train: '0:1800', val: '1800:2400'}}; got {value!r}")
        known = ["k", "length", "protocol", "random", "seed", "train", "val"]
        unknown = sorted(set(value) - set(known))
        if unknown:
            raise SteerlabError(f"unknown {where} options {unknown}; known: {known}")
        if "random" in value:
            if set(value) - {"random", "seed"}:
                raise SteerlabError(f"{where}: random takes only a seed beside it, got {sorted(value)}")
            fraction = value_of(float, value["random"], f"{where}.random", Range(0, 1, lo_open=True, hi_open=True))
            return cls(None, 3, 1000, None, None, fraction, value_of(int, value.get("seed", 0), f"{where}.seed",
                                                                     Range(0)))
        if "seed" in value:
            raise SteerlabError(f"{where}.seed is the seed of a random split ({where}.random): set "
                                f"{where}.random too, or remove the seed")
        if value.get("protocol") is not None:
            if value["protocol"] != "paper" or "train" in value or "val" in value:
                raise SteerlabError(f"{where}: protocol must be paper (without train and val ranges), got "
                                    f"{value['protocol']!r}")
            return cls("paper", value_of(int, value.get("k", 3), f"{where}.k", AT_LEAST_1),
                       value_of(int, value.get("length", 1000), f"{where}.length", AT_LEAST_1))
        if "train" not in value or "val" not in value:
            raise SteerlabError(f"{where} needs 'train' and 'val' ranges (e.g. 0:1800 and 1800:2400), sessions "
                                "({sessions: [...]}) or protocol: paper")
        for part in ("train", "val"):
            if not isinstance(value[part], (str, Mapping)):
                raise SteerlabError(f"{where}.{part} must be a frame range like \"0:1800\" (quote it in YAML files) "
                                    f"or {{sessions: [...]}}, got {value[part]!r}")
        return cls(None, 3, 1000, value["train"], value["val"])

    def as_dict(self) -> dict:
        if self.random is not None:
            return {"random": self.random, "seed": self.seed}
        if self.protocol:
            return {"protocol": self.protocol, "k": self.k, "length": self.length}
        return {"train": self.train, "val": self.val}


def make_split(spec: Split, n: int, sessions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The training and validation frames of a recording of `n` frames (and its `sessions`)."""
    if spec.protocol == "paper":
        return paper_protocol(n, spec.k, spec.length)
    if spec.random is not None:
        val = np.sort(np.random.default_rng(spec.seed).permutation(n)[:max(1, round(spec.random * n))])
        if len(val) == n:
            raise SteerlabError(f"a random split of {spec.random:g} leaves no training frame of {n}: "
                                "give a smaller fraction")
        return np.setdiff1d(np.arange(n), val), val
    train, val = (by_sessions(part, sessions, k) if isinstance(part, Mapping) else block(part, n, k)
                  for k, part in (("train", spec.train), ("val", spec.val)))
    if np.intersect1d(train, val).size:
        raise SteerlabError(f"train split {spec.train} and val split {spec.val} overlap: give ranges that do not")
    return train, val
