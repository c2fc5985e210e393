"""The track world: a small car (`CARS["donkey"]`, `smallcar.SmallCar`) on a closed procedural track
(`track.Track`), seen through the donkeycar fisheye camera (`render.TrackRenderer`), stepped at the frame rate,
and the options of recording in it and driving in it. It is a world of `core.driving.drive_loop` like the road
world's, with what racing a small car on a hall floor brings:

- the speed comes from the throttle: `step(road_wheel, throttle)` drives the car's throttle model (`Car.motor`);
  a pilot that gives no throttle drives at the world's constant `throttle`;
- leaving the lane is an off-track event, the track's intervention: the car's body (its four corners, `Car.body`)
  overhangs a lane edge by more than `limit_m` (0 by default: any part of the body outside the lane, as a race
  marshal sees it). The car is put back on the lane centre at its place along the track, heading along it, at
  its speed;
- laps (`Laps`): the world follows the rear axle's progress along the track (`Track.delta` between successive
  positions, so that driving backwards undoes progress) and times every lap from the start line. The car starts
  on the start line at standstill, so the first lap includes the standing start; a lap with an off-track event
  is not clean.

`RacerPilot` is the racing expert (`expert.Racer`) as a pilot of the same loop: recordings and the suite's
reference laps are driven by it through `drive_loop` too. What is done in the world is `run.py`; its suite is
`suite.py`.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Literal

import numpy as np

from steerlab.control import DEFAULT_THROTTLE, LAT_ACC, PACE_MAX, Throttle, throttle_held
from steerlab.data.car import CARS, Car, VehicleState
from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera, load_calibration
from steerlab.data.recording import SteeringConvention
from steerlab.options import (AT_LEAST_0, FPS, MINUTES, Options, Range, SEED, UNIT, frames_held,
                              option)
from steerlab.pilot import Controls
from steerlab.sim.track.expert import Racer, expert_controls, pursuit
from steerlab.sim.track.look import LOOK, Look
from steerlab.sim.track.smallcar import SmallCar
from steerlab.sim.track.track import LANE_WIDTH, Track
from steerlab.sim.track.render import TrackRenderer

THROTTLE = DEFAULT_THROTTLE  # the constant throttle of a pilot that gives none (0.3): about 1.4 m/s on a straight
DRIFT_EVERY_S = 12.0  # the racing expert's drift-and-recover episodes in a recording, on average


def lane_width_option(help: str = "lane width in metres: between the tape lines, or around the painted centre "
                                  "line"):
    body = CARS["donkey"].body.width  # a narrower lane has no room for the car: every tick off the track
    return option(LANE_WIDTH, Range(body, 2, lo_open=True, unit="m"),
                  f"a number in ({body:g}, 2] m, wider than the car's {body:g} m body", help=help)


def _style():
    return option("taped", help="taped (a line along each lane edge) or centre (one painted centre line)")


def calibration_option():
    """The option of every track command that renders: the fisheye calibration file of the car's camera."""
    return option(None, path="file", help="fisheye calibration of the car's camera (JSON or YAML: image size "
                  "160x120, K, D; default: a 160-degree Raspberry Pi camera)")


def throttle_option():
    """The option of every track command that drives a model: the throttle of one that predicts none (None:
    THROTTLE). Given for models that all learned the throttle, it would change nothing, and is refused."""
    return option(None, UNIT, help=f"the constant throttle of a model that predicts none (default {THROTTLE}); "
                  "refused where every model driven learned its own")


def constant_throttle(given: float | None) -> float:
    """The constant throttle of a model that predicts none: the one given, else THROTTLE."""
    return THROTTLE if given is None else given


def max_throttle_option():
    """The option of every track command that drives a model: the cap of a learned throttle, by default the
    donkeycar part's own (0.5, about 2.4 m/s), as on a real car; 1 races uncapped."""
    return option(0.5, Range(0, 1, lo_open=True), help="the cap of a model's learned throttle and of the racing "
                  "expert's on the suite (the donkeycar part's max_throttle; 1: uncapped)")


