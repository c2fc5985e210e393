"""Where a round runs, and the paths its tables name: OUT_DIR (`ROOT`, the runner's argument, set by `place`), its
fixtures `FIX` (OUT_DIR/fx), the folder its cases run in `WORK` (OUT_DIR/work), the real recordings `SHARED`
(../shared/data beside the repository) and the repository of the build tried `REPO` (the one whose src/ is on
PYTHONPATH: its scripts are those of studies/ and benchmarks/ beside it).

A table writes these as `{root}`, `{fx}`, `{work}`, `{shared}` and `{repo}` inside its texts (`{fx}/a.pt`), and as
`Path("{fx}/a.pt")` where a call is given a `pathlib.Path`; `fill` puts the folders of this run in their place."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import steerlab

ROOT = FIX = WORK = None  # set by `place`
SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"
REPO = Path(steerlab.__file__).resolve().parents[2]


def place(out_dir) -> None:
    """The round's folders under OUT_DIR, the round's argument."""
    global ROOT, FIX, WORK
    ROOT = Path(out_dir).resolve()
    FIX, WORK = ROOT / "fx", ROOT / "work"


def folders() -> dict[str, str]:
    return {"{root}": str(ROOT), "{fx}": str(FIX), "{work}": str(WORK), "{shared}": str(SHARED),
            "{repo}": str(REPO)}


def fill(value):
    """`value` with the folders of this run in place of `{root}`, `{fx}`, `{work}`, `{shared}` and `{repo}`, in a
    text, a Path, the items of a list, tuple or dict, or the fields of a dataclass (other values as they are)."""
    if isinstance(value, str):
        for name, folder in folders().items():
            value = value.replace(name, folder)
        return value
    if isinstance(value, Path):
        return Path(fill(str(value)))
    if isinstance(value, list):
        return [fill(v) for v in value]
    if isinstance(value, tuple):
        return tuple(fill(v) for v in value)
    if isinstance(value, dict):
        return {fill(k): fill(v) for k, v in value.items()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):  # a Source of the Python API, say
        return dataclasses.replace(value, **{f.name: fill(getattr(value, f.name)) for f in dataclasses.fields(value)
                                             if f.init})
    return value


def name_of(path: str) -> str:
    """The last part of a table's path (`{fx}/sim/driving_log.csv` -> `driving_log.csv`), as Path.name."""
    return Path(path).name
