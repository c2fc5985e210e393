"""What the suites of every world share (`road.suite`, `track.suite`): the pilots to race (`Entrant`: a checkpoint,
a donkeycar part, any pilot) and their labels, the drives planned and reused from their folders, the grouping of a
summary and its CSV.

A suite drives every entrant on every road or track of a fixed, versioned set. Each drive is kept in its folder
(`drive.json` and `trajectory.csv`) with a cache key: the pilot's identity (the checkpoint's sha256; a part's, the
sha256 of its model file) and every option that changes the result. A later run reuses a kept drive only when its
key is exactly the planned one; a drive of another pilot or other options (or one kept without a key) is driven
again, so an interrupted suite continues where it stopped and a changed pilot is never scored by its old drives.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
from collections.abc import Callable, Iterator
from dataclasses import dataclass, fields
from functools import partial
from pathlib import Path

from steerlab import files
from steerlab.errors import DataError, SteerlabError
from steerlab.sim.core.parallel import run_parallel


RESERVED_SEEDS = range(9000, 10000)  # the suites' roads and tracks: never recorded, never rolled out on


def check_seed(seed: int, world: str) -> None:
    """A seed that recordings and rollouts may use: not one of the suites' (`world`: "road" or "track")."""
    if seed in RESERVED_SEEDS:
        raise SteerlabError(f"{world} seeds {RESERVED_SEEDS.start}-{RESERVED_SEEDS.stop - 1} are reserved for the "
                            f"{world} suites and never recorded; choose another seed")


def check_world_of(out: str | Path, world: str, other: str, column: str) -> None:
    """A suite's folder holds one world's suite: a `suite.csv` with the `column` of the `other` world's (the road
    world's `road_type`, the track world's `style`) is refused in one line, not written over (the outputs' check
    takes a suite's folder as any suite's); one torn by a killed run is this world's to write again."""
    table = Path(out) / "suite.csv"
    lines = table.read_text(errors="replace").splitlines() if table.is_file() else []
    if lines and column in lines[0].split(","):
        raise DataError(out, f"the output folder holds a {other}-world suite ({table} has its {column} column); "
                             f"a {world}-world suite goes into a new folder or one of its own")


@dataclass(frozen=True)
class Entrant:
    """A pilot a suite races: `label` (its folder below the suite's, its rows' label), `source` (the file it drives
    with: suite.csv's checkpoint column, and an input the outputs are checked against), `identity` (what a kept
    drive's cache key holds of it: `checkpoint_sha256`, or for a part `model_sha256`) and `make(options)`, which
    makes the pilot (`contracts.Pilot`) from the suite's options in the worker process that drives it (a
    module-level function or a partial of one: worker processes receive it pickled). A pilot with `close()` is
    closed after each drive."""

    label: str
    source: str
    identity: dict
    make: Callable


def entrants(pilots, pilot_of: Callable) -> list[Entrant]:
    """A suite's entrants: each of `pilots` an `Entrant`, or a checkpoint (a path: a file, labelled by
    `labels_for`, its identity its sha256), which `pilot_of(checkpoint, options)` makes the pilot of. At least one,
    each label once."""
    pilots = list(pilots)
    paths = [p for p in pilots if not isinstance(p, Entrant)]
    labels = iter(checkpoints_to_drive(paths)[1] if paths else [])
    out = []
    for p in pilots:
        if not isinstance(p, Entrant):
            p = Entrant(next(labels), str(Path(p)), {"checkpoint_sha256": file_sha256(Path(p))},
                        partial(pilot_of, str(Path(p))))
        out.append(p)
    if not out:
        raise SteerlabError("no checkpoint to drive: name at least one")
    labels = [e.label for e in out]
    if twice := sorted({n for n in labels if labels.count(n) > 1}):
        raise SteerlabError(f"two pilots of the suite are labelled {twice[0]!r}: give each a label of its own")
    return out


def close(pilot) -> None:
    """The end of a pilot's drive: a pilot that holds a process or a file (a part behind a pipe) lets it go."""
    if callable(getattr(pilot, "close", None)):
        pilot.close()


def checkpoints_to_drive(checkpoints) -> tuple[list[Path], list[str]]:
    """The checkpoints a suite or replay drives (at least one, each a file) and their labels (`labels_for`)."""
    checkpoints = [Path(c) for c in checkpoints]
    if not checkpoints:
        raise SteerlabError("no checkpoint to drive: name at least one")
    for c in checkpoints:
        if not c.is_file():
            raise SteerlabError(f"{c}: checkpoint not found: check the path")
    return checkpoints, labels_for(checkpoints)


