"""`steerlab replay`: checkpoints replayed in closed loop on a recording (`sim/replay.py`), in parallel worker
processes, and the reports: `replay.csv` (one row per checkpoint), `segments.csv` (per segment), `replay.md`,
`replay.json`, `replay.png` (the offset along the route, interventions marked) and `LABEL/trajectory.csv`."""

from __future__ import annotations

import csv
import json
from dataclasses import asdict, dataclass
from pathlib import Path

from steerlab.data.car import CARS
from steerlab.data.geometry import CAMERAS, with_overrides
from steerlab.data.readers import Source
from steerlab.errors import DataError, SteerlabError, warn
from steerlab.pilot import smoothing_option
from steerlab.options import AT_LEAST_1, Options, POSITIVE, option
from steerlab.sim.bench import labels_for
from steerlab.sim.driving import Trajectory
from steerlab.sim.parallel import run_parallel, tick_reporter
from steerlab.sim.replay import MAX_HEADING_DEG, MOUNT_HEIGHT, PITCH, Replay, human_road_wheel, replay_recording, replay_segments, \
    replay_speed
from steerlab.sim.replay_track import TrackReplay, TrackReplayOptions, track_replay, world_of

RESULT_FIELDS = ["checkpoint", "recording", "segment", "frames", "km", "seconds", "speed_mps", "speed_source",
                 "autonomy", "interventions", "interventions_per_km", "mean_offset_m", "max_offset_m",
                 "mean_heading_deg", "max_heading_deg", "gamma"]
POSITIVE_WORDS = "positive and finite"


@dataclass(frozen=True)
class ReplayOptions(Options):
    """`steerlab replay`'s options."""

    speed: float | None = option(None, POSITIVE, POSITIVE_WORDS,
                                 help="speed in m/s (default: the recorded one, else estimated from the frames)")
    limit: float | None = option(None, POSITIVE, POSITIVE_WORDS, help="road: metres off the human's path that "
                                 "count as an intervention (default: the car's: 1 for cars, 0.3 for donkeycars)")
    max_heading: float = option(MAX_HEADING_DEG, POSITIVE, POSITIVE_WORDS, help="road: degrees of heading error "
                                "beyond which the warped view is not trusted: an intervention")
    mount_height: float | None = option(None, MOUNT_HEIGHT, help="camera height above the road, m (default: the "
                                        "geometry's)")
    pitch: float | None = option(None, PITCH, help="camera pitch, degrees down (default: the geometry's)")
    fov: float | None = option(None, POSITIVE, POSITIVE_WORDS,
                               help="road: horizontal field of view, degrees (default: the geometry's)")
    workers: int = option(2, AT_LEAST_1, help="checkpoints replayed in parallel")
    smoothing: float | None = smoothing_option()


def _job(checkpoint: str, label: str, source: Source, kind: type[Replay], replay: dict, video: str | None,
         out: str, smoothing: float | None) -> list[dict]:
    """One checkpoint on one recording (in a worker process): result rows, and the trajectory in `out`."""
    from steerlab.pilot import Pilot

    rec = source.open()
    rows, traj = replay_recording(Pilot(checkpoint, smoothing=smoothing), kind(rec, **replay, frames=source.frames),
                                  video, on_tick=tick_reporter())
    Path(out).mkdir(parents=True, exist_ok=True)
    traj.write(Path(out) / "trajectory.csv")
    return [{"checkpoint": label, "recording": rec.name, **r} for r in rows]


