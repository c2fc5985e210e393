"""Closed-loop replay on recorded camera data (`steerlab replay`): would this model keep the car in the lane
of a road it has only seen as a recording?

As NVIDIA tested PilotNet on recorded video: the human's path is rebuilt from the recorded steering and speed
through the kinematic bicycle (`human_path`); a simulated car starts on it and, each tick, takes the recorded
frame at its arc length along the path, warped to its own viewpoint (lateral offset and heading error, flat
road: `geometry.shift_view`), asks the pilot for a command and moves by it, in the driving loop that the
synthetic world uses (`sim.driving.drive_loop`). Further than the lane limit from the path (1 m for a car), or
turned further than the warp's valid range, is an intervention: the car is put back on the path and the pilot
forgets its past. Recordings without a speed signal get one estimated from the frames (`estimate_speed`)."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from steerlab.data.geometry import Car, Camera, shift_view
from steerlab.data.recording import Recording
from steerlab.data.writer import RecordingWriter
from steerlab.errors import DataError, SteerlabError, warn
from steerlab.sim.driving import TRAJECTORY, autonomy, drive_loop, drive_metrics
from steerlab.sim.plots import plot_offsets
from steerlab.sim.render import SIDE_OFFSET
from steerlab.sim.vehicle import Vehicle, VehicleParams, VehicleState

MAX_HEADING_DEG = 10.0  # beyond this the warped view shows too much of what the camera never saw
MIN_SECONDS = 3.0       # shorter segments are not replayed
RESULT_FIELDS = ["checkpoint", "recording", "segment", "frames", "km", "seconds", "speed_mps", "speed_source",
                 "autonomy", "interventions", "interventions_per_km", "mean_offset_m", "max_offset_m",
                 "mean_heading_deg", "max_heading_deg", "gamma"]


@dataclass
class HumanPath:
    """The path the human drove, one point per frame: time (s), pose (m, rad) and arc length (m), speed (m/s)
    and the human's road-wheel angle (rad, positive left)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    psi: np.ndarray
    s: np.ndarray
    v: np.ndarray
    wheel: np.ndarray


def human_path(road_wheel: np.ndarray, speed: np.ndarray, times_s: np.ndarray, params: VehicleParams) -> HumanPath:
    """Integrate the recorded road-wheel angles (rad, positive left) and speeds through the vehicle model: frame
    i's steering and frame i+1's speed take the car from frame i to frame i+1."""
    car = Vehicle(VehicleState(0.0, 0.0, 0.0, float(speed[0])), params)
    pose = [(0.0, 0.0, 0.0)]
    for i in range(1, len(times_s)):
        st = car.advance(float(road_wheel[i - 1]), float(speed[i]), float(times_s[i] - times_s[i - 1]))
        pose.append((st.x, st.y, st.psi))
    x, y, psi = np.array(pose).T
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    return HumanPath(np.asarray(times_s, float), x, y, psi, s, np.asarray(speed, float), np.asarray(road_wheel, float))


