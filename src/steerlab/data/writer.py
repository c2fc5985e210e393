"""The writers of recordings: `RecordingWriter` (frames and per-frame rows as a steerlab recording, `native.py`,
or a Udacity simulator driving log, `simlog.py`) and `TubWriter` (a donkeycar tub v2, `tub.py`), each in the
layout its reader reads back."""

from __future__ import annotations

import csv
import json
import math
import shutil
from datetime import datetime, timezone
from pathlib import Path

import cv2
import numpy as np

from steerlab.files import write_json
from steerlab.data.car import car_of
from steerlab.data.native import EPISODES, NATIVE_COLUMNS
from steerlab.data.recording import SteeringConvention
from steerlab.data.simlog import image_name, log_row, to_sim_steering
from steerlab.data.tub import LANE_FIELDS
from steerlab.errors import SteerlabError

CONVENTION = SteeringConvention("steering_wheel", "left")  # the road world's, like CH2: steering wheel, left
EPOCH_NS = int(datetime(2020, 1, 1, tzinfo=timezone.utc).timestamp()) * 1_000_000_000  # recorded times start here
JPEG = [cv2.IMWRITE_JPEG_QUALITY, 92]


def begin(out: Path) -> Path:
    """The folder a writer fills for `out` (which must be new or empty): for a new `out`, its hidden sibling
    `.<name>.part` (a leftover of an interrupted writer removed first), which `finish` renames to `out` once the
    recording is whole, so an interrupted recording leaves nothing and the same command run again records it
    afresh; an `out` that exists already (an empty folder, a symlink to one, a mount point) is written into
    directly, as it cannot be replaced by a rename."""
    if out.exists() and any(out.iterdir()):
        raise SteerlabError(f"{out} exists and is not empty; choose a new output folder")
    if out.exists():
        return out
    part = out.parent / f".{out.name}.part"
    shutil.rmtree(part, ignore_errors=True)
    part.mkdir(parents=True)
    return part


def finish(part: Path, out: Path) -> Path:
    """`begin`'s folder, whole, at `out`."""
    if part != out:
        part.rename(out)
    return out


class RecordingWriter:
    """Writes frames and per-frame rows as a steerlab recording (`recording.json`, `log.csv`, one folder of
    JPEGs per camera) or in the Udacity simulator's `driving_log.csv` layout. Steering is written in
    `convention` (the road world's own by default); `geometry` is the camera geometry of the frames, which
    also names the car (`data.car`). `quality`: the JPEG quality of the frames (None: 92)."""

    def __init__(self, out: str | Path, cameras: list[str], layout: str = "steerlab",
                 convention: SteeringConvention = CONVENTION, geometry: str = "sim",
                 quality: int | None = None):
        if layout not in ("steerlab", "udacity-sim"):
            raise SteerlabError(f"unknown layout {layout!r}; choose steerlab or udacity-sim")
        self.out, self.cameras, self.layout, self.convention = Path(out), cameras, layout, convention
        self.geometry, self.jpeg = geometry, JPEG if quality is None else [cv2.IMWRITE_JPEG_QUALITY, quality]
        self.dir = begin(self.out)
        for cam in cameras:
            (self.dir / ("IMG" if layout == "udacity-sim" else cam)).mkdir(parents=True, exist_ok=True)
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
            cv2.imwrite(str(self.dir / names[cam]), frames[cam], self.jpeg)
        self.rows.append({"frame": i, **{c: names.get(c, "") for c in ("center", "left", "right")}, **row})

    def close(self, meta: dict) -> Path:
        ratio = car_of(self.geometry).steering_ratio
        if self.layout == "udacity-sim":
            with open(self.dir / "driving_log.csv", "w", newline="") as f:
                w = csv.writer(f)
                for r in self.rows:
                    road_wheel = self.convention.to_road_wheel_left(r["steering"], ratio)
                    w.writerow(log_row(r["center"], r["left"], r["right"], to_sim_steering(road_wheel),
                                       r["throttle"], r["brake"], r["speed"]))
            return finish(self.dir, self.out)
        with open(self.dir / "log.csv", "w", newline="") as f:
            w = csv.DictWriter(f, NATIVE_COLUMNS)
            w.writeheader()
            for r in self.rows:
                w.writerow({k: (f"{v:.6f}" if isinstance(v, float) else v) for k, v in r.items()})
        write_json(self.dir / "recording.json", {"format": "steerlab-recording-1", **meta, "geometry": self.geometry,
                                                 "steering": self.convention.as_dict(), "episodes": list(EPISODES)})
        return finish(self.dir, self.out)


TUB_KEYS = ["cam/image_array", "user/angle", "user/throttle", "user/mode"]
TUB_TYPES = ["image_array", "float", "float", "str"]
TUB_JPEG = [cv2.IMWRITE_JPEG_QUALITY, 75]  # what donkeycar's own writer (PIL's default quality) gives


