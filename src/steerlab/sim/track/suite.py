"""The track suite (`steerlab sim bench --world track`): every checkpoint races one fixed, versioned set of unseen
tracks, through the donkeycar part, for a fixed time each; laps are the measure.

The tracks of a suite version never change (seed, lane width and style), and their seeds lie in 9000-9999, which
`sim record --world track` refuses, so no model has seen them. Each track is also driven once by the racing
expert (no drift episodes, from the car's state, without a camera): its lap times are the reference a model's
are put against, driven under the same throttle cap as the models (`--max-throttle`; its drives are kept per cap,
in `expert-max<cap>/`). Drives run in parallel worker processes; a finished drive is reused when the suite runs
again with the same cache key (`core.suite`): the checkpoint's content hash, suite version, minutes, smoothing,
the constant throttle, the learned throttle's cap, the steering step, the latency, the camera and what it steers
by (`TrackSuiteOptions.key`); the expert's drives
with the same suite version, minutes and cap.

Per drive (`suite.csv`): laps completed, clean laps (no off-track event), best and mean clean lap time, the
expert's on the same track, the pace (the mean clean lap over the expert's; none without a clean lap: the track is
not finished), off-track events per lap and per km, and NVIDIA's autonomy, (1 - events x 6 s / elapsed s) x 100.
Per checkpoint and style and over all tracks (`summary.csv`, `suite.md`), every checkpoint over the same tracks:
laps, clean laps and their share, tracks finished of the tracks driven, off-track events, and one pace: the mean
pace over the tracks that every checkpoint compared finished, so that no checkpoint's pace leaves out a track
another's counts. `tracks/<style>-<seed>.png` draws every checkpoint's line on each track.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import astuple, dataclass
from functools import partial
from pathlib import Path
from typing import Literal

import numpy as np

from steerlab.control import Throttle, throttle_held
from steerlab.data.car import CARS
from steerlab.errors import SteerlabError
from steerlab.options import MINUTES, Options, WORKERS, frames_held, frames_in, names_from, names_held, option
from steerlab.paths import check_outputs
from steerlab.pilot import DriveWith, smoothing_option, steering_step_option
from steerlab.sim.core.driving import autonomy
from steerlab.sim.core.parallel import tick_reporter
from steerlab.sim.core.part import PartPilot, learns_throttle
from steerlab.sim.core.suite import (Entrant, Planned, as_stored, check_world_of, close, entrants, file_sha256, grouped,
                                     run_drives, when_set, write_csv)
from steerlab.sim.track import run
from steerlab.sim.track.run import TrackDrive, drive_expert
from steerlab.sim.track.world import (TrackDriveOptions, TrackRecordOptions, calibration_option, camera_of,
                                      constant_throttle, lat_acc_option, latency_option, max_throttle_option,
                                      pace_held, part_throttle, steer_by_option, throttle_by_option,
                                      throttle_floor_option, throttle_option, throttle_scale_option)

TRACK_SUITES = {
    # 8 tracks of 2 minutes, 0.9 m lanes: six taped, two with a painted centre line (28-54 m laps; the expert
    # laps them in 8-17 s, a model at the default throttle in about twice that)
    "t1": {"minutes": 2.0, "lane_width": 0.9,
           "tracks": {"taped": [9401, 9402, 9403, 9404, 9405, 9406], "centre": [9451, 9452]}},
    # the selection tracks: recipes are chosen on these, and scored on t1's (also reserved: never recorded)
    "s1": {"minutes": 2.0, "lane_width": 0.9,
           "tracks": {"taped": [9501, 9502, 9503, 9504, 9505, 9506], "centre": [9551, 9552]}},
    # the second scoring suite: t1 was raced after each round of selection and so became one; t2 is raced once,
    # when a recipe is chosen (docs/results/racing.md, "The suites and how often each was raced")
    "t2": {"minutes": 2.0, "lane_width": 0.9,
           "tracks": {"taped": [9701, 9702, 9703, 9704, 9705, 9706], "centre": [9751, 9752]}},
    # the third scoring suite, for the choice after t2's: raced once, when that recipe is chosen
    "t3": {"minutes": 2.0, "lane_width": 0.9,
           "tracks": {"taped": [9801, 9802, 9803, 9804, 9805, 9806], "centre": [9851, 9852]}},
}
FPS = 20.0
EXPERT = "expert"  # the label of the expert's reference laps (its drives: `expert_folder`)


@dataclass(frozen=True)
class TrackSuiteOptions(Options):
    """`steerlab sim bench --world track`."""

    suite: str = option("t1", lambda v: v in TRACK_SUITES, " or ".join(TRACK_SUITES), help="track suite version")
    minutes: float | None = option(None, MINUTES, help="minutes per track (default: the suite's, 2 for t1)")
    workers: int = option(2, WORKERS, help="tracks driven in parallel")
    smoothing: float | None = smoothing_option()
    steering_step: float | None = steering_step_option()
    styles: str | None = option(None, help="comma list of the suite's track styles to drive (default: all)")
    throttle: float | None = throttle_option()
    max_throttle: float = max_throttle_option()
    throttle_scale: float = throttle_scale_option()
    throttle_floor: float = throttle_floor_option()
    latency: int = latency_option()
    calibration: str | None = calibration_option()
    steer_by: Literal["steering", "lane"] = steer_by_option()
    throttle_by: Literal["model", "lane"] = throttle_by_option()
    lat_acc: float | None = lat_acc_option()

    @classmethod
    def related(cls, v):
        yield from frames_held(v, "minutes", fps=FPS)
        yield from throttle_held(v.max_throttle, v.throttle_floor)
        yield from pace_held(v)
        if v.suite in TRACK_SUITES:
            yield from names_held(v, "styles", TRACK_SUITES[v.suite]["tracks"], "track styles")

    @property
    def place_minutes(self) -> float:
        return TRACK_SUITES[self.suite]["minutes"] if self.minutes is None else self.minutes

    def drives(self) -> list[tuple[str, int]]:
        """(style, seed) of every track to drive."""
        tracks = TRACK_SUITES[self.suite]["tracks"]
        styles = names_from(self.styles, tracks, "track styles", f"suite {self.suite}") or list(tracks)
        return [(style, seed) for style in styles for seed in tracks[style]]

    def drive_options(self, style: str, seed: int) -> TrackDriveOptions:
        return TrackDriveOptions(seed=seed, minutes=self.place_minutes, fps=FPS, limit_m=0.0,
                                 lane_width=TRACK_SUITES[self.suite]["lane_width"], style=style,
                                 calibration=self.calibration, throttle=self.throttle, max_throttle=self.max_throttle,
                                 latency=self.latency, throttle_scale=self.throttle_scale,
                                 throttle_floor=self.throttle_floor, steer_by=self.steer_by,
                                 throttle_by=self.throttle_by, lat_acc=self.lat_acc)

    def expert_folder(self) -> str:
        """The folder of the expert's drives under this cap."""
        return f"{EXPERT}-max{self.max_throttle:g}"

    def record_options(self, style: str, seed: int) -> TrackRecordOptions:
        """The racing expert's recording of one track of the suite, to replay models on against their drives there
        (`run.record(..., suite_ok=True)`): the suite's track (its lane width and style) through this camera for
        the suite's minutes, without drift episodes."""
        return TrackRecordOptions(seed=seed, minutes=self.place_minutes, drift=False,
                                  lane_width=TRACK_SUITES[self.suite]["lane_width"], style=style,
                                  calibration=self.calibration)

    def key(self, entrant: Entrant) -> dict:
        """Everything that changes a drive's result besides its track: the pilot's identity, the suite
        version, minutes, smoothing, the constant throttle, the learned throttle's cap, the camera's calibration
        (its K and D), and where set the steering step, the latency, the throttle's scale and floor, what it
        steers by and what sets its throttle (drives made before they existed stay reusable)."""
        camera = None if self.calibration is None else list(astuple(camera_of(self.calibration)))
        return as_stored({**entrant.identity, "suite": self.suite,
                          "minutes": self.place_minutes, "smoothing": self.smoothing,
                          "throttle": constant_throttle(self.throttle),
                          "max_throttle": self.max_throttle, "camera": camera,
                          **when_set(self, "steering_step", "latency", "throttle_scale", "throttle_floor", "steer_by",
                                     "throttle_by", "lat_acc")})


