"""Does closed-loop replay on recordings predict true closed-loop driving?

python -m studies.replay_vs_road_suite --out runs/replay-truth [--minutes 1.0] [--workers 2]

In the road world both exist. The script
1. records the expert (no drift episodes, centre camera) on every road of the closed-loop suite v1 for
   `--minutes` each (`common.record_expert`: the suite's own road, same length);
2. trains a handful of zoo models on a short mixed-road recording (seed 3, 4 minutes), with and without side
   cameras and flips, and keeps a snapshot after chosen epochs, plus the zero and train-mean baselines: at
   least 20 checkpoints of very different quality;
3. drives every checkpoint on the suite (the truth: `sim.road.suite.run_suite`) and replays it on the 11 expert
   recordings (`sim.replay.run.run_replay`, recorded speed), summed per checkpoint over the recordings;
4. reports the Spearman rank correlation (tied values share their mean rank) and R^2 (squared Pearson) of
   replay against truth, for autonomy and for interventions per km, a Markdown table (`results.md`,
   `results.csv`) and a scatter plot (`scatter.png`);
5. measures the viewpoint warp (`data.geometry.shift_view`) against the renderer over lateral offset x
   heading, for the `sim` and `ch2` cameras (`warp.md`).

Everything already done in `--out` is reused (recordings, snapshots, suite drives, replays per recording), so
an interrupted run continues where it stopped.
"""

from __future__ import annotations

import csv
import math
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.options import MINUTES, WORKERS, Options, option
from steerlab.sim.core.suite import labels_for
from steerlab.sim.road.suite import SUITES
from studies.common import begin_study
from studies.common.truth import (correlation_table, correlations, record_expert, replay_missing, scatter_axes,
                                  train_baseline, train_snapshots, write_table)

TRAIN_DATA = {"seed": 3, "minutes": 4.0, "road": "country,twisty,highway,twisty"}
BASE_TRAIN = {"epochs": 1, "batch_size": 32, "lr": 3e-4, "patience": 99, "min_speed": 4.0}
# name -> (model section, preprocess overrides, train overrides, epochs whose weights are kept)
VARIANTS = {
    "pilotnet-plain": ({"name": "pilotnet", "dropout": 0.3}, {}, {}, [1, 2, 4]),
    "pilotnet-flip": ({"name": "pilotnet", "dropout": 0.3}, {}, {"flip": True}, [1, 3]),
    "pilotnet-side": ({"name": "pilotnet", "dropout": 0.3}, {},
                      {"side_cameras": True, "flip": True, "exclude_episodes": ["drift-out"]}, [1, 2, 4, 6]),
    "pilotnet-flow-side": ({"name": "pilotnet-flow", "dropout": 0.3}, {},
                           {"side_cameras": True, "flip": True, "exclude_episodes": ["drift-out"]}, [1, 3]),
    "cg23-side": ({"name": "cg23", "dropout": 0.3}, {},
                  {"side_cameras": True, "flip": True, "exclude_episodes": ["drift-out"]}, [1, 3]),
    "lstm-side": ({"name": "lstm", "dropout": 0.3}, {},
                  {"side_cameras": True, "exclude_episodes": ["drift-out"], "batch_size": 16}, [1, 3]),
    "multimodal-lstm-side": ({"name": "multimodal-lstm", "dropout": 0.3}, {},
                             {"side_cameras": True, "exclude_episodes": ["drift-out"], "batch_size": 16}, [1, 3]),
    "flow-lstm-side": ({"name": "flow-lstm", "dropout": 0.3}, {"color": "yuv"},
                       {"side_cameras": True, "exclude_episodes": ["drift-out"], "batch_size": 16}, [1, 3]),
}
BASELINES = ["zero", "train-mean"]
OFFSETS = [0.25, 0.5, 1.0, 1.5]
HEADINGS = [0.0, 2.0, 5.0, 10.0]


def training_data(out: Path) -> Path:
    from steerlab.sim.road.run import record
    from steerlab.sim.road.world import RecordOptions

    folder = out / "train-data"
    if not (folder / "recording.json").exists():
        shutil.rmtree(folder, ignore_errors=True)
        t0 = time.time()
        record(folder, RecordOptions(seed=TRAIN_DATA["seed"], minutes=TRAIN_DATA["minutes"], road=TRAIN_DATA["road"]),
               progress=False)
        print(f"recorded the training data ({TRAIN_DATA}) in {time.time() - t0:.0f} s", flush=True)
    return folder


