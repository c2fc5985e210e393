"""`RecordingWriter`: frames and per-frame rows written as a steerlab recording (`native.py`) or as a Udacity
simulator driving log (`simlog.py`), the layouts their readers read back."""

from __future__ import annotations

import csv
import json
from datetime import datetime, timezone
from pathlib import Path

import cv2
import numpy as np

from steerlab.data.car import car_of
from steerlab.data.native import EPISODES, NATIVE_COLUMNS
from steerlab.data.recording import SteeringConvention
from steerlab.data.simlog import image_name, log_row, to_sim_steering
from steerlab.errors import SteerlabError

CONVENTION = SteeringConvention("steering_wheel", "left")  # the synthetic world's, like CH2: steering wheel, left
EPOCH_NS = int(datetime(2020, 1, 1, tzinfo=timezone.utc).timestamp()) * 1_000_000_000  # recorded times start here
JPEG = [cv2.IMWRITE_JPEG_QUALITY, 92]


class RecordingWriter:
    """Writes frames and per-frame rows as a steerlab recording (`recording.json`, `log.csv`, one folder of
    JPEGs per camera) or in the Udacity simulator's `driving_log.csv` layout. Steering is written in
    `convention` (the synthetic world's own by default); `geometry` is the camera geometry of the frames, which
    also names the car (`data.car`)."""

    def __init__(self, out: str | Path, cameras: list[str], layout: str = "steerlab",
                 convention: SteeringConvention = CONVENTION, geometry: str = "sim"):
        if layout not in ("steerlab", "udacity-sim"):
            raise SteerlabError(f"unknown layout {layout!r}; choose steerlab or udacity-sim")
        self.out, self.cameras, self.layout, self.convention = Path(out), cameras, layout, convention
        self.geometry = geometry
        if self.out.exists() and any(self.out.iterdir()):
            raise SteerlabError(f"{self.out} exists and is not empty; choose a new output folder")
        for cam in cameras:
            (self.out / ("IMG" if layout == "udacity-sim" else cam)).mkdir(parents=True, exist_ok=True)
        self.rows: list[dict] = []

    def add(self, frames: dict[str, np.ndarray], row: dict) -> None:
        """row: timestamp_ns, steering (in the writer's convention), speed, throttle, brake, lateral_offset, heading_error,
        curvature, episode."""
        i, ts = len(self.rows), row["timestamp_ns"]
        names = {}
        for cam in self.cameras:
            if self.layout == "udacity-sim":
                names[cam] = f"IMG/{image_name(cam, EPOCH_NS + ts)}"
            else:
                names[cam] = f"{cam}/{i:06d}.jpg"
            cv2.imwrite(str(self.out / names[cam]), frames[cam], JPEG)
        self.rows.append({"frame": i, **{c: names.get(c, "") for c in ("center", "left", "right")}, **row})

    def close(self, meta: dict) -> Path:
        ratio = car_of(self.geometry).steering_ratio
        if self.layout == "udacity-sim":
            with open(self.out / "driving_log.csv", "w", newline="") as f:
                w = csv.writer(f)
                for r in self.rows:
                    road_wheel = self.convention.to_road_wheel_left(r["steering"], ratio)
                    w.writerow(log_row(r["center"], r["left"], r["right"], to_sim_steering(road_wheel),
                                       r["throttle"], r["brake"], r["speed"]))
            return self.out
        with open(self.out / "log.csv", "w", newline="") as f:
            w = csv.DictWriter(f, NATIVE_COLUMNS)
            w.writeheader()
            for r in self.rows:
                w.writerow({k: (f"{v:.6f}" if isinstance(v, float) else v) for k, v in r.items()})
        (self.out / "recording.json").write_text(json.dumps(
            {"format": "steerlab-recording-1", **meta, "geometry": self.geometry, "steering": self.convention.as_dict(),
             "episodes": list(EPISODES)}, indent=1))
        return self.out
