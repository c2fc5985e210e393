"""Recording the expert (`steerlab sim record`) and letting a trained model drive (`steerlab sim drive`)."""

from __future__ import annotations

import csv
import json
from datetime import datetime, timedelta, timezone
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from steerlab.data.readers import EPISODES, MPH_TO_MS, NATIVE_COLUMNS, SIM_CONVENTION, SIM_FULL_LOCK_RAD
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.evaluate.plots import plot_trajectory
from steerlab.sim.driver import ExpertDriver, cruise
from steerlab.sim.render import CAMERAS, SIDE_OFFSET, Renderer
from steerlab.sim.road import LANE_CENTER, Road
from steerlab.sim.vehicle import Vehicle, VehicleParams, VehicleState

CONVENTION = SteeringConvention("steering_wheel", "left")  # like CH2: steering-wheel angle, positive left
EPOCH = datetime(2020, 1, 1, tzinfo=timezone.utc)
JPEG = [cv2.IMWRITE_JPEG_QUALITY, 92]


def _check(minutes: float, fps: float) -> int:
    if not minutes > 0:
        raise SteerlabError(f"minutes must be positive, got {minutes}")
    if not fps > 0:
        raise SteerlabError(f"fps must be positive, got {fps}")
    return int(round(minutes * 60 * fps))


def start_state(road: Road, s: float = 5.0, v: float | None = None) -> VehicleState:
    x, y, psi = road.pose(s, LANE_CENTER)
    return VehicleState(x, y, psi, road.speed_limit[road.index(s)] if v is None else v)


def _world(seed: int, road: str, camera: str, seconds: float):
    """A road long enough for `seconds` of driving, its renderer, and a car on its lane at the start."""
    rd = Road(seed, road, length_m=seconds * 35 + 400)
    params = VehicleParams()
    return rd, Renderer(rd, camera), params, Vehicle(start_state(rd), params)


