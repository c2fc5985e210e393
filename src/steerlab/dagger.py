"""DAgger (`steerlab sim dagger CONFIG`), in any registered world or in replay on the config's own recording.

Round 0 trains the model on the config's data. Every later round rolls the current model out (with
probability beta per tick the expert drives instead: beta = `beta` x `beta_decay`^(round - 1)), lets the
expert label every visited frame, adds those recordings to the training data (`extra_data`) and trains again,
starting from the previous round's weights. In a world (`dagger.world`: a name of `sim.worlds.WORLDS`), the rollouts
drive fresh places of it, one of each kind its own options name (`WorldEntry.dagger.options`: the road world's
`roads`, the track world's `styles`), through the world's `rollout` (the road world: pure pursuit of the lane
centre labels the frames, `road.run.rollout`; the track world: the model races as the track suite drives it, its
learned throttle capped at `max_throttle`, and the expert labels steering and throttle, `track.run.rollout`), and
the world's suite is driven after every round (unless `suite` is null); `world: replay` rolls out in closed-loop
replay over the training frames of the config's recording (the expert: the human's steering plus pure pursuit's
way back to the path, `replay.run.rollout_recording`) and replays the validation frames after every round.
`dagger.csv` and `dagger.png` show the place's closed-loop columns (the world's `dagger.columns`: autonomy per road
type; clean laps, lap time over the expert's, off-track events per lap; or replay's autonomy) against the round.
Every step is kept on disk and reused, so an interrupted run continues where it stopped. The final round's
`best.pt`, `log.csv`, `val_predictions.csv` and `metrics.json` are copied to the output folder.
"""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import dataclass, fields, replace
from pathlib import Path

from steerlab.files import exponents_read, write_json
from steerlab.data.car import car_of
from steerlab.errors import SteerlabError
from steerlab.options import (AT_LEAST_0, AT_LEAST_1, MINUTES, Options, SEED, SPEED, UNIT, WORKERS, as_dict,
                              frames_in, holds_frames, option, parse)
from steerlab.paths import check_outputs
from steerlab.sim.core.parallel import run_parallel
from steerlab.sim.worlds import WORLDS, all_suites, default_world, suite_world
from steerlab.split_replay import SplitReplay
from steerlab.train.config import TrainConfig, another_config, differences, parse_config, unreadable
from steerlab.train.sources import main_recording

REPLAY = "replay"  # DAgger in replay on the config's own recording: the one place that is not a registered world


def places() -> list[str]:
    """Where DAgger's rollouts drive: every registered world, and replay."""
    return [*WORLDS, REPLAY]


@dataclass(frozen=True)
class ReplayDaggerOptions(Options):
    """The options of a `dagger:` section that only DAgger in replay takes."""

    speed: float | None = option(None, SPEED, help="replay: m/s for a recording without speed")

    def kinds(self) -> list[str]:
        return []


