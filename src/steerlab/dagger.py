"""DAgger (`steerlab sim dagger CONFIG`), in the road world, in replay on the config's own recording or in the
track world.

Round 0 trains the model on the config's data. Every later round rolls the current model out (with
probability beta per tick the expert drives instead: beta = `beta` x `beta_decay`^(round - 1)), lets the
expert label every visited frame, adds those recordings to the training data (`extra_data`) and trains again,
starting from the previous round's weights. `world: road` rolls out on fresh procedural roads (the expert: pure
pursuit of the lane centre, `road.run.rollout`) and drives the closed-loop suite after every round (unless
`suite` is null); `world: replay` rolls out in closed-loop replay over the training frames of the config's
recording (the expert: the human's steering plus pure pursuit's way back to the path,
`replay.run.rollout_recording`) and replays the validation frames after every round; `world: track` (a config of
donkeycar tubs, the track world's camera) races the model as the track suite drives it, its learned throttle capped
at `max_throttle`, on fresh tracks of the styles `styles` (both by default: taped and centre line) seen through
the recording's fisheye (the expert, steering and throttle: pure pursuit of the lane centre and the feed-forward
throttle to the track's speed profile, capped as the car is, `track.run.rollout`), records the rollouts as tubs and
drives the track suite (`suite: t1` or s1) after every round. The worlds are `sim.worlds.WORLDS`' entries. `dagger.csv`
and `dagger.png` show autonomy (the track world: clean laps, lap time over the expert's, off-track events per
lap) against the round. Every step is kept on disk and reused, so an interrupted run continues where it stopped.
The final round's `best.pt`, `log.csv`, `val_predictions.csv` and `metrics.json` are copied to the output folder.
"""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Literal

from steerlab.files import write_json
from steerlab.data.car import car_of
from steerlab.errors import SteerlabError
from steerlab.options import (AT_LEAST_0, AT_LEAST_1, MINUTES, Options, SEED, SPEED, UNIT, WORKERS, Range, as_dict,
                              frames_in, holds_frames, option, parse)
from steerlab.paths import check_outputs
from steerlab.sim.core.parallel import run_parallel
from steerlab.sim.road.world import ROADS, road_types
from steerlab.sim.worlds import WORLDS, suite_world, track_styles
from steerlab.split_replay import SplitReplay
from steerlab.train.config import TrainConfig, another_config, differences, parse_config, unreadable
from steerlab.train.sources import main_recording

ALL_SUITES = [v for w in WORLDS.values() for v in w.suites]


def _roads(road: str) -> bool:
    road_types(road)
    return True


def _styles(styles: str) -> bool:
    track_styles(styles)
    return True


@dataclass(frozen=True)
class DaggerOptions(Options):
    """A config's `dagger:` section."""

    world: Literal["road", "replay", "track"] = option(
        "road", help="where the rollouts drive: fresh roads of the road world, the config's recording in replay, or "
        "fresh tracks of the track world (a config of donkeycar tubs)")
    iterations: int = option(3, AT_LEAST_0, help="rounds of rollout + retraining after the first training")
    minutes: float = option(4.0, MINUTES, help="minutes of rollouts per round, shared by the road types (the "
                            "track world: by the track styles)")
    seeds_from: int = option(5000, SEED, help="round r drives road (or track) seeds seeds_from + 100 r + k")
    beta: float = option(0.5, UNIT, help="probability that the expert drives a tick, in round 1")
    beta_decay: float = option(0.5, UNIT, help="beta is multiplied by this every round")
    epochs: int = option(4, AT_LEAST_1, help="epochs of every retraining (round 0 uses train.epochs)")
    warm_start: bool = option(True, help="retrain from the previous round's weights (else from scratch)")
    suite: str | None = option("v1", lambda v: v in ALL_SUITES, " or ".join(ALL_SUITES),
                               help="closed-loop suite after every round: a road suite for world road, a track "
                               "suite for world track (default: the world's first, v1 or t1; null: none)")
    suite_minutes: float | None = option(None, MINUTES, help="minutes per suite road or track")
    workers: int = option(2, WORKERS, help="parallel rollouts and suite drives")
    roads: str = option("mixed", _roads, ROADS, help="road world: road types of the rollouts")
    suite_roads: str | None = option(None, help="road world: comma list of the suite's road types to drive "
                                     "(default: all)")
    styles: str | None = option(None, _styles, "taped, centre or a comma list of them",
                                help="track world: track styles of the rollouts (default: both)")
    suite_styles: str | None = option(None, help="track world: comma list of the suite's track styles to drive "
                                      "(default: all)")
    max_throttle: float = option(0.5, Range(0, 1, lo_open=True), help="track world: the cap of the learned throttle "
                                 "in the rollouts and the suite, and of the expert's throttle labels (1: uncapped)")
    speed: float | None = option(None, SPEED, help="replay: m/s for a recording without speed")

    related = holds_frames("minutes", "suite_minutes", fps=20.0)


