"""The one driving loop of every closed loop: the road world (`sim drive`, the suite, DAgger rollouts), the track
world of small cars (`sim drive/bench --world track`) and replay on recorded camera data (`steerlab replay`), and
the `Trajectory` it returns.

A world and a pilot are what `contracts.World` and `contracts.Pilot` say, checked before the first tick. Each tick
the car is put back if it left the lane (an intervention, after which the pilot forgets its past; what leaving the
lane means, and what `limit_m` measures, is the world's), the camera frame is taken, the pilot answers, and the car
moves by the model's command and, where the pilot gives one, its throttle (or, for DAgger, by whatever `choose`
picks): a world whose speed comes from the throttle (the track world) drives by it, the others follow their own
speed profile or recording and ignore it."""

from __future__ import annotations

import csv
from collections import deque
from dataclasses import dataclass, fields
from functools import cached_property
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.errors import SteerlabError
from steerlab.sim.core.contracts import World, check


@dataclass
class Trajectory:
    """One row per tick: time (s), pose (m) and arc length along the road or path (m), lateral offset from the
    lane centre or the human's path (m, left positive), the pilot's steering command (in its checkpoint's
    convention), speed (m/s), heading error (rad), whether the car was put back before the tick; for replay
    also the recording's segment and frame of the tick."""

    time_s: np.ndarray
    x: np.ndarray
    y: np.ndarray
    s: np.ndarray
    offset: np.ndarray
    command: np.ndarray
    speed: np.ndarray
    heading: np.ndarray
    intervention: np.ndarray
    segment: np.ndarray | None = None
    frame: np.ndarray | None = None

    COLUMNS = {"time_s": "time_s", "x": "x", "y": "y", "s": "s", "offset": "lateral_offset_m", "command": "steering",
               "speed": "speed", "heading": "heading_error_rad", "intervention": "intervention",
               "segment": "segment", "frame": "frame"}

    def __len__(self) -> int:
        return len(self.time_s)

    @property
    def interventions(self) -> int:
        return int(np.sum(self.intervention))

    def _present(self) -> list[str]:
        return [f.name for f in fields(self) if getattr(self, f.name) is not None]

    def concat(self, other: Trajectory) -> Trajectory:
        return Trajectory(**{k: np.concatenate([getattr(self, k), getattr(other, k)]) for k in self._present()})

    def write(self, path: str | Path) -> None:
        names = self._present()
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow([self.COLUMNS[k] for k in names])
            columns = [getattr(self, k) for k in names]
            ints = {"intervention", "segment", "frame"}
            w.writerows([[int(v) if k in ints else f"{v:.4f}" for k, v in zip(names, row)] for row in zip(*columns)])

    @classmethod
    def read(cls, path: str | Path) -> Trajectory:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        by_column = {v: k for k, v in cls.COLUMNS.items()}
        data = np.array(rows[1:], float).reshape(-1, len(rows[0]))
        return cls(**{by_column[name]: data[:, i] if by_column[name] not in ("intervention", "segment", "frame")
                      else data[:, i].astype(np.int64) for i, name in enumerate(rows[0])})

    def metrics(self, dt: float) -> DriveMetrics:
        """The closed-loop metrics of a drive stepped every `dt` s."""
        km = float(np.sum(self.speed) * dt / 1000)
        n = self.interventions
        return DriveMetrics(autonomy(n, len(self) * dt), n, n / max(km, 1e-9), float(np.mean(np.abs(self.offset))),
                            float(np.max(np.abs(self.offset))),
                            float(np.degrees(np.std(np.diff(self.command)))) if len(self) > 1 else 0.0, km)


@dataclass(frozen=True)
class DriveMetrics:
    """A drive's closed-loop metrics: NVIDIA's autonomy (%), interventions and interventions per km, mean and
    largest |lateral offset| (m), command gamma (degrees of the pilot's steering convention) and km driven."""

    autonomy: float
    interventions: int
    interventions_per_km: float
    mean_abs_offset_m: float
    max_abs_offset_m: float
    command_gamma_deg: float
    distance_km: float


@dataclass
class Tick:
    """What one tick saw and did: steering as road-wheel angles in radians, positive left, and the pilot's
    throttle (None when it gives none). `expert`, the expert's steering in this state, is computed only when
    something asks for it (a video, a DAgger label)."""

    index: int
    frame: np.ndarray
    offset: float
    heading: float
    model: float
    intervention: bool
    world: World
    throttle: float | None = None

    @cached_property
    def expert(self) -> float:
        return self.world.expert_steering()