def _config(data: Path, out: Path, run: Path, model: dict, pre: dict, train: dict):
    """The training config (a `TrainConfig`) of one run."""
    from steerlab.train.config import load_config

    frames = int(round(TRAIN_DATA["minutes"] * 60 * 20))
    split = int(frames * 0.8)
    return load_config(None, base={"data": str(data), "cache": str(out / "cache"), "out": str(run),
                                   "preprocess": {"preset": "sim", "color": "gray", **pre},
                                   "split": {"train": f"0:{split}", "val": f"{split}:{frames}"},
                                   "model": model, "train": {**BASE_TRAIN, **train}})


def checkpoints(out: Path, data: Path) -> list[Path]:
    """Train the baselines and every variant (one run each, the weights after each kept epoch copied to
    `out/checkpoints/`); anything already there is reused."""
    ckpts = out / "checkpoints"
    result = [train_baseline(name, _config(data, out, out / "runs" / name, {"name": name}, {}, {}), ckpts)
              for name in BASELINES]
    for name, (model, pre, tr, keep) in VARIANTS.items():
        config = _config(data, out, out / "runs" / name, model, pre, {**tr, "epochs": max(keep)})
        result += train_snapshots(name, config, keep, ckpts)
    return result


def true_closed_loop(ckpts: list[Path], out: Path, minutes: float, workers: int) -> dict:
    """The suite for every checkpoint: its summary row over all roads (`SuiteSummary`) by label."""
    from steerlab.sim.road.suite import SuiteOptions, run_suite

    t0 = time.time()
    summary = run_suite(ckpts, out / "suite", SuiteOptions("v1", minutes, workers=workers), progress=False)
    print(f"suite v1 ({minutes:g} min per road) for {len(ckpts)} checkpoints in {time.time() - t0:.0f} s", flush=True)
    return {r.label: r for r in summary if r.road_type == "all"}


def replay(ckpts: list[Path], recs: dict, out: Path, workers: int) -> tuple[dict[str, dict], list[dict]]:
    """Every checkpoint on every expert recording (recorded speed); per checkpoint the sums over recordings."""
    from steerlab.data.readers import Source
    from steerlab.sim.core.driving import autonomy
    from steerlab.sim.replay.run import ReplayOptions

    labels = labels_for(ckpts)
    rows = []
    for (road, seed), folder in recs.items():
        have = replay_missing(ckpts, labels, Source(str(folder)), out / "replay" / folder.name,
                              ReplayOptions(speed=None, workers=workers), folder.name)
        rows += [{**have[label], "road_type": road, "seed": seed} for label in labels]
    total = {}
    for label in labels:
        mine = [r for r in rows if r["checkpoint"] == label]
        n = sum(int(r["interventions"]) for r in mine)
        km = sum(float(r["km"]) for r in mine)
        seconds = sum(float(r["seconds"]) for r in mine)
        total[label] = {"interventions": n, "km": km, "seconds": seconds, "autonomy": autonomy(n, seconds),
                        "interventions_per_km": n / max(km, 1e-9),
                        "mean_offset_m": float(np.mean([float(r["mean_offset_m"]) for r in mine]))}
    return total, rows


def per_road_type(out: Path, labels: list[str], rows: list[dict]) -> list[str]:
    """Replay against truth (interventions per km) within each road type and over all drives."""
    drives = {(d["label"], d["road_type"], int(d["seed"])): d for d in csv.DictReader(open(out / "suite" / "suite.csv"))}
    groups = {}
    for kind in [*SUITES["v1"]["roads"], "all"]:
        groups[kind] = [(float(drives[(r["checkpoint"], r["road_type"], int(r["seed"]))]["interventions_per_km"]),
                         float(r["interventions_per_km"]))
                        for r in rows if r["checkpoint"] in labels and kind in ("all", r["road_type"])]
    return correlation_table(groups, "road", "int/km", "int/km")