# the options that belong to some worlds only: given for another, they are refused
OWN = {"roads": ("road",), "suite_roads": ("road",), "styles": ("track",), "suite_styles": ("track",),
       "max_throttle": ("track",), "suite": ("road", "track"), "suite_minutes": ("road", "track"),
       "minutes": ("road", "track"), "speed": ("replay",)}  # minutes: replay's rollouts drive the training frames


def dagger_options(cfg: TrainConfig) -> DaggerOptions:
    """The `dagger:` section, its world named as the CLI names it (`synthetic`, the road world's earlier name, is
    read as `road` with a notice), without the options of another world."""
    raw = _renamed(cfg.dagger, notice=True)
    o = parse(DaggerOptions, raw, "dagger")
    for key in sorted(set(raw) & set(OWN)):
        if o.world not in OWN[key]:
            raise SteerlabError(f"dagger.{key} is an option of dagger.world {' and '.join(OWN[key])}; dagger.world "
                                f"{o.world} does not take it")
    if "suite" not in raw:  # the default suite is the world's own (replay drives none)
        o = replace(o, suite=next(iter(WORLDS[o.world].suites)) if o.world in WORLDS else None)
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
    if o.world == "replay":
        return None
    world = WORLDS[o.world]
    if o.suite and o.suite not in world.suites:
        raise SteerlabError(f"dagger.suite: {o.suite} is a {suite_world(o.suite).name} suite; world {o.world} "
                            f"drives a {o.world} suite ({', '.join(world.suites)}) or none (null): set it to one of "
                            "them")
    given = {"suite": o.suite, "minutes": o.suite_minutes, "workers": o.workers,
             world.kinds: getattr(o, f"suite_{world.kinds}")}
    if "max_throttle" in {f.name for f in fields(world.suite_options)}:
        given["max_throttle"] = o.max_throttle
    names = {"minutes": "suite_minutes", world.kinds: f"suite_{world.kinds}"}  # as the dagger section names them
    return parse(world.suite_options, {k: v for k, v in given.items() if v is not None},
                 name=lambda f: f"dagger.{names.get(f, f)}")


def _check_world(o: DaggerOptions, rec) -> None:
    """The rollouts' world must render the camera of the config's recording."""
    if o.world == "replay" or rec.geometry in WORLDS[o.world].cameras:
        return
    other = next((w.name for w in WORLDS.values() if rec.geometry in w.cameras), "replay")
    raise SteerlabError(f"dagger.world: {o.world} renders the {' or '.join(WORLDS[o.world].cameras)} camera, and "
                        f"{rec.source} holds {rec.geometry!r} frames: choose world {other}"
                        + (" (train on tubs of the track world: steerlab sim record --world track)"
                           if o.world == "track" else ""))


