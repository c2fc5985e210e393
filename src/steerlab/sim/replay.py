"""Closed-loop replay on recorded camera data (`steerlab replay`): would this model keep the car in the lane
of a road it has only seen as a recording?

As NVIDIA tested PilotNet on recorded video: the human's path is rebuilt from the recorded steering and speed
through the kinematic bicycle (`human_path`); a simulated car starts on it and, each tick, takes the recorded
frame at its arc length along the path, warped to its own viewpoint (lateral offset and heading error, flat
road: `geometry.shift_view`), asks the pilot for a command and moves by it, in the driving loop that the
synthetic world uses (`sim.driving.drive_loop`). Further than the lane limit from the path (1 m for a car), or
turned further than the warp's valid range, is an intervention: the car is put back on the path and the pilot
forgets its past. Recordings without a speed signal get one estimated from the frames (`data.speed`).
`replay.run_replay` (sim/replay_run.py) is the command around it; `replay_track.py` makes of it the replay of
small cars (the fisheye's view, the speed from the throttle, the body leaving the lane)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from steerlab.data.car import Car
from steerlab.data.geometry import Camera, shift_view
from steerlab.data.recording import Recording
from steerlab.data.speed import estimate_speed
from steerlab.data.writer import RecordingWriter
from steerlab.errors import DataError, SteerlabError
from steerlab.options import Range
from steerlab.sim.driving import Trajectory, autonomy, drive_loop, rollout
from steerlab.sim.vehicle import Vehicle, VehicleState

MAX_HEADING_DEG = 10.0  # beyond this the warped view shows too much of what the camera never saw
MIN_SECONDS = 3.0       # shorter segments are not replayed
MOUNT_HEIGHT = Range(0, 10, lo_open=True, hi_open=True, unit="m")  # the camera mounts a replay takes
PITCH = Range(-45, 45, lo_open=True, hi_open=True, unit="degrees")


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


def human_path(road_wheel: np.ndarray, speed: np.ndarray, times_s: np.ndarray, car: Car) -> HumanPath:
    """Integrate the recorded road-wheel angles (rad, positive left) and speeds through the vehicle model: frame
    i's steering and frame i+1's speed take the car from frame i to frame i+1."""
    vehicle = Vehicle(VehicleState(0.0, 0.0, 0.0, float(speed[0])), car)
    pose = [(0.0, 0.0, 0.0)]
    for i in range(1, len(times_s)):
        st = vehicle.advance(float(road_wheel[i - 1]), float(speed[i]), float(times_s[i] - times_s[i - 1]))
        pose.append((st.x, st.y, st.psi))
    x, y, psi = np.array(pose).T
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    return HumanPath(np.asarray(times_s, float), x, y, psi, s, np.asarray(speed, float), np.asarray(road_wheel, float))


class ReplayWorld:
    """One segment of a recording as a world for `drive_loop`: the car follows the human's speed tick by tick
    and sees the recorded frame at its arc length, warped to its viewpoint."""

    camera_forward = 0.0  # m from the path's pose to the camera

    def __init__(self, rec: Recording, start: int, path: HumanPath, cam: Camera, car: Car,
                 max_heading_deg: float = MAX_HEADING_DEG):
        self.rec, self.start, self.path, self.cam, self.car = rec, start, path, cam, car
        self.max_heading = math.radians(max_heading_deg)
        self.steering_ratio = car.steering_ratio
        self.vehicle = Vehicle(VehicleState(path.x[0], path.y[0], path.psi[0], path.v[0]), car)
        self.k = 0      # tick = index of the human's frame in time
        self.i = 0      # path segment [i, i + 1] the car is on
        self.s = 0.0    # the car's arc length along the path
        self.view = (0.0, 0.0)  # the last warp (shift m, yaw deg)

    @property
    def state(self) -> VehicleState:
        return self.vehicle.state

    @property
    def done(self) -> bool:
        return self.k >= len(self.path.t) - 1 or self.s >= self.path.s[-1]

    def _pose(self, s: float) -> tuple[float, float, float]:
        p = self.path
        return (float(np.interp(s, p.s, p.x)), float(np.interp(s, p.s, p.y)), float(np.interp(s, p.s, p.psi)))

    def project(self, px, py) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Points (arrays) near the car on the human's path: the index of the path segment [j, j + 1] nearest to
        each (searched near the car), where along it (0..1), and the signed distance from it (m, left positive).
        None where the human stood still over the whole search."""
        p = self.path
        lo, hi = max(min(self.i, self.k) - 5, 0), min(max(self.i, self.k) + 40, len(p.s) - 1)
        x0, y0, dx, dy = p.x[lo:hi], p.y[lo:hi], np.diff(p.x[lo:hi + 1]), np.diff(p.y[lo:hi + 1])
        length2 = dx * dx + dy * dy
        moves = length2 >= 1e-12
        if not moves.any():
            return None
        px, py = np.asarray(px, float)[..., None], np.asarray(py, float)[..., None]
        u = np.clip(((px - x0) * dx + (py - y0) * dy) / np.where(moves, length2, 1.0), 0.0, 1.0)
        ex, ey = px - (x0 + u * dx), py - (y0 + u * dy)
        best = np.argmin(np.where(moves, ex * ex + ey * ey, np.inf), axis=-1)[..., None]
        offset = (dx * ey - dy * ex) / np.sqrt(np.where(moves, length2, 1.0))
        return (lo + best[..., 0], *(np.take_along_axis(a, best, -1)[..., 0] for a in (u, offset)))

    def observe(self) -> tuple[float, float]:
        """(lateral offset from the human's path [m, left positive], heading error [rad]) of the car now."""
        st = self.vehicle.state
        nearest = self.project(st.x, st.y)
        if nearest is None:
            return 0.0, 0.0
        self.i, u, offset = int(nearest[0]), float(nearest[1]), float(nearest[2])
        p = self.path
        self.s = p.s[self.i] + u * (p.s[self.i + 1] - p.s[self.i])
        heading = (st.psi - self._pose(self.s)[2] + math.pi) % (2 * math.pi) - math.pi
        return offset, heading

    def leaves_lane(self, offset: float, heading: float, limit_m: float) -> bool:
        """Whether the car at this (offset, heading error) is an intervention: further than `limit_m` from the
        path, or turned further than the warp's valid range."""
        return abs(offset) > limit_m or abs(heading) > self.max_heading

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        offset, heading = self.observe()
        if not self.leaves_lane(offset, heading, limit_m):
            return False, offset, heading
        x, y, psi = self._pose(self.s)
        self.vehicle.state = VehicleState(x, y, psi, self.vehicle.state.v)
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
        j = self.frame_index()
        shift, yaw = self.relative_view(j)
        if not lateral:
            self.view = (shift, yaw)
        return self.warp(self.rec.load_frame(self.start + j), shift + lateral, yaw)

    def relative_view(self, j: int) -> tuple[float, float]:
        """(m to the left, degrees turned left) of the car's camera relative to the human's at frame j; the
        camera sits `camera_forward` ahead of the pose the path follows (0 for a road car: at it)."""
        p, st, ahead = self.path, self.vehicle.state, self.camera_forward
        dx = st.x + ahead * math.cos(st.psi) - (p.x[j] + ahead * math.cos(p.psi[j]))
        dy = st.y + ahead * math.sin(st.psi) - (p.y[j] + ahead * math.sin(p.psi[j]))
        shift = -math.sin(p.psi[j]) * dx + math.cos(p.psi[j]) * dy
        return shift, math.degrees((st.psi - p.psi[j] + math.pi) % (2 * math.pi) - math.pi)

    def warp(self, frame: np.ndarray, shift_m: float, yaw_deg: float) -> np.ndarray:
        """A recorded frame seen from a camera moved `shift_m` to the left and turned `yaw_deg` to the left."""
        return shift_view(frame, self.cam, shift_m, yaw_deg)

    def expert_steering(self) -> float:
        """The label of a visited state: the road-wheel angle (rad, positive left) that brings the car back to
        the human's path. The human's own steering at the car's place on the path, plus the correction of pure
        pursuit (pure pursuit of the path from the car's pose, minus pure pursuit from the path's own pose
        there): on the path exactly the human's steering, as the recording labels it, and off it the
        generalisation of paper 002's side-camera label (Eq. 3)."""
        st = self.vehicle.state
        x, y, psi = self._pose(self.s)
        return (float(self.path.wheel[self.frame_index()]) + self._pursuit(st.x, st.y, st.psi, st.v)
                - self._pursuit(x, y, psi, st.v))

    def _pursuit(self, x: float, y: float, psi: float, v: float) -> float:
        """Pure pursuit of the path from a pose: the road-wheel angle towards the path point one lookahead
        ahead of the car's arc length."""
        lookahead = max(0.9 * v, 3.0 * self.car.wheelbase)
        tx, ty, _ = self._pose(self.s + lookahead)
        alpha = (math.atan2(ty - y, tx - x) - psi + math.pi) % (2 * math.pi) - math.pi
        return math.atan2(2 * self.car.wheelbase * math.sin(alpha), math.hypot(tx - x, ty - y))

    def step(self, road_wheel: float, throttle: float | None = None) -> None:
        """Apply a road-wheel angle for one frame at the recorded (or replayed) speed; a pilot's throttle is not
        used: the recording's frames come at its own pace."""
        p = self.path
        self.vehicle.advance(road_wheel, float(p.v[self.k + 1]), float(p.t[self.k + 1] - p.t[self.k]))
        self.k += 1

    def record_row(self, tick: int) -> dict:
        """What a DAgger rollout records of a tick besides the frames, the label and the episode."""
        return {"timestamp_ns": int(self.rec.timestamps_ns[self.start + tick]), "speed": self.state.v,
                "throttle": 0.0, "brake": 0.0, "curvature": 0.0}


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