@dataclass(frozen=True)
class DaggerOptions(Options):
    """A config's `dagger:` section: the options of every place, and `own`, those of its world (the world's
    `dagger_options`, made by `dagger_options` from the section's other keys)."""

    world: str = option(default_world().name, lambda v: v in places(), " or ".join(places()), help="where the "
                        "rollouts drive: fresh places of a world (road: roads, track: tracks, from a config of "
                        "donkeycar tubs) or the config's recording in replay")
    iterations: int = option(3, AT_LEAST_0, help="rounds of rollout + retraining after the first training")
    minutes: float = option(4.0, MINUTES, help="minutes of rollouts per round, shared by the road types (the "
                            "track world: by the track styles)")
    seeds_from: int = option(5000, SEED, help="round r drives road (or track) seeds seeds_from + 100 r + k")
    beta: float = option(0.5, UNIT, help="probability that the expert drives a tick, in round 1")
    beta_decay: float = option(0.5, UNIT, help="beta is multiplied by this every round")
    epochs: int = option(4, AT_LEAST_1, help="epochs of every retraining (round 0 uses train.epochs)")
    warm_start: bool = option(True, help="retrain from the previous round's weights (else from scratch)")
    suite: str | None = option(next(iter(default_world().suite.versions)), lambda v: v in all_suites(),
                               " or ".join(all_suites()), help="closed-loop suite after every round: one of the "
                               "rollouts' world (default: the world's first, v1 or t1; null: none)")
    suite_minutes: float | None = option(None, MINUTES, help="minutes per suite road or track")
    workers: int = option(2, WORKERS, help="parallel rollouts and suite drives")
    own: Options | None = option(None, lambda v: v is None or isinstance(v, Options), "the options of its world",
                                 help="the options of the rollouts' world (the section's other keys)")

    related = holds_frames("minutes", "suite_minutes", fps=20.0)

    def as_dict(self) -> dict:
        """The section as written: the options of every place and those of its world, side by side."""
        return {**{f.name: as_dict(getattr(self, f.name)) for f in fields(self) if f.name != "own"},
                **as_dict(self.own or {})}


WORLD_KEYS = ("minutes", "suite", "suite_minutes")  # options of DAgger in a world, not in replay


def own_options(world: str) -> type:
    """The options class of a `dagger:` section's keys that only `world` takes."""
    return ReplayDaggerOptions if world == REPLAY else WORLDS[world].dagger.options


def taking(key: str) -> list[str]:
    """The places whose DAgger takes the option `key` (every place for one of `DaggerOptions`)."""
    if key in WORLD_KEYS:
        return list(WORLDS)
    if key in {f.name for f in fields(DaggerOptions)} - {"own"}:
        return places()
    return [p for p in places() if key in {f.name for f in fields(own_options(p))}]


def dagger_options(cfg: TrainConfig) -> DaggerOptions:
    """The `dagger:` section, its world named as the CLI names it (`synthetic`, the road world's earlier name, is
    read as `road` with a notice), without the options of another world."""
    return _parsed(_renamed(cfg.dagger, notice=True))


def _parsed(raw: dict, earlier: bool = False) -> DaggerOptions:
    """The options of a `dagger:` section (`earlier`: one that a dagger.json of an earlier version stored, with
    every world's options at their defaults: those of other worlds are left out)."""
    generic = {f.name for f in fields(DaggerOptions)} - {"own"}
    o = parse(DaggerOptions, {k: v for k, v in raw.items() if k in generic}, "dagger")
    mine = own_options(o.world)
    rest = {k: v for k, v in raw.items() if k not in generic}
    for key in sorted(set(raw)):
        where = taking(key)
        if where and o.world not in where:
            if earlier and key not in generic:
                rest.pop(key, None)
                continue
            raise SteerlabError(f"dagger.{key} is an option of dagger.world {' and '.join(where)}; dagger.world "
                                f"{o.world} does not take it")
    o = replace(o, own=parse(mine, rest, "dagger"))
    if "suite" not in raw:  # the default suite is the world's own (replay drives none)
        o = replace(o, suite=next(iter(WORLDS[o.world].suite.versions)) if o.world in WORLDS else None)
    return o


def _renamed(section: dict | None, notice: bool = False) -> dict:
    """A `dagger:` section with the road world's earlier name, `synthetic`, read as `road`."""
    raw = dict(section or {})
    if raw.get("world") == "synthetic":
        if notice:
            print("notice: dagger.world: synthetic is the road world's earlier name; read as road")
        raw["world"] = "road"
    return raw


