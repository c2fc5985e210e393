"""The closed-loop benchmark suite (`steerlab sim bench`): every checkpoint drives one fixed, versioned set of
unseen roads, and the drives are summarised per road type.

The roads of a suite version never change, and their seeds (9000-9999) are refused by `sim record` and by
DAgger's rollouts, so no model has seen them. Drives run in parallel worker processes (one torch thread
each); a finished drive is kept in its folder and reused when the suite is run again, so an interrupted
suite continues where it stopped. It is reused only when its drive.json holds the same cache key: the
checkpoint's content hash, suite version, minutes and smoothing (`SuiteOptions.key`).
"""

from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.pilot import smoothing_option
from steerlab.options import AT_LEAST_1, Options, POSITIVE, option, parse
from steerlab.sim.driving import Trajectory, autonomy
from steerlab.sim.parallel import run_parallel, tick_reporter
from steerlab.sim.world import DriveOptions, make_road

SUITES = {
    # 11 roads of 3 minutes: 33 minutes of driving, about 30 km
    "v1": {"minutes": 3.0, "roads": {"country": [9101, 9102, 9103, 9104, 9105], "highway": [9201, 9202, 9203],
                                     "twisty": [9301, 9302, 9303]}},
}
DRIVE_FIELDS = ["label", "checkpoint", "road_type", "seed", "minutes", "autonomy", "interventions",
                "interventions_per_km", "mean_abs_offset_m", "max_abs_offset_m", "command_gamma_deg", "distance_km"]
SUMMARY_FIELDS = ["label", "road_type", "drives", "minutes", "distance_km", "interventions", "autonomy",
                  "interventions_per_km", "mean_abs_offset_m", "max_abs_offset_m", "command_gamma_deg"]

FPS = 20.0  # the suite's frame rate


@dataclass(frozen=True)
class SuiteOptions(Options):
    """The closed-loop suite: `steerlab sim bench`'s options and a config's `closed_loop:` section."""

    suite: str = option("v1", lambda v: v in SUITES, " or ".join(SUITES), help="suite version")
    minutes: float | None = option(None, POSITIVE, "positive and finite",
                                   help="minutes per road (default: the suite's, 3 for v1)")
    workers: int = option(2, AT_LEAST_1, help="roads driven in parallel")
    smoothing: float | None = smoothing_option()
    roads: str | None = option(None, help="comma list of the suite's road types to drive (default: all)")

    @property
    def road_minutes(self) -> float:
        return SUITES[self.suite]["minutes"] if self.minutes is None else self.minutes

    def drives(self) -> list[tuple[str, int]]:
        """(road type, seed) of every road to drive."""
        spec = SUITES[self.suite]
        types = list(spec["roads"]) if self.roads is None else [t.strip() for t in self.roads.split(",") if t.strip()]
        unknown = [t for t in types if t not in spec["roads"]]
        if unknown:
            raise SteerlabError(f"suite {self.suite} has no {', '.join(unknown)} roads; it has "
                                f"{', '.join(spec['roads'])}")
        if not types:
            raise SteerlabError(f"no road to drive: choose road types of suite {self.suite} "
                                f"({', '.join(spec['roads'])})")
        return [(t, s) for t in types for s in spec["roads"][t]]

    def key(self, checkpoint: Path) -> dict:
        """Everything that changes a drive's result besides its road: the checkpoint's content (the sha256 of
        the file; an exported .onnx carries its metadata inside), the suite version, the minutes and the
        smoothing. A finished drive is reused only when its drive.json holds exactly this key."""
        with open(checkpoint, "rb") as f:
            digest = hashlib.file_digest(f, "sha256").hexdigest()
        key = {"checkpoint_sha256": digest, "suite": self.suite, "minutes": self.road_minutes,
               "smoothing": self.smoothing}
        return json.loads(json.dumps(key))  # as drive.json gives it back


def suite_options(section: dict | None, where: str) -> SuiteOptions:
    """A config's `closed_loop:` section (None: the default suite)."""
    return parse(SuiteOptions, section or {}, where)