@dataclass(frozen=True)
class SuiteDrive:
    """One drive of the suite, with the expert's lap times on the same track (under the same cap) and the pace,
    the mean clean lap over the expert's (None without a clean lap: the track is not finished): suite.csv's row."""

    label: str
    checkpoint: str
    style: str
    seed: int
    lap_m: float
    minutes: float
    laps_driven: float
    laps: int
    clean_laps: int
    best_lap_s: float | None
    mean_lap_s: float | None
    expert_best_lap_s: float | None
    expert_mean_lap_s: float | None
    pace: float | None
    off_track: int
    off_track_per_lap: float
    off_track_per_km: float
    autonomy: float
    distance_km: float
    mean_speed: float
    mean_abs_offset_m: float
    command_gamma_deg: float


@dataclass(frozen=True)
class SuiteSummary:
    """A checkpoint's drives of one style (or "all"): summary.csv's row. `finished`: the tracks with a clean lap, of
    `tracks`; `pace`: the mean of the drives' paces over the `pace_tracks` tracks that every checkpoint of the
    summary finished (None when there is none)."""

    label: str
    style: str
    tracks: int
    finished: int
    minutes: float
    distance_km: float
    laps: int
    clean_laps: int
    clean_pct: float | None
    off_track: int
    off_track_per_lap: float
    off_track_per_km: float
    autonomy: float
    pace: float | None
    pace_tracks: int
    command_gamma_deg: float


