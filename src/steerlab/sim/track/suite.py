"""The track suite (`steerlab sim bench --world track`): every checkpoint races one fixed, versioned set of unseen
tracks, through the donkeycar part, for a fixed time each; laps are the measure.

The tracks of a suite version never change (seed, lane width and style), and their seeds lie in 9000-9999, which
`sim record --world track` refuses, so no model has seen them. Each track is also driven once by the racing
expert (no drift episodes, from the car's state, without a camera): its lap times are the reference a model's
are put against. Drives run in parallel worker processes; a finished drive is reused when the suite runs again
with the same cache key (`core.suite`): the checkpoint's content hash, suite version, minutes, smoothing, the
constant throttle, the learned throttle's cap and the camera (`TrackSuiteOptions.key`); the expert's drives with
the same suite version and minutes.

Per drive (`suite.csv`) and per checkpoint and style and over all tracks (`summary.csv`, `suite.md`): laps
completed, clean laps (no off-track event), best and mean clean lap time against the expert's on the same track
(a summary takes the mean of the drives' ratios), off-track events per lap and per km, and NVIDIA's autonomy,
(1 - events x 6 s / elapsed s) x 100. `tracks/<style>-<seed>.png` draws every checkpoint's line on each track.
"""

from __future__ import annotations

from dataclasses import astuple, dataclass
from pathlib import Path

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.options import MINUTES, Options, WORKERS, frames_held, names_from, names_held, option
from steerlab.paths import check_outputs
from steerlab.pilot import smoothing_option
from steerlab.sim.core.driving import autonomy
from steerlab.sim.core.parallel import tick_reporter
from steerlab.sim.core.suite import (Planned, as_stored, checkpoints_to_drive, file_sha256, grouped, run_drives,
                                     write_csv)
from steerlab.sim.track.run import TrackDrive, drive_checkpoint, drive_expert
from steerlab.sim.track.world import (TrackDriveOptions, calibration_option, camera_of, max_throttle_option,
                                      throttle_option)

TRACK_SUITES = {
    # 8 tracks of 2 minutes, 0.9 m lanes: six taped, two with a painted centre line (28-54 m laps; the expert
    # laps them in 8-17 s, a model at the default throttle in about twice that)
    "t1": {"minutes": 2.0, "lane_width": 0.9,
           "tracks": {"taped": [9401, 9402, 9403, 9404, 9405, 9406], "centre": [9451, 9452]}},
}
FPS = 20.0
EXPERT = "expert"  # the folder of the expert's drives


@dataclass(frozen=True)
class TrackSuiteOptions(Options):
    """`steerlab sim bench --world track`."""

    suite: str = option("t1", lambda v: v in TRACK_SUITES, " or ".join(TRACK_SUITES), help="track suite version")
    minutes: float | None = option(None, MINUTES, help="minutes per track (default: the suite's, 2 for t1)")
    workers: int = option(2, WORKERS, help="tracks driven in parallel")
    smoothing: float | None = smoothing_option()
    styles: str | None = option(None, help="comma list of the suite's track styles to drive (default: all)")
    throttle: float = throttle_option()
    max_throttle: float = max_throttle_option()
    calibration: str | None = calibration_option()

    @classmethod
    def related(cls, v):
        yield from frames_held(v, "minutes", fps=FPS)
        if v.suite in TRACK_SUITES:
            yield from names_held(v, "styles", TRACK_SUITES[v.suite]["tracks"], "track styles")

    @property
    def track_minutes(self) -> float:
        return TRACK_SUITES[self.suite]["minutes"] if self.minutes is None else self.minutes

    def drives(self) -> list[tuple[str, int]]:
        """(style, seed) of every track to drive."""
        tracks = TRACK_SUITES[self.suite]["tracks"]
        styles = names_from(self.styles, tracks, "track styles", f"suite {self.suite}") or list(tracks)
        return [(style, seed) for style in styles for seed in tracks[style]]

    def drive_options(self, style: str, seed: int) -> TrackDriveOptions:
        return TrackDriveOptions(seed, self.track_minutes, FPS, 0.0, TRACK_SUITES[self.suite]["lane_width"], style,
                                 self.calibration, self.throttle, self.max_throttle)

    def key(self, checkpoint: Path) -> dict:
        """Everything that changes a drive's result besides its track: the checkpoint's content, the suite
        version, minutes, smoothing, the constant throttle, the learned throttle's cap and the camera's calibration
        (its K and D)."""
        camera = None if self.calibration is None else list(astuple(camera_of(self.calibration)))
        return as_stored({"checkpoint_sha256": file_sha256(checkpoint), "suite": self.suite,
                          "minutes": self.track_minutes, "smoothing": self.smoothing, "throttle": self.throttle,
                          "max_throttle": self.max_throttle, "camera": camera})


