"""The Udacity simulator's `driving_log.csv` (with or without header; `center,left,right,steering,throttle,brake,
speed`): its one home, read here and written by `log_row`/`image_name` (recordings, the drive server's sessions).
Steering +-1 is +-25 degrees of road-wheel angle, positive right; speed in mph; the capture time is in the
image names (`center_YYYY_MM_DD_HH_MM_SS_mmm.jpg`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from steerlab.data.car import CARS
from steerlab.data.recording import Recording, SteeringConvention
from steerlab.data.rows import (Reader, apply_range, check_images, check_increasing, check_unique, csv_header, ends_torn,
                                number, read_rows)
from steerlab.errors import DataError, warn_once
from steerlab.options import Options, option

MPH_TO_MS = 0.44704
SIM_FULL_LOCK_RAD = math.radians(25.0)  # the simulator's steering value +-1 is +-25 degrees
SIM_CONVENTION = SteeringConvention("road_wheel", "right")


def to_sim_steering(road_wheel_left: float) -> float:
    """A road-wheel angle (rad, positive left) as the simulator's steering value in [-1, 1]."""
    return -road_wheel_left / SIM_FULL_LOCK_RAD


def image_name(camera: str, timestamp_ns: int) -> str:
    """The simulator's image file name, which carries the capture time (UTC, milliseconds)."""
    t = datetime.fromtimestamp(timestamp_ns // 1_000_000_000, timezone.utc)
    return f"{camera}_{t:%Y_%m_%d_%H_%M_%S}_{(timestamp_ns // 1_000_000) % 1000:03d}.jpg"


def log_row(center, left, right, steering: float, throttle: float, brake: float, speed_ms: float) -> list[str]:
    """One driving-log row in the simulator's units (steering in [-1, 1], pedals in [0, 1], speed in mph)."""
    return [str(center), str(left), str(right), f"{steering:.6f}", f"{throttle:.6f}", f"{brake:.6f}",
            f"{speed_ms / MPH_TO_MS:.6f}"]
SIM_COLUMNS = ["center", "left", "right", "steering", "throttle", "brake", "speed"]


@dataclass(frozen=True)
class SimLogOptions(Options):
    """A driving log's reader options."""

    strict: bool = option(False, help="refuse a torn last line instead of reading past it")


SIM_OPTIONS = SimLogOptions
# the physical range of each recorded value: steering +-1 = full lock, pedals 0..1, speed in mph up to the fastest
# the road world's car drives (a log in km/h reads too fast)
MAX_MPH = CARS["sim"].speeds[1] / MPH_TO_MS
SIM_RANGES = {"steering": (-1.0, 1.0, "in [-1, 1]"), "throttle": (0.0, 1.0, "in [0, 1]"),
              "brake": (0.0, 1.0, "in [0, 1]"),
              "speed": (0.0, MAX_MPH, f"in [0, {MAX_MPH:.0f}] (mph, as the simulator records it; not km/h)")}


def _sim_timestamp(name: str) -> int | None:
    """`center_2018_11_08_17_48_38_718.jpg` -> nanoseconds since the epoch (UTC), or None."""
    parts = Path(name).stem.split("_")[-7:]
    try:
        y, mo, d, h, mi, s, ms = (int(p) for p in parts)
        dt = datetime(y, mo, d, h, mi, s, ms * 1000, tzinfo=timezone.utc)
    except (ValueError, TypeError):
        return None
    return int(dt.timestamp()) * 1_000_000_000 + ms * 1_000_000


def _resolve(log: Path, text: str, row: int, column: str) -> Path:
    """Paths in a driving log are often absolute paths of another machine: resolve by file name in IMG/."""
    text = text.strip()
    if not text:
        raise DataError(log, f"column {column!r} is empty; an image path is expected", row)
    p = Path(text.replace("\\", "/"))
    if p.is_absolute() and p.is_file():
        return p
    local = log.parent / "IMG" / p.name
    if local.is_file() or p.is_absolute():
        return local
    return log.parent / p


def _sim_row(log: Path, row: list[str], r: int, idx: list[int]) -> tuple[dict[str, Path], list[float], int]:
    """One driving-log row: its image paths, values (SIM_COLUMNS[3:]) and capture time."""
    if len(row) < 7:
        raise DataError(log, f"expected at least 7 columns ({','.join(SIM_COLUMNS)}), got {len(row)}", r)
    paths = {cam: _resolve(log, row[i], r, cam) for cam, i in zip(("center", "left", "right"), idx[:3])
             if cam == "center" or row[i].strip()}
    values = []
    for c, i in zip(SIM_COLUMNS[3:], idx[3:]):
        v, (lo, hi, expected) = number(log, r, c, row[i]), SIM_RANGES[c]
        if not lo - 1e-6 <= v <= hi + 1e-6:
            raise DataError(log, f"column {c!r} is {row[i].strip()}; a number {expected} is expected", r)
        values.append(v)
    ts = _sim_timestamp(paths["center"].name)
    if ts is None:
        raise DataError(log, f"cannot read the capture time from image name {paths['center'].name!r} "
                             "(expected center_YYYY_MM_DD_HH_MM_SS_mmm.jpg)", r)
    return paths, values, ts


def read_sim_log(log: str | Path, frame_range=None, strict: bool = False) -> Recording:
    """A simulator driving log. A torn last line (a recording cut off mid-write) is left out with a warning (once a
    process), or refused with `strict`; a bad line anywhere else is an error."""
    log = Path(log)
    rows = read_rows(log)
    if rows and rows[0][0].strip() == "center":
        header = csv_header(log, rows[0])
        missing = [c for c in SIM_COLUMNS if c not in header]
        if missing:
            raise DataError(log, f"header lacks columns {missing}; expected {','.join(SIM_COLUMNS)}", 1)
        idx = [header.index(c) for c in SIM_COLUMNS]
        rows, first = rows[1:], 2
    else:
        idx, first = list(range(7)), 1
    if rows and not strict and ends_torn(log, rows[-1]):
        last = first + len(rows) - 1
        try:
            _sim_row(log, rows[-1], last, idx)
        except DataError as e:
            warn_once(f"{log}: row {last} is torn (the recording was cut off mid-write?): left out, 1 record "
                      f"lost ({e.message}; reader option strict: true refuses such a log)")
            rows = rows[:-1]
    if not rows:
        raise DataError(log, "the driving log has no rows: record it again, or give another log")
    cut = apply_range(len(rows), frame_range, log)
    rows, first = rows[cut], first + cut.start
    frames: dict[str, list[Path]] = {"center": [], "left": [], "right": []}
    vals = {c: [] for c in SIM_COLUMNS[3:]}
    stamps = []
    for r, row in enumerate(rows, start=first):
        paths, values, ts = _sim_row(log, row, r, idx)
        for cam, p in paths.items():
            frames[cam].append(p)
        for c, v in zip(SIM_COLUMNS[3:], values):
            vals[c].append(v)
        stamps.append(ts)
    frames = {c: p for c, p in frames.items() if len(p) == len(rows)}
    stamps_a = np.array(stamps, dtype=np.int64)
    check_unique(stamps_a, log, first)
    check_increasing(stamps_a, log, first)
    for paths in frames.values():
        check_images(paths, log, first, cut.start)
    return Recording(
        name=log.parent.name, source=log, frames=frames, timestamps_ns=stamps_a,
        steering=np.array(vals["steering"]) * SIM_FULL_LOCK_RAD, convention=SIM_CONVENTION, frame_ids=stamps_a,
        speed=np.array(vals["speed"]) * MPH_TO_MS, throttle=np.array(vals["throttle"]),
        brake=np.array(vals["brake"]), geometry="sim",
    )


def _recognises(path: Path) -> bool:
    """A .csv file (the log itself), or a folder with driving_log.csv."""
    return (path.is_file() and path.suffix == ".csv") or (path.is_dir() and (path / "driving_log.csv").is_file())


READER = Reader("udacity-sim", "a driving_log.csv", _recognises,
                lambda path, rng, strict=False: read_sim_log(path if path.is_file() else path / "driving_log.csv", rng,
                                                              strict), SIM_OPTIONS)
