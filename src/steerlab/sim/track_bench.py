"""The track suite (`steerlab sim bench --world track`): every checkpoint races one fixed, versioned set of unseen
tracks, through the donkeycar part, for a fixed time each; laps are the measure.

The tracks of a suite version never change (seed, lane width and style), and their seeds lie in 9000-9999, which
`sim record --world track` refuses, so no model has seen them. Each track is also driven once by the racing
expert (no drift episodes, from the car's state, without a camera): its lap times are the reference a model's
are put against. Drives run in parallel worker processes (`run_parallel`); a finished drive is kept in its folder
and reused when the suite runs again with the same cache key: the checkpoint's content hash, suite version,
minutes, smoothing, the constant throttle, the learned throttle's cap and the camera (`TrackSuiteOptions.key`); the expert's drives with the
same suite version and minutes.

Per drive (`suite.csv`) and per checkpoint and style and over all tracks (`summary.csv`, `suite.md`): laps
completed, clean laps (no off-track event), best and mean clean lap time against the expert's on the same track
(a summary takes the mean of the drives' ratios), off-track events per lap and per km, and NVIDIA's autonomy,
(1 - events x 6 s / elapsed s) x 100. `tracks/<style>-<seed>.png` draws every checkpoint's line on each track.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import astuple, dataclass
from pathlib import Path

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_1, Options, POSITIVE, option
from steerlab.pilot import smoothing_option
from steerlab.sim.bench import grouped, labels_for, write_csv
from steerlab.sim.driving import Trajectory, autonomy
from steerlab.sim.parallel import run_parallel, tick_reporter
from steerlab.sim.track_world import (TrackDriveOptions, calibration_option, camera_of, max_throttle_option,
                                      throttle_option)

TRACK_SUITES = {
    # 8 tracks of 2 minutes, 0.9 m lanes: six taped, two with a painted centre line (28-54 m laps; the expert
    # laps them in 8-17 s, a model at the default throttle in about twice that)
    "t1": {"minutes": 2.0, "lane_width": 0.9,
           "tracks": {"taped": [9401, 9402, 9403, 9404, 9405, 9406], "centre": [9451, 9452]}},
}
FPS = 20.0
EXPERT = "expert"  # the folder of the expert's drives
DRIVE_FIELDS = ["label", "checkpoint", "style", "seed", "lap_m", "minutes", "laps_driven", "laps", "clean_laps",
                "best_lap_s", "mean_lap_s", "expert_best_lap_s", "expert_mean_lap_s", "lap_ratio", "off_track",
                "off_track_per_lap", "off_track_per_km", "autonomy", "distance_km", "mean_speed", "mean_abs_offset_m",
                "command_gamma_deg"]
SUMMARY_FIELDS = ["label", "style", "drives", "minutes", "distance_km", "laps", "clean_laps", "off_track",
                  "off_track_per_lap", "off_track_per_km", "autonomy", "lap_ratio", "command_gamma_deg"]


@dataclass(frozen=True)
class TrackSuiteOptions(Options):
    """`steerlab sim bench --world track`."""

    suite: str = option("t1", lambda v: v in TRACK_SUITES, " or ".join(TRACK_SUITES), help="track suite version")
    minutes: float | None = option(None, POSITIVE, "positive and finite",
                                   help="minutes per track (default: the suite's, 2 for t1)")
    workers: int = option(2, AT_LEAST_1, help="tracks driven in parallel")
    smoothing: float | None = smoothing_option()
    styles: str | None = option(None, help="comma list of the suite's track styles to drive (default: all)")
    throttle: float = throttle_option()
    max_throttle: float = max_throttle_option()
    calibration: str | None = calibration_option()

    @property
    def track_minutes(self) -> float:
        return TRACK_SUITES[self.suite]["minutes"] if self.minutes is None else self.minutes

    def drives(self) -> list[tuple[str, int]]:
        """(style, seed) of every track to drive."""
        tracks = TRACK_SUITES[self.suite]["tracks"]
        styles = list(tracks) if self.styles is None else [t.strip() for t in self.styles.split(",") if t.strip()]
        unknown = [t for t in styles if t not in tracks]
        if unknown or not styles:
            raise SteerlabError(f"suite {self.suite} has no {', '.join(unknown) or 'such'} tracks; choose styles "
                                f"of {', '.join(tracks)}")
        return [(style, seed) for style in styles for seed in tracks[style]]

    def drive_options(self, style: str, seed: int) -> TrackDriveOptions:
        return TrackDriveOptions(seed, self.track_minutes, FPS, 0.0, TRACK_SUITES[self.suite]["lane_width"], style,
                                 self.calibration, self.throttle, self.max_throttle)

    def key(self, checkpoint: Path) -> dict:
        """Everything that changes a drive's result besides its track: the checkpoint's content, the suite
        version, minutes, smoothing, the constant throttle, the learned throttle's cap and the camera's calibration
        (its K and D)."""
        with open(checkpoint, "rb") as f:
            digest = hashlib.file_digest(f, "sha256").hexdigest()
        camera = None if self.calibration is None else list(astuple(camera_of(self.calibration)))
        key = {"checkpoint_sha256": digest, "suite": self.suite, "minutes": self.track_minutes,
               "smoothing": self.smoothing, "throttle": self.throttle, "max_throttle": self.max_throttle,
               "camera": camera}
        return json.loads(json.dumps(key))  # as drive.json gives it back


def _job(checkpoint: str | None, o: TrackSuiteOptions, style: str, seed: int, out: str, key: dict) -> dict:
    """One drive of the suite: a checkpoint through the donkeycar part, or (None) the racing expert."""
    from steerlab.sim.part import donkey_pilot
    from steerlab.sim.track_run import drive_expert, drive_track

    d = o.drive_options(style, seed)
    if checkpoint is None:
        return drive_expert(out, d, on_tick=tick_reporter(), meta={"cache_key": key})
    return drive_track(donkey_pilot(checkpoint, o.throttle, o.smoothing, o.max_throttle), out, d, progress=False,
                       on_tick=tick_reporter(), plot=False, meta={"cache_key": key})


def _cached(done: Path, key: dict) -> dict | None:
    try:
        result = json.loads(done.read_text())
    except (OSError, ValueError):
        return None
    return result if isinstance(result, dict) and result.get("cache_key") == key else None


def run_track_suite(checkpoints, out: str | Path, o: TrackSuiteOptions = TrackSuiteOptions(), progress: bool = True,
                    plots: bool = True) -> list[dict]:
    """Drive every checkpoint (and the expert) on every track of the suite (or of the styles in `o.styles`);
    write `suite.csv`, `summary.csv`, `suite.md` and, with `plots`, `tracks/<style>-<seed>.png`. Returns the
    summary rows."""
    checkpoints = [Path(c) for c in checkpoints]
    if not checkpoints:
        raise SteerlabError("no checkpoint to drive: name at least one")
    for c in checkpoints:
        if not c.is_file():
            raise SteerlabError(f"{c}: checkpoint not found")
    tracks, out = o.drives(), Path(out)
    labels = labels_for(checkpoints)
    if EXPERT in labels:
        raise SteerlabError(f"{checkpoints[labels.index(EXPERT)]}: its label {EXPERT!r} is the folder of the "
                            "expert's drives; name it otherwise (its run folder)")
    expert_key = json.loads(json.dumps({"suite": o.suite, "minutes": o.track_minutes}))
    runs = [(EXPERT, None, expert_key)] + [(label, str(c), o.key(c)) for label, c in zip(labels, checkpoints)]
    jobs, rows = [], {}
    for label, ckpt, key in runs:
        for style, seed in tracks:
            folder = out / label / f"{style}-{seed}"
            cached = _cached(folder / "drive.json", key)
            if cached is not None:
                rows[(label, seed)] = cached
            else:
                jobs.append(((label, seed), (ckpt, o, style, seed, str(folder), key)))
    results = run_parallel(_job, [job for _, job in jobs], o.workers, round(o.track_minutes * 60 * FPS), progress,
                           f"track suite {o.suite}")
    rows.update({where: r for (where, _), r in zip(jobs, results)})
    drives = [drive_row(rows[(label, seed)], rows[(EXPERT, seed)], label, ckpt, style, seed)
              for label, ckpt, _ in runs[1:] for style, seed in tracks]
    summary = summarize(drives)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "suite.csv", DRIVE_FIELDS, drives)
    write_csv(out / "summary.csv", SUMMARY_FIELDS, summary)
    (out / "suite.md").write_text(markdown(summary, drives, o))
    if plots:
        plot_tracks(out, drives, o)
    return summary


def drive_row(r: dict, expert: dict, label: str, checkpoint: str, style: str, seed: int) -> dict:
    """A drive's row of suite.csv, with the expert's lap times on the same track and the ratio of the mean
    clean lap times (None without a clean lap)."""
    ratio = None if r["mean_lap_s"] is None or expert["mean_lap_s"] is None else r["mean_lap_s"] / expert["mean_lap_s"]
    return {**{k: r[k] for k in DRIVE_FIELDS if k in r}, "label": label, "checkpoint": checkpoint, "style": style,
            "seed": seed, "expert_best_lap_s": expert["best_lap_s"], "expert_mean_lap_s": expert["mean_lap_s"],
            "lap_ratio": ratio}


def summarize(drives: list[dict]) -> list[dict]:
    """Per label and style (and "all"): laps and clean laps, off-track events per lap (over the laps driven,
    fractions included) and per km, autonomy over the summed time, the mean lap-time ratio to the expert over
    the drives with a clean lap (None without one) and the mean command gamma."""
    out = []
    for label, style, ds in grouped(drives, "style"):
        n = sum(d["off_track"] for d in ds)
        km = sum(d["distance_km"] for d in ds)
        laps_driven = sum(d["laps_driven"] for d in ds)
        seconds = sum(d["minutes"] * 60 for d in ds)
        ratios = [d["lap_ratio"] for d in ds if d["lap_ratio"] is not None]
        out.append({"label": label, "style": style, "drives": len(ds), "minutes": seconds / 60, "distance_km": km,
                    "laps": sum(d["laps"] for d in ds), "clean_laps": sum(d["clean_laps"] for d in ds),
                    "off_track": n, "off_track_per_lap": n / max(laps_driven, 1e-9),
                    "off_track_per_km": n / max(km, 1e-9), "autonomy": autonomy(n, seconds),
                    "lap_ratio": float(np.mean(ratios)) if ratios else None,
                    "command_gamma_deg": float(np.mean([d["command_gamma_deg"] for d in ds]))})
    return out


def _num(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def markdown(summary: list[dict], drives: list[dict], o: TrackSuiteOptions) -> str:
    lines = [f"Track suite {o.suite}: {o.track_minutes:g} min per track, {TRACK_SUITES[o.suite]['lane_width']:g} m "
             f"lanes, constant throttle {o.throttle:g} for models that predict none; lap times are of clean laps "
             "(no off-track event), the first from a standing start; lap / expert: mean clean lap over the expert's "
             "on the same track; autonomy = (1 - off-track events x 6 s / elapsed s) x 100.", "",
             "| checkpoint | tracks | drives | km | laps | clean laps | off track | off track / lap | off track / km | "
             "autonomy [%] | lap / expert | command gamma [deg] |", "|---" * 12 + "|"]
    for r in summary:
        lines.append(f"| {r['label']} | {r['style']} | {r['drives']} | {r['distance_km']:.2f} | {r['laps']} | "
                     f"{r['clean_laps']} | {r['off_track']} | {r['off_track_per_lap']:.2f} | "
                     f"{r['off_track_per_km']:.1f} | {r['autonomy']:.1f} | {_num(r['lap_ratio'], '.2f')} | "
                     f"{r['command_gamma_deg']:.3f} |")
    lines += ["", "| checkpoint | track | lap [m] | laps | clean laps | best lap [s] | mean lap [s] | expert best / "
              "mean lap [s] | lap / expert | off track | autonomy [%] | mean speed [m/s] |", "|---" * 12 + "|"]
    for d in drives:
        lines.append(f"| {d['label']} | {d['style']}-{d['seed']} | {d['lap_m']:.1f} | {d['laps']} | "
                     f"{d['clean_laps']} | {_num(d['best_lap_s'], '.2f')} | {_num(d['mean_lap_s'], '.2f')} | "
                     f"{_num(d['expert_best_lap_s'], '.2f')} / {_num(d['expert_mean_lap_s'], '.2f')} | "
                     f"{_num(d['lap_ratio'], '.2f')} | {d['off_track']} | {d['autonomy']:.1f} | "
                     f"{d['mean_speed']:.2f} |")
    return "\n".join(lines) + "\n"


def plot_tracks(out: Path, drives: list[dict], o: TrackSuiteOptions) -> None:
    """One figure per track: the expert's and every checkpoint's line, off-track events marked."""
    from steerlab.sim.plots import plot_track
    from steerlab.sim.track import Track

    (out / "tracks").mkdir(exist_ok=True)
    for style, seed in dict.fromkeys((d["style"], d["seed"]) for d in drives):
        name = f"{style}-{seed}"
        trajs = {EXPERT: Trajectory.read(out / EXPERT / name / "trajectory.csv")}
        for d in drives:
            if (d["style"], d["seed"]) == (style, seed):
                trajs[f"{d['label']}: {d['clean_laps']}/{d['laps']} clean laps"] = Trajectory.read(
                    out / d["label"] / name / "trajectory.csv")
        plot_track(out / "tracks" / f"{name}.png", Track(seed, TRACK_SUITES[o.suite]["lane_width"], style), trajs,
                   f"{style} track {seed}")