def throttle_scale_option():
    """The option of every track command that drives a model: the gain of its learned throttle."""
    return option(1.0, Range(0, 10, lo_open=True), help="the learned throttle times this, then capped: more speed "
                  "where the model slows (as donkeycar's AI_THROTTLE_MULT, which scales after the cap)")


def throttle_floor_option():
    """The option of every track command that drives a model: the least throttle while the car is at rest."""
    return option(0.0, UNIT, help="the least throttle while the car stands (below 0.1 m/s), within the cap: a "
                  "throttle learned from the image alone can brake at rest where the expert braked at speed (0: none)")
def part_throttle(o) -> Throttle:
    """How a drive's or a suite's options `o` shape a donkeycar part's throttle (its scale, cap and floor):
    `core.part.PartPilot(throttle=...)` for a part that is not steerlab's."""
    return Throttle(scale=o.throttle_scale, cap=o.max_throttle, floor=o.throttle_floor)


def steer_by_option():
    """The option of every track command that drives a model: what it steers by."""
    return option("steering", help="steering: the model's steering head; lane: a Stanley controller on the lane its "
                  "lane head sees (train.lane_weight; sim/track/lane.py), with its learned throttle as usual")


def throttle_by_option():
    """The option of every track command that drives a model: what sets its throttle."""
    return option("model", help="model: its own throttle (learned, or the constant one); lane: the pace from the "
                  "lane its lane head sees, the speed the curvature allows at --lat-acc (control.lane_throttle)")


def lat_acc_option():
    """The option of every track command that drives a model: the lateral acceleration of the pace from the lane."""
    return option(None, Range(0, PACE_MAX, lo_open=True, unit="m/s^2"), help="with --throttle-by lane: the lateral "
                  f"acceleration the pace allows, m/s^2 (default {LAT_ACC:g}, the racing expert's)")


def pace_held(v) -> Iterator[tuple[str, str]]:
    """(option, what it must be) where the pace from the lane and the shaping of a learned throttle meet: one sets
    the throttle or the other (options' `related`)."""
    if v.throttle_by == "lane":
        for name, default in (("throttle_scale", 1.0), ("throttle_floor", 0.0)):
            if getattr(v, name) != default:
                yield name, (f"{default:g} with throttle_by lane (--throttle-by lane: the lane sets the pace; it "
                             "shapes a learned throttle)")
        if v.throttle is not None:
            yield "throttle", "left out with throttle_by lane (--throttle-by lane: the lane sets the pace)"
    elif v.lat_acc is not None:
        yield "lat_acc", "given only with throttle_by lane (--throttle-by lane: it shapes the pace from the lane)"


def latency_option():
    """The option of every track command that drives a model: the age of the frame it steers on."""
    return option(0, Range(0, 20), help="ticks the frame the model steers on is late (a real part's camera and "
                  "model time: 1 at 20 frames/s is 50 ms); train such a model with train.target_shift_s to match")


