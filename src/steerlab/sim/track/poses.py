"""Frames from every pose (`steerlab sim record --world track --poses`): the camera's frame rendered from poses
drawn around the line the racing expert drives, each labelled with what the expert would do from there.

The expert first drives the track (`o.minutes`, with its drift-and-recover episodes unless `o.drift` is false)
without a frame rendered; each tick of that drive gives a place along the track (the rear axle's arc length) and
the speed the car drives there, so that the places and speeds are those of driving (more frames where the car is
slow, in the corners). At each, the car is set down with its rear axle a lateral offset from the lane centre drawn
uniformly within +-`pose_offset` half lane widths (1: the axle on a lane line; above 1: beyond the lane's edge)
and its heading to the lane drawn uniformly within +-`pose_heading` degrees, both independent of each other and of
every other frame (`draw`). The world renders the camera there exactly
as the driving loop does, and the record holds the expert's steering and throttle in that state
(`expert.expert_controls`: pure pursuit of the lane centre and the feed-forward throttle, no lag, noise or memory,
as DAgger's labels) and the lane values there (offset, heading, curvature). Every record is a session of its own
(no frame history spans two poses). The tub's manifest metadata says how the poses were drawn (`poses`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.data.fisheye import camera_fields
from steerlab.data.writer import TubWriter
from steerlab.options import frames_in
from steerlab.sim.core.driving import drive_loop
from steerlab.data.car import VehicleState
from steerlab.sim.track.world import DRIFT_EVERY_S, RacerPilot, TrackWorld

POSE_OFFSET = 1.25   # half lane widths either side of the lane centre: across the lane and beyond its edges
POSE_HEADING = 30.0  # degrees either way of the lane's direction


def racing_line(o) -> tuple[np.ndarray, np.ndarray]:
    """(arc length [m], speed [m/s]) of every tick of the expert's drive of the record options `o`, no frame
    rendered: the places and speeds the poses are drawn at."""
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera=None)
    t = drive_loop(world, RacerPilot(world, o.seed, DRIFT_EVERY_S if o.drift else None), frames_in(o.minutes, o.fps),
                   0.0, o.fps, progress=False)
    return t.s, t.speed


def manifest(o) -> dict:
    """How the poses of the record options `o` are drawn (the tub's metadata `poses`): the largest offset (m) and
    heading (degrees) either way, the seed, in words the rest."""
    return {"around": f"the racing expert's drive of {o.minutes:g} min ({'with' if o.drift else 'without'} "
                      "drift episodes): its places along the track and its speeds",
            "offset_m": o.lane_width / 2 * (POSE_OFFSET if o.pose_offset is None else o.pose_offset),
            "heading_deg": POSE_HEADING if o.pose_heading is None else o.pose_heading,
            "seed": 0 if o.pose_seed is None else o.pose_seed,
            "distribution": "uniform within +-offset_m of the lane centre and +-heading_deg of the lane's "
                            "direction, independent",
            "labels": "the expert's controls from the pose (pure pursuit of the lane centre, feed-forward "
                      "throttle)"}


def draw(poses: dict, track_seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """`n` (lateral offset [m, positive left], heading to the lane [rad, positive turned left]) drawn as the
    metadata `poses` (`manifest`) says, on the track made from `track_seed`."""
    rng = np.random.default_rng([poses["seed"], track_seed, 31])
    heading = math.radians(poses["heading_deg"])
    return rng.uniform(-poses["offset_m"], poses["offset_m"], n), rng.uniform(-heading, heading, n)


def set_pose(world: TrackWorld, s: float, offset: float, heading: float, speed: float) -> None:
    """Put the car of `world` with its rear axle at (s, offset) in road coordinates, turned `heading` to the lane,
    at `speed`."""
    x, y, psi = (float(v) for v in world.track.pose(s, offset))
    world.smallcar.state = VehicleState(x, y, psi + heading, speed)
    world.s = s


def record_poses(out: str | Path, o, progress: bool = True) -> Path:
    """The pose frames of the record options `o` (`o.poses`) as a tub in `out` (see the module's docstring)."""
    camera, look = o.camera(), o.look()
    s, speed = racing_line(o)
    poses = manifest(o)
    offset, heading = draw(poses, o.seed, len(s))
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera, room=o.room, look=look)
    tub = TubWriter(out, world.car.full_lock_deg, quality=look.jpeg_quality, lane=True,
                    metadata={"fisheye": camera_fields(camera), **look.metadata(), "poses": poses})
    for k in tqdm(range(len(s)), desc=f"poses track {o.seed}", unit="frame", disable=None if progress else True):
        set_pose(world, float(s[k]), float(offset[k]), float(heading[k]), float(speed[k]))
        wheel, throttle = world.expert_controls()
        tub.add(world.render(), int(round(k * 1e9 / o.fps)), wheel, throttle, new_session=True,
                lane=(*world.observe(), world.lane_curvature()))
    return tub.close()