@dataclass(frozen=True)
class SuiteDrive:
    """One drive of the suite, with the expert's lap times on the same track and the ratio of the mean clean lap
    times (None without a clean lap): suite.csv's row."""

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
    lap_ratio: float | None
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
    """A checkpoint's drives of one style (or "all"): summary.csv's row."""

    label: str
    style: str
    drives: int
    minutes: float
    distance_km: float
    laps: int
    clean_laps: int
    off_track: int
    off_track_per_lap: float
    off_track_per_km: float
    autonomy: float
    lap_ratio: float | None
    command_gamma_deg: float


def _job(checkpoint: str | None, o: TrackSuiteOptions, style: str, seed: int, out: str, key: dict) -> TrackDrive:
    """One drive of the suite: a checkpoint through the donkeycar part, or (None) the racing expert."""
    d = o.drive_options(style, seed)
    if checkpoint is None:
        return drive_expert(out, d, on_tick=tick_reporter(), meta={"cache_key": key})
    return drive_checkpoint(checkpoint, out, d, o.smoothing, progress=False, on_tick=tick_reporter(), plot=False,
                            meta={"cache_key": key})


def run_suite(checkpoints, out: str | Path, o: TrackSuiteOptions = TrackSuiteOptions(), progress: bool = True,
              plots: bool = True) -> list[SuiteSummary]:
    """Drive every checkpoint (and the expert) on every track of the suite (or of the styles in `o.styles`);
    write `suite.csv`, `summary.csv`, `suite.md` and, with `plots`, `tracks/<style>-<seed>.png`. Returns the
    summary rows."""
    checkpoints, labels = checkpoints_to_drive(checkpoints)
    check_outputs({"output folder": out}, inputs=checkpoints, kind="suite")
    tracks, out = o.drives(), Path(out)
    if EXPERT in labels:
        raise SteerlabError(f"{checkpoints[labels.index(EXPERT)]}: its label {EXPERT!r} is the folder of the "
                            "expert's drives; name it otherwise (its run folder)")
    expert_key = as_stored({"suite": o.suite, "minutes": o.track_minutes})
    runs = [(EXPERT, None, expert_key)] + [(label, str(c), o.key(c)) for label, c in zip(labels, checkpoints)]
    planned = [Planned((label, seed), out / label / f"{style}-{seed}", key,
                       (ckpt, o, style, seed, str(out / label / f"{style}-{seed}"), key))
               for label, ckpt, key in runs for style, seed in tracks]
    rows = run_drives(_job, TrackDrive, planned, o.workers, round(o.track_minutes * 60 * FPS), progress,
                      f"track suite {o.suite}")
    drives = [drive_row(rows[(label, seed)], rows[(EXPERT, seed)], label, ckpt, style, seed)
              for label, ckpt, _ in runs[1:] for style, seed in tracks]
    summary = summarize(drives)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "suite.csv", drives)
    write_csv(out / "summary.csv", summary)
    (out / "suite.md").write_text(markdown(summary, drives, o))
    if plots:
        from steerlab.sim.track.plots import plot_tracks  # matplotlib: imported where it draws

        plot_tracks(out, drives, TRACK_SUITES[o.suite]["lane_width"], EXPERT)
    return summary


