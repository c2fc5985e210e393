"""What is done in the track world: recording the racing expert (`steerlab sim record --world track`), letting a
model drive (`steerlab sim drive --world track`), the expert's reference laps of the suite, and rolling a model out
with the expert labelling every visited frame (DAgger's rollouts, `dagger: {world: track}`), all through
`core.driving.drive_loop`.

A recording is a donkeycar tub v2 by default, what a donkeycar owner's own driving gives: `user/angle` (the
servo command: the expert's road-wheel angle over the car's full lock, positive right) and `user/throttle` (the
expert's throttle) of every frame, and the lane the car is in (`lane/offset`, `lane/heading`,
`lane/curvature`: the values steerlab's layout records as lateral offset, heading error and curvature). A tub
has no episode column, so the expert's drift-out stretches (it lets the car drift towards a lane line, to show
the recovery that follows) are written and marked deleted (`deleted_indexes`), as an owner cuts their mistakes
out with donkeycar's tub editor: neither donkeycar's training nor steerlab's reader uses them, the recover
frames that follow are kept, and each kept stretch after a cut is a session of its own, so that no model's frame
history spans a cut. steerlab's own layout (`layout="steerlab"`)
keeps every frame with its episode, lateral offset, heading error and curvature (training leaves drift-outs out
with `exclude_episodes: [drift-out]`), the steering in the tub's unit (normalized, positive right, with the
car's full lock) and the throttle split into throttle and brake. Both carry the camera (`fisheye`: its K, D and
mount, in the tub's manifest metadata or in recording.json), which replay reads; a varied room's (`vary`) also
its look (`look`: what `look.Look.draw` drew, the jittered mount among it), its frames at the look's JPEG quality.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera, camera_fields
from steerlab.data.recording import SteeringConvention
from steerlab.data.writer import RecordingWriter, TubWriter
from steerlab.errors import SteerlabError
from steerlab.options import frames_in
from steerlab.pilot import DriveWith
from steerlab.sim.core.driving import Trajectory, check_steers, drive_loop
from steerlab.sim.core.parallel import tick_reporter
from steerlab.sim.core.plots import write_strip
from steerlab.sim.core.suite import check_seed, write_json
from steerlab.sim.track.look import LOOK, Look
from steerlab.sim.track.poses import record_poses
from steerlab.sim.track.world import (DRIFT_EVERY_S, RacerPilot, TrackDriveOptions, TrackRecordOptions, TrackWorld,
                                      camera_of, constant_throttle)
from steerlab.video import DriveVideo


@dataclass(frozen=True)
class TrackDrive:
    """A drive's result: the pilot's label, the track (seed, style, lane width, lap length) and minutes; its laps
    (`world.Laps`: laps driven in fractions, laps completed, clean ones, best and mean clean lap time, every lap's
    time, the laps with an off-track event); off-track events, per lap driven and per km; NVIDIA's autonomy with an
    off-track event as the intervention; distance, mean speed, offsets and command gamma."""

    label: str
    seed: int
    style: str
    lane_width: float
    lap_m: float
    minutes: float
    laps_driven: float
    laps: int
    clean_laps: int
    best_lap_s: float | None
    mean_lap_s: float | None
    lap_times_s: list[float]
    off_track_laps: list[int]
    off_track: int
    off_track_per_lap: float
    off_track_per_km: float
    autonomy: float
    distance_km: float
    mean_speed: float
    mean_abs_offset_m: float
    max_abs_offset_m: float
    command_gamma_deg: float


def record(out: str | Path, o: TrackRecordOptions = TrackRecordOptions(), progress: bool = True, *,
           suite_ok: bool = False) -> Path:
    """The racing expert on the track made from `o.seed` (with drift-and-recover episodes unless `o.drift` is
    false), written as a tub or a steerlab recording (see the module's docstring); with `o.poses`, frames from
    poses drawn around its line (`poses.record_poses`). Same options, same bytes.

    `suite_ok=True` is for evaluation recordings only (replay against the track suite, with the options of
    `TrackSuiteOptions.record_options`; not in the CLI, never for training data): it allows the track suite's
    reserved seeds, so that the recording shows the suite's own track."""
    if not suite_ok:
        check_seed(o.seed, "track")
    if o.poses:
        return record_poses(out, o, progress)
    camera, look = o.camera(), o.look()
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera, room=o.room, look=look)
    expert = RacerPilot(world, o.seed, DRIFT_EVERY_S if o.drift else None)
    car = world.car
    if o.layout == "tub":
        tub = TubWriter(out, car.full_lock_deg, metadata={"fisheye": camera_fields(camera), **look.metadata()},
                        quality=look.jpeg_quality, lane=True)

        def write(t):
            tub.add(t.frame, int(round(t.index * 1e9 / o.fps)), t.model, t.throttle,
                    deleted=expert.episode == "drift-out", lane=(t.offset, t.heading, world.lane_curvature()))
    else:
        convention = SteeringConvention("normalized", "right", car.full_lock)
        writer = RecordingWriter(out, ["center"], convention=convention, geometry="donkey", quality=look.jpeg_quality)

        def write(t):
            writer.add({"center": t.frame}, {
                **world.record_row(t.index), "throttle": max(t.throttle, 0.0), "brake": max(-t.throttle, 0.0),
                "lateral_offset": t.offset, "heading_error": t.heading, "episode": expert.episode,
                "steering": float(convention.from_road_wheel_left(t.model, car.steering_ratio))})

    drive_loop(world, expert, frames_in(o.minutes, o.fps), 0.0, o.fps, on_step=write, desc=f"record track {o.seed}",
               progress=progress)
    if o.layout == "tub":
        return tub.close()
    return writer.close({"world": "track", "seed": o.seed, "room": o.room, "lane_width": o.lane_width,
                         "style": o.style, "lap_m": world.track.length, "fps": o.fps, "minutes": o.minutes,
                         "fisheye": camera_fields(camera), **look.metadata()})


