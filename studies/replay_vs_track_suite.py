"""Does replay of small-car recordings predict true closed-loop racing in the track world?

python -m studies.replay_vs_track_suite --out runs/replay-track-truth [--minutes 0.5] [--workers 1]

The track world's counterpart of `replay_vs_road_suite.py`. The script
1. records the racing expert (no drift episodes) as a donkeycar tub on every track of the track suite t1 for
   `--minutes` each (`common.record_expert`: the suite's own track, lane width and style);
2. trains small models on the track-world tubs of `configs/track_pilotnet.yaml` (`--tubs`: the racing expert on
   tracks 1-4, 3 minutes each) on few frames and for few epochs, keeping a snapshot after chosen epochs, plus
   the zero and train-mean baselines and any `--extra` checkpoints: at least 20 checkpoints of very different
   quality;
3. drives every checkpoint on the suite for `--minutes` per track (the truth: `sim.track.suite.run_suite`,
   through the donkeycar part, the model's learned throttle) and replays it on the expert's recordings of those
   tracks (`sim.replay.run.run_replay` with `TrackReplayOptions`, the suite's lane width; the speed as in the
   suite: the model's learned throttle, else the speed of the suite's constant throttle);
4. reports per checkpoint off-track events per lap (truth: events over the laps driven; replay: interventions
   over the laps the recordings cover), summed over the tracks, and the Spearman rank correlation and R^2
   (squared Pearson: a straight-line fit) of replay against truth, in `results.md`, `results.csv` and
   `results.png` (a scatter plot); with `--speed recorded` the replay at the recorded throttle's speed instead of
   the speed the suite drives at, in `results-recorded.*`.

Everything already done in `--out` is reused (recordings, snapshots, suite drives, replays per recording), so
an interrupted run continues where it stopped.
"""

from __future__ import annotations

import csv
import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal


from steerlab.cli import path_option, run_script, script_parser
from steerlab.data.car import CARS
from steerlab.data.readers import open_recording
from steerlab.options import MINUTES, WORKERS, Options, option
from steerlab.sim.core.suite import labels_for
from steerlab.sim.track.suite import TRACK_SUITES
from studies.common import ROOT, begin_study
from studies.common.truth import (correlation_table, correlations, record_expert, replay_missing, replayed,
                                  scatter_axes, train_baseline, train_snapshots, write_table)

SUITE = "t1"
BASE_TRAIN = {"batch_size": 32, "lr": 3e-4, "patience": 99, "loss": "mae"}
VAL = "3000:3538"  # the validation block of configs/track_pilotnet.yaml (the end of tub 1)
# name -> (model section, extra tubs (indices into --tubs; tub 1 is index 0), training frames of tub 1, kept epochs)
VARIANTS = {
    "pilotnet-100": ({"name": "pilotnet"}, [], "0:100", [1, 4]),
    "pilotnet-300": ({"name": "pilotnet"}, [], "0:300", [1, 2, 4]),
    "pilotnet-1000": ({"name": "pilotnet"}, [], "0:1000", [1, 2, 4]),
    "pilotnet-3000": ({"name": "pilotnet"}, [], "0:3000", [1, 3]),
    "cg23-300": ({"name": "cg23"}, [], "0:300", [1, 3]),
    "cg23-1000": ({"name": "cg23"}, [], "0:1000", [1, 2, 4]),
    "pilotnet-4tubs": ({"name": "pilotnet"}, [1, 2, 3], "0:3000", [1, 2, 3, 5]),
    "cg23-4tubs": ({"name": "cg23"}, [1, 2, 3], "0:3000", [1, 3]),
}
BASELINES = ["zero", "train-mean"]
SPEEDS = {"model": "the model's throttle where it learned one, else the speed the suite's constant throttle holds",
          "recorded": "the recorded throttle's"}
LOCK = {"full_lock_deg": str(CARS["donkey"].full_lock_deg)}  # the track world's tubs: normalized of the car's lock


def _config(tubs: list[Path], extra: list[int], frames: str, out: Path, run: Path, model: dict, train: dict):
    """The training config (a `TrainConfig`) of one run on the tubs."""
    from steerlab.train.config import load_config

    return load_config(None, base={"data": str(tubs[0]), "extra_data": [str(tubs[i]) for i in extra], "reader": LOCK,
                                   "cache": str(out / "cache"), "out": str(run),
                                   "preprocess": {"preset": "donkey", "color": "gray"},
                                   "split": {"train": frames, "val": VAL}, "model": model,
                                   "train": {**BASE_TRAIN, **train}})


