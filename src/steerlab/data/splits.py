"""Contiguous time-block splits. Never frame-by-frame at random: neighbouring frames are near-duplicates."""

from __future__ import annotations

import numpy as np

from steerlab.data.rows import parse_range
from steerlab.errors import SteerlabError


def block(text: str, n: int, name: str) -> np.ndarray:
    """Frame indices of one "a:b" range, checked against the dataset length n."""
    start, stop = parse_range(text)
    start = 0 if start is None else start
    stop = n if stop is None else stop
    if not (0 <= start < stop <= n):
        raise SteerlabError(f"{name} range {text!r} is empty or outside the dataset's 0:{n}")
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
        raise SteerlabError(f"{k} validation segments of {length} frames overlap in {n} frames")
    train_idx = np.setdiff1d(np.arange(n), val_idx)
    return train_idx, val_idx


def by_sessions(part: dict, sessions: np.ndarray | None, name: str) -> np.ndarray:
    """Frame indices of the sessions listed in {"sessions": [...]} (donkeycar tubs record one per drive)."""
    wanted = part.get("sessions")
    if sessions is None:
        raise SteerlabError(f"the {name} split names sessions, but this recording has no sessions")
    if not isinstance(wanted, list) or not wanted:
        raise SteerlabError(f"the {name} split needs a non-empty list of sessions, e.g. {{sessions: [{sessions[0]}]}}")
    unknown = sorted(set(map(str, wanted)) - set(sessions))
    if unknown:
        raise SteerlabError(f"{name} sessions {unknown} are not in the recording; it has "
                            f"{', '.join(dict.fromkeys(sessions))}")
    return np.flatnonzero(np.isin(sessions, [str(w) for w in wanted]))


def make_split(spec: dict, n: int, sessions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """From a config: {"train": "a:b", "val": "c:d"}, {"train": {"sessions": [...]}, "val": {"sessions": [...]}}
    or {"protocol": "paper", "k": 3, "length": 1000}."""
    spec = dict(spec or {})
    if spec.get("protocol") == "paper":
        return paper_protocol(n, int(spec.get("k", 3)), int(spec.get("length", 1000)))
    if "train" not in spec or "val" not in spec:
        raise SteerlabError("split needs 'train' and 'val' ranges (e.g. 0:1800 and 1800:2400), sessions "
                            "({sessions: [...]}) or protocol: paper")
    train, val = (by_sessions(spec[k], sessions, k) if isinstance(spec[k], dict) else block(spec[k], n, k)
                  for k in ("train", "val"))
    if np.intersect1d(train, val).size:
        raise SteerlabError(f"train split {spec['train']} and val split {spec['val']} overlap")
    return train, val