def round_suite(o: DaggerOptions):
    """The options of the closed-loop suite of the rollouts' world (None in replay): what every round drives unless
    `suite` is null, and how the rollouts drive (the track world's cap)."""
    if o.world not in WORLDS:
        return None
    world = WORLDS[o.world]
    if o.suite and o.suite not in world.suite.versions:
        raise SteerlabError(f"dagger.suite: {o.suite} is a {suite_world(o.suite).name} suite; world {o.world} "
                            f"drives a {o.world} suite ({', '.join(world.suite.versions)}) or none (null): set it to one of "
                            "them")
    keys = type(o.own).suite_keys  # the suite's options that the world's own options set, and their dagger keys
    given = {"suite": o.suite, "minutes": o.suite_minutes, "workers": o.workers,
             **{k: getattr(o.own, v) for k, v in keys.items()}}
    names = {"minutes": "suite_minutes", **keys}  # as the dagger section names them
    return parse(world.suite.options, {k: v for k, v in given.items() if v is not None},
                 name=lambda f: f"dagger.{names.get(f, f)}")


def _check_world(o: DaggerOptions, rec) -> None:
    """The rollouts' world must render the camera of the config's recording."""
    if o.world not in WORLDS or rec.geometry in WORLDS[o.world].cameras:
        return
    other = next((w.name for w in WORLDS.values() if rec.geometry in w.cameras), REPLAY)
    raise SteerlabError(f"dagger.world: {o.world} renders the {' or '.join(WORLDS[o.world].cameras)} camera, and "
                        f"{rec.source} holds {rec.geometry!r} frames: choose world {other}"
                        + (f" (train on recordings of the {o.world} world: steerlab sim record --world {o.world})"
                           if o.world != default_world().name else ""))


class _InWorld:
    """A round of DAgger in a world: rollouts in fresh places of it (one of each kind the world's own options
    name, `kinds()`), the world's suite after the round (unless `suite` is null), its columns of dagger.csv."""

    def __init__(self, o: DaggerOptions, rec):
        self.o, self.world = o, WORLDS[o.world]
        self.drives = round_suite(o)  # how the rollouts and the suite drive
        self.suite = self.drives if o.suite else None
        self.kinds = o.own.kinds()  # one rollout of each per round
        self.camera = self.world.dagger.camera(rec)
        self.columns, self.series = self.world.dagger.columns, self.world.dagger.series
        if self.suite:  # its places checked before anything is written
            try:
                self.suite.drives()
            except SteerlabError as e:
                raise SteerlabError(f"dagger.{type(o.own).suite_places}: {e}") from None

    def rollouts(self, out: Path, r: int, beta: float, extra: list, progress: bool) -> list[float]:
        """Round `r`'s rollouts (those not made yet), their folders added to `extra`; their autonomies."""
        o, world, jobs = self.o, self.world, []
        for k, kind in enumerate(self.kinds):
            folder = out / f"round{r}" / "rollouts" / f"{kind}-{o.seeds_from + 100 * r + k}"
            extra.append(str(folder))
            if not (folder / world.dagger.done).exists():
                shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                jobs.append((str(out / f"round{r - 1}" / "best.pt"), str(folder), o.seeds_from + 100 * r + k,
                             o.minutes / len(self.kinds), kind, beta, self.camera, self.drives))
        if progress and jobs:
            print(f"== DAgger round {r}: rolling out round {r - 1}'s model in {len(jobs)} fresh place(s) of the "
                  f"{world.name} world, beta {beta:.3f}")
        return [m.autonomy for m in run_parallel(world.dagger.rollout, jobs, o.workers,
                                                 frames_in(o.minutes / len(self.kinds), 20.0), progress, "rollouts")]

    def evaluate(self, run: Path, progress: bool) -> dict:
        if not self.suite:
            return {}
        return self.world.dagger.round_columns(self.world.suite.run([run / "best.pt"], run / "suite", self.suite,
                                                         progress=progress))