def checkpoint_pilot(checkpoint: str, o: TrackSuiteOptions):
    """steerlab's donkeycar part on `checkpoint`, as the suite races it (`run.checkpoint_pilot`)."""
    return run.checkpoint_pilot(checkpoint, o, DriveWith(o.smoothing, o.steering_step))


def part_entrant(label: str, model: str | Path, make_part: Callable) -> Entrant:
    """A donkeycar part as a pilot of the suite: `make_part()` makes the part (anything with `run(img_arr) ->
    (angle, throttle)`; a module-level function or a partial of one) and `model` is the file it drives with, whose
    sha256 is its identity. Its throttle reaches the car times the suite's `throttle_scale`, then capped at its
    `max_throttle`, at least its `throttle_floor` at rest (`race_part`)."""
    return Entrant(label, str(model), {"model_sha256": file_sha256(Path(model))},
                   partial(race_part, make_part, label, str(model)))


def race_part(make_part: Callable, name: str, source: str, o: TrackSuiteOptions) -> PartPilot:
    """The part of `make_part()` driving the track world's car under the suite's throttle scale, cap and floor."""
    if o.steer_by != "steering":
        raise SteerlabError(f"{source}: steer_by {o.steer_by} steers by a steerlab checkpoint's lane head; a "
                            "donkeycar part steers by its own angle: set steer_by to steering")
    if o.throttle_by != "model":
        raise SteerlabError(f"{source}: throttle_by {o.throttle_by} paces by a steerlab checkpoint's lane head; a "
                            "donkeycar part drives at its own throttle: set throttle_by to model")
    return PartPilot(make_part(), CARS["donkey"].full_lock_deg, name=name, source=source,
                     throttle=part_throttle(o))


def _job(entrant: Entrant | None, o: TrackSuiteOptions, style: str, seed: int, out: str, key: dict) -> TrackDrive:
    """One drive of the suite: an entrant's pilot, or (None) the racing expert."""
    d = o.drive_options(style, seed)
    if entrant is None:
        return drive_expert(out, d, on_tick=tick_reporter(), meta={"cache_key": key})
    pilot = entrant.make(o)
    try:
        if callable(getattr(pilot, "on_track", None)):  # a part set up for the track it drives (PartPilot.on_track)
            pilot.on_track(d)
        return run.drive(pilot, out, d, progress=False, on_tick=tick_reporter(), plot=False, meta={"cache_key": key})
    finally:
        close(pilot)


def run_suite(pilots, out: str | Path, o: TrackSuiteOptions = TrackSuiteOptions(), progress: bool = True,
              plots: bool = True) -> list[SuiteSummary]:
    """Drive every pilot (checkpoints, or `core.suite.Entrant`s: `part_entrant`) and the expert on every track of
    the suite (or of the styles in `o.styles`); write `suite.csv`, `summary.csv`, `suite.md` and, with `plots`,
    `tracks/<style>-<seed>.png`. Returns the summary rows."""
    return report(race(pilots, out, o, progress), out, o, plots)