class ReplayWorld:
    """One segment of a recording as a world for `drive_loop`: the car follows the human's speed tick by tick
    and sees the recorded frame at its arc length, warped to its viewpoint."""

    def __init__(self, rec: Recording, start: int, path: HumanPath, cam: Camera, params: VehicleParams,
                 max_heading_deg: float = MAX_HEADING_DEG):
        self.rec, self.start, self.path, self.cam, self.params = rec, start, path, cam, params
        self.max_heading = math.radians(max_heading_deg)
        self.steering_ratio = params.steering_ratio
        self.car = Vehicle(VehicleState(path.x[0], path.y[0], path.psi[0], path.v[0]), params)
        self.k = 0      # tick = index of the human's frame in time
        self.i = 0      # path segment [i, i + 1] the car is on
        self.s = 0.0    # the car's arc length along the path
        self.view = (0.0, 0.0)  # the last warp (shift m, yaw deg)

    @property
    def state(self) -> VehicleState:
        return self.car.state

    @property
    def done(self) -> bool:
        return self.k >= len(self.path.t) - 1 or self.s >= self.path.s[-1]

    def _pose(self, s: float) -> tuple[float, float, float]:
        p = self.path
        return (float(np.interp(s, p.s, p.x)), float(np.interp(s, p.s, p.y)), float(np.interp(s, p.s, p.psi)))

    def observe(self) -> tuple[float, float]:
        """(lateral offset from the human's path [m, left positive], heading error [rad]) of the car now."""
        p, st = self.path, self.car.state
        lo, hi = max(min(self.i, self.k) - 5, 0), min(max(self.i, self.k) + 40, len(p.s) - 1)  # near the car
        best = None
        for j in range(lo, hi):
            dx, dy = p.x[j + 1] - p.x[j], p.y[j + 1] - p.y[j]
            length2 = dx * dx + dy * dy
            if length2 < 1e-12:
                continue
            u = min(max(((st.x - p.x[j]) * dx + (st.y - p.y[j]) * dy) / length2, 0.0), 1.0)
            ex, ey = st.x - (p.x[j] + u * dx), st.y - (p.y[j] + u * dy)
            dist2 = ex * ex + ey * ey
            if best is None or dist2 < best[0]:
                best = (dist2, j, u, (dx * ey - dy * ex) / math.sqrt(length2))
        if best is None:  # the human stood still over the whole window
            return 0.0, 0.0
        _, self.i, u, offset = best
        self.s = p.s[self.i] + u * (p.s[self.i + 1] - p.s[self.i])
        heading = (st.psi - self._pose(self.s)[2] + math.pi) % (2 * math.pi) - math.pi
        return offset, heading

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        offset, heading = self.observe()
        if abs(offset) <= limit_m and abs(heading) <= self.max_heading:
            return False, offset, heading
        x, y, psi = self._pose(self.s)
        self.car.state = VehicleState(x, y, psi, self.car.state.v)
        return True, 0.0, 0.0

    def frame_index(self) -> int:
        """The recorded frame at the car's arc length; where the human stood still, the one nearest in time."""
        s = self.path.s
        j = int(np.clip(np.searchsorted(s, self.s), 1, len(s) - 1))
        j = j - 1 if self.s - s[j - 1] < s[j] - self.s else j
        lo, hi = np.searchsorted(s, s[j], "left"), np.searchsorted(s, s[j], "right")
        return int(np.clip(self.k, lo, hi - 1))

    def render(self, lateral: float = 0.0) -> np.ndarray:
        """The recorded frame at the car's arc length seen from the car: moved sideways and turned by the car's
        pose relative to the human's pose at that frame. `lateral`: seen from a camera that far to the left of
        the car's centre (a rollout's side cameras)."""
        j, p, st = self.frame_index(), self.path, self.car.state
        dx, dy = st.x - p.x[j], st.y - p.y[j]
        shift = -math.sin(p.psi[j]) * dx + math.cos(p.psi[j]) * dy
        yaw = math.degrees((st.psi - p.psi[j] + math.pi) % (2 * math.pi) - math.pi)
        if not lateral:
            self.view = (shift, yaw)
        return shift_view(self.rec.load_frame(self.start + j), self.cam, shift + lateral, yaw)

    def expert_steering(self) -> float:
        """The label of a visited state: the road-wheel angle (rad, positive left) that brings the car back to
        the human's path. The human's own steering at the car's place on the path, plus the correction of pure
        pursuit (pure pursuit of the path from the car's pose, minus pure pursuit from the path's own pose
        there): on the path exactly the human's steering, as the recording labels it, and off it the
        generalisation of paper 002's side-camera label (Eq. 3)."""
        st = self.car.state
        x, y, psi = self._pose(self.s)
        return (float(self.path.wheel[self.frame_index()]) + self._pursuit(st.x, st.y, st.psi, st.v)
                - self._pursuit(x, y, psi, st.v))

    def _pursuit(self, x: float, y: float, psi: float, v: float) -> float:
        """Pure pursuit of the path from a pose: the road-wheel angle towards the path point one lookahead
        ahead of the car's arc length."""
        lookahead = max(0.9 * v, 3.0 * self.params.wheelbase)
        tx, ty, _ = self._pose(self.s + lookahead)
        alpha = (math.atan2(ty - y, tx - x) - psi + math.pi) % (2 * math.pi) - math.pi
        return math.atan2(2 * self.params.wheelbase * math.sin(alpha), math.hypot(tx - x, ty - y))

    def step(self, road_wheel: float) -> None:
        p = self.path
        self.car.advance(road_wheel, float(p.v[self.k + 1]), float(p.t[self.k + 1] - p.t[self.k]))
        self.k += 1