def human_road_wheel(rec: Recording, car: Car) -> np.ndarray:
    """The recorded steering as road-wheel angles (rad, positive left), which rebuild the driven path."""
    try:
        return rec.convention.to_road_wheel_left(rec.steering, car.steering_ratio)
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


@dataclass(frozen=True)
class Replay:
    """A recording as worlds to drive: its camera and car, the speed (None: the recorded one), the limits of
    an intervention, and which frames (None: all)."""

    rec: Recording
    cam: Camera
    car: Car
    speed: float | None = None
    limit_m: float | None = None
    max_heading_deg: float = MAX_HEADING_DEG
    frames: np.ndarray | None = None

    @property
    def limit(self) -> float:
        return self.car.lane_limit_m if self.limit_m is None else self.limit_m

    def speeds(self, a: int, b: int) -> np.ndarray:
        """The human's speed (m/s) at frames a..b - 1."""
        return np.full(b - a, self.speed) if self.speed is not None else np.asarray(self.rec.speed[a:b], float)

    def world(self, start: int, path: HumanPath) -> ReplayWorld:
        return ReplayWorld(self.rec, start, path, self.cam, self.car, self.max_heading_deg)

    def worlds(self):
        """(segment index, first frame, world, ticks) for every segment to replay."""
        human = human_road_wheel(self.rec, self.car)
        for n, (a, b) in enumerate(replay_segments(self.rec, self.frames)):
            path = human_path(human[a:b], self.speeds(a, b), self.rec.timestamps_ns[a:b] / 1e9, self.car)
            yield n, a, self.world(a, path), b - a