@dataclass(frozen=True)
class TrackRecordOptions(Options):
    """`steerlab sim record --world track`: the racing expert on the track made from `seed`."""

    seed: int = option(0, SEED, help="track seed (9000-9999 are the track suite's, never recorded)")
    minutes: float = option(1.0, MINUTES, help="minutes of driving")
    fps: float = option(20.0, FPS, help="frames per second")
    drift: bool = option(True, help="drift-and-recover episodes")
    layout: Literal["tub", "steerlab"] = option("tub", help="a donkeycar tub v2, or steerlab's own layout (with "
                                                "the episode of every frame)")
    lane_width: float = lane_width_option()
    style: Literal["taped", "centre"] = _style()
    calibration: str | None = calibration_option()
    room: int | None = option(None, SEED, help="seed of the room the track lies in: its floor, light and clutter "
                              "(default: the track's seed); the same track in other rooms is cheap augmentation")
    mount_height: float | None = option(None, Range(0.05, 0.5, unit="m"), help="the camera's height above the floor, "
                                        "m (default: the fisheye's, 0.15)")
    pitch: float | None = option(None, Range(0, 45, unit="degrees"), help="the camera's pitch, degrees down "
                                 "(default: the fisheye's, 20)")
    vary: bool = option(False, help="a room that cannot be memorised: its floor, tape, light, clutter, people and "
                        "the camera (noise, blur, JPEG quality, mount +-3 cm, pitch +-4 degrees) drawn from far wider "
                        "ranges (the look is kept in the recording's metadata)")

    poses: bool = option(False, help="frames rendered from poses drawn around the expert's line instead of its own "
                         "view (the lane crossed and left, the car turned), each labelled with the expert's controls "
                         "from there (sim/track/poses.py): a tub")
    pose_offset: float | None = option(None, Range(0, 3), help="with poses: the lateral offsets drawn, in half lane "
                                       "widths either side of the lane centre (default 1.25; 1: the rear axle on a "
                                       "lane line)")
    pose_heading: float | None = option(None, Range(0, 90, unit="degrees"), help="with poses: the headings to the "
                                        "lane drawn, degrees either way (default 30)")
    pose_seed: int | None = option(None, SEED, help="with poses: the seed of the draw (default 0)")

    @classmethod
    def related(cls, v):
        yield from frames_held(v, "minutes")
        if v.poses and v.layout != "tub":
            yield "layout", "tub with poses (pose frames are written as a tub)"
        for name in ("pose_offset", "pose_heading", "pose_seed"):
            if not v.poses and getattr(v, name) is not None:
                yield name, "given only with poses (--poses): it shapes the pose frames"

    def look(self) -> Look:
        """The room's look: its own, or with `vary` one drawn from the room's seed (`look.Look.draw`)."""
        return Look.draw(self.seed if self.room is None else self.room) if self.vary else LOOK

    def camera(self) -> FisheyeCamera:
        """The fisheye the recording is rendered through: the calibration's (or the default), at the mount given
        (jittered by a varied look)."""
        mount = {"mount_height": self.mount_height, "pitch_deg": self.pitch}
        given = replace(camera_of(self.calibration), **{k: v for k, v in mount.items() if v is not None})
        return self.look().mount(given)


@dataclass(frozen=True)
class TrackDriveOptions(Options):
    """`steerlab sim drive --world track`: a model on the track made from `seed` (100: not used for training)."""

    seed: int = option(100, SEED, help="track seed (100: not used for training data)")
    minutes: float = option(1.0, MINUTES, help="minutes of driving")
    fps: float = option(20.0, FPS, help="frames per second")
    limit_m: float = option(0.0, AT_LEAST_0, help="metres the car's body may overhang the lane edge before it is "
                            "an off-track event")
    lane_width: float = lane_width_option()
    style: Literal["taped", "centre"] = _style()
    calibration: str | None = calibration_option()
    throttle: float | None = throttle_option()
    max_throttle: float = max_throttle_option()
    latency: int = latency_option()
    throttle_scale: float = throttle_scale_option()
    throttle_floor: float = throttle_floor_option()
    light: float | None = option(None, Range(0.2, 2), help="the room's light level (default: its own, drawn in "
                                 "0.75-1.2): the same track at another time of day")
    steer_by: Literal["steering", "lane"] = steer_by_option()
    throttle_by: Literal["model", "lane"] = throttle_by_option()
    lat_acc: float | None = lat_acc_option()

    @classmethod
    def related(cls, v):
        yield from frames_held(v, "minutes")
        yield from throttle_held(v.max_throttle, v.throttle_floor)
        yield from pace_held(v)


def camera_of(calibration: str | None) -> FisheyeCamera:
    """The fisheye the frames are rendered through: the donkeycar default, or a calibration file's."""
    return DONKEY_FISHEYE if calibration is None else load_calibration(calibration)