def labels_for(checkpoints: list[Path]) -> list[str]:
    """Short unique names (each a folder below the output folder): the run folder of `run/best.pt`, with as
    many parent folders as it takes (and the file name where one run's best.pt and last.pt are compared). The
    same checkpoint named twice is an error."""
    seen = {}
    for p in checkpoints:
        if p.resolve() in seen:
            raise SteerlabError(f"{p} is named twice (as {seen[p.resolve()]} too): name each checkpoint once")
        seen[p.resolve()] = p
    for short in (True, False):
        for depth in range(1, 8):
            names = ["/".join((p.parent if short and p.name in ("best.pt", "last.pt") else p.with_suffix(""))
                              .parts[-depth:]) for p in checkpoints]
            names = [n.lstrip("/") for n in names]
            if len(set(names)) == len(names) and all(names):
                return names
    return [f"{k}-{p.stem}" for k, p in enumerate(checkpoints)]


def file_sha256(path: Path) -> str:
    """The sha256 of a checkpoint's bytes (an exported .onnx carries its metadata inside): a drive's cache key."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def when_set(options, *names: str) -> dict:
    """The options `names` that are set (not at their defaults): what a cache key adds of options that came after
    drives were first kept, so that those drives stay reusable."""
    default = {f.name: f.default for f in fields(options)}
    return {n: getattr(options, n) for n in names if getattr(options, n) != default[n]}


def as_stored(key: dict) -> dict:
    """A cache key as drive.json gives it back (tuples become lists), so that the two compare equal."""
    return json.loads(json.dumps(key))


@dataclass(frozen=True)
class Planned:
    """One drive of a suite: `where` it goes in the results, its `folder`, its cache `key` and the job's
    arguments (`args`, for the suite's job function)."""

    where: tuple
    folder: Path
    key: dict
    args: tuple


def run_drives(job: Callable, result: type, planned: list[Planned], workers: int, ticks_per_job: int,
               progress: bool, desc: str) -> dict:
    """Every planned drive's result (a `result` dataclass) by `where`: read from its folder's drive.json when that
    holds exactly the planned key and every field of `result` (an unreadable or partial one is driven anew), else
    `job(*args)`, the jobs in `workers` worker processes."""
    results, todo = {}, []
    for p in planned:
        stored = _stored(p.folder / "drive.json", p.key)
        if stored is not None and {f.name for f in dataclasses.fields(result)} <= set(stored):
            results[p.where] = from_json(result, stored)
        else:
            todo.append(p)
    driven = run_parallel(job, [p.args for p in todo], workers, ticks_per_job, progress, desc)
    results.update({p.where: r for p, r in zip(todo, driven)})
    return results


def _stored(done: Path, key: dict) -> dict | None:
    try:
        stored = json.loads(done.read_text())
    except (OSError, ValueError):
        return None
    return stored if isinstance(stored, dict) and stored.get("cache_key") == key else None


def from_json(cls: type, data: dict):
    """A result dataclass from the dict of its drive.json (which holds more: the cache key)."""
    return cls(**{f.name: data[f.name] for f in dataclasses.fields(cls)})


def write_json(path: Path, result, meta: dict | None = None) -> None:
    """A drive's result (a dataclass) and `meta` (its cache key) as drive.json."""
    files.write_json(path, {**dataclasses.asdict(result), **(meta or {})})


def grouped(drives: list, key: str) -> Iterator[tuple[str, str, list]]:
    """A suite's summary rows: per label, its drives of each value of the attribute `key` (in the order they
    come), then all of its drives (value "all"), as (label, value, drives)."""
    for label in dict.fromkeys(d.label for d in drives):
        mine = [d for d in drives if d.label == label]
        for value in [*dict.fromkeys(getattr(d, key) for d in mine), "all"]:
            yield label, value, [d for d in mine if value in ("all", getattr(d, key))]


def write_csv(path: Path, rows: list, fields: list[str] | None = None) -> None:
    """A table of dataclass rows (all their fields, or `fields`), an empty cell for None (a value that does not
    exist)."""
    fields = fields or [f.name for f in dataclasses.fields(rows[0])]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fields)
        w.writeheader()
        w.writerows([{k: "" if getattr(r, k) is None else getattr(r, k) for k in fields} for r in rows])
