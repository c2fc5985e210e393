"""Recording the expert (`steerlab sim record`), letting a trained model drive (`steerlab sim drive`) and
rolling a model out with the expert labelling every visited state (DAgger, `steerlab sim dagger`).

All three run the same `World`: a car on one procedural road, rendered by one camera, stepped at the frame
rate. More than `limit_m` off the lane centre is an intervention: the car is put back on the lane centre."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
from tqdm import tqdm

from steerlab.data.car import car_of
from steerlab.data.writer import CONVENTION, RecordingWriter
from steerlab.errors import SteerlabError, warn
from steerlab.options import Options, POSITIVE, option
from steerlab.sim.driver import ExpertDriver, cruise, pure_pursuit
from steerlab.sim.driving import check_steers, drive_loop, rollout
from steerlab.sim.render import Renderer
from steerlab.sim.road import LANE_CENTER, ROAD_TYPES, Road
from steerlab.sim.vehicle import Vehicle, VehicleState
from steerlab.video import DriveVideo

ROAD_CAMERAS = ("sim", "ch2")  # the camera geometries the road world renders
RESERVED_SEEDS = range(9000, 10000)  # the roads of the closed-loop benchmark (sim/bench.py): never recorded
CHUNK_GAP_NS = 1_000_000_000  # between the chunks of a mixed recording: a new segment


def road_types(road: str) -> list[str]:
    """"country", "mixed" (every road type) or a comma list such as "country,twisty"."""
    types = list(ROAD_TYPES) if road == "mixed" else [t.strip() for t in road.split(",") if t.strip()]
    bad = [t for t in types if t not in ROAD_TYPES]
    if bad or not types:
        raise SteerlabError(f"unknown road type {','.join(bad) or road!r}; choose one of "
                            f"{', '.join(ROAD_TYPES)}, mixed, or a comma list")
    return types


def _roads(road: str) -> bool:
    road_types(road)
    return True


ROADS = "highway, country, twisty, mixed (all three) or a comma list of them"


@dataclass(frozen=True)
class RecordOptions(Options):
    """`steerlab sim record`: the expert on roads made from `seed`."""

    seed: int = option(0, help="road seed (9000-9999 are the closed-loop suite's, never recorded)")
    minutes: float = option(1.0, POSITIVE, "positive and finite", help="minutes of driving")
    road: str = option("country", _roads, ROADS, help=f"road type: {ROADS}")
    geometry: Literal["sim", "ch2"] = option("sim", help="camera geometry: sim (320x160) or ch2 (640x480)")
    fps: float = option(20.0, POSITIVE, "positive and finite", help="frames per second")
    drift: bool = option(True, help="drift-and-recover episodes")
    side_cameras: bool = option(True, help="the left and right cameras")
    layout: Literal["steerlab", "udacity-sim"] = option("steerlab", help="steerlab's own recording layout, or the "
                                                        "Udacity simulator's driving_log.csv")
    chunk_minutes: float = option(1.0, POSITIVE, "positive and finite",
                                  help="with several road types: minutes before the next one")


@dataclass(frozen=True)
class DriveOptions(Options):
    """`steerlab sim drive`: a model on a road made from `seed` (100 by default: not used for training data)."""

    seed: int = option(100, help="road seed (100: not used for training data)")
    minutes: float = option(1.0, POSITIVE, "positive and finite", help="minutes of driving")
    road: str = option("country", _roads, ROADS, help=f"road type: {ROADS}")
    geometry: Literal["sim", "ch2"] | None = option(None, help="camera geometry (default: the checkpoint's)")
    fps: float = option(20.0, POSITIVE, "positive and finite", help="frames per second")
    limit_m: float = option(1.0, POSITIVE, "positive and finite",
                            help="metres off the lane centre that count as an intervention")


def start_state(road: Road, s: float = 5.0, v: float | None = None) -> VehicleState:
    x, y, psi = road.pose(s, LANE_CENTER)
    return VehicleState(x, y, psi, road.speed_limit[road.index(s)] if v is None else v)


def make_road(seed: int, road: str, seconds: float) -> Road:
    """The road made from `seed`, long enough for `seconds` of driving."""
    return Road(seed, road, length_m=seconds * 35 + 400)


class World:
    """A car on its lane at the start of a road made from `seed`, long enough for `seconds` of driving."""

    def __init__(self, seed: int, road: str, geometry: str, seconds: float, fps: float = 20.0):
        self.road = make_road(seed, road, seconds)
        self.renderer = Renderer(self.road, geometry)
        self.car = car_of(geometry)
        self.vehicle = Vehicle(start_state(self.road), self.car)
        self.fps = fps
        self.s = 5.0
        self.steering_ratio = self.car.steering_ratio
        self.done = False  # a road is long enough for the drive it was made for

    @property
    def state(self) -> VehicleState:
        return self.vehicle.state

    def observe(self) -> tuple[float, float]:
        """(lateral offset from the lane centre [m, left positive], heading error [rad]) of the car now."""
        st = self.vehicle.state
        self.s, d, road_psi = self.road.project(st.x, st.y, self.s)
        return d - LANE_CENTER, (st.psi - road_psi + np.pi) % (2 * np.pi) - np.pi

    def put_back(self) -> None:
        """An intervention: the car is set on the lane centre, along the road, at its current speed."""
        self.vehicle.state = start_state(self.road, self.s, self.vehicle.state.v)
        self.observe()

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        """Put the car back (an intervention) if it is more than `limit_m` off the lane centre. Returns whether
        it did and the car's (offset, heading error) after it, as `observe`."""
        offset, heading = self.observe()
        if abs(offset) <= limit_m:
            return False, offset, heading
        self.put_back()
        return (True, *self.observe())

    def render(self, lateral: float = 0.0) -> np.ndarray:
        """The camera's frame; `lateral`: from a camera that far to the left of the car's centre."""
        st = self.vehicle.state
        return self.renderer.render(st.x, st.y, st.psi, self.s, lateral)

    def expert_steering(self) -> float:
        """The expert's road-wheel angle (rad, positive left) in this state: pure pursuit of the lane centre."""
        return pure_pursuit(self.road, self.vehicle.state, self.s, LANE_CENTER, self.car.wheelbase)

    def step(self, road_wheel: float, throttle: float | None = None) -> None:
        """Apply a road-wheel angle for one frame; the speed follows the road's speed profile (a pilot's
        `throttle` is not used: the road world's car keeps to the road's speeds)."""
        throttle, brake = cruise(self.road, self.s, self.vehicle.state.v)
        self.vehicle.step(road_wheel, throttle, brake, 1.0 / self.fps)

    def record_row(self, tick: int) -> dict:
        """What a recording holds of this tick besides the frames, the steering and the episode."""
        throttle, brake = cruise(self.road, self.s, self.state.v)
        return {"timestamp_ns": int(round(tick * 1e9 / self.fps)), "speed": self.state.v, "throttle": throttle,
                "brake": brake, "curvature": self.road.kappa[self.road.index(self.s)]}