class Laps:
    """Lap timing along a loop of `length` m: `advance(delta, t)` adds `delta` m of progress along the track made
    by time t (s). A lap is complete when the progress passes a whole multiple of the length, at the time
    interpolated between the two ticks around it; `off_track()` marks the lap in progress as not clean."""

    def __init__(self, length: float):
        self.length = length
        self.progress, self.t = 0.0, 0.0
        self.crossings = [0.0]  # when the car passed the start line; the start is the first
        self.dirty: set[int] = set()  # laps (1-based) with an off-track event

    def advance(self, delta: float, t: float) -> None:
        before, self.progress = self.progress, self.progress + delta
        while self.progress >= len(self.crossings) * self.length:
            line = len(self.crossings) * self.length
            self.crossings.append(self.t + (t - self.t) * (line - before) / (self.progress - before))
        self.t = t

    def off_track(self) -> None:
        self.dirty.add(len(self.crossings))

    def result(self) -> dict:
        """Laps completed, clean ones, the best and mean time of the clean laps (None without one), every lap's
        time and the laps with an off-track event (a lap in progress at the end included)."""
        times = np.diff(self.crossings).tolist()
        clean = [t for k, t in enumerate(times, start=1) if k not in self.dirty]
        return {"laps": len(times), "clean_laps": len(clean), "best_lap_s": min(clean) if clean else None,
                "mean_lap_s": float(np.mean(clean)) if clean else None, "lap_times_s": times,
                "off_track_laps": sorted(self.dirty)}


@lru_cache(maxsize=4)
def renderer_of(seed: int, lane_width: float, style: str, camera: FisheyeCamera,
                room: int | None = None, look: Look = LOOK) -> TrackRenderer:
    """The renderer of a track (in the room drawn from `room`, default the track's seed, with the look `look`), built
    once per process for the last few tracks (0.2-0.5 s and up to 22 MB each): the track suite, DAgger and replay
    drive a track many times. A renderer does not change as it renders."""
    return TrackRenderer(Track(seed, lane_width, style), camera, room, look)


