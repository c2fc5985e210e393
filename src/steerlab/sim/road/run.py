"""What is done in the road world: recording the expert (`steerlab sim record`), letting a model drive
(`steerlab sim drive`) and rolling a model out with the expert labelling every visited state (DAgger's
rollouts, `steerlab sim dagger`), all in the one driving loop (`core.driving.drive_loop`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.data.car import car_of
from steerlab.data.writer import CONVENTION, RecordingWriter
from steerlab.errors import SteerlabError, warn
from steerlab.options import frames_in
from steerlab.pilot import DriveWith
from steerlab.sim.core.driving import check_steers, drive_loop, rollout as drive_rollout
from steerlab.sim.core.parallel import tick_reporter
from steerlab.sim.core.plots import write_strip
from steerlab.sim.core.suite import check_seed, write_json
from steerlab.sim.road.expert import ExpertDriver
from steerlab.sim.road.world import ROAD_CAMERAS, DriveOptions, RecordOptions, World, cameras, road_types
from steerlab.video import DriveVideo

CHUNK_GAP_NS = 1_000_000_000  # between the chunks of a mixed recording: a new segment


@dataclass(frozen=True)
class RoadDrive:
    """A drive's result: the pilot's label, the road (seed, type) and minutes, and the closed-loop metrics
    (`core.driving.DriveMetrics`)."""

    label: str
    seed: int
    road: str
    minutes: float
    autonomy: float
    interventions: int
    interventions_per_km: float
    mean_abs_offset_m: float
    max_abs_offset_m: float
    command_gamma_deg: float
    distance_km: float


def record(out: str | Path, o: RecordOptions = RecordOptions(), progress: bool = True, *,
           suite_ok: bool = False) -> Path:
    """Drive the expert on roads made from `o.seed` and write a labelled recording. Same options, same bytes.

    With several road types (`road="mixed"` or a comma list) the expert drives one road of each type and
    the recording takes turns between them every `chunk_minutes`, each chunk its own segment, so that any
    contiguous block of the recording (a validation split, say) mixes the road types.

    `suite_ok=True` is for evaluation recordings only (replay against the closed-loop suite, with the options
    of `SuiteOptions.record_options`; not in the CLI, never for training data): it allows the suite's reserved
    seeds and makes each road exactly as long as `drive` makes it for the same minutes, so that the recording
    shows the suite's own road."""
    if not suite_ok:
        check_seed(o.seed, "road")
    n = frames_in(o.minutes, o.fps)
    types = road_types(o.road)
    chunk = n if len(types) == 1 else frames_in(o.chunk_minutes, o.fps)
    schedule = [types[(i // chunk) % len(types)] for i in range(n)]  # a type may be listed twice for a larger share
    extra = 0 if suite_ok else chunk  # the suite's roads: as long as `drive` makes them
    worlds = {t: World(o.seed, t, o.geometry, (schedule.count(t) + extra) / o.fps, o.fps) for t in dict.fromkeys(types)}
    drivers = {t: ExpertDriver(w.road, o.seed, w.car, 1.0 / o.fps, drift_every_s=25.0 if o.drift else None)
               for t, w in worlds.items()}
    clocks = dict.fromkeys(worlds, 0)
    car = car_of(o.geometry)
    cams = cameras(car, o.side_cameras)
    writer = RecordingWriter(out, list(cams), o.layout, geometry=o.geometry)
    ts = 0
    for i in tqdm(range(n), desc=f"record seed {o.seed}", unit="frame", disable=None if progress else True):
        kind = schedule[i]
        if i and i % chunk == 0:
            ts += CHUNK_GAP_NS  # a new chunk is a new segment
        world, driver = worlds[kind], drivers[kind]
        offset, heading = world.observe()
        delta, _, _, episode = driver.act(world.state, world.s, offset, clocks[kind] / o.fps)
        writer.add({c: world.render(shift) for c, shift in cams.items()},
                   {**world.record_row(0), "timestamp_ns": ts, "lateral_offset": offset, "heading_error": heading,
                    "steering": CONVENTION.from_road_wheel_left(delta, car.steering_ratio), "episode": episode})
        world.step(delta)
        clocks[kind] += 1
        ts += int(round(1e9 / o.fps))
    return writer.close({"seed": o.seed, "road": o.road, "roads": types, "fps": o.fps, "minutes": o.minutes})


def geometry_for(pilot, geometry: str | None) -> str:
    """The camera geometry to drive a pilot with: by default the one it was trained on. Another one (`geometry`)
    only for a Pilot that takes other cameras' frames (`Pilot(other_camera=True)`); `mismatch` warns of it."""
    if geometry is None:
        if pilot.geometry in ROAD_CAMERAS or pilot.geometry is None:
            return pilot.geometry or "sim"
        raise SteerlabError(f"{pilot.source}: model {pilot.name!r} was trained on the {pilot.geometry!r} camera, which "
                            f"the road world does not render (it renders {', '.join(ROAD_CAMERAS)}); choose one with "
                            "geometry (steerlab sim drive --geometry) to drive it with another camera anyway")
    if geometry != pilot.geometry and getattr(pilot, "frame_size", None) is not None:
        raise SteerlabError(f"{pilot.source}: model {pilot.name!r} was trained on the {pilot.geometry!r} camera and "
                            f"takes no {geometry!r} frames (a Pilot with other_camera=True does)")
    return geometry


def mismatch(pilot, geometry: str) -> None:
    if geometry != (pilot.geometry or geometry):
        warn(f"the checkpoint was trained on the {pilot.geometry!r} camera geometry and is driven with the "
             f"{geometry!r} camera: expect it to drive worse than it can")


def drive(pilot, out: str | Path | None, o: DriveOptions = DriveOptions(), video: str | Path | None = None,
          progress: bool = True, on_tick=None, plot: bool = True, meta: dict | None = None) -> RoadDrive:
    """Closed loop: each tick renders the centre camera, asks `pilot.step(frame, speed)` for controls and
    applies their steering (in `pilot.convention`); the speed follows the road's speed profile. Off the lane
    centre by more than `o.limit_m` is an intervention: the car is put back on the lane centre and
    `pilot.reset()` clears the pilot's memory. `on_tick(k)` is called every 100 ticks (progress of the suite).
    With `out`: trajectory.csv, frames.png, drive.json (the result and `meta`) and, with `plot`, path.png."""
    geometry = geometry_for(pilot, o.geometry)
    check_steers(pilot, car_of(geometry))
    mismatch(pilot, geometry)
    n = frames_in(o.minutes, o.fps)
    world = World(o.seed, o.road, geometry, n / o.fps, o.fps)
    ratio = world.steering_ratio
    strip = []
    movie = DriveVideo(video, o.fps) if video else None
    interventions = 0

    def on_step(t):
        nonlocal interventions
        interventions += t.intervention
        if out is not None and t.index % int(o.fps * 5) == 0 and len(strip) < 12:
            strip.append(t.frame)
        if movie:
            st = world.state
            movie.add(t.frame, t.model * ratio, t.expert * ratio, t.offset,
                      f"{o.road} road {o.seed}  t {t.index / o.fps:5.1f} s  {st.v * 3.6:3.0f} km/h  "
                      f"interventions {interventions}")

    t = drive_loop(world, pilot, n, o.limit_m, o.fps, on_step=on_step, desc=f"drive {o.road} {o.seed}",
                   progress=progress, on_tick=on_tick)
    if movie:
        movie.close()
    result = RoadDrive(pilot.name, o.seed, o.road, o.minutes, **vars(t.metrics(1.0 / o.fps)))
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        t.write(out / "trajectory.csv")
        if plot:
            from steerlab.sim.road.plots import plot_trajectory  # matplotlib: imported where it draws

            plot_trajectory(out / "path.png", world.road, {pilot.name: t},
                            f"{pilot.name} on {o.road} road {o.seed}: autonomy {result.autonomy:.1f} %, "
                            f"{interventions} interventions, mean |offset| {result.mean_abs_offset_m:.2f} m", o.limit_m)
        write_strip(out / "frames.png", strip)
        write_json(out / "drive.json", result, meta)
    return result


def drive_checkpoint(checkpoint: str | Path, out: str | Path | None, o: DriveOptions, w: DriveWith = DriveWith(),
                     video: str | Path | None = None, progress: bool = True, on_tick=None, plot: bool = True,
                     meta: dict | None = None) -> RoadDrive:
    """`drive` with steerlab's Pilot on `checkpoint`, made as `w` says (`o.geometry`: another camera than it was
    trained on)."""
    from steerlab.pilot import Pilot

    pilot = Pilot(checkpoint, smoothing=w.smoothing, steering_step=w.steering_step,
                  other_camera=o.geometry is not None)
    return drive(pilot, out, o, video, progress, on_tick, plot, meta)


def rollout(pilot, out: str | Path, seed: int, minutes: float, road: str = "country", beta: float = 0.0,
            geometry: str | None = None, fps: float = 20.0, limit_m: float = 1.0, side_cameras: bool = True,
            on_tick=None) -> RoadDrive:
    """DAgger's data collection on a fresh road (`core.driving.rollout`), recorded as a steerlab recording in
    `out`. Interventions as in `drive`. Returns the drive's result."""
    check_seed(seed, "road")
    n = frames_in(minutes, fps)
    geometry = geometry_for(pilot, geometry)
    check_steers(pilot, car_of(geometry))
    mismatch(pilot, geometry)
    world = World(seed, road, geometry, n / fps, fps)
    writer = RecordingWriter(out, list(cameras(world.car, side_cameras)), geometry=geometry)
    t = drive_rollout(pilot, [(world, n)], writer, CONVENTION, beta, np.random.default_rng([seed, 5]), limit_m, fps,
                      on_tick, f"rollout {road} {seed}")
    writer.close({"seed": seed, "road": road, "roads": [road], "fps": fps, "minutes": minutes, "beta": beta,
                  "policy": pilot.name})
    return RoadDrive(pilot.name, seed, road, minutes, **vars(t.metrics(1.0 / fps)))


def rollout_job(checkpoint: str, out: str, seed: int, minutes: float, road: str, beta: float, geometry: str | None,
                suite) -> RoadDrive:
    """A DAgger rollout in a worker process: steerlab's Pilot on `checkpoint` made as the round's suite makes it
    (`suite`: its options; smoothing, steering step), the recording's camera."""
    from steerlab.pilot import Pilot

    pilot = Pilot(checkpoint, smoothing=suite.smoothing, steering_step=suite.steering_step)
    return rollout(pilot, out, seed, minutes, road, beta, geometry, on_tick=tick_reporter())