def run_replay(checkpoints, source: Source, out: str | Path, o: ReplayOptions | TrackReplayOptions = ReplayOptions(),
               video: str | Path | None = None, progress: bool = True) -> list[dict]:
    """Replay every checkpoint on the recording of `source` (only its frames, if given, e.g. a validation
    split): the road replay with `ReplayOptions`, the small cars' (`replay_track`) with `TrackReplayOptions`;
    write the reports. Returns the rows of replay.csv."""
    from steerlab.pilot import Pilot

    checkpoints = [Path(c) for c in checkpoints]
    for c in checkpoints:
        if not c.is_file():
            raise SteerlabError(f"{c}: checkpoint not found")
    names = labels_for(checkpoints)
    rec = source.open()
    if rec.geometry not in CAMERAS:
        raise DataError(rec.source, f"no camera geometry for its {rec.geometry!r} frames; replay knows "
                                    f"{', '.join(CAMERAS)}")
    track = isinstance(o, TrackReplayOptions)
    if track and world_of(rec) != "track":
        raise SteerlabError(f"{rec.source}: the track replay is for the donkey camera (donkeycar tubs, the track "
                            f"world's recordings), not the {rec.geometry!r} camera: replay it with --world road")
    if track:
        replay, speed_source = track_replay(rec, o)
    car = CARS[rec.geometry]
    for c in checkpoints:
        pilot = Pilot(c)
        if pilot.geometry != rec.geometry:
            raise SteerlabError(f"{c} was trained on the {pilot.geometry!r} camera geometry and {rec.source} has the "
                                f"{rec.geometry!r} geometry: replay it on recordings of its own camera")
        if not track and pilot.speed_history and rec.speed is None and o.speed is None:
            warn(f"{c} reads the speed; {rec.source} records none, so it gets the estimated constant speed")
        try:
            pilot.convention.to_road_wheel_left(0.0, car.steering_ratio)
        except SteerlabError as e:
            raise SteerlabError(f"{c}: its steering cannot become a wheel angle: {e}") from None
        if track and o.throttle == "model" and "throttle" not in pilot.targets:
            raise SteerlabError(f"{c} predicts no throttle: --throttle model needs a model that learned it "
                                "(train.throttle_weight)")
    human_road_wheel(rec, car)  # the path can be rebuilt
    segments = replay_segments(rec, source.frames)
    if track:
        kind = TrackReplay
        limit = o.lane_width / 2 - car.body.width / 2  # the offset at which the body meets a lane edge, straight on
        limit_label = "the body at the lane edge when parallel to the path (turned: sooner)"
        criterion = f"the car's body leaves the {o.lane_width:g} m lane around the human's path"
        camera = {"fisheye": asdict(replay["fisheye"]), "lane_width_m": o.lane_width}
    else:
        cam = with_overrides(CAMERAS[rec.geometry], o.mount_height, o.pitch, o.fov)
        speed, speed_source = replay_speed(rec, cam, car, o.speed)
        replay = {"cam": cam, "car": car, "speed": speed, "limit_m": o.limit, "max_heading_deg": o.max_heading}
        kind, limit = Replay, car.lane_limit_m if o.limit is None else o.limit
        limit_label = "intervention limit"
        criterion = (f"the car is more than {limit:g} m off the human's path or turned more than {o.max_heading:g} "
                     "deg from it")
        camera = {"camera": asdict(cam), "limit_m": limit}
    out = Path(out)
    videos = [None] * len(names) if video is None else (
        [str(video)] if len(names) == 1 else [str(Path(video).with_name(f"{Path(video).stem}-{n.replace('/', '-')}"
                                                                           f"{Path(video).suffix}")) for n in names])
    jobs = [(str(c), n, source, kind, replay, v, str(out / n), o.smoothing)
            for c, n, v in zip(checkpoints, names, videos)]
    results = run_parallel(_job, jobs, o.workers, sum(b - a for a, b in segments), progress, "replay")
    rows = [{**r, "speed_source": speed_source} for rs in results for r in rs]
    out.mkdir(parents=True, exist_ok=True)
    for name, keep in (("replay.csv", lambda r: r["segment"] == "all"), ("segments.csv", lambda r: True)):
        with open(out / name, "w", newline="") as f:
            w = csv.DictWriter(f, RESULT_FIELDS)
            w.writeheader()
            w.writerows([{k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows if keep(r)])
    whole = [r for r in rows if r["segment"] == "all"]
    (out / "replay.md").write_text(markdown(whole, criterion, o.smoothing))
    (out / "replay.json").write_text(json.dumps({"data": source.data, "range": source.range, **camera,
                                                 "car": asdict(car), "smoothing": o.smoothing, "rows": rows}, indent=1))
    from steerlab.sim.plots import plot_offsets  # matplotlib: imported where it draws, not with the options

    plot_offsets(out / "replay.png", {n: Trajectory.read(out / n / "trajectory.csv") for n in names}, limit,
                 f"replay on {rec.name}", limit_label)
    return whole


def markdown(rows: list[dict], criterion: str, smoothing: float | None = None) -> str:
    """replay.md: the table of `rows`, after a sentence on when an intervention is counted (`criterion`)."""
    smoothed = "" if smoothing is None else f" The steering is smoothed exponentially, a = {smoothing:g}."
    lines = [f"Closed-loop replay: an intervention when {criterion}; autonomy = (1 - interventions x 6 s / elapsed "
             f"s) x 100, negative when a short drive needs many.{smoothed}", "",
             "| checkpoint | recording | km | speed [m/s] | interventions | interventions/km | autonomy [%] | "
             "mean abs offset [m] | max abs offset [m] | mean abs heading [deg] | command gamma [deg] |",
             "|---" * 11 + "|"]
    for r in rows:
        lines.append(f"| {r['checkpoint']} | {r['recording']} | {r['km']:.2f} | {r['speed_mps']:.1f} "
                     f"({r['speed_source']}) | {r['interventions']} | {r['interventions_per_km']:.1f} | "
                     f"{r['autonomy']:.1f} | {r['mean_offset_m']:.3f} | {r['max_offset_m']:.3f} | "
                     f"{r['mean_heading_deg']:.2f} | {r['gamma']:.3f} |")
    return "\n".join(lines) + "\n"