def _frames(minutes: float, fps: float) -> int:
    return int(round(minutes * 60 * fps))


def _check_seed(seed: int) -> None:
    if seed in RESERVED_SEEDS:
        raise SteerlabError(f"road seeds {RESERVED_SEEDS.start}-{RESERVED_SEEDS.stop - 1} are reserved for the "
                            "closed-loop benchmark roads and never recorded; choose another seed")


def _cameras(car, side_cameras: bool) -> dict[str, float]:
    off = car.side_camera_offset_m
    return {"center": 0.0, **({"left": off, "right": -off} if side_cameras and off else {})}


def record(out: str | Path, o: RecordOptions = RecordOptions(), progress: bool = True, *,
           suite_roads_ok: bool = False) -> Path:
    """Drive the expert on roads made from `o.seed` and write a labelled recording. Same options, same bytes.

    With several road types (`road="mixed"` or a comma list) the expert drives one road of each type and
    the recording takes turns between them every `chunk_minutes`, each chunk its own segment, so that any
    contiguous block of the recording (a validation split, say) mixes the road types.

    `suite_roads_ok=True` is for evaluation recordings only (replay against the closed-loop suite; not in the
    CLI, never for training data): it allows the suite's reserved seeds and makes each road exactly as long
    as `drive` makes it for the same minutes, so that the recording shows the suite's own road."""
    if not suite_roads_ok:
        _check_seed(o.seed)
    n = _frames(o.minutes, o.fps)
    types = road_types(o.road)
    chunk = n if len(types) == 1 else _frames(o.chunk_minutes, o.fps)
    schedule = [types[(i // chunk) % len(types)] for i in range(n)]  # a type may be listed twice for a larger share
    extra = 0 if suite_roads_ok else chunk  # the suite's roads: as long as `drive` makes them
    worlds = {t: World(o.seed, t, o.geometry, (schedule.count(t) + extra) / o.fps, o.fps) for t in dict.fromkeys(types)}
    drivers = {t: ExpertDriver(w.road, o.seed, w.car, 1.0 / o.fps, drift_every_s=25.0 if o.drift else None)
               for t, w in worlds.items()}
    clocks = dict.fromkeys(worlds, 0)
    car = car_of(o.geometry)
    cams = _cameras(car, o.side_cameras)
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
                            "--geometry to drive it with another camera anyway")
    if geometry != pilot.geometry and getattr(pilot, "frame_size", None) is not None:
        raise SteerlabError(f"{pilot.source}: model {pilot.name!r} was trained on the {pilot.geometry!r} camera and "
                            f"takes no {geometry!r} frames (a Pilot with other_camera=True does)")
    return geometry


def mismatch(pilot, geometry: str) -> None:
    if geometry != (pilot.geometry or geometry):
        warn(f"the checkpoint was trained on the {pilot.geometry!r} camera geometry and is driven with the "
             f"{geometry!r} camera: expect it to drive worse than it can")


def drive(pilot, out: str | Path | None, o: DriveOptions = DriveOptions(), video: str | Path | None = None,
          progress: bool = True, on_tick=None, plot: bool = True, meta: dict | None = None) -> dict:
    """Closed loop: each tick renders the centre camera, asks `pilot.step(frame, speed)` for controls and
    applies their steering (in `pilot.convention`); the speed follows the road's speed profile. Off the lane
    centre by more than `o.limit_m` is an intervention: the car is put back on the lane centre and
    `pilot.reset()` clears the pilot's memory. `on_tick(k)` is called every 100 ticks (progress of the suite).
    With `out`: trajectory.csv, frames.png, drive.json (the result and `meta`) and, with `plot`, path.png."""
    geometry = geometry_for(pilot, o.geometry)
    check_steers(pilot, car_of(geometry))
    mismatch(pilot, geometry)
    n = _frames(o.minutes, o.fps)
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
    result = {"label": pilot.name, "seed": o.seed, "road": o.road, "minutes": o.minutes, **t.metrics(1.0 / o.fps)}
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        t.write(out / "trajectory.csv")
        if plot:
            from steerlab.sim.plots import plot_trajectory  # matplotlib: imported where it draws

            plot_trajectory(out / "path.png", world.road, {pilot.name: t},
                            f"{pilot.name} on {o.road} road {o.seed}: autonomy {result['autonomy']:.1f} %, "
                            f"{interventions} interventions, mean |offset| {result['mean_abs_offset_m']:.2f} m")
        rows = [np.hstack(strip[k:k + 4]) for k in range(0, len(strip) - 3, 4)] or [np.hstack(strip)]
        cv2.imwrite(str(out / "frames.png"), np.vstack(rows))  # one frame every 5 s
        (out / "drive.json").write_text(json.dumps({**result, **(meta or {})}, indent=1))
    return result


def world_rollout(pilot, out: str | Path, seed: int, minutes: float, road: str = "country", beta: float = 0.0,
                  geometry: str | None = None, fps: float = 20.0, limit_m: float = 1.0, side_cameras: bool = True,
                  on_tick=None) -> dict:
    """DAgger's data collection on a fresh road (`driving.rollout`), recorded as a steerlab recording in `out`.
    Interventions as in `drive`. Returns the drive's metrics."""
    _check_seed(seed)
    n = _frames(minutes, fps)
    geometry = geometry_for(pilot, geometry)
    check_steers(pilot, car_of(geometry))
    mismatch(pilot, geometry)
    world = World(seed, road, geometry, n / fps, fps)
    writer = RecordingWriter(out, list(_cameras(world.car, side_cameras)), geometry=geometry)
    t = rollout(pilot, [(world, n)], writer, CONVENTION, beta, np.random.default_rng([seed, 5]), limit_m, fps,
                on_tick, f"rollout {road} {seed}")
    writer.close({"seed": seed, "road": road, "roads": [road], "fps": fps, "minutes": minutes, "beta": beta,
                  "policy": pilot.name})
    return t.metrics(1.0 / fps)