class _InReplay:
    """A round of DAgger in replay: the previous round's model replayed over the training frames of the config's
    recording, the validation frames replayed after the round."""

    columns = ("replay_autonomy", "replay_interventions_per_km")
    series = (("replay_autonomy", "kD-", "replay"),)

    def __init__(self, cfg: TrainConfig, o: DaggerOptions):
        self.o, self.replay = o, SplitReplay(cfg, o.own.speed)  # its checks before anything is written

    def rollouts(self, out: Path, r: int, beta: float, extra: list, progress: bool) -> list[float]:
        folder = out / f"round{r}" / "rollouts" / "replay"
        extra.append(str(folder))
        if (folder / "recording.json").exists():
            return []
        shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
        if progress:
            print(f"== DAgger round {r}: replaying round {r - 1}'s model over the training frames, beta {beta:.3f}")
        return [m["autonomy"] for m in self.replay.rollouts(out / f"round{r - 1}" / "best.pt", folder, beta,
                                                             self.o.seeds_from + 100 * r, progress)]

    def evaluate(self, run: Path, progress: bool) -> dict:
        return self.replay.evaluate(run / "best.pt", run / "replay", progress)


def run_dagger(cfg: TrainConfig, progress: bool = True) -> Path:
    """Run DAgger as configured (a training config with a `dagger` section); returns the final checkpoint."""
    from steerlab.train.loop import train

    o = dagger_options(cfg)
    rec = main_recording(cfg)
    _check_world(o, rec)
    rounds = _InWorld(o, rec) if o.world in WORLDS else None
    check_outputs({"output folder (out)": cfg.out}, inputs=cfg.inputs(), kind="dagger")
    out = Path(cfg.out)
    car = car_of(rec.geometry)
    cfg = cfg.for_car(car)
    rounds = rounds or _InReplay(cfg, o)
    _claim(out, cfg, o, car)
    base = replace(cfg, dagger=None)
    rows, extra = _read_log(out), list(cfg.extra_data)
    for r in range(o.iterations + 1):
        run = out / f"round{r}"
        beta = 1.0 if r == 0 else o.beta * o.beta_decay ** (r - 1)
        autonomies = rounds.rollouts(out, r, beta, extra, progress) if r > 0 else []  # of the rollouts made now
        round_cfg = replace(base, out=str(run), extra_data=tuple(extra))
        if r > 0:
            round_cfg = replace(round_cfg, train=replace(round_cfg.train, epochs=o.epochs,
                                                         init=str(out / f"round{r - 1}" / "best.pt")
                                                         if o.warm_start else round_cfg.train.init))
        if not (run / "metrics.json").exists():
            if progress:
                print(f"== DAgger round {r}: training on {1 + len(extra)} recording(s)")
            metrics = train(round_cfg, progress=progress)
            write_json(run / "metrics.json", metrics)
        metrics = json.loads((run / "metrics.json").read_text())
        if r >= len(rows):
            rows.append(_log_row(r, beta, extra, autonomies, metrics, rounds.evaluate(run, progress), rounds.columns))
            _write_log(out, rows, rounds)
    for name in ("best.pt", "log.csv", "val_predictions.csv", "metrics.json"):
        shutil.copyfile(out / f"round{len(rows) - 1}" / name, out / name)
    return out / "best.pt"


def _settings(cfg: TrainConfig, o: DaggerOptions) -> dict:
    """What a DAgger run's rounds depend on: the training config and the options but the workers and the
    number of iterations."""
    return {**replace(cfg, dagger=None).identity(),
            "dagger": {k: v for k, v in as_dict(o).items() if k not in ("workers", "iterations")}}


