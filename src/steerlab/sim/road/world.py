"""The road world: a full-size car on one procedural road (`road.Road`), rendered by one pinhole camera
(`render.Renderer`), stepped at the frame rate (`World`), and the options of recording in it and driving in it.
More than `limit_m` off the lane centre is an intervention: the car is put back on the lane centre. What is done
in it (recording the expert, a model's drive, DAgger's rollouts) is `run.py`; its suite is `suite.py`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from steerlab.data.car import Vehicle, VehicleState, car_of
from steerlab.errors import SteerlabError
from steerlab.options import FPS, MINUTES, OFF_PATH, Options, SEED, holds_frames, option
from steerlab.sim.road.expert import cruise, pure_pursuit
from steerlab.sim.road.render import Renderer
from steerlab.sim.road.road import LANE_CENTER, ROAD_TYPES, Road

ROAD_CAMERAS = ("sim", "ch2")  # the camera geometries the road world renders



def road_types(road: str) -> list[str]:
    """"country", "mixed" (every road type) or a comma list such as "country,twisty,twisty": the chunks' types in
    turn, so a repeat means more of that type; one type named several times alone means that type once, and is
    refused."""
    types = list(ROAD_TYPES) if road == "mixed" else [t.strip() for t in road.split(",") if t.strip()]
    bad = [t for t in types if t not in ROAD_TYPES]
    if bad or not types:
        raise SteerlabError(f"unknown road type {','.join(bad) or road!r}; choose one of "
                            f"{', '.join(ROAD_TYPES)}, mixed, or a comma list")
    if len(types) > 1 and len(set(types)) == 1:
        raise SteerlabError(f"{types[0]} named {len(types)} times and nothing else: the same as {types[0]}; name it "
                            "once")
    return types


def _roads(road: str) -> bool:
    try:
        road_types(road)
    except SteerlabError:
        return False
    return True


ROADS = "highway, country, twisty, mixed (all three) or a comma list of them (not one name alone, repeated)"


@dataclass(frozen=True)
class RecordOptions(Options):
    """`steerlab sim record`: the expert on roads made from `seed`."""

    seed: int = option(0, SEED, help="road seed (9000-9999 are the closed-loop suite's, never recorded)")
    minutes: float = option(1.0, MINUTES, help="minutes of driving")
    road: str = option("country", _roads, ROADS, help=f"road type: {ROADS}")
    geometry: Literal["sim", "ch2"] = option("sim", help="camera geometry: sim (320x160) or ch2 (640x480)")
    fps: float = option(20.0, FPS, help="frames per second")
    drift: bool = option(True, help="drift-and-recover episodes")
    side_cameras: bool = option(True, help="the left and right cameras")
    layout: Literal["steerlab", "udacity-sim"] = option("steerlab", help="steerlab's own recording layout, or the "
                                                        "Udacity simulator's driving_log.csv")
    chunk_minutes: float = option(1.0, MINUTES, help="with several road types: minutes before the next one")

    related = holds_frames("minutes", "chunk_minutes")


@dataclass(frozen=True)
class DriveOptions(Options):
    """`steerlab sim drive`: a model on a road made from `seed` (100 by default: not used for training data)."""

    seed: int = option(100, SEED, help="road seed (100: not used for training data)")
    minutes: float = option(1.0, MINUTES, help="minutes of driving")
    road: str = option("country", _roads, ROADS, help=f"road type: {ROADS}")
    geometry: Literal["sim", "ch2"] | None = option(None, help="camera geometry (default: the checkpoint's)")
    fps: float = option(20.0, FPS, help="frames per second")
    limit_m: float = option(1.0, OFF_PATH, help="metres off the lane centre that count as an intervention")

    related = holds_frames("minutes")


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


def cameras(car, side_cameras: bool) -> dict[str, float]:
    """The cameras a recording in the road world writes and their offsets to the left of the car's centre (m)."""
    off = car.side_camera_offset_m
    return {"center": 0.0, **({"left": off, "right": -off} if side_cameras and off else {})}
