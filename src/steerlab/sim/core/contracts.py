"""What the one driving loop (`driving.drive_loop`) asks of a world and of a pilot, as protocols the code checks.

A **world** is a car in a place it can be rendered, stepped and put back: the road world (`road.world.World`), the
track world (`track.world.TrackWorld`) and a recording seen as a world (`replay.world.ReplayWorld` and the small
cars' `track.replay.TrackReplayWorld`). A **pilot** turns a camera frame and the measured speed into controls:
steerlab's `Pilot` on a checkpoint, any donkeycar part (`part.PartPilot`) and the racing expert
(`track.world.RacerPilot`). `drive_loop` checks both before the first tick (`check`): an object that lacks a
member is refused with one line naming the members it lacks, not an AttributeError in the middle of a drive.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from steerlab.data.car import Car, VehicleState
    from steerlab.data.recording import SteeringConvention
    from steerlab.pilot import Controls


@runtime_checkable
class World(Protocol):
    """A car in a world, stepped at its frame rate.

    - `car`: the driven car's numbers (`data.car.Car`); `steering_ratio`: what turns a steering-wheel angle into a
      road-wheel angle for it;
    - `state`: the car's pose and speed (`VehicleState`, m, rad, m/s); `s`: its arc length along the road, track
      or recorded path (m);
    - `done`: the world has nothing more to drive (the end of a recording; a road or track never ends);
    - `intervene(limit_m)`: puts the car back if it left its lane (what that means, and what `limit_m` measures, is
      the world's) and returns (whether it did, lateral offset m left positive, heading error rad);
    - `render(lateral=0.0)`: the camera frame (BGR), or from a camera `lateral` m to the left (side cameras);
    - `expert_steering()`: the expert's road-wheel angle in this state (rad, positive left): the label of DAgger;
    - `step(road_wheel, throttle=None)`: one frame with this road-wheel angle and, in a world whose speed comes
      from the throttle, this throttle (None: the world's own);
    - `record_row(tick)`: what a recording keeps of a tick besides the frames, the steering and the episode.
    """

    car: Car
    steering_ratio: float
    s: float

    @property
    def state(self) -> VehicleState: ...

    @property
    def done(self) -> bool: ...

    def intervene(self, limit_m: float) -> tuple[bool, float, float]: ...

    def render(self, lateral: float = 0.0) -> np.ndarray: ...

    def expert_steering(self) -> float: ...

    def step(self, road_wheel: float, throttle: float | None = None) -> None: ...

    def record_row(self, tick: int) -> dict: ...


@runtime_checkable
class Pilot(Protocol):
    """Frames in, controls out: `step(frame, speed)` -> `pilot.Controls` (steering in `convention`, and a throttle
    where it gives one), `reset()` to forget the past (after an intervention, at a segment's start); `name` (a
    table's label), `geometry` (the camera it expects, None: any) and `source` (what messages name)."""

    name: str
    geometry: str | None
    source: str
    convention: SteeringConvention

    def step(self, frame: np.ndarray, speed: float | None = None) -> Controls: ...

    def reset(self) -> None: ...


def missing(obj, protocol: type) -> list[str]:
    """The members of `protocol` that `obj` lacks."""
    members = [m for m in dir(protocol) if not m.startswith("_")] + list(getattr(protocol, "__annotations__", {}))
    return sorted({m for m in members if not hasattr(obj, m)})


def check(world, pilot) -> None:
    """A world and a pilot that the driving loop can drive, or a TypeError naming what one of them lacks (a
    mistake in code, not in a user's input)."""
    for obj, protocol in ((world, World), (pilot, Pilot)):
        if not isinstance(obj, protocol):
            raise TypeError(f"{type(obj).__name__} is not a {protocol.__name__} of the driving loop: it lacks "
                            f"{', '.join(missing(obj, protocol))} (sim/core/contracts.py)")