def check_steers(pilot, car) -> None:
    """A pilot whose steering cannot become a wheel angle of `car` (normalized steering without a full-lock
    angle) is refused before it drives, naming the model."""
    try:
        pilot.convention.to_road_wheel_left(0.0, car.steering_ratio)
    except SteerlabError:
        raise SteerlabError(f"{pilot.source}: model {pilot.name!r} predicts normalized steering without a full-lock "
                            "angle, so its steering has no angle to steer a car with (train it on the tub with the "
                            "reader option full_lock_deg)") from None


def autonomy(interventions: int, elapsed_s: float) -> float:
    """NVIDIA's autonomy: (1 - interventions * 6 s / elapsed s) * 100."""
    return (1.0 - interventions * 6.0 / elapsed_s) * 100.0


def drive_loop(world, pilot, ticks: int, limit_m: float, fps: float, choose=None, on_step=None, desc: str = "drive",
               progress: bool = True, on_tick=None, latency: int = 0) -> Trajectory:
    """Drive `pilot` in `world` for `ticks` frames (or until `world.done`). The pilot's steering (in
    `pilot.convention`) becomes a road-wheel angle through `world.steering_ratio`; the pilot's throttle
    (`Controls.throttle`, None for a pilot that gives none) goes to `world.step` with it; `choose(tick)` returns
    the (road-wheel angle, throttle) to apply instead (DAgger's mix of model and expert). `latency`: the pilot
    steers on the frame rendered that many ticks before (the first frame until there is one that old), as a
    real car's pilot acts on a frame its camera and model took time over. `on_step(tick)` sees every tick
    (recording, video; `tick.frame` is the frame rendered now); `on_tick(k)` is called every 100 ticks (progress of
    a suite)."""
    check(world, pilot)
    seen = deque(maxlen=latency + 1)  # the frames of the last `latency` + 1 ticks
    rows = []
    for i in tqdm(range(ticks), desc=desc, unit="tick", disable=None if progress else True):
        if world.done:
            break
        put_back, offset, heading = world.intervene(limit_m)
        if put_back:
            pilot.reset()
        frame = world.render()
        seen.append(frame)
        st = world.state
        controls = pilot.step(seen[0], st.v)
        command = controls.steering
        tick = Tick(i, frame, offset, heading, pilot.convention.to_road_wheel_left(command, world.steering_ratio),
                    put_back, world, controls.throttle)
        if on_step:
            on_step(tick)
        rows.append((i / fps, st.x, st.y, world.s, offset, command, st.v, heading, float(put_back)))
        world.step(*((tick.model, controls.throttle) if choose is None else choose(tick)))
        if on_tick and (i + 1) % 100 == 0:
            on_tick(100)
    a = np.array(rows, dtype=float).reshape(-1, 9).T
    return Trajectory(*a[:8], a[8].astype(bool))


def rollout(pilot, worlds, writer, convention, beta: float, rng: np.random.Generator, limit_m: float, fps: float,
            on_tick=None, desc: str = "rollout", progress: bool = False) -> Trajectory:
    """DAgger's data collection in the road world and in replay: drive `pilot` through each (world, ticks) of
    `worlds` while, with probability `beta` each tick, the expert steers instead, and record every visited frame
    with `writer` — the centre camera, and the side views the writer has cameras for (the world rendered from a
    camera the car's `side_camera_offset_m` to either side) — labelled with the expert's steering in
    `convention`. (The track world's, which labels the throttle too and writes a tub, is
    `track.run.rollout`.)"""
    trajs = []
    for world, ticks in worlds:
        sides = {c: off for c, off in (("left", world.car.side_camera_offset_m),
                                       ("right", -(world.car.side_camera_offset_m or 0.0))) if c in writer.cameras}
        pilot.reset()

        def on_step(t, world=world, sides=sides):
            frames = {"center": t.frame, **{c: world.render(off) for c, off in sides.items()}}
            writer.add(frames, {**world.record_row(t.index), "lateral_offset": t.offset, "heading_error": t.heading,
                                "steering": float(convention.from_road_wheel_left(t.expert, world.steering_ratio)),
                                "episode": "rollout"})

        trajs.append(drive_loop(world, pilot, ticks, limit_m, fps, on_step=on_step, desc=desc, progress=progress,
                                choose=lambda t: (t.expert if rng.random() < beta else t.model, t.throttle),
                                on_tick=on_tick))
    out = trajs[0]
    for t in trajs[1:]:
        out = out.concat(t)
    return out