class TubWriter:
    """Writes a donkeycar tub v2 (`tub.py` describes the layout) as donkeycar 5.x's own `Tub` writes it: the
    five manifest lines, catalogs of at most `max_len` records with their `.catalog_manifest` (line lengths),
    and `images/<index>_cam_image_array_.jpg`.

    Frames come in as OpenCV gives them, BGR; `cv2.imwrite` stores a BGR array as a JPEG of its true colours,
    which is what donkeycar's writer (PIL, from its RGB arrays) stores too, so donkeycar reads RGB and steerlab
    BGR from the same bytes. `user/angle` is the servo command: the road-wheel angle over the car's full lock,
    positive right, clipped to [-1, 1]; `user/mode` is "user" (a person drove). Times are `start_ns` (the
    recorded clock's origin, 2020-01-01 by default, so that the same drive gives the same bytes) plus each
    frame's `timestamp_ns`, in whole milliseconds; session ids are the start day's with a count, as donkeycar
    names them. A record added as `deleted` is written and listed in the manifest's `deleted_indexes`, as
    donkeycar's tub editor marks the stretches its owner cut out of a drive (neither donkeycar's training nor
    steerlab's reader uses them); the first record kept after a cut starts a new session, so that no frame
    history or motion spans the cut. `metadata` is the manifest's user metadata (the track world writes its
    camera there: `fisheye`, read back as `Recording.fisheye`). `quality`: the JPEG quality of the frames (None:
    75, donkeycar's). With `lane`, every record also holds the lane the car is in (`tub.LANE_FIELDS`: offset in m,
    positive left; heading in rad, positive turned left; curvature in 1/m, positive turning left), declared as
    floats in the manifest."""

    def __init__(self, out: str | Path, full_lock_deg: float, max_len: int = 1000, start_ns: int = EPOCH_NS,
                 metadata: dict | None = None, quality: int | None = None, lane: bool = False):
        if not 0 < full_lock_deg < 90:
            raise SteerlabError(f"full_lock_deg must lie in (0, 90) degrees, got {full_lock_deg}")
        if max_len < 1:
            raise SteerlabError(f"max_len (records per catalog) must be at least 1, got {max_len}")
        self.out, self.full_lock = Path(out), math.radians(full_lock_deg)
        self.max_len, self.start_ns, self.metadata, self.lane = max_len, start_ns, metadata or {}, lane
        self.jpeg = TUB_JPEG if quality is None else [cv2.IMWRITE_JPEG_QUALITY, quality]
        self.dir = begin(self.out)
        (self.dir / "images").mkdir(parents=True, exist_ok=True)
        self.day = f"{datetime.fromtimestamp(start_ns / 1e9, timezone.utc):%y-%m-%d}"
        self.sessions = [f"{self.day}_0"]
        self.records: list[dict] = []
        self.deleted: list[int] = []

    def servo(self, road_wheel: float) -> float:
        """The servo command of a road-wheel angle (rad, positive left): [-1, 1], positive right."""
        return float(np.clip(-road_wheel / self.full_lock, -1.0, 1.0))

    def add(self, frame: np.ndarray, timestamp_ns: int, road_wheel: float, throttle: float,
            deleted: bool = False, lane: tuple[float, float, float] | None = None, new_session: bool = False) -> None:
        """One record: a BGR frame, its time (ns from the start), the road-wheel angle (rad, positive left) and
        the throttle in [-1, 1]; `deleted`: cut out of the drive (see the class's docstring); `lane`: (offset,
        heading, curvature), given exactly when the writer was made with `lane`; `new_session`: the record starts
        a session (a frame unrelated to the one before it)."""
        if (lane is not None) != self.lane:
            raise SteerlabError(f"TubWriter {self.out}: lane values belong to every record of a tub made with "
                                "lane=True and to none of another: give add(lane=...) exactly when the writer has "
                                "lane=True")
        i = len(self.records)
        if deleted:
            self.deleted.append(i)
        elif (new_session and i) or (self.deleted and self.deleted[-1] == i - 1):  # after a cut, or unrelated
            self.sessions.append(f"{self.day}_{len(self.sessions)}")
        name = f"{i}_cam_image_array_.jpg"
        if not cv2.imwrite(str(self.dir / "images" / name), frame, self.jpeg):
            raise SteerlabError(f"cannot write {self.dir / 'images' / name}: free disk space, or choose "
                                "another output folder")
        self.records.append({"_index": i, "_session_id": self.sessions[-1],
                             "_timestamp_ms": (self.start_ns + int(timestamp_ns)) // 1_000_000,
                             "cam/image_array": name, "user/angle": self.servo(road_wheel),
                             "user/mode": "user", "user/throttle": float(np.clip(throttle, -1.0, 1.0)),
                             **dict(zip(LANE_FIELDS, map(float, lane or ())))})

    def close(self) -> Path:
        created = self.start_ns / 1e9
        paths = []
        for n, first in enumerate(range(0, max(len(self.records), 1), self.max_len)):
            name = f"catalog_{n}.catalog"
            lines = [json.dumps(r, allow_nan=False, sort_keys=True) + "\n"
                     for r in self.records[first: first + self.max_len]]
            (self.dir / name).write_text("".join(lines))
            manifest = {"path": f"catalog_{n}.catalog_manifest", "created_at": created, "start_index": first,
                        "line_lengths": [len(line) for line in lines]}
            (self.dir / f"catalog_{n}.catalog_manifest").write_text(json.dumps(manifest, allow_nan=False,
                                                                               sort_keys=True) + "\n")
            paths.append(name)
        sessions = {"all_full_ids": self.sessions, "last_id": len(self.sessions) - 1,
                    "last_full_id": self.sessions[-1]}
        catalogs = {"paths": paths, "current_index": len(self.records), "max_len": self.max_len,
                    "deleted_indexes": self.deleted}
        lane = list(LANE_FIELDS) if self.lane else []
        lines = [TUB_KEYS + lane, TUB_TYPES + ["float"] * len(lane), self.metadata,
                 {"created_at": created, "sessions": sessions}, catalogs]
        (self.dir / "manifest.json").write_text("".join(json.dumps(line) + "\n" for line in lines))
        return finish(self.dir, self.out)