def checkpoints(out: Path, tubs: list[Path], extra: list[Path]) -> list[Path]:
    """Train the baselines and every variant (one run each, the weights after each kept epoch copied to
    `out/checkpoints/`), and copy the `extra` checkpoints in; anything already there is reused."""
    ckpts = out / "checkpoints"
    ckpts.mkdir(parents=True, exist_ok=True)
    result = [train_baseline(name, _config(tubs, [], "0:1000", out, out / "runs" / name, {"name": name},
                                           {"epochs": 1}), ckpts) for name in BASELINES]
    for name, (model, more, frames, keep) in VARIANTS.items():
        config = _config(tubs, more, frames, out, out / "runs" / name, model, {"epochs": max(keep)})
        result += train_snapshots(name, config, keep, ckpts)
    for c in extra:
        target = ckpts / f"{c.parent.name}-{c.stem}.pt"
        if not target.exists():
            shutil.copy(c, target)
        result.append(target)
    return result


def true_suite(ckpts: list[Path], out: Path, minutes: float, workers: int) -> tuple[dict[str, dict], list[dict]]:
    """The track suite for every checkpoint; per checkpoint off-track events over the laps driven, all tracks."""
    from steerlab.sim.track.suite import TrackSuiteOptions, run_suite

    t0 = time.time()
    run_suite(ckpts, out / "suite", TrackSuiteOptions(SUITE, minutes, workers=workers), progress=False, plots=False)
    print(f"track suite {SUITE} ({minutes:g} min per track) for {len(ckpts)} checkpoints in {time.time() - t0:.0f} s",
          flush=True)
    drives = list(csv.DictReader(open(out / "suite" / "suite.csv")))
    total = {}
    for label in dict.fromkeys(d["label"] for d in drives):
        mine = [d for d in drives if d["label"] == label]
        n, laps = sum(int(d["off_track"]) for d in mine), sum(float(d["laps_driven"]) for d in mine)
        total[label] = {"off_track": n, "laps": laps, "per_lap": n / max(laps, 1e-9),
                        "km": sum(float(d["distance_km"]) for d in mine)}
    return total, drives


def speed_options(ckpts: list[Path], mode: str) -> list:
    """The `TrackReplayOptions` speed settings of each checkpoint: `recorded`, the recorded throttle's speed
    for all; `model`, as the suite drives them: the model's own throttle when it learned one, else the speed
    that the suite's constant throttle holds."""
    from steerlab.pilot import Pilot
    from steerlab.data.car import steady_speed
    from steerlab.sim.track.suite import FPS
    from steerlab.sim.track.world import THROTTLE

    if mode == "recorded":
        return [{}] * len(ckpts)
    constant = {"speed": round(steady_speed(THROTTLE, 1.0 / FPS, CARS["donkey"]), 4)}
    return [{"throttle": "model"} if "throttle" in Pilot(c).targets else constant for c in ckpts]


def replay(ckpts: list[Path], recs: dict, out: Path, workers: int, mode: str) -> tuple[dict[str, dict], list[dict]]:
    """Every checkpoint on every expert recording (the speed as `speed_options(mode)`, the suite's lane width);
    per checkpoint interventions over the laps the replayed car covers, summed over the tracks."""
    from steerlab.data.readers import Source
    from steerlab.sim.track.replay import TrackReplayOptions
    from steerlab.sim.track.track import Track

    labels = labels_for(ckpts)
    lane = TRACK_SUITES[SUITE]["lane_width"]
    speeds = speed_options(ckpts, mode)
    rows = []
    for (style, seed), folder in recs.items():
        where = out / "replay" / folder.name / mode
        lap_m = Track(seed, lane, style).length
        for speed in map(json.loads, dict.fromkeys(json.dumps(s, sort_keys=True) for s in speeds)):
            same = [(c, label) for c, label, s in zip(ckpts, labels, speeds) if s == speed]
            replay_missing([c for c, _ in same], [label for _, label in same], Source(str(folder), reader=LOCK),
                           where, TrackReplayOptions(lane_width=lane, workers=workers, **speed),
                           f"{folder.name} ({speed or 'recorded throttle'})")
        have = replayed(where)
        rows += [{**have[label], "style": style, "seed": seed, "laps": float(have[label]["km"]) * 1000 / lap_m}
                 for label in labels]
    total = {}
    for label in labels:
        mine = [r for r in rows if r["checkpoint"] == label]
        n, laps = sum(int(r["interventions"]) for r in mine), sum(r["laps"] for r in mine)
        total[label] = {"interventions": n, "laps": laps, "per_lap": n / max(laps, 1e-9),
                        "km": sum(float(r["km"]) for r in mine)}
    return total, rows


def per_style(labels: list[str], drives: list[dict], rows: list[dict]) -> list[str]:
    """Spearman and R^2 of replay against truth (events per lap) per checkpoint and track, by track style."""
    truth = {(d["label"], int(d["seed"])): float(d["off_track_per_lap"]) for d in drives}
    groups = {kind: [(truth[(r["checkpoint"], int(r["seed"]))], int(r["interventions"]) / max(r["laps"], 1e-9))
                     for r in rows if r["checkpoint"] in labels and kind in ("all", r["style"])]
              for kind in [*TRACK_SUITES[SUITE]["tracks"], "all"]}
    return correlation_table(groups, "track", "off track / lap", "interventions / lap")