def estimate_speed(rec: Recording, cam: Camera, count: int = 100) -> float:
    """The recording's speed (m/s) from its frames: the optical flow (DIS) of the road plane between pairs of
    consecutive frames, read through the camera's known height and pitch. A textured pixel of the road ahead
    (middle half of the columns, below the far distance, above the bonnet, on an edge across the road whose
    motion the flow can see) at row v lies at distance
    h / tan(depression(v)); where it moved to in the next frame gives the distance the car drove. The median
    over `count` frame pairs spread over the recording; raises when the road shows too little texture."""
    horizon, h = cam.horizon, cam.height
    top, bottom = int(horizon + 0.15 * (h - horizon)), int(h - 0.12 * (h - horizon))
    if bottom - top < 8:
        raise DataError(rec.source, "the camera sees too little road to estimate the speed; give it with --speed M/S")
    rows = np.arange(top, bottom)[:, None] + 0.5
    distance = lambda v: cam.mount_height / np.tan(np.arctan2(v - cam.cy, cam.focal) + np.radians(cam.pitch_deg))  # noqa: E731
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    seg = rec.segment_ids()
    pairs = [i for i in range(len(rec) - 1) if seg[i] == seg[i + 1]]
    estimates = []
    for i in [pairs[k] for k in np.linspace(0, len(pairs) - 1, min(count, len(pairs))).astype(int)] if pairs else []:
        a, b = (cv2.cvtColor(rec.load_frame(j), cv2.COLOR_BGR2GRAY)[top:bottom] for j in (i, i + 1))
        moved = rows + dis.calc(a, b, None)[..., 1]
        gy, gx = np.abs(cv2.Sobel(a, cv2.CV_32F, 0, 1)), np.abs(cv2.Sobel(a, cv2.CV_32F, 1, 0))
        use = (gy > 20) & (gx < 0.3 * gy) & (moved > horizon + 1)  # edges across the road: no aperture problem
        use[:, : cam.width // 4] = use[:, 3 * cam.width // 4:] = False
        if use.sum() >= 50:
            drove = distance(rows) - distance(np.where(use, moved, rows))
            estimates.append(float(np.median(drove[use])) / ((rec.timestamps_ns[i + 1] - rec.timestamps_ns[i]) / 1e9))
    if len(estimates) < max(5, 0.5 * min(count, len(pairs))):
        raise DataError(rec.source, "cannot estimate the speed from the frames (the road shows too little texture); "
                                    "give it with --speed M/S")
    return float(np.median(estimates))


def replay_speed(rec: Recording, cam: Camera, car: Car, speed: float | None) -> tuple[float | None, str]:
    """The speed to replay `rec` at (None: the recorded one) and where it comes from: given, recorded, or
    estimated from the frames (printed; refused when it is not a speed the car drives at)."""
    if speed is not None:
        if not 0 < speed < 100:
            raise SteerlabError(f"--speed must lie in (0, 100) m/s, got {speed}")
        return speed, "given (--speed)"
    if rec.speed is not None:
        return None, "recorded"
    speed = estimate_speed(rec, cam)
    low, high = car.speeds
    if not low <= speed <= high:
        raise DataError(rec.source, f"no speed recorded, and the one estimated from the frames, {speed:.2f} m/s, is "
                                    f"not one this car drives at ({low:g}-{high:g} m/s): the camera geometry may not "
                                    "fit (--mount-height, --pitch, --fov); give the speed with --speed M/S")
    print(f"{rec.source} has no speed signal; estimated from the frames: {speed:.2f} m/s ({speed * 3.6:.0f} km/h); "
          "override with --speed")
    return speed, "estimated from the frames"


def _road_wheel(rec: Recording, steering_ratio: float) -> np.ndarray:
    try:
        return rec.convention.to_road_wheel_left(rec.steering, steering_ratio)
    except SteerlabError as e:
        raise DataError(rec.source, f"{e}: it is needed to rebuild the driven path") from None


def replay_segments(rec: Recording, frames: np.ndarray | None = None) -> list[tuple[int, int]]:
    """The half-open frame ranges to replay: the recording's segments (or the runs of consecutive `frames`
    within them, e.g. a validation split) that last at least MIN_SECONDS."""
    idx = np.arange(len(rec)) if frames is None else np.asarray(frames)
    seg = rec.segment_ids()[idx]
    breaks = np.flatnonzero((np.diff(idx) != 1) | (np.diff(seg) != 0)) + 1
    times = rec.timestamps_ns / 1e9
    runs = [(int(r[0]), int(r[-1]) + 1) for r in np.split(idx, breaks) if len(r)]
    out = [(a, b) for a, b in runs if times[b - 1] - times[a] >= MIN_SECONDS]
    if not out:
        raise DataError(rec.source, f"too short to replay: no segment lasts {MIN_SECONDS:g} s ({len(idx)} frames)")
    return out


def _replay_world(rec: Recording, a: int, b: int, human: np.ndarray, cam: Camera, params: VehicleParams,
                  speed: float | None, max_heading_deg: float) -> ReplayWorld:
    v = np.full(b - a, speed) if speed is not None else np.asarray(rec.speed[a:b], float)
    return ReplayWorld(rec, a, human_path(human[a:b], v, rec.timestamps_ns[a:b] / 1e9, params), cam, params,
                       max_heading_deg)


def replay_recording(pilot, rec: Recording, cam: Camera, car: Car, speed: float | None, limit_m: float,
                     max_heading_deg: float = MAX_HEADING_DEG, video: str | Path | None = None, frames=None,
                     progress: bool = False, on_tick=None) -> tuple[list[dict], np.ndarray]:
    """Replay every segment of `rec` (or of its `frames`) of at least MIN_SECONDS with `pilot`, at the constant
    `speed` (m/s) or, for None, the recorded one. Returns one result row per segment and one for the whole
    recording (segment "all"), and the trajectory of every tick (TRAJECTORY columns, then the segment and the
    frame index)."""
    from steerlab.video import DriveVideo

    params = VehicleParams(wheelbase=car.wheelbase, steering_ratio=car.steering_ratio)
    human = _road_wheel(rec, params.steering_ratio)
    segments = replay_segments(rec, frames)
    fps = rec.frame_rate()
    movie = DriveVideo(video, fps, reference="human") if video else None
    rows, trajs = [], []
    for n, (a, b) in enumerate(segments):
        world = _replay_world(rec, a, b, human, cam, params, speed, max_heading_deg)
        pilot.reset()
        seen = []

        def on_step(t, world=world):
            seen.append(a + world.frame_index())
            if movie:
                r = car.steering_ratio
                movie.add(t.frame, t.model * r, human[seen[-1]] * r, t.offset,
                          f"{rec.name} segment {n}  frame {seen[-1]}  {world.state.v:4.1f} m/s")

        t = drive_loop(world, pilot, b - a, limit_m, fps, on_step=on_step, desc=f"replay segment {n}",
                       progress=progress, on_tick=on_tick)
        t[:, 0] = world.path.t[: len(t)] - world.path.t[0]
        trajs.append(np.column_stack([t, np.full(len(t), n), seen]))
        rows.append(_result(t, fps, str(n), b - a))
    if movie:
        movie.close()
    traj = np.vstack(trajs)
    return [*rows, _result(traj, fps, "all", sum(b - a for a, b in segments))], traj


def rollout_recording(pilot, rec: Recording, cam: Camera, car: Car, speed: float | None, out: str | Path,
                      beta: float, seed: int, frames=None, limit_m: float | None = None,
                      max_heading_deg: float = MAX_HEADING_DEG, on_tick=None) -> dict:
    """DAgger in replay: drive `pilot` over `rec` (or its `frames`) while, with probability `beta` each tick,
    the expert (`ReplayWorld.expert_steering`: back to the human's path) steers instead, and record every
    visited view labelled with the expert's steering, in the recording's own convention and camera geometry,
    as a steerlab recording in `out`. A recording with side cameras gets them in the rollout too, warped from
    the recorded centre frame to SIDE_OFFSET either side of the car (training labels them as it labels recorded
    side cameras). Returns the drive's metrics."""

    params = VehicleParams(wheelbase=car.wheelbase, steering_ratio=car.steering_ratio)
    human = _road_wheel(rec, params.steering_ratio)
    rng = np.random.default_rng([seed, 7])
    sides = {"left", "right"} <= set(rec.cameras)
    writer = RecordingWriter(out, ["center", "left", "right"] if sides else ["center"], convention=rec.convention)
    fps, trajs = rec.frame_rate(), []
    for a, b in replay_segments(rec, frames):
        world = _replay_world(rec, a, b, human, cam, params, speed, max_heading_deg)
        pilot.reset()

        def on_step(t, world=world, a=a):
            views = {"left": world.render(SIDE_OFFSET), "right": world.render(-SIDE_OFFSET)} if sides else {}
            writer.add({"center": t.frame, **views}, {
                "timestamp_ns": int(rec.timestamps_ns[a + t.index]),
                "steering": float(rec.convention.from_road_wheel_left(t.expert, params.steering_ratio)),
                "speed": world.state.v, "throttle": 0.0, "brake": 0.0, "lateral_offset": t.offset,
                "heading_error": t.heading, "curvature": 0.0, "episode": "rollout"})

        trajs.append(drive_loop(world, pilot, b - a, car.lane_limit_m if limit_m is None else limit_m, fps,
                                choose=lambda t: t.expert if rng.random() < beta else t.model, on_step=on_step,
                                progress=False, on_tick=on_tick))
    writer.close({"source": str(rec.source), "geometry": rec.geometry, "fps": fps, "beta": beta, "policy": pilot.name,
                  "wheelbase": car.wheelbase, "side_camera_offset_m": SIDE_OFFSET if sides else None},
                 params.steering_ratio)
    return _result(np.vstack(trajs), fps, "all", len(rec) if frames is None else len(frames))


def _result(t: np.ndarray, fps: float, segment: str, frames: int) -> dict:
    m = drive_metrics(t[:, 4], t[:, 5], t[:, 6], 1.0 / fps, int(t[:, 8].sum()))
    heading = np.degrees(np.abs(t[:, 7]))
    return {"segment": segment, "frames": frames, "km": m["distance_km"], "seconds": len(t) / fps,
            "speed_mps": float(t[:, 6].mean()),
            "autonomy": autonomy(m["interventions"], len(t) / fps), "interventions": m["interventions"],
            "interventions_per_km": m["interventions_per_km"], "mean_offset_m": m["mean_abs_offset_m"],
            "max_offset_m": m["max_abs_offset_m"], "mean_heading_deg": float(heading.mean()),
            "max_heading_deg": float(heading.max()), "gamma": m["command_gamma_deg"]}


def _job(checkpoint: str, label: str, source: dict, cam: Camera, car: Car, speed: float | None, limit_m: float,
         max_heading_deg: float, video: str | None, out: str, smoothing: float | None = None) -> list[dict]:
    """One checkpoint on one recording (in a worker process): result rows, and the trajectory in `out`."""
    from steerlab.data.readers import open_recording
    from steerlab.pilot import Pilot
    from steerlab.sim.bench import tick_reporter

    rec = open_recording(source["data"], source["range"], source["labels"], source["reader"])
    rows, traj = replay_recording(Pilot(checkpoint, smoothing=smoothing), rec, cam, car, speed, limit_m,
                                  max_heading_deg, video, source["frames"], on_tick=tick_reporter())
    Path(out).mkdir(parents=True, exist_ok=True)
    with open(Path(out) / "trajectory.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([*TRAJECTORY, "segment", "frame"])
        w.writerows([[f"{v:.4f}" for v in row[:8]] + [int(v) for v in row[8:]] for row in traj])
    return [{"checkpoint": label, "recording": rec.name, **r} for r in rows]


def run_replay(checkpoints, data: str | Path, out: str | Path, frame_range: str | None = None,
               labels: str | Path | None = None, reader: dict | None = None, speed: float | None = None,
               camera: dict | None = None, limit_m: float | None = None, max_heading_deg: float = MAX_HEADING_DEG,
               video: str | Path | None = None, workers: int = 2, frames=None, progress: bool = True,
               smoothing: float | None = None) -> list[dict]:
    """Replay every checkpoint on the recording `data` (only its `frames`, if given, e.g. a validation split;
    checkpoints in parallel worker processes); write
    `replay.csv` (one row per checkpoint and recording), `segments.csv` (per segment), `replay.md`, `replay.png`
    (the offset along the route, interventions marked) and `LABEL/trajectory.csv`. `camera`: overrides of the
    recording's camera geometry (mount_height, pitch_deg, hfov_deg); `smoothing`: the Pilot's exponential
    smoothing of the steering, as when driving. Returns the rows of replay.csv."""
    from steerlab.data.geometry import CAMERAS, CARS, with_overrides
    from steerlab.data.readers import open_recording
    from steerlab.pilot import Pilot
    from steerlab.sim.bench import labels_for, run_parallel

    checkpoints = [Path(c) for c in checkpoints]
    for c in checkpoints:
        if not c.is_file():
            raise SteerlabError(f"{c}: checkpoint not found")
    rec = open_recording(data, frame_range, labels, reader)
    if rec.geometry not in CAMERAS:
        raise DataError(rec.source, f"no camera geometry for its {rec.geometry!r} frames; replay knows {', '.join(CAMERAS)}")
    cam, car = with_overrides(CAMERAS[rec.geometry], **(camera or {})), CARS[rec.geometry]
    for c in checkpoints:
        pilot = Pilot(c)
        if pilot.geometry != rec.geometry:
            raise SteerlabError(f"{c} was trained on the {pilot.geometry!r} camera geometry and {rec.source} has the "
                                f"{rec.geometry!r} geometry: replay it on recordings of its own camera")
        if pilot.speed_history and rec.speed is None and speed is None:
            warn(f"{c} reads the speed; {rec.source} records none, so it gets the estimated constant speed")
        try:
            pilot.convention.to_road_wheel_left(0.0, car.steering_ratio)
        except SteerlabError as e:
            raise SteerlabError(f"{c}: its steering cannot become a wheel angle: {e}") from None
    _road_wheel(rec, car.steering_ratio)  # the path can be rebuilt
    segments = replay_segments(rec, frames)
    speed, source = replay_speed(rec, cam, car, speed)
    out = Path(out)
    names = labels_for(checkpoints)
    videos = [None] * len(names) if video is None else (
        [str(video)] if len(names) == 1 else [str(Path(video).with_name(f"{Path(video).stem}-{n.replace('/', '-')}"
                                                                           f"{Path(video).suffix}")) for n in names])
    source_spec = {"data": str(data), "range": frame_range, "labels": None if labels is None else str(labels),
                   "reader": reader, "frames": None if frames is None else [int(i) for i in frames]}
    limit = car.lane_limit_m if limit_m is None else limit_m
    jobs = [(str(c), n, source_spec, cam, car, speed, limit, max_heading_deg, v, str(out / n), smoothing)
            for c, n, v in zip(checkpoints, names, videos)]
    minutes = sum(b - a for a, b in segments) / rec.frame_rate() / 60
    results = run_parallel(_job, jobs, workers, minutes, progress, "replay")
    rows = [{**r, "speed_source": source} for rs in results for r in rs]
    out.mkdir(parents=True, exist_ok=True)
    for name, keep in (("replay.csv", lambda r: r["segment"] == "all"), ("segments.csv", lambda r: True)):
        with open(out / name, "w", newline="") as f:
            w = csv.DictWriter(f, RESULT_FIELDS)
            w.writeheader()
            w.writerows([{k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows if keep(r)])
    whole = [r for r in rows if r["segment"] == "all"]
    (out / "replay.md").write_text(markdown(whole, limit, max_heading_deg, smoothing))
    (out / "replay.json").write_text(json.dumps({"data": str(data), "range": frame_range, "camera": cam.__dict__,
                                                 "car": car.__dict__, "limit_m": limit, "smoothing": smoothing,
                                                 "rows": rows}, indent=1))
    plot_offsets(out / "replay.png", {n: np.loadtxt(out / n / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
                                      for n in names}, limit, f"replay on {rec.name}")
    return whole


def markdown(rows: list[dict], limit_m: float, max_heading_deg: float, smoothing: float | None = None) -> str:
    smoothed = "" if smoothing is None else f" The steering is smoothed exponentially, a = {smoothing:g}."
    lines = [f"Closed-loop replay: an intervention when the car is more than {limit_m:g} m off the human's path or "
             f"turned more than {max_heading_deg:g} deg from it; autonomy = (1 - interventions x 6 s / elapsed s) "
             f"x 100, negative when a short drive needs many.{smoothed}", "",
             "| checkpoint | recording | km | speed [m/s] | interventions | interventions/km | autonomy [%] | "
             "mean abs offset [m] | max abs offset [m] | mean abs heading [deg] | command gamma [deg] |",
             "|---" * 11 + "|"]
    for r in rows:
        lines.append(f"| {r['checkpoint']} | {r['recording']} | {r['km']:.2f} | {r['speed_mps']:.1f} "
                     f"({r['speed_source']}) | {r['interventions']} | {r['interventions_per_km']:.1f} | "
                     f"{r['autonomy']:.1f} | {r['mean_offset_m']:.3f} | {r['max_offset_m']:.3f} | "
                     f"{r['mean_heading_deg']:.2f} | {r['gamma']:.3f} |")
    return "\n".join(lines) + "\n"


def _replay_rollout_job(checkpoint: str, out: str, source: dict, beta: float, seed: int) -> dict:
    from steerlab.data.readers import open_recording
    from steerlab.pilot import Pilot
    from steerlab.sim.bench import tick_reporter

    rec = open_recording(source["data"], source["range"], source["labels"], source["reader"])
    return rollout_recording(Pilot(checkpoint), rec, source["cam"], source["car"], source["speed"], out, beta, seed,
                             source["frames"], on_tick=tick_reporter())


class SplitReplay:
    """A training config's recording, its split, camera, car and speed: rollouts over the training frames
    (DAgger in replay) and replays of the validation frames (after every DAgger round, in experiments)."""

    def __init__(self, cfg: dict, speed: float | None = None, workers: int = 1):
        from steerlab.data.geometry import CAMERAS, CARS
        from steerlab.data.readers import open_recording
        from steerlab.data.splits import make_split

        rec = open_recording(cfg["data"], cfg.get("range"), cfg.get("labels"), cfg.get("reader"))
        if rec.geometry not in CAMERAS:
            raise SteerlabError(f"{rec.source}: replay knows no camera geometry for {rec.geometry!r} frames")
        self.train_idx, self.val_idx = make_split(cfg["split"], len(rec), rec.extra.get("session"))
        cam, car = CAMERAS[rec.geometry], CARS[rec.geometry]
        speed, self.speed_source = replay_speed(rec, cam, car, speed)
        self.fps = rec.frame_rate()
        self.source = {"data": cfg["data"], "range": cfg.get("range"), "labels": cfg.get("labels"),
                       "reader": cfg.get("reader"), "cam": cam, "car": car, "speed": speed}
        self.workers = workers

    def rollouts(self, checkpoint: Path, folder: Path, beta: float, seed: int, progress: bool) -> list[dict]:
        from steerlab.sim.bench import run_parallel

        job = (str(checkpoint), str(folder), {**self.source, "frames": [int(i) for i in self.train_idx]}, beta, seed)
        return run_parallel(_replay_rollout_job, [job], 1, len(self.train_idx) / self.fps / 60, progress, "replay rollouts")

    def evaluate(self, checkpoint: Path, out: Path, progress: bool) -> dict:
        from steerlab.sim.replay import run_replay

        s = self.source
        row = run_replay([checkpoint], s["data"], out, s["range"], s["labels"], s["reader"], s["speed"],
                         workers=1, frames=self.val_idx, progress=progress)[0]
        return {"replay_autonomy": row["autonomy"], "replay_interventions_per_km": row["interventions_per_km"],
                "replay_mean_offset_m": row["mean_offset_m"]}