def record(out: str | Path, seed: int = 0, minutes: float = 1.0, road: str = "country", camera: str = "sim",
           fps: float = 20.0, drift: bool = True, side_cameras: bool = True, layout: str = "steerlab",
           progress: bool = True) -> Path:
    """Drive the expert on a road made from `seed` and write a labelled recording. Same arguments, same bytes."""
    n = _check(minutes, fps)
    if layout not in ("steerlab", "udacity-sim"):
        raise SteerlabError(f"unknown layout {layout!r}; choose steerlab or udacity-sim")
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise SteerlabError(f"{out} exists and is not empty; choose a new output folder")
    dt = 1.0 / fps
    rd, renderer, params, car = _world(seed, road, camera, n * dt)
    driver = ExpertDriver(rd, seed, params, dt, drift_every_s=25.0 if drift else None)
    cams = {"center": 0.0, **({"left": SIDE_OFFSET, "right": -SIDE_OFFSET} if side_cameras else {})}
    img_dir = out / ("IMG" if layout == "udacity-sim" else "")
    for cam in cams:
        (img_dir if layout == "udacity-sim" else out / cam).mkdir(parents=True, exist_ok=True)
    rows = []
    s = 5.0
    for i in tqdm(range(n), desc=f"record seed {seed}", unit="frame", disable=None if progress else True):
        st = car.state
        s, d, road_psi = rd.project(st.x, st.y, s)
        offset = d - LANE_CENTER
        heading_err = (st.psi - road_psi + np.pi) % (2 * np.pi) - np.pi
        delta, throttle, brake, episode = driver.act(st, s, offset, i * dt)
        ts = int(round(i * dt * 1e9))
        names = {}
        for cam, shift in cams.items():
            frame = renderer.render(st.x, st.y, st.psi, s, shift)
            if layout == "udacity-sim":
                stamp = (EPOCH + timedelta(microseconds=ts // 1000)).strftime("%Y_%m_%d_%H_%M_%S_") + f"{(ts // 1_000_000) % 1000:03d}"
                names[cam] = f"IMG/{cam}_{stamp}.jpg"
            else:
                names[cam] = f"{cam}/{i:06d}.jpg"
            cv2.imwrite(str(out / names[cam]), frame, JPEG)
        rows.append({"frame": i, "timestamp_ns": ts, **{c: names.get(c, "") for c in ("center", "left", "right")},
                     "steering": CONVENTION.from_road_wheel_left(delta, params.steering_ratio), "speed": st.v,
                     "throttle": throttle, "brake": brake, "lateral_offset": offset, "heading_error": heading_err,
                     "curvature": rd.kappa[rd.index(s)], "episode": episode})
        car.step(delta, throttle, brake, dt)
    if layout == "udacity-sim":
        with open(out / "driving_log.csv", "w", newline="") as f:
            w = csv.writer(f)
            for r in rows:  # the simulator's own units: steering +-1 = +-25 deg road wheel, positive right; mph
                road_wheel = CONVENTION.to_road_wheel_left(r["steering"], params.steering_ratio)
                steer = SIM_CONVENTION.from_road_wheel_left(road_wheel, params.steering_ratio) / SIM_FULL_LOCK_RAD
                w.writerow([r["center"], r["left"], r["right"], f"{steer:.6f}", f"{r['throttle']:.6f}",
                            f"{r['brake']:.6f}", f"{r['speed'] / MPH_TO_MS:.6f}"])
        return out
    with open(out / "log.csv", "w", newline="") as f:
        w = csv.DictWriter(f, NATIVE_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6f}" if isinstance(v, float) else v) for k, v in r.items()})
    meta = {"format": "steerlab-recording-1", "seed": seed, "road": road, "camera": camera, "preset": camera,
            "fps": fps, "minutes": minutes, "steering": CONVENTION.as_dict(),
            "steering_ratio": params.steering_ratio, "wheelbase": params.wheelbase, "episodes": list(EPISODES),
            "side_camera_offset_m": SIDE_OFFSET if side_cameras else None}
    (out / "recording.json").write_text(json.dumps(meta, indent=1))
    return out


def autonomy(interventions: int, elapsed_s: float) -> float:
    """NVIDIA's autonomy: (1 - interventions * 6 s / elapsed s) * 100."""
    return (1.0 - interventions * 6.0 / elapsed_s) * 100.0


def drive(pilot, out: str | Path | None, seed: int = 100, minutes: float = 1.0, road: str = "country",
          camera: str | None = None, fps: float = 20.0, limit_m: float = 1.0, progress: bool = True) -> dict:
    """Closed loop: each tick renders the centre camera (by default the geometry the pilot was trained on),
    asks `pilot.step(frame, speed)` for controls and
    applies their steering (in `pilot.convention`); the speed follows the cruise controller. Off the lane centre
    by more than `limit_m` is an intervention: the car is put back on the lane centre and `pilot.reset()`
    clears the pilot's memory."""
    n = _check(minutes, fps)
    dt = 1.0 / fps
    camera = camera or (pilot.preset if pilot.preset in CAMERAS else "sim")
    rd, renderer, params, car = _world(seed, road, camera, n * dt)
    s, interventions, dist = 5.0, 0, 0.0
    traj = []
    strip = []
    for i in tqdm(range(n), desc=f"drive seed {seed}", unit="tick", disable=None if progress else True):
        st = car.state
        s, d, road_psi = rd.project(st.x, st.y, s)
        offset = d - LANE_CENTER
        if abs(offset) > limit_m:
            interventions += 1
            car.state = start_state(rd, s, st.v)
            pilot.reset()
            st = car.state
            s, d, _ = rd.project(st.x, st.y, s)
            offset = d - LANE_CENTER
        frame = renderer.render(st.x, st.y, st.psi, s)
        if out is not None and i % int(fps * 5) == 0 and len(strip) < 12:
            strip.append(frame)
        command = pilot.step(frame, st.v).steering
        throttle, brake = cruise(rd, s, st.v)
        traj.append((i * dt, st.x, st.y, s, offset, command, st.v))
        car.step(pilot.convention.to_road_wheel_left(command, params.steering_ratio), throttle, brake, dt)
        dist += st.v * dt
    t = np.array(traj)
    elapsed = n * dt
    result = {
        "label": pilot.name, "seed": seed, "road": road, "minutes": minutes,
        "autonomy": autonomy(interventions, elapsed), "interventions": interventions,
        "mean_abs_offset_m": float(np.mean(np.abs(t[:, 4]))), "max_abs_offset_m": float(np.max(np.abs(t[:, 4]))),
        "command_gamma_deg": float(np.degrees(np.std(np.diff(t[:, 5])))), "distance_km": dist / 1000,
        "departures_per_km": interventions / max(dist / 1000, 1e-9),
    }
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "trajectory.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["time_s", "x", "y", "s", "lateral_offset_m", "steering", "speed"])
            w.writerows([[f"{v:.4f}" for v in row] for row in traj])
        plot_trajectory(out / "path.png", rd, t, result)
        rows = [np.hstack(strip[k:k + 4]) for k in range(0, len(strip) - 3, 4)] or [np.hstack(strip)]
        cv2.imwrite(str(out / "frames.png"), np.vstack(rows))  # one frame every 5 s
        (out / "drive.json").write_text(json.dumps(result, indent=1))
    return result