def replay_recording(pilot, replay: Replay, video: str | Path | None = None, progress: bool = False,
                     on_tick=None) -> tuple[list[dict], Trajectory]:
    """Replay every segment of the recording (or of its `frames`) of at least MIN_SECONDS with `pilot`. Returns
    one result row per segment and one for the whole recording (segment "all"), and the trajectory of every
    tick with its segment and frame."""
    from steerlab.video import DriveVideo

    rec, fps, ratio = replay.rec, replay.rec.frame_rate(), replay.car.steering_ratio
    human = human_road_wheel(rec, replay.car)
    movie = DriveVideo(video, fps, reference="human") if video else None
    rows, traj = [], None
    for n, a, world, ticks in replay.worlds():
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


def rollout_recording(pilot, replay: Replay, out: str | Path, beta: float, seed: int, on_tick=None) -> dict:
    """DAgger in replay (`driving.rollout`): the expert is `ReplayWorld.expert_steering` (back to the human's
    path), the views are recorded in the recording's own convention and camera geometry as a steerlab recording
    in `out`. A recording with side cameras gets them in the rollout too, warped from the recorded centre frame
    to the car's side-camera offset either side (training labels them as it labels recorded side cameras).
    Returns the drive's metrics."""
    rec = replay.rec
    sides = {"left", "right"} <= set(rec.cameras) and replay.car.side_camera_offset_m
    writer = RecordingWriter(out, ["center", "left", "right"] if sides else ["center"], convention=rec.convention,
                             geometry=rec.geometry)
    fps = rec.frame_rate()
    worlds = [(world, ticks) for _, _, world, ticks in replay.worlds()]
    t = rollout(pilot, worlds, writer, rec.convention, beta, np.random.default_rng([seed, 7]), replay.limit, fps,
                on_tick)
    writer.close({"source": str(rec.source), "fps": fps, "beta": beta, "policy": pilot.name})
    return result(t, fps, "all", len(rec) if replay.frames is None else len(replay.frames))


def result(t: Trajectory, fps: float, segment: str, frames: int) -> dict:
    """A replay's result row: its distance, speed, interventions, offsets, heading errors and command gamma."""
    m = t.metrics(1.0 / fps)
    heading = np.degrees(np.abs(t.heading))
    return {"segment": segment, "frames": frames, "km": m["distance_km"], "seconds": len(t) / fps,
            "speed_mps": float(t.speed.mean()), "autonomy": autonomy(m["interventions"], len(t) / fps),
            "interventions": m["interventions"], "interventions_per_km": m["interventions_per_km"],
            "mean_offset_m": m["mean_abs_offset_m"], "max_offset_m": m["max_abs_offset_m"],
            "mean_heading_deg": float(heading.mean()), "max_heading_deg": float(heading.max()),
            "gamma": m["command_gamma_deg"]}
