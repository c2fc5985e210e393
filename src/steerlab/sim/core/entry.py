"""What a world provides to the commands, DAgger, experiments and tuning: its registry entry (`WorldEntry`), which
each world's folder builds by keyword in its `entry.py` (`road/entry.py`, `track/entry.py`) and `sim/worlds.py`
registers. Nothing above `sim/` chooses a world by its name: it reads the entry.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True, kw_only=True)
class Column:
    """A closed-loop column of an experiment's table.md: its `header` and the `keys` of the run's metrics shown in
    it (several: joined by " / "), with `digits`, and the spread over the seeds (`std`) for a single key."""

    header: str
    keys: tuple[str, ...]
    digits: int
    std: bool = False


@dataclass(frozen=True, kw_only=True)
class Recorder:
    """Recording a world's expert: `options` (the record options' dataclass) and `run(out, options, progress=True,
    *, suite_ok=False) -> Path` (the recording written)."""

    options: type
    run: Callable[..., Path]


@dataclass(frozen=True, kw_only=True)
class Driver:
    """A model's drive: `options`, `run(checkpoint, out, options, drive_with, video) -> a result dataclass`
    (`pilot.DriveWith`: how its Pilot is made) and the `files` it writes (for the command's last line)."""

    options: type
    run: Callable[..., Any]
    files: str


@dataclass(frozen=True, kw_only=True)
class SuiteEntry:
    """A world's suite: `options` (with `drives()`, the (kind, seed) of its places, and `place_minutes`), its
    `versions` (name -> its places), `run(pilots, out, options, progress, plots) -> summary rows` (`pilots`:
    checkpoints, or `core.suite.Entrant`s: any pilot) and the `figures` it draws."""

    options: type
    versions: dict
    run: Callable[..., list]
    figures: str


@dataclass(frozen=True, kw_only=True)
class ReplayEntry:
    """Replay of a world's recordings: `options` (their `setup(rec)` makes the replay)."""

    options: type


@dataclass(frozen=True, kw_only=True)
class DaggerEntry:
    """DAgger in a world: `options` (the options of a `dagger:` section that only this world takes, with
    `kinds()`: the places of the rollouts), `rollout(checkpoint, out, seed, minutes, kind, beta, camera, suite)`
    (run in a worker process), `camera(rec)`: what the rollouts render through for a training recording,
    `done`: the file a finished rollout has; `round_columns(summary)`: a round's columns of dagger.csv
    (`columns`, in order) and `series`: their lines in dagger.png, (column, matplotlib style, label)."""

    options: type
    rollout: Callable[..., Any]
    camera: Callable[[Any], Any]
    done: str
    round_columns: Callable[[list], dict]
    columns: tuple[str, ...]
    series: tuple[tuple[str, str, str], ...]


@dataclass(frozen=True, kw_only=True)
class ReportEntry:
    """Experiments and tuning: `metrics(checkpoint, options, progress, plots) -> dict` (a checkpoint's metrics on
    the suite, `autonomy` among them: tune's objective), `table`: their columns in table.md (`worst`: the per-kind
    autonomy shown at the worst seed), and `plot_drives(out, suites, options)`: every entry's seed-0 drives
    (`suites`: label -> its run's suite folder) drawn per place."""

    metrics: Callable[..., dict]
    table: tuple[Column, ...]
    worst: Column
    plot_drives: Callable[..., None]


@dataclass(frozen=True, kw_only=True)
class WorldEntry:
    """What a world provides, grouped by what uses it (every field by keyword): `name` and `help` (`--world NAME`
    and what it is), `cameras` (the camera geometries its renderer makes: a recording of one of them is replayed
    in this world unless told otherwise), and `record`, `drive`, `suite`, `replay`, `dagger` and `report` (the
    groups above)."""

    name: str
    help: str
    cameras: tuple[str, ...]
    record: Recorder
    drive: Driver
    suite: SuiteEntry
    replay: ReplayEntry
    dagger: DaggerEntry
    report: ReportEntry