def check_camera(pilot) -> None:
    """A pilot that expects frames of another camera than the donkeycar's is refused before it drives."""
    if pilot.geometry not in (None, "donkey"):
        raise SteerlabError(f"{pilot.source}: model {pilot.name!r} was trained on the {pilot.geometry!r} camera; the "
                            "track world renders the donkeycar camera (160x120 fisheye): train it on a tub (steerlab "
                            "sim record --world track)")


def result_of(label: str, o: TrackDriveOptions, t: Trajectory, world: TrackWorld) -> TrackDrive:
    """A drive's `TrackDrive` from its trajectory and the world's laps (laps driven: fractions of a lap count)."""
    m = t.metrics(1.0 / o.fps)
    laps_driven = world.laps.progress / world.track.length
    return TrackDrive(label=label, seed=o.seed, style=o.style, lane_width=o.lane_width, lap_m=world.track.length,
                      minutes=o.minutes, laps_driven=laps_driven, **world.laps.result(), off_track=m.interventions,
                      off_track_per_lap=m.interventions / max(laps_driven, 1e-9),
                      off_track_per_km=m.interventions_per_km, autonomy=m.autonomy, distance_km=m.distance_km,
                      mean_speed=float(np.mean(t.speed)), mean_abs_offset_m=m.mean_abs_offset_m,
                      max_abs_offset_m=m.max_abs_offset_m, command_gamma_deg=m.command_gamma_deg)