class TrackWorld:
    """A small car at standstill on the start line of the track made from `seed` (see the module's docstring).
    `camera`: the fisheye the frames are rendered through (None: none are rendered, for a driver that reads the
    state, as the racing expert does; `render` gives a black frame). `throttle`: for pilots that give none. `room`
    and `look`: the room (default: the track's) and its look (default: its own)."""

    def __init__(self, seed: int, lane_width: float = LANE_WIDTH, style: str = "taped", fps: float = 20.0,
                 camera: FisheyeCamera | None = DONKEY_FISHEYE, throttle: float = THROTTLE,
                 car: Car = CARS["donkey"], room: int | None = None, look: Look = LOOK):
        self.renderer = None if camera is None else renderer_of(seed, lane_width, style, camera, room, look)
        self.track = Track(seed, lane_width, style) if camera is None else self.renderer.track
        self.blank = np.zeros((DONKEY_FISHEYE.height, DONKEY_FISHEYE.width, 3), np.uint8)
        self.car, self.fps, self.throttle = car, fps, throttle
        x, y, psi = (float(v) for v in self.track.pose(0.0))
        self.smallcar = SmallCar(VehicleState(x, y, psi, 0.0), car)
        self.s, self.ticks, self.applied = 0.0, 0, 0.0
        self.laps = Laps(self.track.length)
        self.steering_ratio = car.steering_ratio
        self.done = False  # a track is a loop: a drive ends when its ticks do

    @property
    def state(self) -> VehicleState:
        return self.smallcar.state

    @property
    def time_s(self) -> float:
        return self.ticks / self.fps

    def observe(self) -> tuple[float, float]:
        """(lateral offset of the rear axle from the lane centre [m, left positive], heading error [rad])."""
        st = self.state
        _, d, track_psi = self.track.project(st.x, st.y, self.s)
        return d, (st.psi - track_psi + math.pi) % (2 * math.pi) - math.pi

    def overhang(self) -> float:
        """How far (m) the body's farthest corner lies outside the lane (negative while all are inside)."""
        return self.track.overhang(*self.smallcar.corners(), self.s)

    def put_back(self) -> None:
        """An off-track event: the car is set on the lane centre at its place, along the track, at its speed."""
        x, y, psi = (float(v) for v in self.track.pose(self.s))
        self.smallcar.state = VehicleState(x, y, psi, self.state.v)
        self.laps.off_track()

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        """Put the car back (an off-track event) if its body overhangs the lane edge by more than `limit_m`.
        Returns whether it did and the car's (offset, heading error) after it, as `observe`."""
        put_back = self.overhang() > limit_m
        if put_back:
            self.put_back()
        return (put_back, *self.observe())

    def render(self, lateral: float = 0.0) -> np.ndarray:
        """The camera's BGR frame; `lateral`: from a camera that far to the left of it."""
        if self.renderer is None:
            return self.blank
        return self.renderer.render(*self.smallcar.camera_pose(lateral), self.s)

    def expert_steering(self) -> float:
        """The expert's road-wheel angle (rad, positive left) in this state: pure pursuit of the lane centre."""
        return pursuit(self.track, self.state, self.s, 0.0, self.car.wheelbase)

    def expert_controls(self) -> tuple[float, float]:
        """The expert's (road-wheel angle, throttle) in this state, without lag, noise or memory
        (`expert.expert_controls`): the labels of DAgger's rollouts."""
        return expert_controls(self.track, self.state, self.s, self.car)

    def step(self, road_wheel: float, throttle: float | None = None) -> None:
        """Apply a road-wheel angle and a throttle in [-1, 1] (None: the world's constant one) for one frame,
        then follow the car along the track and its laps."""
        self.applied = float(np.clip(self.throttle if throttle is None else throttle, -1.0, 1.0))
        self.smallcar.step(road_wheel, self.applied, 1.0 / self.fps)
        self.ticks += 1
        st = self.state
        s = self.track.project(st.x, st.y, self.s, window=3.0 + 2 * st.v / self.fps)[0]
        self.laps.advance(float(self.track.delta(self.s, s)), self.time_s)
        self.s = s

    def lane_curvature(self) -> float:
        """The lane's curvature where the car is (1/m, positive where it turns left)."""
        return float(self.track.curvature(self.s))

    def record_row(self, tick: int) -> dict:
        """What a recording holds of this tick besides the frames, the steering and the episode: the throttle
        last applied as throttle and brake (the ESC's negative throttle brakes), and the lane's curvature."""
        return {"timestamp_ns": int(round(tick * 1e9 / self.fps)), "speed": self.state.v,
                "throttle": max(self.applied, 0.0), "brake": max(-self.applied, 0.0),
                "curvature": self.lane_curvature()}


class RacerPilot:
    """The racing expert as a pilot of `drive_loop` in a `TrackWorld`: it reads the world's state, not the frame,
    and answers its road-wheel angle (positive left) and throttle, the throttle capped to +-`max_throttle` as the
    donkeycar part caps a model's (the suite's reference laps are driven under the models' cap); `episode` labels
    its last answer (normal, drift-out, recover)."""

    name, geometry, source = "expert", "donkey", "the racing expert"
    convention = SteeringConvention("road_wheel", "left")

    def __init__(self, world: TrackWorld, seed: int, drift_every_s: float | None = None, max_throttle: float = 1.0):
        self.world, self.max_throttle = world, max_throttle
        self.racer = Racer(world.track, world.car, seed, 1.0 / world.fps, drift_every_s=drift_every_s)
        self.episode = "normal"

    def step(self, frame, speed=None) -> Controls:
        w = self.world
        offset, _ = w.observe()
        delta, throttle, self.episode = self.racer.act(w.state, w.s, offset, w.time_s)
        return Controls(delta, throttle=float(np.clip(throttle, -self.max_throttle, self.max_throttle)))

    def reset(self) -> None:
        """Nothing to forget: the expert acts on the state."""