def _claim(out: Path, cfg: TrainConfig, o: DaggerOptions, car) -> None:
    """Record the run's settings in `out/dagger.json`. A folder whose rounds were made with other settings is
    refused, so that no rollout or round of other settings is silently reused; the number of workers may
    change, and so may the number of iterations (more rounds continue a finished run). A folder of an earlier
    version holds the same run when its settings parse to the same ones."""
    path = out / "dagger.json"
    if path.exists() and any(out.glob("round*")):
        try:
            stored = exponents_read(json.loads(path.read_text()))  # an earlier version's texts: numbers
            earlier = _settings(parse_config({**stored, "dagger": None}).for_car(car),
                                _parsed(_renamed(stored["dagger"]), earlier=True))
        except (OSError, ValueError, KeyError, TypeError, SteerlabError) as e:
            raise unreadable(out, "dagger.json", e, "a DAgger run") from None
        if changes := differences(earlier, _settings(cfg, o)):
            raise another_config(out, changes, "a DAgger run")
    out.mkdir(parents=True, exist_ok=True)
    write_json(path, {**as_dict(cfg), "dagger": as_dict(o)})


FIELDS = ["round", "beta", "recordings", "rollout_autonomy", "val_rmse"]  # then the place's closed-loop columns


def _log_row(r, beta, extra, autonomies: list[float], metrics, closed: dict, columns) -> dict:
    """One round: its rollouts' mean autonomy, validation RMSE and the closed-loop `columns` (suite or replay)."""
    row = {"round": r, "beta": beta, "recordings": 1 + len(extra), "val_rmse": metrics["rmse"],
           "rollout_autonomy": sum(autonomies) / len(autonomies) if autonomies else "", **closed}
    return {k: row.get(k, "") for k in [*FIELDS, *columns]}


def _read_log(out: Path) -> list[dict]:
    if not (out / "dagger.csv").exists():
        return []
    with open(out / "dagger.csv") as f:
        return list(csv.DictReader(f))


def _write_log(out: Path, rows: list[dict], rounds) -> None:
    columns = [*FIELDS, *rounds.columns]
    with open(out / "dagger.csv", "w", newline="") as f:
        w = csv.DictWriter(f, columns)
        w.writeheader()
        w.writerows([{k: r.get(k, "") for k in columns} for r in rows])  # a log of an earlier version: its columns
    plot_rounds(out / "dagger.png", rows, rounds.series)


def plot_rounds(path: str | Path, rows: list[dict], series) -> None:
    """DAgger: the closed-loop columns of the rollouts' place (`series`: (column, matplotlib style, label); a world's
    `dagger.series`: autonomy per road type, the track suite's clean laps; or in replay) and the validation RMSE
    against the round; the validation RMSE alone when the rounds were not driven (`suite: null`)."""
    import numpy as np

    from steerlab.figures import figure  # matplotlib: imported where it draws

    with figure(path, figsize=(7, 4)) as (fig, ax):
        rounds = [int(r["round"]) for r in rows]
        rmse = [float(r["val_rmse"]) for r in rows]
        if not any(r.get(k, "") != "" for r in rows for k, _, _ in series):
            ax.plot(rounds, rmse, "kx:")
            ax.set_xlabel("DAgger round")
            ax.set_ylabel("validation RMSE [the recording's steering unit]")
            ax.set_xticks(rounds)
            ax.grid(alpha=0.3)
            return
        for key, style, label in series:
            values = [float(r[key]) if r.get(key, "") != "" else np.nan for r in rows]
            if not np.all(np.isnan(values)):
                ax.plot(rounds, values, style, label=label)
        ax.set_xlabel("DAgger round")
        ax.set_ylabel("closed-loop autonomy or clean laps [%]")
        ax.set_ylim(top=101)  # at most 100 %
        ax.set_xticks(rounds)
        ax.grid(alpha=0.3)
        ax2 = ax.twinx()
        ax2.plot(rounds, rmse, color="0.6", ls=":", marker="x", label="val RMSE")
        ax2.set_ylabel("validation RMSE [steering unit]", color="0.4")
        lines = ax.get_legend_handles_labels()
        extra = ax2.get_legend_handles_labels()
        ax.legend(lines[0] + extra[0], lines[1] + extra[1], fontsize=8, loc="upper center", ncol=3,
                  bbox_to_anchor=(0.5, -0.15))  # below the axes: over none of the lines, near 100 % or near 0
