"""Recording the expert (`steerlab sim record`), letting a trained model drive (`steerlab sim drive`) and
rolling a model out with the expert labelling every visited state (DAgger, `steerlab sim dagger`).

All three run the same `World`: a car on one procedural road, rendered by one camera, stepped at the frame
rate. More than `limit_m` off the lane centre is an intervention: the car is put back on the lane centre."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from steerlab.data.geometry import CAMERAS
from steerlab.data.writer import CONVENTION, RecordingWriter
from steerlab.errors import SteerlabError, warn
from steerlab.sim.driver import ExpertDriver, cruise, pure_pursuit
from steerlab.sim.driving import TRAJECTORY, drive_loop, drive_metrics
from steerlab.sim.plots import plot_trajectory
from steerlab.sim.render import SIDE_OFFSET, Renderer
from steerlab.sim.road import LANE_CENTER, ROAD_TYPES, Road
from steerlab.sim.vehicle import Vehicle, VehicleParams, VehicleState
from steerlab.video import DriveVideo

RESERVED_SEEDS = range(9000, 10000)  # the roads of the closed-loop benchmark (sim/bench.py): never recorded
CHUNK_GAP_NS = 1_000_000_000  # between the chunks of a mixed recording: a new segment


def _frames(minutes: float, fps: float) -> int:
    if not minutes > 0:
        raise SteerlabError(f"minutes must be positive, got {minutes}")
    if not fps > 0:
        raise SteerlabError(f"fps must be positive, got {fps}")
    return int(round(minutes * 60 * fps))


def road_types(road: str) -> list[str]:
    """"country", "mixed" (every road type) or a comma list such as "country,twisty"."""
    types = list(ROAD_TYPES) if road == "mixed" else [t.strip() for t in road.split(",") if t.strip()]
    bad = [t for t in types if t not in ROAD_TYPES]
    if bad or not types:
        raise SteerlabError(f"unknown road type {','.join(bad) or road!r}; choose one of "
                            f"{', '.join(ROAD_TYPES)}, mixed, or a comma list")
    return types


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
        self.params = VehicleParams()
        self.car = Vehicle(start_state(self.road), self.params)
        self.dt = 1.0 / fps
        self.s = 5.0
        self.steering_ratio = self.params.steering_ratio
        self.done = False  # a road is long enough for the drive it was made for

    @property
    def state(self) -> VehicleState:
        return self.car.state

    def observe(self) -> tuple[float, float]:
        """(lateral offset from the lane centre [m, left positive], heading error [rad]) of the car now."""
        st = self.car.state
        self.s, d, road_psi = self.road.project(st.x, st.y, self.s)
        return d - LANE_CENTER, (st.psi - road_psi + np.pi) % (2 * np.pi) - np.pi

    def put_back(self) -> None:
        """An intervention: the car is set on the lane centre, along the road, at its current speed."""
        self.car.state = start_state(self.road, self.s, self.car.state.v)
        self.observe()

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        """Put the car back (an intervention) if it is more than `limit_m` off the lane centre. Returns whether
        it did and the car's (offset, heading error) after it, as `observe`."""
        offset, heading = self.observe()
        if abs(offset) <= limit_m:
            return False, offset, heading
        self.put_back()
        return (True, *self.observe())

    def render(self, shift: float = 0.0) -> np.ndarray:
        st = self.car.state
        return self.renderer.render(st.x, st.y, st.psi, self.s, shift)

    def expert_steering(self) -> float:
        """The expert's road-wheel angle (rad, positive left) in this state: pure pursuit of the lane centre."""
        return pure_pursuit(self.road, self.car.state, self.s, LANE_CENTER, self.params.wheelbase)

    def step(self, road_wheel: float) -> None:
        """Apply a road-wheel angle for one frame; the speed follows the road's speed profile."""
        throttle, brake = cruise(self.road, self.s, self.car.state.v)
        self.car.step(road_wheel, throttle, brake, self.dt)


def _row(world: World, ts: int, steering_road_wheel: float, offset: float, heading: float, episode: str) -> dict:
    throttle, brake = cruise(world.road, world.s, world.state.v)
    return {"timestamp_ns": ts, "steering": CONVENTION.from_road_wheel_left(steering_road_wheel, world.params.steering_ratio),
            "speed": world.state.v, "throttle": throttle, "brake": brake, "lateral_offset": offset,
            "heading_error": heading, "curvature": world.road.kappa[world.road.index(world.s)], "episode": episode}


