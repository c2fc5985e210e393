"""What a world provides to the commands, DAgger, experiments and tuning: its registry entry (`WorldEntry`), which
each world's folder builds by keyword in its `entry.py` (`road/entry.py`, `track/entry.py`) and `sim/worlds.py`
registers. Nothing above `sim/` chooses a world by its name: it reads the entry.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class Column:
    """A closed-loop column of an experiment's table.md: its `header` and the `keys` of the run's metrics shown in
    it (several: joined by " / "), with `digits`, and the spread over the seeds (`std`) for a single key."""

    header: str
    keys: tuple[str, ...]
    digits: int
    std: bool = False


@dataclass(frozen=True, kw_only=True)
class WorldEntry:
    """What a world provides (every field by keyword).

    - `name`, `help`: `--world NAME` and what it is; `cameras`: the camera geometries its renderer makes (a
      recording of one of them is replayed in this world unless told otherwise);
    - recording its expert: `record_options`, `record(out, options)`;
    - a model's drive: `drive_options`, `drive(checkpoint, out, options, drive_with, video)` (`pilot.DriveWith`:
      how its Pilot is made) and the files it writes (`drive_files`);
    - its suite: `suite_options` (with `drives()`: the (kind, seed) of its places, and `place_minutes`), `suites`
      (the versions), `suite(pilots, out, options, progress, plots)` -> summary rows (`pilots`: checkpoints, or
      `core.suite.Entrant`s: any pilot), and the figures it draws (`suite_figures`);
    - replay of its recordings: `replay_options` (their `setup(rec)` makes the replay);
    - DAgger: `dagger_options` (the options of a `dagger:` section that only this world takes, with `kinds()`: the
      places of the rollouts, and `suite_given()`: what they set of the round's suite), `rollout(checkpoint, out,
      seed, minutes, kind, beta, camera, suite)` (run in a worker process), `rollout_camera(rec)`: what the
      rollouts render through for a training recording, `rollout_done`: the file a finished rollout has;
      `round_columns(summary)`: a round's columns of dagger.csv (`dagger_columns`, in order) and `dagger_series`:
      their lines in dagger.png, (column, matplotlib style, label);
    - experiments and tuning: `closed_loop_metrics(checkpoint, options, progress, plots)` -> the metrics of a
      checkpoint on the suite (`autonomy` among them: tune's objective), `closed_loop_table`: their columns in
      table.md (`worst`: the per-kind autonomy shown at the worst seed), and `plot_drives(out, suites, options)`:
      every entry's seed-0 drives (`suites`: label -> its run's suite folder) drawn per place.
    """

    name: str
    help: str
    cameras: tuple[str, ...]
    record_options: type
    record: Callable
    drive_options: type
    drive: Callable
    drive_files: str
    suite_options: type
    suites: dict
    suite: Callable
    suite_figures: str
    replay_options: type
    dagger_options: type
    rollout: Callable
    rollout_camera: Callable
    rollout_done: str
    round_columns: Callable
    dagger_columns: tuple[str, ...]
    dagger_series: tuple[tuple[str, str, str], ...]
    closed_loop_metrics: Callable
    closed_loop_table: tuple[Column, ...]
    worst: Column
    plot_drives: Callable