def scatter(path: Path, table: list[dict], corr: dict) -> None:
    from steerlab.figures import figure

    with figure(path, 1, 2, figsize=(13, 6)) as (_, axes):
        for ax, key, unit in ((axes[0], "autonomy", "autonomy [%]"),
                              (axes[1], "interventions_per_km", "interventions / km")):
            scatter_axes(ax, [r["checkpoint"] for r in table], [r[f"true_{key}"] for r in table],
                         [r[f"replay_{key}"] for r in table], corr[key], f"true closed loop (suite v1): {unit}",
                         f"replay on the expert's recordings: {unit}", title=f"{unit}: ")


def warp_error(out: Path) -> list[str]:
    """shift_view against the renderer: the centre frame warped to a car moved sideways and turned, and the
    unwarped centre frame, each against the frame rendered from that pose, on the road rows (below the far
    haze, as in tests/sim/road/test_closed_loop.py)."""
    import cv2

    from steerlab.data.geometry import CAMERAS, shift_view
    from steerlab.sim.road.render import Renderer
    from steerlab.sim.road.road import LANE_CENTER, Road

    roads = [Road(3, "country", 3000), Road(5, "twisty", 3000)]
    positions = [150.0, 400.0, 650.0, 900.0]
    signs = [(1, 1), (-1, -1), (1, -1), (-1, 1)]  # turned away from the lane centre, and back towards it
    lines = ["The centre frame warped by `shift_view` (and left unwarped) against the frame the renderer draws from the "
             "moved and turned pose, on the road rows (below the far haze): mean absolute gray-level error (0-255) and "
             f"the share of pixels within 40 levels; mean over {len(roads)} roads (country 3, twisty 5) x "
             f"{len(positions)} positions x {len(signs)} sign combinations (left/right, turned out/in). The last column: "
             "the share within 40 levels among the pixels the pose change moved by more than 40 levels (markings, "
             "verges: what the model steers by).", ""]
    for preset in ("sim", "ch2"):
        cells = {}
        for road in roads:
            r = Renderer(road, preset)
            rows = slice(int(r.horizon) + r.cam.height // 7, r.cam.height)
            gray = lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(int)[rows]  # noqa: E731
            for s in positions:
                x, y, psi = road.pose(s, LANE_CENTER)
                centre = r.render(x, y, psi, s)
                for off in OFFSETS:
                    for head in HEADINGS:
                        for a, b in signs:
                            truth = gray(r.render(x, y, psi + math.radians(b * head), s, shift=a * off))
                            warped = gray(shift_view(centre, CAMERAS[preset], a * off, b * head))
                            plain = gray(centre)
                            moved = np.abs(plain - truth) > 40  # markings and verges the new pose moved
                            cells.setdefault((off, head), []).append(
                                (np.abs(warped - truth).mean(), (np.abs(warped - truth) <= 40).mean(),
                                 np.abs(plain - truth).mean(), (np.abs(plain - truth) <= 40).mean(),
                                 (np.abs(warped - truth) <= 40)[moved].mean() if moved.any() else np.nan))
        cam = CAMERAS[preset]
        lines += [f"Camera `{preset}` ({cam.width}x{cam.height}): warped | unwarped", "",
                  "| offset [m] | heading [deg] | warped: mean abs error | warped: within 40 | unwarped: mean abs error "
                  "| unwarped: within 40 | warped: within 40 where the view changed |", "|---|---|---|---|---|---|---|"]
        for (off, head), v in cells.items():
            m = np.nanmean(v, axis=0)
            lines.append(f"| {off:g} | {head:g} | {m[0]:.1f} | {100 * m[1]:.1f} % | {m[2]:.1f} | {100 * m[3]:.1f} % | "
                         f"{100 * m[4]:.1f} % |")
        lines.append("")
    return lines


@dataclass(frozen=True)
class RoadReplayStudy(Options):
    out: str = option("runs/replay-truth", path="folder", help="the study's folder (what is done there is reused)")
    minutes: float = option(1.0, MINUTES, help="minutes per suite road, for the truth and the recordings")
    workers: int = option(2, WORKERS, help="drives and replays at a time")
    skip_warp: bool = option(False, help="leave out the warp-error table")


def parser():
    return script_parser(__spec__.name, __doc__, RoadReplayStudy)


def main(_, a: RoadReplayStudy) -> None:
    out = Path(a.out)
    t_start, cpu_start = begin_study(out, a.workers)

    if not a.skip_warp:
        t0 = time.time()
        warp = warp_error(out)
        (out / "warp.md").write_text("\n".join(warp) + "\n")
        print("\n".join(warp), flush=True)
        print(f"(warp table in {time.time() - t0:.0f} s)", flush=True)

    recs = record_expert("road", out, a.minutes)
    data = training_data(out)
    ckpts = checkpoints(out, data)
    print(f"{len(ckpts)} checkpoints", flush=True)
    truth = true_closed_loop(ckpts, out, a.minutes, a.workers)
    rep, rows = replay(ckpts, recs, out, a.workers)

    labels = labels_for(ckpts)
    table = [{"checkpoint": label, "true_autonomy": truth[label].autonomy, "replay_autonomy": rep[label]["autonomy"],
              "true_interventions": truth[label].interventions, "replay_interventions": rep[label]["interventions"],
              "true_interventions_per_km": truth[label].interventions_per_km,
              "replay_interventions_per_km": rep[label]["interventions_per_km"],
              "true_km": truth[label].distance_km, "replay_km": rep[label]["km"],
              "true_mean_offset_m": truth[label].mean_abs_offset_m, "replay_mean_offset_m": rep[label]["mean_offset_m"]}
             for label in labels]
    corr = {k: correlations([r[f"true_{k}"] for r in table], [r[f"replay_{k}"] for r in table])
            for k in ("autonomy", "interventions_per_km")}
    write_table(out / "results.csv", table)
    lines = [f"Replay vs. true closed loop: {len(table)} checkpoints; truth = suite v1 ({a.minutes:g} min on each of its "
             f"{len(recs)} roads); replay = the same checkpoints on the expert's recordings of those roads (no drift "
             "episodes, centre camera, recorded speed), summed over the recordings. Autonomy from the summed time "
             "and interventions.", "",
             "| quantity | checkpoints | Spearman (replay vs. true) | R^2 (squared Pearson) | n |", "|---|---|---|---|---|"]
    trained = [r for r in table if r["checkpoint"] not in BASELINES]  # without the two far-off baselines
    good = [r for r in table if r["true_autonomy"] >= 75]              # the cluster of models that mostly drive
    for k, c in corr.items():
        lines.append(f"| {k.replace('_', ' ')} | all | {c['spearman']:.3f} | {c['r2']:.3f} | {c['n']} |")
        for what, sub in (("trained (no zero, train-mean)", trained), ("true autonomy >= 75 %", good)):
            s = correlations([r[f"true_{k}"] for r in sub], [r[f"replay_{k}"] for r in sub])
            lines.append(f"| {k.replace('_', ' ')} | {what} | {s['spearman']:.3f} | {s['r2']:.3f} | {s['n']} |")
    diff = np.array([r["replay_autonomy"] - r["true_autonomy"] for r in table])
    lines += ["", f"Replay minus true autonomy: mean {diff.mean():+.2f} points, largest |difference| "
                  f"{np.abs(diff).max():.1f} points ({table[int(np.argmax(np.abs(diff)))]['checkpoint']})."]
    lines += ["", "| checkpoint | true autonomy [%] | replay autonomy [%] | true int/km | replay int/km | true interventions "
              "| replay interventions | true mean abs offset [m] | replay mean abs offset [m] |", "|---" * 9 + "|"]
    for r in table:
        lines.append(f"| {r['checkpoint']} | {r['true_autonomy']:.1f} | {r['replay_autonomy']:.1f} | "
                     f"{r['true_interventions_per_km']:.2f} | {r['replay_interventions_per_km']:.2f} | "
                     f"{r['true_interventions']} | {r['replay_interventions']} | {r['true_mean_offset_m']:.3f} | "
                     f"{r['replay_mean_offset_m']:.3f} |")
    lines += ["", "Per road type (one point per checkpoint and road):", "", *per_road_type(out, labels, rows)]
    (out / "results.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines), flush=True)
    scatter(out / "scatter.png", table, corr)
    print(f"\nwrote {out / 'results.md'}, {out / 'results.csv'}, {out / 'scatter.png'}"
          f"{'' if a.skip_warp else ', ' + str(out / 'warp.md')}; wall {time.time() - t_start:.0f} s, "
          f"main-process CPU {time.process_time() - cpu_start:.0f} s", flush=True)


if __name__ == "__main__":
    run_script(parser(), main)