def _drive_job(checkpoint: str, road: str, seed: int, minutes: float, out: str, smoothing: float | None,
               key: dict | None = None) -> dict:
    """One drive of the suite (its path is drawn with the other checkpoints' in the suite's roads/ figure); with
    `key`, its drive.json also holds the key, which later runs compare."""
    from steerlab.pilot import Pilot
    from steerlab.sim.world import drive

    return drive(Pilot(checkpoint, smoothing=smoothing), out, DriveOptions(seed, minutes, road, fps=FPS),
                 progress=False, on_tick=tick_reporter(), plot=False, meta=None if key is None else {"cache_key": key})


def _cached(done: Path, key: dict) -> dict | None:
    """A finished drive's result when its drive.json holds exactly `key` (an unreadable one is driven anew)."""
    try:
        result = json.loads(done.read_text())
    except (OSError, ValueError):
        return None
    return result if isinstance(result, dict) and result.get("cache_key") == key else None


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
            names = ["/".join((p.parent if short and p.name in ("best.pt", "last.pt") else p.with_suffix("")).parts[-depth:])
                     for p in checkpoints]
            names = [n.lstrip("/") for n in names]
            if len(set(names)) == len(names) and all(names):
                return names
    return [f"{k}-{p.stem}" for k, p in enumerate(checkpoints)]


def run_suite(checkpoints, out: str | Path, o: SuiteOptions = SuiteOptions(), progress: bool = True,
              plots: bool = True) -> list[dict]:
    """Drive every checkpoint on every road of the suite (or of the road types in `o.roads`); write
    `suite.csv` (one row per drive), `summary.csv` and `suite.md` (per checkpoint and road type) and, with
    `plots`, one trajectory plot per road in `out/roads/`. Returns the summary rows."""
    checkpoints = [Path(c) for c in checkpoints]
    if not checkpoints:
        raise SteerlabError("no checkpoint to drive: name at least one")
    for c in checkpoints:
        if not c.is_file():
            raise SteerlabError(f"{c}: checkpoint not found")
    roads, minutes = o.drives(), o.road_minutes
    out = Path(out)
    labels = labels_for(checkpoints)
    jobs, rows = [], {}
    for label, ckpt in zip(labels, checkpoints):
        key = o.key(ckpt)
        for road, seed in roads:
            folder = out / label / f"{road}-{seed}"
            cached = _cached(folder / "drive.json", key)
            if cached is not None:
                rows[(label, road, seed)] = cached
            else:
                jobs.append((label, str(ckpt), road, seed, minutes, str(folder), o.smoothing, key))
    results = run_parallel(_drive_job, [job[1:] for job in jobs], o.workers, int(round(minutes * 60 * FPS)),
                           progress, f"suite {o.suite}")
    rows.update({(job[0], job[2], job[3]): r for job, r in zip(jobs, results)})
    drives = [{**{k: rows[(label, road, seed)][k] for k in DRIVE_FIELDS[5:]}, "label": label, "checkpoint": str(ckpt),
               "road_type": road, "seed": seed, "minutes": minutes}
              for label, ckpt in zip(labels, checkpoints) for road, seed in roads]
    summary = summarize(drives)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "suite.csv", DRIVE_FIELDS, drives)
    write_csv(out / "summary.csv", SUMMARY_FIELDS, summary)
    (out / "suite.md").write_text(markdown(summary, o.suite, minutes))
    if plots:
        plot_roads(out / "roads", [{**d, "folder": out / d["label"] / f"{d['road_type']}-{d['seed']}"} for d in drives],
                   minutes)
    return summary


