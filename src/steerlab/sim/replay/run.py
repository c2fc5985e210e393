"""`steerlab replay`: checkpoints replayed in closed loop on a recording (`world.py`, and `track.py` for small
cars), in parallel worker processes, and the reports: `replay.csv` (one row per checkpoint), `segments.csv` (per
segment), `replay.md`, `replay.json`, `replay.png` (the offset along the route, interventions marked), `path.png`
(the human's path as rebuilt, seen from above: whether it looks like the road or track driven) and
`LABEL/trajectory.csv`. The options of each world's replay (`ReplayOptions` here, a world's flavour such as
`track.replay`) make the replay of a recording (`setup`) and refuse what they cannot replay (`check_pilot`)."""

from __future__ import annotations

import csv
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from steerlab.data.car import CARS
from steerlab.data.geometry import CAMERAS, with_overrides
from steerlab.data.readers import Source
from steerlab.data.recording import Recording
from steerlab.data.writer import RecordingWriter
from steerlab.errors import DataError, SteerlabError, warn
from steerlab.files import write_json
from steerlab.options import OFF_PATH, Options, Range, SPEED, WORKERS, option
from steerlab.paths import check_outputs
from steerlab.pilot import smoothing_option
from steerlab.sim.core.driving import Trajectory, autonomy, drive_loop, rollout
from steerlab.sim.core.parallel import run_parallel, tick_reporter
from steerlab.sim.core.suite import checkpoints_to_drive
from steerlab.sim.replay.path import human_road_wheel, replay_segments, replay_speed
from steerlab.sim.replay.world import MAX_HEADING_DEG, MOUNT_HEIGHT, PITCH, Replay, ReplaySetup

RESULT_FIELDS = ["checkpoint", "recording", "segment", "frames", "km", "seconds", "speed_mps", "speed_source",
                 "autonomy", "interventions", "interventions_per_km", "mean_offset_m", "max_offset_m",
                 "mean_heading_deg", "max_heading_deg", "gamma"]


@dataclass(frozen=True)
class ReplayOptions(Options):
    """`steerlab replay`'s options (the road world's replay: a car seen through a pinhole camera)."""

    speed: float | None = option(None, SPEED, help="speed in m/s (default: the recorded one, else estimated from "
                                 "the frames)")
    limit: float | None = option(None, OFF_PATH, help="road: metres off the human's path that count as an "
                                 "intervention (default: the car's: 1 for cars, 0.3 for donkeycars)")
    max_heading: float = option(MAX_HEADING_DEG, Range(1, 90, unit="degrees (not radians)"),
                                help="road: degrees of heading error beyond which the warped view is not trusted: "
                                "an intervention")
    mount_height: float | None = option(None, MOUNT_HEIGHT, help="camera height above the road, m (default: the "
                                        "geometry's)")
    pitch: float | None = option(None, PITCH, help="camera pitch, degrees down (default: the geometry's)")
    fov: float | None = option(None, Range(10, 180, hi_open=True, unit="degrees"),  # below 10: radians?
                               help="road: horizontal field of view, degrees (default: the geometry's)")
    workers: int = option(2, WORKERS, help="checkpoints replayed in parallel")
    smoothing: float | None = smoothing_option()

    def setup(self, rec: Recording) -> ReplaySetup:
        """The road replay of `rec`: its camera (with these options' mount and field of view), car and speed."""
        cam = with_overrides(CAMERAS[rec.geometry], self.mount_height, self.pitch, self.fov)
        car = CARS[rec.geometry]
        speed, speed_source = replay_speed(rec, cam, car, self.speed)
        replay = Replay(cam, car, speed, self.limit, self.max_heading)
        return ReplaySetup(replay, speed_source, f"the car is more than {replay.limit:g} m off the human's path or "
                           f"turned more than {self.max_heading:g} deg from it", replay.limit, "intervention limit",
                           {"camera": asdict(cam), "limit_m": replay.limit})

    def check_pilot(self, pilot, checkpoint, rec: Recording) -> None:
        """A model that reads the speed, on a recording without one, gets the estimated constant speed: said."""
        if pilot.speed_history and rec.speed is None and self.speed is None:
            warn(f"{checkpoint} reads the speed; {rec.source} records none, so it gets the estimated constant speed")