def race(pilots, out: str | Path, o: TrackSuiteOptions, progress: bool = True) -> list[SuiteDrive]:
    """Every pilot's drive of every track of the suite, with the expert's on the same track (under the same
    cap): drives kept in `out/<label>/<style>-<seed>/` and reused."""
    racing = entrants(pilots, checkpoint_pilot)
    check_outputs({"output folder": out}, inputs=[e.source for e in racing], kind="suite")
    check_world_of(out, "track", "road", "road_type")
    tracks, out = o.drives(), Path(out)
    taken = [e.source for e in racing if e.label.startswith(EXPERT)]
    if taken:
        raise SteerlabError(f"{taken[0]}: its label begins with {EXPERT!r}, as the folders of the expert's drives do; "
                            "name it otherwise (its run folder)")
    checkpoints = {e.source: learns_throttle(e.source) for e in racing if "checkpoint_sha256" in e.identity}
    if o.throttle is not None and checkpoints and all(checkpoints.values()):
        raise SteerlabError(f"the throttle {o.throttle:g} (steerlab sim bench --throttle) is the constant throttle "
                            "of a model that predicts none; every checkpoint here learned its own: leave it out "
                            "(throttle_scale, max_throttle and throttle_floor shape a learned throttle)")
    shaping = Throttle(constant_throttle(o.throttle), o.throttle_scale, o.max_throttle, o.throttle_floor)
    for checkpoint, learned in checkpoints.items():  # before any drive: as its part on the car would refuse it
        shaping.for_model(learned, checkpoint)
    expert_key = as_stored({"suite": o.suite, "minutes": o.place_minutes, "max_throttle": o.max_throttle})
    runs = [(o.expert_folder(), None, expert_key), *((e.label, e, o.key(e)) for e in racing)]
    planned = [Planned((label, seed), out / label / f"{style}-{seed}", key,
                       (entrant, o, style, seed, str(out / label / f"{style}-{seed}"), key))
               for label, entrant, key in runs for style, seed in tracks]
    rows = run_drives(_job, TrackDrive, planned, o.workers, frames_in(o.place_minutes, FPS), progress,
                      f"track suite {o.suite}")
    return [drive_row(rows[(e.label, seed)], rows[(o.expert_folder(), seed)], e.label, e.source, style, seed)
            for e in racing for style, seed in tracks]


def report(drives: list[SuiteDrive], out: str | Path, o: TrackSuiteOptions, plots: bool = True) -> list[SuiteSummary]:
    """The suite's tables of `drives` (every label over the same tracks: `summarize`) in `out`: `suite.csv`,
    `summary.csv`, `suite.md` and, with `plots`, `tracks/<style>-<seed>.png`. Returns the summary rows."""
    out = Path(out)
    summary = summarize(drives)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "suite.csv", drives)
    write_csv(out / "summary.csv", summary)
    (out / "suite.md").write_text(markdown(summary, drives, o))
    if plots:
        from steerlab.sim.track.plots import plot_tracks  # matplotlib: imported where it draws

        plot_tracks(out, drives, TRACK_SUITES[o.suite]["lane_width"], o.expert_folder())
    return summary


def drive_row(r: TrackDrive, expert: TrackDrive, label: str, checkpoint: str, style: str, seed: int) -> SuiteDrive:
    """A drive's row of suite.csv, with the expert's lap times on the same track and the pace, the ratio of the
    mean clean lap times (None without a clean lap)."""
    ratio = None if r.mean_lap_s is None or expert.mean_lap_s is None else r.mean_lap_s / expert.mean_lap_s
    return SuiteDrive(label=label, checkpoint=checkpoint, style=style, seed=seed, lap_m=r.lap_m, minutes=r.minutes,
                      laps_driven=r.laps_driven, laps=r.laps, clean_laps=r.clean_laps, best_lap_s=r.best_lap_s,
                      mean_lap_s=r.mean_lap_s, expert_best_lap_s=expert.best_lap_s,
                      expert_mean_lap_s=expert.mean_lap_s, pace=ratio, off_track=r.off_track,
                      off_track_per_lap=r.off_track_per_lap, off_track_per_km=r.off_track_per_km, autonomy=r.autonomy,
                      distance_km=r.distance_km, mean_speed=r.mean_speed, mean_abs_offset_m=r.mean_abs_offset_m,
                      command_gamma_deg=r.command_gamma_deg)


def summarize(drives: list[SuiteDrive]) -> list[SuiteSummary]:
    """Per label and style (and "all"), every label over the same tracks: laps and clean laps, tracks finished (a
    clean lap), off-track events per lap (over the laps driven, fractions included) and per km, autonomy over the
    summed time, the mean pace over the tracks that every label finished, and the mean command gamma."""
    finished = {}  # (style or "all") -> the tracks every label finished
    for label, style, ds in grouped(drives, "style"):
        mine = {(d.style, d.seed) for d in ds if d.pace is not None}
        finished[style] = mine if style not in finished else finished[style] & mine
    out = []
    for label, style, ds in grouped(drives, "style"):
        n = sum(d.off_track for d in ds)
        km = sum(d.distance_km for d in ds)
        laps, clean = sum(d.laps for d in ds), sum(d.clean_laps for d in ds)
        laps_driven = sum(d.laps_driven for d in ds)
        seconds = sum(d.minutes * 60 for d in ds)
        paces = [d.pace for d in ds if (d.style, d.seed) in finished[style]]
        out.append(SuiteSummary(
            label=label, style=style, tracks=len(ds), finished=sum(d.pace is not None for d in ds),
            minutes=seconds / 60, distance_km=km, laps=laps, clean_laps=clean,
            clean_pct=100 * clean / laps if laps else None, off_track=n, off_track_per_lap=n / max(laps_driven, 1e-9),
            off_track_per_km=n / max(km, 1e-9), autonomy=autonomy(n, seconds),
            pace=float(np.mean(paces)) if paces else None, pace_tracks=len(paces),
            command_gamma_deg=float(np.mean([d.command_gamma_deg for d in ds]))))
    return out


