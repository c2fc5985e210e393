"""Recording the racing expert in the track world (`steerlab sim record --world track`), letting a model drive it
(`steerlab sim drive --world track`) and rolling a model out with the expert labelling every visited frame (DAgger,
`dagger: {world: track}`), all through `driving.drive_loop`.

A recording is a donkeycar tub v2 by default, what a donkeycar owner's own driving gives: `user/angle` (the
servo command: the expert's road-wheel angle over the car's full lock, positive right) and `user/throttle` (the
expert's throttle) of every frame. A tub has no episode column, so the expert's drift-out stretches (it lets the
car drift towards a lane line, to show the recovery that follows) are written and marked deleted
(`deleted_indexes`), as an owner cuts their mistakes out with donkeycar's tub editor: neither donkeycar's training
nor steerlab's reader uses them, the recover frames that follow are kept, and each kept stretch after a cut is a
session of its own, so that no model's frame history spans a cut. steerlab's own layout (`layout="steerlab"`)
keeps every frame with its episode, lateral offset, heading error and curvature (training leaves drift-outs out
with `exclude_episodes: [drift-out]`), the steering in the tub's unit (normalized, positive right, with the
car's full lock) and the throttle split into throttle and brake. Both carry the camera (`fisheye`: its K, D and
mount, in the tub's manifest metadata or in recording.json), which replay reads.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import cv2
import numpy as np

from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera
from steerlab.data.recording import SteeringConvention
from steerlab.data.writer import RecordingWriter, TubWriter
from steerlab.errors import SteerlabError
from steerlab.sim.driving import Trajectory, check_steers, drive_loop
from steerlab.sim.track_world import (DRIFT_EVERY_S, RacerPilot, TrackDriveOptions, TrackRecordOptions, TrackWorld,
                                      camera_of, check_track_seed)
from steerlab.video import DriveVideo


def _ticks(minutes: float, fps: float) -> int:
    return int(round(minutes * 60 * fps))


def record_track(out: str | Path, o: TrackRecordOptions = TrackRecordOptions(), progress: bool = True, *,
                 suite_tracks_ok: bool = False) -> Path:
    """The racing expert on the track made from `o.seed` (with drift-and-recover episodes unless `o.drift` is
    false), written as a tub or a steerlab recording (see the module's docstring). Same options, same bytes.

    `suite_tracks_ok=True` is for evaluation recordings only (replay against the track suite; not in the CLI,
    never for training data): it allows the track suite's reserved seeds, so that the recording shows the
    suite's own track (give the suite's lane width and style)."""
    if not suite_tracks_ok:
        check_track_seed(o.seed)
    camera = camera_of(o.calibration)
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera)
    expert = RacerPilot(world, o.seed, DRIFT_EVERY_S if o.drift else None)
    car = world.car
    if o.layout == "tub":
        tub = TubWriter(out, car.full_lock_deg, metadata={"fisheye": asdict(camera)})

        def write(t):
            tub.add(t.frame, int(round(t.index * 1e9 / o.fps)), t.model, t.throttle,
                    deleted=expert.episode == "drift-out")
    else:
        convention = SteeringConvention("normalized", "right", car.full_lock)
        writer = RecordingWriter(out, ["center"], convention=convention, geometry="donkey")

        def write(t):
            writer.add({"center": t.frame}, {
                **world.record_row(t.index), "throttle": max(t.throttle, 0.0), "brake": max(-t.throttle, 0.0),
                "lateral_offset": t.offset, "heading_error": t.heading, "episode": expert.episode,
                "steering": float(convention.from_road_wheel_left(t.model, car.steering_ratio))})

    drive_loop(world, expert, _ticks(o.minutes, o.fps), 0.0, o.fps, on_step=write, desc=f"record track {o.seed}",
               progress=progress)
    if o.layout == "tub":
        return tub.close()
    return writer.close({"world": "track", "seed": o.seed, "lane_width": o.lane_width, "style": o.style,
                         "lap_m": world.track.length, "fps": o.fps, "minutes": o.minutes, "fisheye": asdict(camera)})


def check_camera(pilot) -> None:
    """A pilot that expects frames of another camera than the donkeycar's is refused before it drives."""
    if pilot.geometry not in (None, "donkey"):
        raise SteerlabError(f"{pilot.source}: model {pilot.name!r} was trained on the {pilot.geometry!r} camera; the "
                            "track world renders the donkeycar camera (160x120 fisheye): train it on a tub (steerlab "
                            "sim record --world track)")


def track_result(label: str, o: TrackDriveOptions, t: Trajectory, world: TrackWorld) -> dict:
    """A drive's laps and off-track events: laps completed and clean, best and mean clean lap time, every lap's
    time; off-track events, per lap driven (fractions of a lap count) and per km; NVIDIA's autonomy with an
    off-track event as the intervention; distance, mean speed, offsets and command gamma."""
    m = t.metrics(1.0 / o.fps)
    events = t.interventions
    laps_driven = world.laps.progress / world.track.length
    return {"label": label, "seed": o.seed, "style": o.style, "lane_width": o.lane_width, "lap_m": world.track.length,
            "minutes": o.minutes, "laps_driven": laps_driven, **world.laps.result(), "off_track": events,
            "off_track_per_lap": events / max(laps_driven, 1e-9), "off_track_per_km": m["interventions_per_km"],
            "autonomy": m["autonomy"], "distance_km": m["distance_km"], "mean_speed": float(np.mean(t.speed)),
            "mean_abs_offset_m": m["mean_abs_offset_m"], "max_abs_offset_m": m["max_abs_offset_m"],
            "command_gamma_deg": m["command_gamma_deg"]}