def drive_row(r: TrackDrive, expert: TrackDrive, label: str, checkpoint: str, style: str, seed: int) -> SuiteDrive:
    """A drive's row of suite.csv, with the expert's lap times on the same track and the ratio of the mean
    clean lap times (None without a clean lap)."""
    ratio = None if r.mean_lap_s is None or expert.mean_lap_s is None else r.mean_lap_s / expert.mean_lap_s
    return SuiteDrive(label, checkpoint, style, seed, r.lap_m, r.minutes, r.laps_driven, r.laps, r.clean_laps,
                      r.best_lap_s, r.mean_lap_s, expert.best_lap_s, expert.mean_lap_s, ratio, r.off_track,
                      r.off_track_per_lap, r.off_track_per_km, r.autonomy, r.distance_km, r.mean_speed,
                      r.mean_abs_offset_m, r.command_gamma_deg)


def summarize(drives: list[SuiteDrive]) -> list[SuiteSummary]:
    """Per label and style (and "all"): laps and clean laps, off-track events per lap (over the laps driven,
    fractions included) and per km, autonomy over the summed time, the mean lap-time ratio to the expert over
    the drives with a clean lap (None without one) and the mean command gamma."""
    out = []
    for label, style, ds in grouped(drives, "style"):
        n = sum(d.off_track for d in ds)
        km = sum(d.distance_km for d in ds)
        laps_driven = sum(d.laps_driven for d in ds)
        seconds = sum(d.minutes * 60 for d in ds)
        ratios = [d.lap_ratio for d in ds if d.lap_ratio is not None]
        out.append(SuiteSummary(label, style, len(ds), seconds / 60, km, sum(d.laps for d in ds),
                                sum(d.clean_laps for d in ds), n, n / max(laps_driven, 1e-9), n / max(km, 1e-9),
                                autonomy(n, seconds), float(np.mean(ratios)) if ratios else None,
                                float(np.mean([d.command_gamma_deg for d in ds]))))
    return out


def round_columns(summary: list[SuiteSummary]) -> dict:
    """A DAgger round's columns of dagger.csv, over all the suite's tracks: clean laps in % of the laps completed
    (empty without a lap), the mean clean lap time over the expert's (empty without a clean lap) and off-track
    events per lap driven."""
    a = next(s for s in summary if s.style == "all")
    return {"clean_laps_pct": 100 * a.clean_laps / a.laps if a.laps else "",
            "lap_ratio": "" if a.lap_ratio is None else a.lap_ratio, "off_track_per_lap": a.off_track_per_lap}


def _num(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def markdown(summary: list[SuiteSummary], drives: list[SuiteDrive], o: TrackSuiteOptions) -> str:
    lines = [f"Track suite {o.suite}: {o.track_minutes:g} min per track, {TRACK_SUITES[o.suite]['lane_width']:g} m "
             f"lanes, constant throttle {o.throttle:g} for models that predict none; lap times are of clean laps "
             "(no off-track event), the first from a standing start; lap / expert: mean clean lap over the expert's "
             "on the same track; autonomy = (1 - off-track events x 6 s / elapsed s) x 100.", "",
             "| checkpoint | tracks | drives | km | laps | clean laps | off track | off track / lap | off track / km | "
             "autonomy [%] | lap / expert | command gamma [deg] |", "|---" * 12 + "|"]
    for r in summary:
        lines.append(f"| {r.label} | {r.style} | {r.drives} | {r.distance_km:.2f} | {r.laps} | {r.clean_laps} | "
                     f"{r.off_track} | {r.off_track_per_lap:.2f} | {r.off_track_per_km:.1f} | {r.autonomy:.1f} | "
                     f"{_num(r.lap_ratio, '.2f')} | {r.command_gamma_deg:.3f} |")
    lines += ["", "| checkpoint | track | lap [m] | laps | clean laps | best lap [s] | mean lap [s] | expert best / "
              "mean lap [s] | lap / expert | off track | autonomy [%] | mean speed [m/s] |", "|---" * 12 + "|"]
    for d in drives:
        lines.append(f"| {d.label} | {d.style}-{d.seed} | {d.lap_m:.1f} | {d.laps} | {d.clean_laps} | "
                     f"{_num(d.best_lap_s, '.2f')} | {_num(d.mean_lap_s, '.2f')} | "
                     f"{_num(d.expert_best_lap_s, '.2f')} / {_num(d.expert_mean_lap_s, '.2f')} | "
                     f"{_num(d.lap_ratio, '.2f')} | {d.off_track} | {d.autonomy:.1f} | {d.mean_speed:.2f} |")
    return "\n".join(lines) + "\n"