def drive(pilot, out: str | Path | None, o: TrackDriveOptions = TrackDriveOptions(),
                video: str | Path | None = None, progress: bool = True, on_tick=None, plot: bool = True,
                meta: dict | None = None, on_step=None) -> TrackDrive:
    """Closed loop on a track: each tick renders the car's fisheye frame, asks `pilot.step(frame, speed)` for
    controls and applies their steering (in `pilot.convention`) and throttle (a pilot without one drives at
    `o.throttle`). The body overhanging the lane edge by more than `o.limit_m` is an off-track event: the car is
    put back on the lane centre and `pilot.reset()` clears its memory. `on_tick(k)` is called every 100 ticks,
    `on_step(tick)` every tick (`sim.core.driving.Tick`: the world as the frame was rendered). With `out`:
    trajectory.csv, frames.png (a frame every 5 s), drive.json (the result and `meta`) and, with `plot`, track.png
    (the driven line on the track)."""
    check_camera(pilot)
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera_of(o.calibration), constant_throttle(o.throttle),
                       look=LOOK if o.light is None else Look(light=o.light))
    check_steers(pilot, world.car)
    strip = []
    movie = DriveVideo(video, o.fps) if video else None
    room = o.lane_width / 2 - world.car.body.width / 2  # where the body meets a lane line on a straight
    events = 0

    def step(t):
        nonlocal events
        if on_step:
            on_step(t)
        events += t.intervention
        if out is not None and t.index % int(o.fps * 5) == 0 and len(strip) < 12:
            strip.append(t.frame)
        if movie:
            movie.add(t.frame, t.model, t.expert, t.offset, f"track {o.seed}  lap {len(world.laps.crossings)}  "
                      f"{world.state.v:3.1f} m/s  off track {events}", limit=room)

    t = drive_loop(world, pilot, frames_in(o.minutes, o.fps), o.limit_m, o.fps, on_step=step,
                   desc=f"drive track {o.seed}", progress=progress, on_tick=on_tick, latency=o.latency)
    if movie:
        movie.close()
    result = result_of(pilot.name, o, t, world)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        t.write(out / "trajectory.csv")
        if plot:
            from steerlab.sim.track.plots import plot_track  # matplotlib: imported where it draws

            plot_track(out / "track.png", world.track, {pilot.name: t}, title(result))
        write_strip(out / "frames.png", strip)
        write_json(out / "drive.json", result, meta)
    return result


def checkpoint_pilot(checkpoint: str | Path, o, w: DriveWith = DriveWith()):
    """steerlab's donkeycar part on `checkpoint` (`core.part.donkey_pilot`) as the options `o` of a drive or a suite
    race it: the constant throttle `o.throttle` for a model that predicts none (refused for one that learned the
    throttle), its learned throttle times `o.throttle_scale` capped at `o.max_throttle` (at least `o.throttle_floor`
    while the car stands), its steering shaped as `w` says; with `o.steer_by` lane, steering by the lane its model's
    lane head sees (`donkey.SteerlabPilot(steer_by="lane")`); with `o.throttle_by` lane, at that lane's pace."""
    from steerlab.sim.core.part import donkey_pilot

    pilot = donkey_pilot(checkpoint, constant_throttle(o.throttle), w.smoothing, o.max_throttle,
                         steering_step=w.steering_step, throttle_scale=o.throttle_scale,
                         throttle_floor=o.throttle_floor, steer_by=o.steer_by, throttle_by=o.throttle_by,
                         lat_acc=o.lat_acc)
    if o.throttle is not None and pilot.part.learned:
        raise SteerlabError(f"{checkpoint} learned the throttle; the throttle {o.throttle:g} (steerlab sim drive "
                            "--throttle) is the constant throttle of a model that predicts none: leave it out "
                            "(throttle_scale, max_throttle and throttle_floor shape a learned throttle)")
    return pilot


def drive_checkpoint(checkpoint: str | Path, out: str | Path | None, o: TrackDriveOptions, w: DriveWith = DriveWith(),
                     video: str | Path | None = None, progress: bool = True, on_tick=None, plot: bool = True,
                     meta: dict | None = None) -> TrackDrive:
    """`drive` with steerlab's donkeycar part on `checkpoint` (`checkpoint_pilot`)."""
    return drive(checkpoint_pilot(checkpoint, o, w), out, o, video, progress, on_tick, plot, meta)


