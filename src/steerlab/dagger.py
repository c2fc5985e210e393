"""DAgger (`steerlab sim dagger CONFIG`), in the synthetic world, in replay on the config's own recording or in
the track world.

Round 0 trains the model on the config's data. Every later round rolls the current model out (with
probability beta per tick the expert drives instead: beta = `beta` x `beta_decay`^(round - 1)), lets the
expert label every visited frame, adds those recordings to the training data (`extra_data`) and trains again,
starting from the previous round's weights. `world: synthetic` rolls out on fresh procedural roads (the
expert: pure pursuit of the lane centre, `world.world_rollout`) and drives the closed-loop suite after every round
(unless `suite` is null); `world: replay` rolls out in closed-loop replay over the training frames of the
config's recording (the expert: the human's steering plus pure pursuit's way back to the path,
`replay.rollout_recording`) and replays the validation frames after every round; `world: track` (a config of
donkeycar tubs, the track world's camera) races the model, with its learned throttle capped as the track suite
caps it, on fresh tracks of both styles (taped and centre line) seen through the recording's fisheye (the expert,
steering and throttle: pure pursuit of the lane centre and the feed-forward throttle to the track's speed
profile, `track_run.track_rollout`), records the rollouts as tubs and drives the track suite (`suite: t1`; its
tables, without the figures of the tracks) after every round. `dagger.csv` and `dagger.png` show autonomy (the
track world: clean laps, lap time over the expert's, off-track events per lap) against the round. Every step is
kept on disk and reused, so an interrupted run continues where it stopped. The final round's `best.pt`,
`log.csv`, `val_predictions.csv` and `metrics.json` are copied to the output folder.
"""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

from steerlab.data.car import car_of
from steerlab.data.fisheye import DONKEY_FISHEYE
from steerlab.paths import folder_to_write
from steerlab.options import AT_LEAST_0, AT_LEAST_1, Options, POSITIVE, UNIT, as_dict, option, parse
from steerlab.errors import SteerlabError
from steerlab.sim.bench import SUITES, SuiteOptions, run_suite
from steerlab.sim.parallel import run_parallel, tick_reporter
from steerlab.sim.track import STYLES
from steerlab.sim.track_bench import TRACK_SUITES, TrackSuiteOptions, run_track_suite
from steerlab.sim.world import ROAD_CAMERAS, ROADS, road_types
from steerlab.split_replay import SplitReplay
from steerlab.train.config import TrainConfig, parse_config
from steerlab.train.sources import main_recording


def _roads(road: str) -> bool:
    road_types(road)
    return True


@dataclass(frozen=True)
class DaggerOptions(Options):
    """A config's `dagger:` section."""

    iterations: int = option(3, AT_LEAST_0, help="rounds of rollout + retraining after the first training")
    minutes: float = option(4.0, POSITIVE, help="minutes of rollouts per round, shared by the road types (the "
                            "track world: by the track styles)")
    roads: str = option("mixed", _roads, ROADS, help="road types of the rollouts")
    seeds_from: int = option(5000, help="round r drives road (or track) seeds seeds_from + 100 r + k")
    beta: float = option(0.5, UNIT, help="probability that the expert drives a tick, in round 1")
    beta_decay: float = option(0.5, UNIT, help="beta is multiplied by this every round")
    epochs: int = option(4, AT_LEAST_1, help="epochs of every retraining (round 0 uses train.epochs)")
    warm_start: bool = option(True, help="retrain from the previous round's weights (else from scratch)")
    suite: str | None = option("v1", lambda v: v in SUITES or v in TRACK_SUITES, " or ".join([*SUITES, *TRACK_SUITES]),
                               help="closed-loop suite after every round: a road suite (v1) for world synthetic, a "
                               "track suite (t1) for world track (null: none)")
    suite_minutes: float | None = option(None, POSITIVE, "positive and finite",
                                         help="minutes per suite road or track")
    suite_roads: str | None = option(None, help="comma list of the suite's road types (the track world: track "
                                     "styles) to drive (default: all)")
    workers: int = option(2, AT_LEAST_1, help="parallel rollouts and suite drives")
    world: Literal["synthetic", "replay", "track"] = option(
        "synthetic", help="where the rollouts drive: fresh roads, the config's recording in replay, or fresh tracks "
        "of the track world (a config of donkeycar tubs)")
    speed: float | None = option(None, POSITIVE, help="replay: m/s for a recording without speed")


def dagger_options(cfg: TrainConfig) -> DaggerOptions:
    return parse(DaggerOptions, cfg.dagger or {}, "dagger")