def _check_seed(seed: int) -> None:
    if seed in RESERVED_SEEDS:
        raise SteerlabError(f"road seeds {RESERVED_SEEDS.start}-{RESERVED_SEEDS.stop - 1} are reserved for the "
                            "closed-loop benchmark roads and never recorded; choose another seed")


def record(out: str | Path, seed: int = 0, minutes: float = 1.0, road: str = "country", geometry: str = "sim",
           fps: float = 20.0, drift: bool = True, side_cameras: bool = True, layout: str = "steerlab",
           chunk_minutes: float = 1.0, progress: bool = True, *, suite_roads_ok: bool = False) -> Path:
    """Drive the expert on roads made from `seed` and write a labelled recording. Same arguments, same bytes.

    With several road types (`road="mixed"` or a comma list) the expert drives one road of each type and
    the recording takes turns between them every `chunk_minutes`, each chunk its own segment, so that any
    contiguous block of the recording (a validation split, say) mixes the road types.

    `suite_roads_ok=True` is for evaluation recordings only (replay against the closed-loop suite; not in the
    CLI, never for training data): it allows the suite's reserved seeds and makes each road exactly as long
    as `drive` makes it for the same minutes, so that the recording shows the suite's own road."""
    if not suite_roads_ok:
        _check_seed(seed)
    n = _frames(minutes, fps)
    types = road_types(road)
    chunk = n if len(types) == 1 else _frames(chunk_minutes, fps)
    schedule = [types[(i // chunk) % len(types)] for i in range(n)]  # a type may be listed twice for a larger share
    extra = 0 if suite_roads_ok else chunk  # the suite's roads: as long as `drive` makes them
    worlds = {t: World(seed, t, geometry, (schedule.count(t) + extra) / fps, fps) for t in dict.fromkeys(types)}
    drivers = {t: ExpertDriver(w.road, seed, w.params, w.dt, drift_every_s=25.0 if drift else None)
               for t, w in worlds.items()}
    clocks = dict.fromkeys(worlds, 0)
    cams = {"center": 0.0, **({"left": SIDE_OFFSET, "right": -SIDE_OFFSET} if side_cameras else {})}
    writer = RecordingWriter(out, list(cams), layout)
    ts = 0
    for i in tqdm(range(n), desc=f"record seed {seed}", unit="frame", disable=None if progress else True):
        kind = schedule[i]
        if i and i % chunk == 0:
            ts += CHUNK_GAP_NS  # a new chunk is a new segment
        world, driver = worlds[kind], drivers[kind]
        offset, heading = world.observe()
        delta, _, _, episode = driver.act(world.state, world.s, offset, clocks[kind] / fps)
        writer.add({c: world.render(shift) for c, shift in cams.items()},
                   _row(world, ts, delta, offset, heading, episode))
        world.step(delta)
        clocks[kind] += 1
        ts += int(round(1e9 / fps))
    p = VehicleParams()
    return writer.close({"seed": seed, "road": road, "roads": types, "geometry": geometry,
                         "fps": fps, "minutes": minutes, "wheelbase": p.wheelbase,
                         "side_camera_offset_m": SIDE_OFFSET if side_cameras else None}, p.steering_ratio)


def geometry_for(pilot, geometry: str | None) -> str:
    """The camera geometry to drive a pilot with: by default the one it was trained on; warns on a mismatch."""
    if geometry is None:
        if pilot.geometry in CAMERAS:
            return pilot.geometry
        warn(f"the checkpoint was trained on the {pilot.geometry!r} camera geometry, which the synthetic world "
             "does not render; driving with the 'sim' camera")
        return "sim"
    if geometry != pilot.geometry:
        warn(f"the checkpoint was trained on the {pilot.geometry!r} camera geometry and is driven with the "
             f"{geometry!r} camera: expect it to drive worse than it can")
    return geometry


def drive(pilot, out: str | Path | None, seed: int = 100, minutes: float = 1.0, road: str = "country",
          geometry: str | None = None, fps: float = 20.0, limit_m: float = 1.0, video: str | Path | None = None,
          progress: bool = True, on_tick=None, plot: bool = True, meta: dict | None = None) -> dict:
    """Closed loop: each tick renders the centre camera, asks `pilot.step(frame, speed)` for controls and
    applies their steering (in `pilot.convention`); the speed follows the road's speed profile. Off the lane
    centre by more than `limit_m` is an intervention: the car is put back on the lane centre and
    `pilot.reset()` clears the pilot's memory. `on_tick(k)` is called every 100 ticks (progress of the suite).
    With `out`: trajectory.csv, frames.png, drive.json (the result and `meta`) and, with `plot`, path.png."""
    n = _frames(minutes, fps)
    world = World(seed, road, geometry_for(pilot, geometry), n / fps, fps)
    ratio = world.steering_ratio
    strip = []
    movie = DriveVideo(video, fps) if video else None
    interventions = 0

    def on_step(t):
        nonlocal interventions
        interventions += t.intervention
        if out is not None and t.index % int(fps * 5) == 0 and len(strip) < 12:
            strip.append(t.frame)
        if movie:
            st = world.state
            movie.add(t.frame, t.model * ratio, t.expert * ratio, t.offset,
                      f"{road} road {seed}  t {t.index / fps:5.1f} s  {st.v * 3.6:3.0f} km/h  interventions {interventions}")

    t = drive_loop(world, pilot, n, limit_m, fps, on_step=on_step, desc=f"drive {road} {seed}", progress=progress,
                   on_tick=on_tick)
    if movie:
        movie.close()
    result = {"label": pilot.name, "seed": seed, "road": road, "minutes": minutes,
              **drive_metrics(t[:, 4], t[:, 5], t[:, 6], 1.0 / fps, interventions)}
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "trajectory.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(TRAJECTORY[:7])
            w.writerows([[f"{v:.4f}" for v in row[:7]] for row in t])
        if plot:
            plot_trajectory(out / "path.png", world.road, {pilot.name: t},
                            f"{pilot.name} on {road} road {seed}: autonomy {result['autonomy']:.1f} %, "
                            f"{interventions} interventions, mean |offset| {result['mean_abs_offset_m']:.2f} m")
        rows = [np.hstack(strip[k:k + 4]) for k in range(0, len(strip) - 3, 4)] or [np.hstack(strip)]
        cv2.imwrite(str(out / "frames.png"), np.vstack(rows))  # one frame every 5 s
        (out / "drive.json").write_text(json.dumps({**result, **(meta or {})}, indent=1))
    return result


def rollout(pilot, out: str | Path, seed: int, minutes: float, road: str = "country", beta: float = 0.0,
            geometry: str | None = None, fps: float = 20.0, limit_m: float = 1.0, side_cameras: bool = True,
            progress: bool = True, on_tick=None) -> dict:
    """DAgger's data collection: drive with the model's steering (or, with probability `beta` each tick,
    the expert's) and record every visited frame labelled with the expert's steering in that state, as a
    steerlab recording in `out`. Interventions as in `drive`. Returns the drive's metrics."""
    _check_seed(seed)
    n = _frames(minutes, fps)
    geometry = geometry_for(pilot, geometry)
    world = World(seed, road, geometry, n / fps, fps)
    ratio = world.steering_ratio
    rng = np.random.default_rng([seed, 5])
    cams = {"center": 0.0, **({"left": SIDE_OFFSET, "right": -SIDE_OFFSET} if side_cameras else {})}
    writer = RecordingWriter(out, list(cams))

    def on_step(t):
        frames = {c: t.frame if c == "center" else world.render(shift) for c, shift in cams.items()}
        writer.add(frames, _row(world, int(round(t.index * 1e9 / fps)), t.expert, t.offset, t.heading, "rollout"))

    t = drive_loop(world, pilot, n, limit_m, fps, choose=lambda t: t.expert if rng.random() < beta else t.model,
                   on_step=on_step, desc=f"rollout {road} {seed}", progress=progress, on_tick=on_tick)
    writer.close({"seed": seed, "road": road, "roads": [road], "geometry": geometry, "fps": fps, "minutes": minutes, "beta": beta,
                  "policy": pilot.name, "wheelbase": world.params.wheelbase,
                  "side_camera_offset_m": SIDE_OFFSET if side_cameras else None}, ratio)
    model = np.array([pilot.convention.to_road_wheel_left(c, ratio) for c in t[:, 5]])
    return drive_metrics(t[:, 4], model * ratio, t[:, 6], 1.0 / fps, int(t[:, 8].sum()))