def _job(checkpoint: str, label: str, source: Source, replay: Replay, video: str | None, out: str,
         smoothing: float | None) -> list[dict]:
    """One checkpoint on one recording (in a worker process): result rows, and the trajectory in `out`."""
    from steerlab.pilot import Pilot

    rec = source.open()
    rows, traj = replay_recording(Pilot(checkpoint, smoothing=smoothing), replay, rec, source.frames, video,
                                  on_tick=tick_reporter())
    Path(out).mkdir(parents=True, exist_ok=True)
    traj.write(Path(out) / "trajectory.csv")
    return [{"checkpoint": label, "recording": rec.name, **r} for r in rows]


def run_replay(checkpoints, source: Source, out: str | Path, o=ReplayOptions(), video: str | Path | None = None,
               progress: bool = True) -> list[dict]:
    """Replay every checkpoint on the recording of `source` (only its frames, if given, e.g. a validation
    split) as the options `o` of a world's replay make it (`ReplayOptions`, a world's flavour:
    `track.replay.TrackReplayOptions`); write the reports. Returns the rows of replay.csv."""
    from steerlab.pilot import Pilot

    checkpoints, names = checkpoints_to_drive(checkpoints)
    check_outputs({"output folder": out}, {"video": video}, [*checkpoints, source.data, source.labels], "replay")
    rec = source.open()
    if rec.geometry not in CAMERAS:
        raise DataError(rec.source, f"no camera geometry for its {rec.geometry!r} frames; replay knows "
                                    f"{', '.join(CAMERAS)}")
    setup = o.setup(rec)
    car = setup.replay.car
    for c in checkpoints:
        pilot = Pilot(c)
        if pilot.geometry != rec.geometry:
            raise SteerlabError(f"{c} was trained on the {pilot.geometry!r} camera geometry and {rec.source} has the "
                                f"{rec.geometry!r} geometry: replay it on recordings of its own camera")
        if not pilot.convention.matches(rec.convention):
            raise SteerlabError(f"{c} predicts {pilot.convention.describe()} steering and {rec.source} records "
                                f"{rec.convention.describe()} steering: the human's path and the model's steering "
                                "would be two cars; replay it on recordings of its own convention (the reader "
                                "options it was trained with)")
        o.check_pilot(pilot, c, rec)
        try:
            pilot.convention.to_road_wheel_left(0.0, car.steering_ratio)
        except SteerlabError as e:
            raise SteerlabError(f"{c}: its steering cannot become a wheel angle: {e}") from None
    human_road_wheel(rec, car)  # the path can be rebuilt
    segments = replay_segments(rec, source.frames)
    out = Path(out)
    videos = [None] * len(names) if video is None else (
        [str(video)] if len(names) == 1 else [str(Path(video).with_name(f"{Path(video).stem}-{n.replace('/', '-')}"
                                                                           f"{Path(video).suffix}")) for n in names])
    jobs = [(str(c), n, source, setup.replay, v, str(out / n), o.smoothing)
            for c, n, v in zip(checkpoints, names, videos)]
    results = run_parallel(_job, jobs, o.workers, sum(b - a for a, b in segments), progress, "replay")
    rows = [{**r, "speed_source": setup.speed_source} for rs in results for r in rs]
    out.mkdir(parents=True, exist_ok=True)
    for name, keep in (("replay.csv", lambda r: r["segment"] == "all"), ("segments.csv", lambda r: True)):
        with open(out / name, "w", newline="") as f:
            w = csv.DictWriter(f, RESULT_FIELDS)
            w.writeheader()
            w.writerows([{k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()}
                         for r in rows if keep(r)])
    whole = [r for r in rows if r["segment"] == "all"]
    (out / "replay.md").write_text(markdown(whole, setup.criterion, o.smoothing))
    from steerlab.sim.replay.plots import path_summary, plot_offsets, plot_paths  # matplotlib: where it draws

    paths = [p for _, _, p in setup.replay.paths(rec, source.frames)]
    write_json(out / "replay.json", {"data": source.data, "range": source.range, **setup.camera, "car": asdict(car),
                                     "smoothing": o.smoothing, "paths": [path_summary(p) for p in paths],
                                     "rows": rows})
    trajs = {n: Trajectory.read(out / n / "trajectory.csv") for n in names}
    plot_offsets(out / "replay.png", trajs, setup.plot_limit, f"replay on {rec.name}", setup.limit_label)
    plot_paths(out / "path.png", paths, trajs, rec.name)
    return whole