def round_suite(o: DaggerOptions) -> SuiteOptions | TrackSuiteOptions | None:
    """The closed-loop suite every round drives (None: none): a road suite, or in the track world a track
    suite."""
    if not o.suite:
        return None
    track = o.world == "track"
    if track != (o.suite in TRACK_SUITES):
        want = f"a track suite ({', '.join(TRACK_SUITES)})" if track else f"a road suite ({', '.join(SUITES)})"
        raise SteerlabError(f"dagger.suite: {o.suite} is a {'road' if track else 'track'} suite; world {o.world} "
                            f"drives {want} or none (null)")
    if track:
        return TrackSuiteOptions(o.suite, o.suite_minutes, o.workers, styles=o.suite_roads)
    return SuiteOptions(o.suite, o.suite_minutes, o.workers, roads=o.suite_roads)


def _check_world(o: DaggerOptions, rec) -> None:
    """The rollouts' world must render the camera of the config's recording."""
    if o.world == "track" and rec.geometry != "donkey":
        raise SteerlabError(f"dagger.world: track renders the donkeycar camera, and {rec.source} holds "
                            f"{rec.geometry!r} frames: train on tubs of the track world (steerlab sim record --world "
                            "track), or choose world synthetic or replay")
    if o.world == "synthetic" and rec.geometry not in ROAD_CAMERAS:
        raise SteerlabError(f"dagger.world: synthetic renders the {' or '.join(ROAD_CAMERAS)} camera, and "
                            f"{rec.source} holds {rec.geometry!r} frames: choose world "
                            f"{'track' if rec.geometry == 'donkey' else 'replay'}")


def _rollout_job(checkpoint: str, out: str, seed: int, minutes: float, road: str, beta: float) -> dict:
    from steerlab.pilot import Pilot
    from steerlab.sim.world import world_rollout

    return world_rollout(Pilot(checkpoint), out, seed, minutes, road, beta, on_tick=tick_reporter())


def _track_rollout_job(checkpoint: str, out: str, seed: int, minutes: float, style: str, beta: float,
                       camera) -> dict:
    """A rollout in the track world: the model drives through the donkeycar part as in the track suite (its
    default throttle, cap of the learned throttle and smoothing)."""
    from steerlab.sim.part import donkey_pilot
    from steerlab.sim.track_run import track_rollout

    d = TrackSuiteOptions()
    pilot = donkey_pilot(checkpoint, d.throttle, d.smoothing, d.max_throttle)
    return track_rollout(pilot, out, seed, minutes, style, beta, camera, on_tick=tick_reporter())