def run_dagger(cfg: TrainConfig, progress: bool = True) -> Path:
    """Run DAgger as configured (a training config with a `dagger` section); returns the final checkpoint."""
    from steerlab.train.loop import train

    o = dagger_options(cfg)
    rec = main_recording(cfg)
    _check_world(o, rec)
    world = None if o.world == "replay" else WORLDS[o.world]
    drives = round_suite(o)  # how the rollouts and the suite drive
    suite = drives if o.suite else None
    kinds = world.parse_kinds(getattr(o, world.kinds)) if world else []  # one rollout of each per round
    if suite:  # its road types or track styles checked before anything is written
        try:
            suite.drives()
        except SteerlabError as e:
            raise SteerlabError(f"dagger.suite_{world.kinds}: {e}") from None
    check_outputs({"output folder (out)": cfg.out}, inputs=cfg.inputs(), kind="dagger")
    out = Path(cfg.out)
    car = car_of(rec.geometry)
    cfg = cfg.for_car(car)
    replay = SplitReplay(cfg, o.speed) if o.world == "replay" else None  # its checks before anything is written
    _claim(out, cfg, o, car)
    base = replace(cfg, dagger=None)
    rows, extra = _read_log(out), list(cfg.extra_data)
    for r in range(o.iterations + 1):
        run = out / f"round{r}"
        beta = 1.0 if r == 0 else o.beta * o.beta_decay ** (r - 1)
        autonomies = []  # of the rollouts made now (none: reused)
        if r > 0 and replay:
            folder = run / "rollouts" / "replay"
            extra.append(str(folder))
            if not (folder / "recording.json").exists():
                shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                if progress:
                    print(f"== DAgger round {r}: replaying round {r - 1}'s model over the training frames, "
                          f"beta {beta:.3f}")
                autonomies = [m["autonomy"] for m in replay.rollouts(out / f"round{r - 1}" / "best.pt", folder, beta,
                                                                      o.seeds_from + 100 * r, progress)]
        elif r > 0:
            jobs = []
            for k, kind in enumerate(kinds):
                folder = run / "rollouts" / f"{kind}-{o.seeds_from + 100 * r + k}"
                extra.append(str(folder))
                if not (folder / world.rollout_done).exists():
                    shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                    jobs.append((str(out / f"round{r - 1}" / "best.pt"), str(folder), o.seeds_from + 100 * r + k,
                                 o.minutes / len(kinds), kind, beta, world.rollout_camera(rec), drives))
            if progress and jobs:
                print(f"== DAgger round {r}: rolling out round {r - 1}'s model in {len(jobs)} fresh place(s) of the "
                      f"{world.name} world, beta {beta:.3f}")
            autonomies = [m.autonomy for m in run_parallel(world.rollout, jobs, o.workers,
                                                           frames_in(o.minutes / len(kinds), 20.0), progress,
                                                           "rollouts")]
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
        if replay:
            closed = replay.evaluate(run / "best.pt", run / "replay", progress)
        elif suite:
            closed = world.round_columns(world.suite([run / "best.pt"], run / "suite", suite, progress=progress))
        else:
            closed = {}
        if r >= len(rows):
            rows.append(_log_row(r, beta, extra, autonomies, metrics, closed))
            _write_log(out, rows)
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
            stored = json.loads(path.read_text())
            earlier = _settings(parse_config({**stored, "dagger": None}).for_car(car),
                                parse(DaggerOptions, _renamed(stored["dagger"]), "dagger"))
        except (OSError, ValueError, KeyError, TypeError, SteerlabError) as e:
            raise unreadable(out, "dagger.json", e, "a DAgger run") from None
        if changes := differences(earlier, _settings(cfg, o)):
            raise another_config(out, changes, "a DAgger run")
    out.mkdir(parents=True, exist_ok=True)
    write_json(path, {**as_dict(cfg), "dagger": as_dict(o)})


FIELDS = ["round", "beta", "recordings", "rollout_autonomy", "val_rmse", "autonomy_country", "autonomy_highway",
          "autonomy_twisty", "autonomy_all", "interventions_per_km", "replay_autonomy", "replay_interventions_per_km",
          "clean_laps_pct", "lap_ratio", "off_track_per_lap"]  # the last three: the track suite's


def _log_row(r, beta, extra, autonomies: list[float], metrics, closed: dict) -> dict:
    """One round: its rollouts' mean autonomy, validation RMSE and the closed-loop columns (suite or replay)."""
    row = {"round": r, "beta": beta, "recordings": 1 + len(extra), "val_rmse": metrics["rmse"],
           "rollout_autonomy": sum(autonomies) / len(autonomies) if autonomies else "", **closed}
    return {k: row.get(k, "") for k in FIELDS}


def _read_log(out: Path) -> list[dict]:
    if not (out / "dagger.csv").exists():
        return []
    with open(out / "dagger.csv") as f:
        return list(csv.DictReader(f))


def _write_log(out: Path, rows: list[dict]) -> None:
    with open(out / "dagger.csv", "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(rows)
    plot_rounds(out / "dagger.png", rows)


def plot_rounds(path: str | Path, rows: list[dict]) -> None:
    """DAgger: closed-loop autonomy per road type, or in replay, or the track suite's clean laps (and the
    validation RMSE) against the round; the validation RMSE alone when the rounds were not driven (`suite: null`)."""
    import numpy as np

    from steerlab.figures import figure  # matplotlib: imported where it draws

    with figure(path, figsize=(7, 4)) as (fig, ax):
        rounds = [int(r["round"]) for r in rows]
        rmse = [float(r["val_rmse"]) for r in rows]
        if not any(r.get(k, "") != "" for r in rows for k in ("autonomy_all", "replay_autonomy", "clean_laps_pct")):
            ax.plot(rounds, rmse, "kx:")
            ax.set_xlabel("DAgger round")
            ax.set_ylabel("validation RMSE [the recording's steering unit]")
            ax.set_xticks(rounds)
            ax.grid(alpha=0.3)
            return
        for key, style, label in [("autonomy_country", "o-", "country"), ("autonomy_highway", "s-", "highway"),
                                  ("autonomy_twisty", "^-", "twisty"), ("autonomy_all", "k.--", "all"),
                                  ("replay_autonomy", "kD-", "replay"),
                                  ("clean_laps_pct", "g*-", "clean laps of the track suite")]:
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
