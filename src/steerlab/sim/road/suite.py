"""The road world's closed-loop suite (`steerlab sim bench`): every checkpoint drives one fixed, versioned set of
unseen roads, and the drives are summarised per road type.

The roads of a suite version never change, and their seeds (9000-9999) are refused by `sim record` and by
DAgger's rollouts, so no model has seen them. Drives run in parallel worker processes (one torch thread each);
a finished drive is reused when the suite is run again with the same cache key: the checkpoint's content hash,
suite version, minutes, smoothing and the steering step (`SuiteOptions.key`; `core.suite`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.options import MINUTES, Options, WORKERS, frames_held, frames_in, names_from, names_held, option
from steerlab.paths import check_outputs
from steerlab.pilot import smoothing_option, steering_step_option
from steerlab.sim.core.driving import autonomy
from steerlab.sim.core.parallel import tick_reporter
from steerlab.sim.core.suite import (Entrant, Planned, as_stored, check_world_of, close, entrants, grouped, run_drives,
                                     when_set, write_csv)
from steerlab.sim.road.run import RoadDrive, drive
from steerlab.sim.road.world import DriveOptions, RecordOptions

SUITES = {
    # 11 roads of 3 minutes: 33 minutes of driving, about 30 km
    "v1": {"minutes": 3.0, "roads": {"country": [9101, 9102, 9103, 9104, 9105], "highway": [9201, 9202, 9203],
                                     "twisty": [9301, 9302, 9303]}},
}
FPS = 20.0  # the suite's frame rate


@dataclass(frozen=True)
class SuiteOptions(Options):
    """The closed-loop suite: `steerlab sim bench`'s options and a config's `closed_loop:` section."""

    suite: str = option("v1", lambda v: v in SUITES, " or ".join(SUITES), help="suite version")
    minutes: float | None = option(None, MINUTES, help="minutes per road (default: the suite's, 3 for v1)")
    workers: int = option(2, WORKERS, help="roads driven in parallel")
    smoothing: float | None = smoothing_option()
    steering_step: float | None = steering_step_option()
    roads: str | None = option(None, help="comma list of the suite's road types to drive (default: all)")

    @classmethod
    def related(cls, v):
        yield from frames_held(v, "minutes", fps=FPS)
        if v.suite in SUITES:
            yield from names_held(v, "roads", SUITES[v.suite]["roads"], "road types")

    @property
    def place_minutes(self) -> float:
        return SUITES[self.suite]["minutes"] if self.minutes is None else self.minutes

    def drives(self) -> list[tuple[str, int]]:
        """(road type, seed) of every road to drive."""
        spec = SUITES[self.suite]
        types = names_from(self.roads, spec["roads"], "road types", f"suite {self.suite}") or list(spec["roads"])
        return [(t, s) for t in types for s in spec["roads"][t]]

    def record_options(self, road: str, seed: int) -> RecordOptions:
        """The expert's recording of one road of the suite, to replay models on against their drives there
        (`run.record(..., suite_ok=True)`): the suite's road for its minutes, without drift episodes or side
        cameras."""
        return RecordOptions(seed=seed, minutes=self.place_minutes, road=road, drift=False, side_cameras=False)

    def key(self, entrant: Entrant) -> dict:
        """Everything that changes a drive's result besides its road: the pilot's identity (a checkpoint's content,
        the sha256 of the file; an exported .onnx carries its metadata inside), the suite version, the minutes, the
        smoothing and the steering step (only when set: drives made before it existed stay reusable). A finished
        drive is reused only when its drive.json holds exactly this key."""
        return as_stored({**entrant.identity, "suite": self.suite, "minutes": self.place_minutes,
                          "smoothing": self.smoothing, **when_set(self, "steering_step")})


@dataclass(frozen=True)
class SuiteDrive:
    """One drive of the suite: suite.csv's row."""

    label: str
    checkpoint: str
    road_type: str
    seed: int
    minutes: float
    autonomy: float
    interventions: int
    interventions_per_km: float
    mean_abs_offset_m: float
    max_abs_offset_m: float
    command_gamma_deg: float
    distance_km: float


@dataclass(frozen=True)
class SuiteSummary:
    """A checkpoint's drives of one road type (or "all"): summary.csv's row."""

    label: str
    road_type: str
    drives: int
    minutes: float
    distance_km: float
    interventions: int
    autonomy: float
    interventions_per_km: float
    mean_abs_offset_m: float
    max_abs_offset_m: float
    command_gamma_deg: float


def checkpoint_pilot(checkpoint: str, o: SuiteOptions):
    """steerlab's Pilot on `checkpoint`, as the suite drives it (its smoothing and steering step)."""
    from steerlab.pilot import Pilot

    return Pilot(checkpoint, smoothing=o.smoothing, steering_step=o.steering_step)


def _job(entrant: Entrant, o: SuiteOptions, road: str, seed: int, out: str, key: dict) -> RoadDrive:
    """One drive of the suite (its path is drawn with the other pilots' in the suite's roads/ figure); its
    drive.json also holds the key, which later runs compare."""
    pilot = entrant.make(o)
    try:
        return drive(pilot, out, DriveOptions(seed=seed, minutes=o.place_minutes, road=road, fps=FPS), progress=False,
                     on_tick=tick_reporter(), plot=False, meta={"cache_key": key})
    finally:
        close(pilot)


