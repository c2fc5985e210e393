"""The one driving loop of every closed loop: the synthetic world (`sim drive`, the suite, DAgger rollouts) and
replay on recorded camera data (`steerlab replay`).

A world here is anything with `intervene(limit_m)`, `render()`, `state` (with `.v`, m/s), `expert_steering()`,
`step(road_wheel)`, `steering_ratio` and `done`: the synthetic `World` and the replay of a recording
(`sim.replay.ReplayWorld`). Each tick the car is put back if it left the lane (an intervention, after which the
pilot forgets its past), the camera frame is taken, the pilot answers, and the car moves by the model's
command (or, for DAgger, by whatever `choose` picks)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from tqdm import tqdm

TRAJECTORY = ["time_s", "x", "y", "s", "lateral_offset_m", "steering", "speed", "heading_error_rad", "intervention"]


@dataclass
class Tick:
    """What one tick saw and did: steering as road-wheel angles in radians, positive left. `expert`, the
    expert's steering in this state, is computed only when something asks for it (a video, a DAgger label)."""

    index: int
    frame: np.ndarray
    offset: float
    heading: float
    model: float
    intervention: bool
    world: object

    @cached_property
    def expert(self) -> float:
        return self.world.expert_steering()


def autonomy(interventions: int, elapsed_s: float) -> float:
    """NVIDIA's autonomy: (1 - interventions * 6 s / elapsed s) * 100."""
    return (1.0 - interventions * 6.0 / elapsed_s) * 100.0


def drive_metrics(offset: np.ndarray, command: np.ndarray, speed: np.ndarray, dt: float, interventions: int) -> dict:
    """Closed-loop metrics of one drive from its per-tick lateral offsets (m), steering commands (rad) and
    speeds (m/s): autonomy, interventions per km, mean and max |offset|, command gamma, km driven."""
    km = float(np.sum(speed) * dt / 1000)
    return {"autonomy": autonomy(interventions, len(offset) * dt), "interventions": int(interventions),
            "interventions_per_km": interventions / max(km, 1e-9),
            "mean_abs_offset_m": float(np.mean(np.abs(offset))), "max_abs_offset_m": float(np.max(np.abs(offset))),
            "command_gamma_deg": float(np.degrees(np.std(np.diff(command)))) if len(command) > 1 else 0.0,
            "distance_km": km}


def drive_loop(world, pilot, ticks: int, limit_m: float, fps: float, choose=None, on_step=None, desc: str = "drive",
               progress: bool = True, on_tick=None) -> np.ndarray:
    """Drive `pilot` in `world` for `ticks` frames (or until `world.done`). The pilot's steering (in
    `pilot.convention`) becomes a road-wheel angle through `world.steering_ratio`; `choose(tick)` returns the
    road-wheel angle to apply instead (DAgger's mix of model and expert); `on_step(tick)` sees every tick
    (recording, video); `on_tick(k)` is called every 100 ticks (progress of a suite). Returns the trajectory,
    one row per tick with the columns of TRAJECTORY (steering: the pilot's command in its convention)."""
    rows = []
    for i in tqdm(range(ticks), desc=desc, unit="tick", disable=None if progress else True):
        if world.done:
            break
        put_back, offset, heading = world.intervene(limit_m)
        if put_back:
            pilot.reset()
        frame = world.render()
        st = world.state
        command = pilot.step(frame, st.v).steering
        tick = Tick(i, frame, offset, heading, pilot.convention.to_road_wheel_left(command, world.steering_ratio),
                    put_back, world)
        if on_step:
            on_step(tick)
        rows.append((i / fps, st.x, st.y, world.s, offset, command, st.v, heading, float(put_back)))
        world.step(tick.model if choose is None else choose(tick))
        if on_tick and (i + 1) % 100 == 0:
            on_tick(100)
    return np.array(rows, dtype=float).reshape(-1, len(TRAJECTORY))