def closed_loop_metrics(checkpoint: Path, o: TrackSuiteOptions, progress: bool, plots: bool = True) -> dict:
    """A checkpoint on the track suite (drives kept in the `suite` folder beside it): autonomy over all tracks and
    per style, clean laps in % of the laps (NaN without a lap), the pace (NaN without a finished track), off-track
    events per lap and command gamma."""
    summary = run_suite([checkpoint], checkpoint.parent / "suite", o, progress=progress, plots=plots)
    a = next(s for s in summary if s.style == "all")
    return {**{f"autonomy_{s.style}": s.autonomy for s in summary}, "autonomy": a.autonomy,
            "clean_laps_pct": math.nan if a.clean_pct is None else a.clean_pct,
            "lap_ratio": math.nan if a.pace is None else a.pace, "off_track_per_lap": a.off_track_per_lap,
            "command_gamma_deg": a.command_gamma_deg}


def round_columns(summary: list[SuiteSummary]) -> dict:
    """A DAgger round's columns of dagger.csv, over all the suite's tracks: clean laps in % of the laps completed
    (empty without a lap), the pace over the tracks it finished (empty without a clean lap) and off-track events per
    lap driven."""
    a = next(s for s in summary if s.style == "all")
    return {"clean_laps_pct": "" if a.clean_pct is None else a.clean_pct,
            "lap_ratio": "" if a.pace is None else a.pace, "off_track_per_lap": a.off_track_per_lap}


def _num(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def markdown(summary: list[SuiteSummary], drives: list[SuiteDrive], o: TrackSuiteOptions) -> str:
    scaled = "" if o.throttle_scale == 1 else f" (the learned one times {o.throttle_scale:g} first)"
    if o.throttle_floor:
        scaled += f", at least {min(o.throttle_floor, o.max_throttle):g} while the car stands"
    lines = [f"Track suite {o.suite}: {o.place_minutes:g} min per track, {TRACK_SUITES[o.suite]['lane_width']:g} m "
             f"lanes, the learned throttle and the expert's capped at {o.max_throttle:g}{scaled}, constant throttle "
             f"{constant_throttle(o.throttle):g} for models that predict none. A lap is clean without an off-track "
             "event (the first starts standing); a track is finished with a clean lap; pace: mean clean lap over the "
             "expert's on the same track, the summary's over the tracks every checkpoint finished (their number "
             "beside it); autonomy = (1 - off-track events x 6 s / elapsed s) x 100.", "",
             "| checkpoint | style | finished | laps | clean laps | clean [%] | off track | off track / lap | "
             "off track / km | autonomy [%] | pace (tracks) | km | command gamma [deg] |", "|---" * 13 + "|"]
    for r in summary:
        lines.append(f"| {r.label} | {r.style} | {r.finished} of {r.tracks} | {r.laps} | {r.clean_laps} | "
                     f"{_num(r.clean_pct, '.1f')} | {r.off_track} | {r.off_track_per_lap:.2f} | "
                     f"{r.off_track_per_km:.1f} | {r.autonomy:.1f} | {_num(r.pace, '.2f')} ({r.pace_tracks}) | "
                     f"{r.distance_km:.2f} | {r.command_gamma_deg:.3f} |")
    tracks = list(dict.fromkeys((d.style, d.seed) for d in drives))
    expert = {(d.style, d.seed): d.expert_mean_lap_s for d in drives}
    lines += ["", "Per track: clean laps / laps, pace or not finished, off-track events.", "",
              "| checkpoint | " + " | ".join(f"{style}-{seed}" for style, seed in tracks) + " |",
              "|---" * (1 + len(tracks)) + "|",
              "| expert: mean lap [s] | " + " | ".join(_num(expert[t], ".2f") for t in tracks) + " |"]
    for label in dict.fromkeys(d.label for d in drives):
        cells = {(d.style, d.seed): f"{d.clean_laps}/{d.laps}, {'not finished' if d.pace is None else f'{d.pace:.2f}'}"
                 f", {d.off_track}" for d in drives if d.label == label}
        lines.append(f"| {label} | " + " | ".join(cells[t] for t in tracks) + " |")
    return "\n".join(lines) + "\n"