def drive_track(pilot, out: str | Path | None, o: TrackDriveOptions = TrackDriveOptions(),
                video: str | Path | None = None, progress: bool = True, on_tick=None, plot: bool = True,
                meta: dict | None = None) -> dict:
    """Closed loop on a track: each tick renders the car's fisheye frame, asks `pilot.step(frame, speed)` for
    controls and applies their steering (in `pilot.convention`) and throttle (a pilot without one drives at
    `o.throttle`). The body overhanging the lane edge by more than `o.limit_m` is an off-track event: the car is
    put back on the lane centre and `pilot.reset()` clears its memory. `on_tick(k)` is called every 100 ticks.
    With `out`: trajectory.csv, frames.png (a frame every 5 s), drive.json (`track_result` and `meta`) and, with
    `plot`, track.png (the driven line on the track)."""
    check_camera(pilot)
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera_of(o.calibration), o.throttle)
    check_steers(pilot, world.car)
    strip = []
    movie = DriveVideo(video, o.fps) if video else None
    room = o.lane_width / 2 - world.car.body.width / 2  # where the body meets a lane line on a straight
    events = 0

    def on_step(t):
        nonlocal events
        events += t.intervention
        if out is not None and t.index % int(o.fps * 5) == 0 and len(strip) < 12:
            strip.append(t.frame)
        if movie:
            movie.add(t.frame, t.model, t.expert, t.offset, f"track {o.seed}  lap {len(world.laps.crossings)}  "
                      f"{world.state.v:3.1f} m/s  off track {events}", limit=room)

    t = drive_loop(world, pilot, _ticks(o.minutes, o.fps), o.limit_m, o.fps, on_step=on_step,
                   desc=f"drive track {o.seed}", progress=progress, on_tick=on_tick)
    if movie:
        movie.close()
    result = track_result(pilot.name, o, t, world)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        t.write(out / "trajectory.csv")
        if plot:
            from steerlab.sim.plots import plot_track  # matplotlib: imported where it draws

            plot_track(out / "track.png", world.track, {pilot.name: t}, title(result))
        rows = [np.hstack(strip[k:k + 4]) for k in range(0, len(strip) - 3, 4)] or [np.hstack(strip)]
        cv2.imwrite(str(out / "frames.png"), np.vstack(rows))
        (out / "drive.json").write_text(json.dumps({**result, **(meta or {})}, indent=1))
    return result


def drive_expert(out: str | Path, o: TrackDriveOptions, on_tick=None, meta: dict | None = None) -> dict:
    """The racing expert (no drift episodes) on a track as `drive_track` drives a model, without rendering a
    frame (it reads the car's state): the reference laps of the track suite. Writes trajectory.csv and
    drive.json into `out`."""
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera=None)
    expert = RacerPilot(world, o.seed)
    t = drive_loop(world, expert, _ticks(o.minutes, o.fps), o.limit_m, o.fps, progress=False, on_tick=on_tick)
    result = track_result(expert.name, o, t, world)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t.write(out / "trajectory.csv")
    (out / "drive.json").write_text(json.dumps({**result, **(meta or {})}, indent=1))
    return result


def track_rollout(pilot, out: str | Path, seed: int, minutes: float, style: str = "taped", beta: float = 0.0,
                  camera: FisheyeCamera = DONKEY_FISHEYE, fps: float = 20.0, on_tick=None) -> dict:
    """DAgger's data collection in the track world: `pilot` races the track made from `seed` (`style`, the default
    lane width) for `minutes`, seen through `camera`, with off-track events as in `drive_track`, while with
    probability `beta` each tick the expert drives instead, steering and throttle. Every visited frame is written
    to a tub in `out` labelled with the expert's steering and throttle in its state (`TrackWorld.expert_controls`:
    the expert without lag, noise or drift episodes). Returns the drive's `track_result`."""
    check_track_seed(seed)
    check_camera(pilot)
    world = TrackWorld(seed, style=style, fps=fps, camera=camera)
    check_steers(pilot, world.car)
    tub = TubWriter(out, world.car.full_lock_deg, metadata={"fisheye": asdict(camera)})
    rng = np.random.default_rng([seed, 9])
    expert = {}

    def label(t):
        expert["controls"] = world.expert_controls()
        tub.add(t.frame, int(round(t.index * 1e9 / fps)), *expert["controls"])

    t = drive_loop(world, pilot, _ticks(minutes, fps), 0.0, fps, on_step=label, desc=f"rollout track {seed}",
                   progress=False, on_tick=on_tick,
                   choose=lambda t: expert["controls"] if rng.random() < beta else (t.model, t.throttle))
    tub.close()
    return track_result(pilot.name, TrackDriveOptions(seed, minutes, fps, style=style), t, world)


def title(r: dict) -> str:
    best = "no clean lap" if r["best_lap_s"] is None else f"best clean lap {r['best_lap_s']:.2f} s"
    return (f"{r['label']} on {r['style']} track {r['seed']} ({r['lap_m']:.1f} m lap): {r['laps']} laps, "
            f"{r['clean_laps']} clean, {best}, {r['off_track']} off track")
