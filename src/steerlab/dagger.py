"""DAgger (`steerlab sim dagger CONFIG`), in the synthetic world or in replay on the config's own recording.

Round 0 trains the model on the config's data. Every later round rolls the current model out (with
probability beta per tick the expert steers instead: beta = `beta` x `beta_decay`^(round - 1)), lets the
expert label every visited frame, adds those recordings to the training data (`extra_data`) and trains again,
starting from the previous round's weights. `world: synthetic` rolls out on fresh procedural roads (the
expert: pure pursuit of the lane centre, `world.rollout`) and drives the closed-loop suite after every round
(unless `suite` is null); `world: replay` rolls out in closed-loop replay over the training frames of the
config's recording (the expert: the human's steering plus pure pursuit's way back to the path,
`replay.rollout_recording`) and replays the validation frames after every round. `dagger.csv` and
`dagger.png` show autonomy against the round. Every step is kept on disk and reused, so an interrupted run
continues where it stopped. The final round's `best.pt`,
`log.csv`, `val_predictions.csv` and `metrics.json` are copied to the output folder.
"""

from __future__ import annotations

import copy
import csv
import json
import shutil
from pathlib import Path

from steerlab.errors import SteerlabError
from steerlab.sim.bench import run_parallel, run_suite
from steerlab.sim.replay import SplitReplay
from steerlab.sim.world import road_types

DEFAULTS = {
    "iterations": 3,     # rounds of rollout + retraining after the first training
    "minutes": 4.0,      # minutes of rollouts per round, shared by the road types
    "roads": "mixed",    # road types of the rollouts
    "seeds_from": 5000,  # round r drives road seeds seeds_from + 100 r + k
    "beta": 0.5,         # probability that the expert steers a tick, in round 1
    "beta_decay": 0.5,   # ... multiplied by this every round
    "epochs": 4,         # epochs of every retraining (round 0 uses train.epochs)
    "warm_start": True,  # retrain from the previous round's weights (else from scratch)
    "suite": "v1",       # closed-loop suite after every round (null: none, e.g. when the caller drives it after)
    "suite_minutes": None,  # minutes per suite road (default: the suite's)
    "workers": 2,        # parallel rollouts and suite drives
    "world": "synthetic",  # where the rollouts drive: synthetic (fresh roads) or replay (the config's recording)
    "speed": None,       # replay: m/s for a recording without speed (default: estimated from its frames)
}


def dagger_options(cfg: dict) -> dict:
    opts = {**DEFAULTS, **(cfg.get("dagger") or {})}
    unknown = set(opts) - set(DEFAULTS)
    if unknown:
        raise SteerlabError(f"unknown dagger options {sorted(unknown)}; known: {sorted(DEFAULTS)}")
    if int(opts["iterations"]) < 0 or not float(opts["minutes"]) > 0 or not 0 <= float(opts["beta"]) <= 1:
        raise SteerlabError("dagger needs iterations >= 0, minutes > 0 and 0 <= beta <= 1")
    road_types(opts["roads"])
    if opts["world"] not in ("synthetic", "replay"):
        raise SteerlabError(f"dagger world must be synthetic or replay, got {opts['world']!r}")
    return opts


def _rollout_job(checkpoint: str, out: str, seed: int, minutes: float, road: str, beta: float) -> dict:
    from steerlab.pilot import Pilot
    from steerlab.sim.bench import tick_reporter
    from steerlab.sim.world import rollout

    return rollout(Pilot(checkpoint), out, seed, minutes, road, beta, progress=False, on_tick=tick_reporter())


def run_dagger(cfg: dict, progress: bool = True) -> Path:
    """Run DAgger as configured (a training config with a `dagger` section); returns the final checkpoint."""
    from steerlab.train.loop import train

    opts = dagger_options(cfg)
    out = Path(cfg["out"])
    _claim(out, cfg)
    base = {k: v for k, v in copy.deepcopy(cfg).items() if k != "dagger"}
    types = road_types(opts["roads"])
    replay = SplitReplay(cfg, opts["speed"], int(opts["workers"])) if opts["world"] == "replay" else None
    rows, extra = _read_log(out), list(cfg.get("extra_data") or [])
    for r in range(int(opts["iterations"]) + 1):
        run = out / f"round{r}"
        beta = 1.0 if r == 0 else float(opts["beta"]) * float(opts["beta_decay"]) ** (r - 1)
        rollout_metrics = []
        if r > 0 and replay:
            folder = run / "rollouts" / "replay"
            extra.append(str(folder))
            if not (folder / "recording.json").exists():
                shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                if progress:
                    print(f"== DAgger round {r}: replaying round {r - 1}'s model over the training frames, beta {beta:.3f}")
                rollout_metrics = replay.rollouts(out / f"round{r - 1}" / "best.pt", folder, beta,
                                                  int(opts["seeds_from"]) + 100 * r, progress)
        elif r > 0:
            jobs = []
            for k, road in enumerate(types):
                folder = run / "rollouts" / f"{road}-{int(opts['seeds_from']) + 100 * r + k}"
                extra.append(str(folder))
                if not (folder / "recording.json").exists():
                    shutil.rmtree(folder, ignore_errors=True)  # an interrupted rollout starts again
                    jobs.append((str(out / f"round{r - 1}" / "best.pt"), str(folder),
                                 int(opts["seeds_from"]) + 100 * r + k, float(opts["minutes"]) / len(types), road, beta))
            if progress and jobs:
                print(f"== DAgger round {r}: rolling out round {r - 1}'s model on {len(jobs)} road(s), beta {beta:.3f}")
            rollout_metrics = run_parallel(_rollout_job, jobs, int(opts["workers"]), float(opts["minutes"]) / len(types),
                                           progress, "rollouts")
        round_cfg = {**copy.deepcopy(base), "out": str(run), "extra_data": list(extra)}
        if r > 0:
            round_cfg["train"] = {**round_cfg["train"], "epochs": int(opts["epochs"])}
            if opts["warm_start"]:
                round_cfg["train"]["init"] = str(out / f"round{r - 1}" / "best.pt")
        if not (run / "metrics.json").exists():
            if progress:
                print(f"== DAgger round {r}: training on {1 + len(extra)} recording(s)")
            metrics = train(round_cfg, progress=progress)
            (run / "metrics.json").write_text(json.dumps(metrics, indent=1))
        metrics = json.loads((run / "metrics.json").read_text())
        if replay:
            closed = replay.evaluate(run / "best.pt", run / "replay", progress)
        elif opts["suite"]:
            summary = run_suite([run / "best.pt"], run / "suite", opts["suite"], opts["suite_minutes"],
                                int(opts["workers"]), progress=progress)
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


def _claim(out: Path, cfg: dict) -> None:
    """Record the run's settings in `out/dagger.json`. A folder whose rounds were made with other settings is
    refused, so that no rollout or round of other settings is silently reused; the number of workers may
    change, and so may the number of iterations (more rounds continue a finished run)."""
    opts = {k: v for k, v in dagger_options(cfg).items() if k not in ("workers", "iterations")}
    mine = json.loads(json.dumps({**cfg, "dagger": opts}))
    path = out / "dagger.json"
    if path.exists() and any(out.glob("round*")) and json.loads(path.read_text()) != mine:
        raise SteerlabError(f"{out} holds a DAgger run with another config; choose a new out directory or delete it")
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(mine, indent=1))


FIELDS = ["round", "beta", "recordings", "rollout_autonomy", "val_rmse", "autonomy_country", "autonomy_highway",
          "autonomy_twisty", "autonomy_all", "interventions_per_km", "replay_autonomy", "replay_interventions_per_km"]


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