def replay_recording(pilot, replay: Replay, rec: Recording, frames: np.ndarray | None = None,
                     video: str | Path | None = None, progress: bool = False,
                     on_tick=None) -> tuple[list[dict], Trajectory]:
    """Replay every segment of `rec` (or of its `frames`) of at least MIN_SECONDS with `pilot`. Returns one
    result row per segment and one for the whole recording (segment "all"), and the trajectory of every tick
    with its segment and frame."""
    from steerlab.video import DriveVideo

    fps, ratio = rec.frame_rate(), replay.car.steering_ratio
    human = human_road_wheel(rec, replay.car)
    movie = DriveVideo(video, fps, reference="human") if video else None
    rows, traj = [], None
    for n, a, world, ticks in replay.worlds(rec, frames):
        pilot.reset()
        seen = []

        def on_step(t, world=world, a=a, n=n):
            seen.append(a + world.frame_index())
            if movie:
                movie.add(t.frame, t.model * ratio, human[seen[-1]] * ratio, t.offset,
                          f"{rec.name} segment {n}  frame {seen[-1]}  {world.state.v:4.1f} m/s")

        t = drive_loop(world, pilot, ticks, replay.limit, fps, on_step=on_step, desc=f"replay segment {n}",
                       progress=progress, on_tick=on_tick)
        t = replace(t, time_s=world.path.t[: len(t)] - world.path.t[0], segment=np.full(len(t), n),
                    frame=np.array(seen))
        rows.append(result(t, fps, str(n), ticks))
        traj = t if traj is None else traj.concat(t)
    if movie:
        movie.close()
    return [*rows, result(traj, fps, "all", sum(r["frames"] for r in rows))], traj


def rollout_recording(pilot, replay: Replay, rec: Recording, frames: np.ndarray | None, out: str | Path,
                      beta: float, seed: int, on_tick=None) -> dict:
    """DAgger in replay (`core.driving.rollout`) over `rec` (or its `frames`): the expert is
    `ReplayWorld.expert_steering` (back to the human's path), the views are recorded in the recording's own
    convention and camera geometry as a steerlab recording in `out`. A recording with side cameras gets them in
    the rollout too, warped from the recorded centre frame to the car's side-camera offset either side (training
    labels them as it labels recorded side cameras). Returns the drive's result row."""
    sides = {"left", "right"} <= set(rec.cameras) and replay.car.side_camera_offset_m
    writer = RecordingWriter(out, ["center", "left", "right"] if sides else ["center"], convention=rec.convention,
                             geometry=rec.geometry)
    fps = rec.frame_rate()
    worlds = [(world, ticks) for _, _, world, ticks in replay.worlds(rec, frames)]
    t = rollout(pilot, worlds, writer, rec.convention, beta, np.random.default_rng([seed, 7]), replay.limit, fps,
                on_tick)
    writer.close({"source": str(rec.source), "fps": fps, "beta": beta, "policy": pilot.name})
    return result(t, fps, "all", len(rec) if frames is None else len(frames))


def result(t: Trajectory, fps: float, segment: str, frames: int) -> dict:
    """A replay's result row: its distance, speed, interventions, offsets, heading errors and command gamma."""
    m = t.metrics(1.0 / fps)
    heading = np.degrees(np.abs(t.heading))
    return {"segment": segment, "frames": frames, "km": m.distance_km, "seconds": len(t) / fps,
            "speed_mps": float(t.speed.mean()), "autonomy": autonomy(m.interventions, len(t) / fps),
            "interventions": m.interventions, "interventions_per_km": m.interventions_per_km,
            "mean_offset_m": m.mean_abs_offset_m, "max_offset_m": m.max_abs_offset_m,
            "mean_heading_deg": float(heading.mean()), "max_heading_deg": float(heading.max()),
            "gamma": m.command_gamma_deg}


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