def run_dagger(cfg: TrainConfig, progress: bool = True) -> Path:
    """Run DAgger as configured (a training config with a `dagger` section); returns the final checkpoint."""
    from steerlab.train.loop import train

    o = dagger_options(cfg)
    rec = main_recording(cfg)
    _check_world(o, rec)
    suite = None if o.world == "replay" else round_suite(o)
    if suite:  # its road types checked before anything is written
        try:
            suite.drives()
        except SteerlabError as e:
            raise SteerlabError(f"dagger.suite_roads: {e}") from None
    out = folder_to_write(cfg.out, "output folder (out)")
    car = car_of(rec.geometry)
    cfg = cfg.for_car(car)
    _claim(out, cfg, o, car)
    base = replace(cfg, dagger=None)
    track = o.world == "track"
    kinds = STYLES if track else road_types(o.roads)  # one rollout of each per round
    camera = (rec.fisheye or DONKEY_FISHEYE,) if track else ()  # the track world renders the recording's fisheye
    replay = SplitReplay(cfg, o.speed) if o.world == "replay" else None
    rows, extra = _read_log(out), list(cfg.extra_data)
    for r in range(o.iterations + 1):
        run = out / f"round{r}"
        beta = 1.0 if r == 0 else o.beta * o.beta_decay ** (r - 1)
        rollout_metrics = []
        if r > 0 and replay:
            folder = run / "rollouts" / "replay"
            extra.append(str(folder))
            if not (folder / "recording.json").exists():
                shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                if progress:
                    print(f"== DAgger round {r}: replaying round {r - 1}'s model over the training frames, beta {beta:.3f}")
                rollout_metrics = replay.rollouts(out / f"round{r - 1}" / "best.pt", folder, beta,
                                                  o.seeds_from + 100 * r, progress)
        elif r > 0:
            jobs = []
            for k, kind in enumerate(kinds):
                folder = run / "rollouts" / f"{kind}-{o.seeds_from + 100 * r + k}"
                extra.append(str(folder))
                if not (folder / ("manifest.json" if track else "recording.json")).exists():
                    shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                    jobs.append((str(out / f"round{r - 1}" / "best.pt"), str(folder), o.seeds_from + 100 * r + k,
                                 o.minutes / len(kinds), kind, beta, *camera))
            if progress and jobs:
                print(f"== DAgger round {r}: rolling out round {r - 1}'s model on {len(jobs)} "
                      f"{'track' if track else 'road'}(s), beta {beta:.3f}")
            rollout_metrics = run_parallel(_track_rollout_job if track else _rollout_job, jobs, o.workers,
                                           int(round(o.minutes / len(kinds) * 60 * 20)), progress, "rollouts")
        round_cfg = replace(base, out=str(run), extra_data=tuple(extra))
        if r > 0:
            round_cfg = replace(round_cfg, train=replace(round_cfg.train, epochs=o.epochs,
                                                         init=str(out / f"round{r - 1}" / "best.pt")
                                                         if o.warm_start else round_cfg.train.init))
        if not (run / "metrics.json").exists():
            if progress:
                print(f"== DAgger round {r}: training on {1 + len(extra)} recording(s)")
            metrics = train(round_cfg, progress=progress)
            (run / "metrics.json").write_text(json.dumps(metrics, indent=1))
        metrics = json.loads((run / "metrics.json").read_text())
        if replay:
            closed = replay.evaluate(run / "best.pt", run / "replay", progress)
        elif track and suite:
            closed = _track_columns(run_track_suite([run / "best.pt"], run / "suite", suite, progress=progress,
                                                    plots=False))  # the tables; `sim bench` draws the tracks
        elif suite:
            summary = run_suite([run / "best.pt"], run / "suite", suite, progress=progress)
            closed = {f"autonomy_{s['road_type']}": s["autonomy"] for s in summary}
            closed["interventions_per_km"] = next(s for s in summary if s["road_type"] == "all")["interventions_per_km"]
        else:
            closed = {}
        if r >= len(rows):
            rows.append(_log_row(r, beta, extra, rollout_metrics, metrics, closed))
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
                                parse(DaggerOptions, stored["dagger"], "dagger"))
        except (OSError, ValueError, KeyError, TypeError, SteerlabError):
            earlier = None
        if earlier != _settings(cfg, o):
            raise SteerlabError(f"{out} holds a DAgger run with another config; choose a new out directory or "
                                "delete it")
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({**as_dict(cfg), "dagger": as_dict(o)}, indent=1))


FIELDS = ["round", "beta", "recordings", "rollout_autonomy", "val_rmse", "autonomy_country", "autonomy_highway",
          "autonomy_twisty", "autonomy_all", "interventions_per_km", "replay_autonomy", "replay_interventions_per_km",
          "clean_laps_pct", "lap_ratio", "off_track_per_lap"]  # the last three: the track suite's


def _track_columns(summary: list[dict]) -> dict:
    """The track suite over all its tracks: clean laps in % of the laps completed (empty without a lap), the mean
    clean lap time over the expert's (empty without a clean lap) and off-track events per lap driven."""
    a = next(s for s in summary if s["style"] == "all")
    return {"clean_laps_pct": 100 * a["clean_laps"] / a["laps"] if a["laps"] else "",
            "lap_ratio": "" if a["lap_ratio"] is None else a["lap_ratio"], "off_track_per_lap": a["off_track_per_lap"]}


def _log_row(r, beta, extra, rollout_metrics, metrics, closed: dict) -> dict:
    """One round: its rollouts' mean autonomy, validation RMSE and the closed-loop columns (suite or replay)."""
    row = {"round": r, "beta": beta, "recordings": 1 + len(extra), "val_rmse": metrics["rmse"],
           "rollout_autonomy": (sum(m["autonomy"] for m in rollout_metrics) / len(rollout_metrics)
                                if rollout_metrics else ""), **closed}
    return {k: row.get(k, "") for k in FIELDS}


def _read_log(out: Path) -> list[dict]:
    if not (out / "dagger.csv").exists():
        return []
    with open(out / "dagger.csv") as f:
        return list(csv.DictReader(f))


def _write_log(out: Path, rows: list[dict]) -> None:
    from steerlab.sim.plots import plot_rounds

    with open(out / "dagger.csv", "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(rows)
    plot_rounds(out / "dagger.png", rows)