def scatter(path: Path, table: list[dict], corr: dict, minutes: float) -> None:
    from steerlab.figures import figure

    with figure(path, figsize=(7, 6)) as (_, ax):
        scatter_axes(ax, [r["checkpoint"] for r in table], [r["true_off_track_per_lap"] for r in table],
                     [r["replay_interventions_per_lap"] for r in table], corr,
                     f"true closed loop (track suite {SUITE}, {minutes:g} min per track): off-track events / lap",
                     "replay of the expert's recordings: interventions / lap", fit=True)


@dataclass(frozen=True)
class TrackReplayStudy(Options):
    out: str = option("runs/replay-track-truth", path="folder", help="the study's folder (what is done there is "
                      "reused)")
    minutes: float = option(0.5, MINUTES, help="minutes per suite track, for the truth and the recordings")
    workers: int = option(1, WORKERS, help="drives and replays at a time")
    speed: Literal["model", "recorded"] = option("model", help="replay speed: model = as the suite drives (the "
                                                 "learned throttle, else the suite's constant throttle's speed); "
                                                 "recorded = the recorded throttle's")


def parser():
    p = script_parser(__spec__.name, __doc__, TrackReplayStudy)
    p.add_argument("--tubs", nargs="+", default=[str(ROOT / "runs" / "track" / f"tub-{k}") for k in range(1, 5)],
                   help="the track-world tubs of configs/track_pilotnet.yaml (tub 1 first)")
    path_option(p, "--extra", kind="file", nargs="*", default=[], help="more checkpoints of the donkey camera to "
                "include")
    return p


def main(args, a: TrackReplayStudy) -> None:
    for tub in args.tubs:  # before anything is recorded or trained
        open_recording(tub)
    out = Path(a.out)
    t_start, cpu_start = begin_study(out, a.workers)

    recs = record_expert("track", out, a.minutes)
    ckpts = checkpoints(out, [Path(t) for t in args.tubs], [Path(c) for c in args.extra])
    print(f"{len(ckpts)} checkpoints", flush=True)
    truth, drives = true_suite(ckpts, out, a.minutes, a.workers)
    rep, rows = replay(ckpts, recs, out, a.workers, a.speed)

    labels = labels_for(ckpts)
    table = [{"checkpoint": label, "true_off_track": truth[label]["off_track"], "true_laps": truth[label]["laps"],
              "true_off_track_per_lap": truth[label]["per_lap"], "true_km": truth[label]["km"],
              "replay_interventions": rep[label]["interventions"], "replay_laps": rep[label]["laps"],
              "replay_interventions_per_lap": rep[label]["per_lap"], "replay_km": rep[label]["km"]}
             for label in labels]
    corr = correlations([r["true_off_track_per_lap"] for r in table],
                        [r["replay_interventions_per_lap"] for r in table])
    name = "results" if a.speed == "model" else f"results-{a.speed}"
    write_table(out / f"{name}.csv", table)
    trained = [r for r in table if r["checkpoint"] not in BASELINES]
    sub = correlations([r["true_off_track_per_lap"] for r in trained],
                       [r["replay_interventions_per_lap"] for r in trained])
    lines = [f"Replay vs. true closed loop in the track world: {len(table)} checkpoints; truth = track suite {SUITE} "
             f"({a.minutes:g} min on each of its {len(recs)} tracks, the donkeycar part, the model's throttle): "
             "off-track events over the laps driven; replay = the same checkpoints on the racing expert's recordings "
             f"of those tracks (no drift episodes, the suite's lane width; speed: {SPEEDS[a.speed]}): interventions "
             "over the laps the replayed car covers; both summed over the tracks.", "",
             "| checkpoints | Spearman (replay vs. true, per lap) | R^2 (squared Pearson) | n |", "|---|---|---|---|",
             f"| all | {corr['spearman']:.3f} | {corr['r2']:.3f} | {corr['n']} |",
             f"| trained (no zero, train-mean) | {sub['spearman']:.3f} | {sub['r2']:.3f} | {sub['n']} |", "",
             "| checkpoint | true off track | true laps | true off track / lap | replay interventions | replay laps | "
             "replay interventions / lap |", "|---" * 7 + "|"]
    for r in table:
        lines.append(f"| {r['checkpoint']} | {r['true_off_track']} | {r['true_laps']:.2f} | "
                     f"{r['true_off_track_per_lap']:.2f} | {r['replay_interventions']} | {r['replay_laps']:.2f} | "
                     f"{r['replay_interventions_per_lap']:.2f} |")
    lines += ["", "Per track style (one point per checkpoint and track):", "", *per_style(labels, drives, rows)]
    (out / f"{name}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines), flush=True)
    scatter(out / f"{name}.png", table, corr, a.minutes)
    print(f"\nwrote {out / name}.md, .csv and .png; wall "
          f"{time.time() - t_start:.0f} s, main-process CPU {time.process_time() - cpu_start:.0f} s", flush=True)


if __name__ == "__main__":
    run_script(parser(), main)