def closed_loop_metrics(checkpoint: Path, o: SuiteOptions, progress: bool, plots: bool = True) -> dict:
    """A checkpoint on the closed-loop suite (drives kept in the `suite` folder beside it): autonomy over all
    roads and per road type, interventions per km and command gamma."""
    summary = run_suite([checkpoint], checkpoint.parent / "suite", o, progress=progress, plots=plots)
    out = {f"autonomy_{s['road_type']}": s["autonomy"] for s in summary}
    overall = next(s for s in summary if s["road_type"] == "all")
    return {**out, "autonomy": overall["autonomy"], "interventions_per_km": overall["interventions_per_km"],
            "command_gamma_deg": overall["command_gamma_deg"]}


def summarize(drives: list[dict]) -> list[dict]:
    """Per label and road type (and "all"): autonomy over the summed time and interventions, interventions
    per km over the summed distance, the mean of the drives' mean |offset|, the largest |offset|, the mean
    command gamma, and the km driven."""
    out = []
    for label, road, ds in grouped(drives, "road_type"):
        km = sum(d["distance_km"] for d in ds)
        n = sum(d["interventions"] for d in ds)
        seconds = sum(d["minutes"] * 60 for d in ds)
        out.append({"label": label, "road_type": road, "drives": len(ds), "minutes": seconds / 60, "distance_km": km,
                    "interventions": n, "autonomy": autonomy(n, seconds), "interventions_per_km": n / max(km, 1e-9),
                    "mean_abs_offset_m": float(np.mean([d["mean_abs_offset_m"] for d in ds])),
                    "max_abs_offset_m": float(max(d["max_abs_offset_m"] for d in ds)),
                    "command_gamma_deg": float(np.mean([d["command_gamma_deg"] for d in ds]))})
    return out


def grouped(drives: list[dict], key: str):
    """A suite's summary rows: per label, its drives of each value of `key` (in the order they come), then all
    of its drives (value "all"), as (label, value, drives)."""
    for label in dict.fromkeys(d["label"] for d in drives):
        mine = [d for d in drives if d["label"] == label]
        for value in [*dict.fromkeys(d[key] for d in mine), "all"]:
            yield label, value, [d for d in mine if value in ("all", d[key])]


def markdown(summary: list[dict], suite: str, minutes: float) -> str:
    lines = [f"Closed-loop suite {suite}: {minutes:g} min per road; autonomy = (1 - interventions x 6 s / "
             "elapsed s) x 100.", "",
             "| checkpoint | roads | drives | km | interventions | autonomy [%] | interventions/km | "
             "mean abs offset [m] | max abs offset [m] | command gamma [deg] |", "|---" * 10 + "|"]
    for r in summary:
        lines.append(f"| {r['label']} | {r['road_type']} | {r['drives']} | {r['distance_km']:.1f} | "
                     f"{r['interventions']} | {r['autonomy']:.1f} | {r['interventions_per_km']:.2f} | "
                     f"{r['mean_abs_offset_m']:.3f} | {r['max_abs_offset_m']:.3f} | {r['command_gamma_deg']:.3f} |")
    return "\n".join(lines) + "\n"


def write_csv(path: Path, fields: list[str], rows: list[dict]) -> None:
    """A suite's table: the `fields` of every row, an empty cell for None (a value that does not exist)."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fields)
        w.writeheader()
        w.writerows([{k: "" if r[k] is None else r[k] for k in fields} for r in rows])


def plot_roads(out: Path, drives: list[dict], minutes: float) -> None:
    """One figure per road in `out`: the path and lateral offset over time of every drive on it (a suite's rows,
    each with the `folder` of its trajectory.csv), labelled with the drive's label and autonomy."""
    from steerlab.sim.plots import plot_trajectory

    out.mkdir(parents=True, exist_ok=True)
    for road, seed in dict.fromkeys((d["road_type"], int(d["seed"])) for d in drives):
        trajs = {f"{d['label']} ({float(d['autonomy']):.0f} %)": Trajectory.read(Path(d["folder"]) / "trajectory.csv")
                 for d in drives if (d["road_type"], int(d["seed"])) == (road, seed)}
        plot_trajectory(out / f"{road}-{seed}.png", make_road(seed, road, minutes * 60), trajs, f"{road} road {seed}")