def drive_expert(out: str | Path, o: TrackDriveOptions, on_tick=None, meta: dict | None = None) -> TrackDrive:
    """The racing expert (no drift episodes) on a track as `drive` drives a model, its throttle capped at
    `o.max_throttle` as a model's is, without rendering a frame (it reads the car's state): the reference laps of
    the track suite. Writes trajectory.csv and drive.json into `out`."""
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera=None)
    expert = RacerPilot(world, o.seed, max_throttle=o.max_throttle)
    t = drive_loop(world, expert, frames_in(o.minutes, o.fps), o.limit_m, o.fps, progress=False, on_tick=on_tick)
    result = result_of(expert.name, o, t, world)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t.write(out / "trajectory.csv")
    write_json(out / "drive.json", result, meta)
    return result


def rollout(pilot, out: str | Path, seed: int, minutes: float, style: str = "taped", beta: float = 0.0,
            camera: FisheyeCamera = DONKEY_FISHEYE, fps: float = 20.0, on_tick=None, max_throttle: float = 1.0,
            latency: int = 0) -> TrackDrive:
    """DAgger's data collection in the track world: `pilot` races the track made from `seed` (`style`, the default
    lane width) for `minutes`, seen through `camera`, with off-track events as in `drive`, while with
    probability `beta` each tick the expert drives instead, steering and throttle. Every visited frame is written
    to a tub in `out` labelled with the expert's steering and throttle in its state (`TrackWorld.expert_controls`:
    the expert without lag, noise or drift episodes), its throttle capped at `max_throttle` as the car's is: labels
    the car can follow at the speed and cap it drives with. `latency`: the pilot steers on the frame of that many
    ticks before (train with `train.target_shift_s` to match). Returns the drive's result."""
    check_seed(seed, "track")
    check_camera(pilot)
    world = TrackWorld(seed, style=style, fps=fps, camera=camera)
    check_steers(pilot, world.car)
    tub = TubWriter(out, world.car.full_lock_deg, metadata={"fisheye": camera_fields(camera)})
    rng = np.random.default_rng([seed, 9])
    expert = {}

    def label(t):
        wheel, throttle = world.expert_controls()
        expert["controls"] = (wheel, float(np.clip(throttle, -max_throttle, max_throttle)))
        tub.add(t.frame, int(round(t.index * 1e9 / fps)), *expert["controls"])

    t = drive_loop(world, pilot, frames_in(minutes, fps), 0.0, fps, on_step=label, desc=f"rollout track {seed}",
                   progress=False, on_tick=on_tick, latency=latency,
                   choose=lambda t: expert["controls"] if rng.random() < beta else (t.model, t.throttle))
    tub.close()
    return result_of(pilot.name, TrackDriveOptions(seed=seed, minutes=minutes, fps=fps, style=style), t, world)


def rollout_job(checkpoint: str, out: str, seed: int, minutes: float, style: str, beta: float, camera: FisheyeCamera,
                suite) -> TrackDrive:
    """A DAgger rollout in a worker process: the model races through the donkeycar part as the round's track suite
    drives it (`suite`: its options; the constant throttle, the learned throttle's scale, its cap and the labels',
    smoothing, steering step and latency), seen through the recording's fisheye."""
    from steerlab.sim.core.part import donkey_pilot

    pilot = donkey_pilot(checkpoint, constant_throttle(suite.throttle), suite.smoothing, suite.max_throttle,
                         steering_step=suite.steering_step, throttle_scale=suite.throttle_scale,
                         throttle_floor=suite.throttle_floor)
    return rollout(pilot, out, seed, minutes, style, beta, camera, on_tick=tick_reporter(),
                   max_throttle=suite.max_throttle, latency=suite.latency)


def title(r: TrackDrive) -> str:
    best = "no clean lap" if r.best_lap_s is None else f"best clean lap {r.best_lap_s:.2f} s"
    return (f"{r.label} on {r.style} track {r.seed} ({r.lap_m:.1f} m lap): {r.laps} laps, {r.clean_laps} clean, "
            f"{best}, {r.off_track} off track")