def run_suite(pilots, out: str | Path, o: SuiteOptions = SuiteOptions(), progress: bool = True,
              plots: bool = True) -> list[SuiteSummary]:
    """Drive every pilot (checkpoints, or `core.suite.Entrant`s) on every road of the suite (or of the road types
    in `o.roads`); write `suite.csv` (one row per drive), `summary.csv` and `suite.md` (per pilot and road type)
    and, with `plots`, one trajectory plot per road in `out/roads/`. Returns the summary rows."""
    racing = entrants(pilots, checkpoint_pilot)
    check_outputs({"output folder": out}, inputs=[e.source for e in racing], kind="suite")
    check_world_of(out, "road", "track", "style")
    roads, minutes, out = o.drives(), o.place_minutes, Path(out)
    keys = {e.label: o.key(e) for e in racing}
    planned = [Planned((e.label, road, seed), out / e.label / f"{road}-{seed}", keys[e.label],
                       (e, o, road, seed, str(out / e.label / f"{road}-{seed}"), keys[e.label]))
               for e in racing for road, seed in roads]
    results = run_drives(_job, RoadDrive, planned, o.workers, frames_in(minutes, FPS), progress, f"suite {o.suite}")
    drives = []
    for e in racing:
        for road, seed in roads:
            r = results[(e.label, road, seed)]
            drives.append(SuiteDrive(
                label=e.label, checkpoint=e.source, road_type=road, seed=seed, minutes=minutes, autonomy=r.autonomy,
                interventions=r.interventions, interventions_per_km=r.interventions_per_km,
                mean_abs_offset_m=r.mean_abs_offset_m, max_abs_offset_m=r.max_abs_offset_m,
                command_gamma_deg=r.command_gamma_deg, distance_km=r.distance_km))
    summary = summarize(drives)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "suite.csv", drives)
    write_csv(out / "summary.csv", summary)
    (out / "suite.md").write_text(markdown(summary, o.suite, minutes))
    if plots:
        from steerlab.sim.road.plots import plot_roads  # matplotlib: imported where it draws

        plot_roads(out / "roads", [{**dataclasses.asdict(d), "folder": out / d.label / f"{d.road_type}-{d.seed}"}
                                   for d in drives], minutes)
    return summary


def closed_loop_metrics(checkpoint: Path, o: SuiteOptions, progress: bool, plots: bool = True) -> dict:
    """A checkpoint on the closed-loop suite (drives kept in the `suite` folder beside it): autonomy over all
    roads and per road type, interventions per km and command gamma."""
    summary = run_suite([checkpoint], checkpoint.parent / "suite", o, progress=progress, plots=plots)
    overall = next(s for s in summary if s.road_type == "all")
    return {**{f"autonomy_{s.road_type}": s.autonomy for s in summary}, "autonomy": overall.autonomy,
            "interventions_per_km": overall.interventions_per_km, "command_gamma_deg": overall.command_gamma_deg}


def round_columns(summary: list[SuiteSummary]) -> dict:
    """A DAgger round's columns of dagger.csv: autonomy per road type and over all, interventions per km."""
    overall = next(s for s in summary if s.road_type == "all")
    return {**{f"autonomy_{s.road_type}": s.autonomy for s in summary},
            "interventions_per_km": overall.interventions_per_km}


def summarize(drives: list[SuiteDrive]) -> list[SuiteSummary]:
    """Per label and road type (and "all"): autonomy over the summed time and interventions, interventions
    per km over the summed distance, the mean of the drives' mean |offset|, the largest |offset|, the mean
    command gamma, and the km driven."""
    out = []
    for label, road, ds in grouped(drives, "road_type"):
        km = sum(d.distance_km for d in ds)
        n = sum(d.interventions for d in ds)
        seconds = sum(d.minutes * 60 for d in ds)
        out.append(SuiteSummary(
            label=label, road_type=road, drives=len(ds), minutes=seconds / 60, distance_km=km, interventions=n,
            autonomy=autonomy(n, seconds), interventions_per_km=n / max(km, 1e-9),
            mean_abs_offset_m=float(np.mean([d.mean_abs_offset_m for d in ds])),
            max_abs_offset_m=float(max(d.max_abs_offset_m for d in ds)),
            command_gamma_deg=float(np.mean([d.command_gamma_deg for d in ds]))))
    return out


def markdown(summary: list[SuiteSummary], suite: str, minutes: float) -> str:
    lines = [f"Closed-loop suite {suite}: {minutes:g} min per road; autonomy = (1 - interventions x 6 s / "
             "elapsed s) x 100.", "",
             "| checkpoint | roads | drives | km | interventions | autonomy [%] | interventions/km | "
             "mean abs offset [m] | max abs offset [m] | command gamma [deg] |", "|---" * 10 + "|"]
    for r in summary:
        lines.append(f"| {r.label} | {r.road_type} | {r.drives} | {r.distance_km:.1f} | {r.interventions} | "
                     f"{r.autonomy:.1f} | {r.interventions_per_km:.2f} | {r.mean_abs_offset_m:.3f} | "
                     f"{r.max_abs_offset_m:.3f} | {r.command_gamma_deg:.3f} |")
    return "\n".join(lines) + "\n"
