"""Closed-loop replay on recorded camera data (`steerlab replay`): would this model keep the car in the lane
of a road it has only seen as a recording?

As NVIDIA tested PilotNet on recorded video: the human's path is rebuilt from the recorded steering and speed
through the kinematic bicycle (`data.path.human_path`); a simulated car starts on it and, each tick, takes the recorded
frame at its arc length along the path, warped to its own viewpoint (lateral offset and heading error, flat
road: `geometry.shift_view`), asks the pilot for a command and moves by it, in the driving loop that every world
uses (`core.driving.drive_loop`): `ReplayWorld` is one segment of a recording seen as a world. Further than the
lane limit from the path (1 m for a car), or turned further than the warp's valid range, is an intervention: the
car is put back on the path and the pilot forgets its past. `Replay` holds how a recording is replayed (camera,
car, speed, limits); `track.py` makes of it the replay of small cars (the fisheye's view, the speed from the
throttle, the body leaving the lane); `run.py` is the command and its reports."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from steerlab.data.car import Car, Vehicle, VehicleState
from steerlab.data.geometry import Camera, shift_view
from steerlab.data.path import HumanPath, human_path, return_steering
from steerlab.data.recording import Recording
from steerlab.errors import DataError, SteerlabError
from steerlab.options import Range
from steerlab.sim.replay.path import human_road_wheel, replay_segments

MAX_HEADING_DEG = 10.0  # beyond this the warped view shows too much of what the camera never saw
MOUNT_HEIGHT = Range(0, 10, lo_open=True, hi_open=True, unit="m")  # the camera mounts a replay takes
PITCH = Range(-45, 45, lo_open=True, hi_open=True, unit="degrees")


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
        heading = (st.psi - self.path.pose(self.s)[2] + math.pi) % (2 * math.pi) - math.pi
        return offset, heading

    def leaves_lane(self, offset: float, heading: float, limit_m: float) -> bool:
        """Whether the car at this (offset, heading error) is an intervention: further than `limit_m` from the
        path, or turned further than the warp's valid range."""
        return abs(offset) > limit_m or abs(heading) > self.max_heading

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        offset, heading = self.observe()
        if not self.leaves_lane(offset, heading, limit_m):
            return False, offset, heading
        x, y, psi = self.path.pose(self.s)
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
        i = self.start + j
        frame = self.rec.load_frame(i)
        try:
            return self.warp(frame, shift + lateral, yaw)
        except SteerlabError as e:  # a frame of another size than the camera's: named by its file
            raise DataError(self.rec.frames["center"][i], f"frame {i}: {e}") from None

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
        the human's path (`data.path.return_steering`: the human's steering at the car's place on the path plus
        the correction of pure pursuit)."""
        st = self.vehicle.state
        return return_steering(self.path, self.frame_index(), self.s, st.x, st.y, st.psi, st.v, self.car)

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


@dataclass(frozen=True)
class Replay:
    """How a recording is driven in replay: its camera and car, the speed (None: the recorded one) and the
    limits of an intervention. `worlds(rec, frames)` makes the worlds of a recording's segments."""

    cam: Camera
    car: Car
    speed: float | None = None
    limit_m: float | None = None
    max_heading_deg: float = MAX_HEADING_DEG

    @property
    def limit(self) -> float:
        return self.car.lane_limit_m if self.limit_m is None else self.limit_m

    def speeds(self, rec: Recording, a: int, b: int) -> np.ndarray:
        """The human's speed (m/s) at frames a..b - 1."""
        return np.full(b - a, self.speed) if self.speed is not None else np.asarray(rec.speed[a:b], float)

    def world(self, rec: Recording, start: int, path: HumanPath) -> ReplayWorld:
        return ReplayWorld(rec, start, path, self.cam, self.car, self.max_heading_deg)

    def paths(self, rec: Recording, frames: np.ndarray | None = None) -> list[tuple[int, int, HumanPath]]:
        """(first frame, frames, the human's path) of every segment of `rec` (or of its `frames`) to replay: the
        path rebuilt from the recorded steering and the speed."""
        human = human_road_wheel(rec, self.car)
        return [(a, b - a, human_path(human[a:b], self.speeds(rec, a, b), rec.timestamps_ns[a:b] / 1e9, self.car))
                for a, b in replay_segments(rec, frames)]

    def worlds(self, rec: Recording, frames: np.ndarray | None = None):
        """(segment index, first frame, world, ticks) for every segment of `rec` (or of its `frames`) to replay."""
        for n, (a, ticks, path) in enumerate(self.paths(rec, frames)):
            yield n, a, self.world(rec, a, path), ticks


@dataclass(frozen=True)
class ReplaySetup:
    """A recording's replay as its options make it (`ReplayOptions.setup`, a world's flavour:
    `track.replay.TrackReplayOptions.setup`): the
    `Replay`, where its speed comes from, and what the reports say: the sentence on when an intervention is
    counted (`criterion`), the offset limit the plot draws (+-`plot_limit` m, named `limit_label`) and the camera
    entry of replay.json."""

    replay: Replay
    speed_source: str
    criterion: str
    plot_limit: float
    limit_label: str
    camera: dict
