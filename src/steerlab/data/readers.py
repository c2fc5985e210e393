"""Readers that turn recordings on disk into `Recording`s.

Supported layouts (detected by `open_recording`):
- Udacity CH2 folder: `center/` (optional `left/`, `right/`) with `<ns>.jpg` frames plus a label CSV, either
  `interpolated.csv` (`index,timestamp,width,height,frame_id,filename,angle,torque,speed,lat,long,alt`) or the
  answer/submission layout (`frame_id,steering_angle[,public]`).
- Udacity simulator `driving_log.csv` (with or without header; `center,left,right,steering,throttle,brake,speed`).
- steerlab's native layout written by the synthetic world: `recording.json` + `log.csv` + camera folders.
- donkeycar tub v2 folders (`data/tub.py`), ROS 1/2 bags as Udacity released its data (`data/bag.py`) and
  video files with a CSV log (`data/videolog.py`).
"""

from __future__ import annotations

import csv
import json
import math
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from steerlab.data.recording import Recording, SteeringConvention
from steerlab.errors import DataError, warn

MPH_TO_MS = 0.44704
SIM_FULL_LOCK_RAD = math.radians(25.0)  # the simulator's steering value +-1 is +-25 degrees
CH2_CONVENTION = SteeringConvention("steering_wheel", "left")
SIM_CONVENTION = SteeringConvention("road_wheel", "right")
NATIVE_COLUMNS = ["frame", "timestamp_ns", "center", "left", "right", "steering", "speed", "throttle", "brake",
                  "lateral_offset", "heading_error", "curvature", "episode"]
EPISODES = ("normal", "drift-out", "recover", "rollout")  # rollout: a DAgger frame, labelled by the expert


def parse_range(text: str | None) -> tuple[int | None, int | None] | None:
    """Parse "a:b" (either side may be empty) into a tuple; None stays None."""
    if text is None:
        return None
    if not isinstance(text, str):
        raise DataError("<range>", f"frame range {text!r} must be text like \"0:1800\" (quote it in YAML files)")
    parts = str(text).split(":")
    if len(parts) != 2:
        raise DataError("<range>", f"frame range {text!r} must look like START:STOP, e.g. 0:1800")
    try:
        return tuple(int(p) if p.strip() else None for p in parts)  # type: ignore[return-value]
    except ValueError:
        raise DataError("<range>", f"frame range {text!r} must hold integers, e.g. 0:1800") from None


VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")


def open_recording(path: str | Path, frame_range: str | tuple | None = None, labels: str | Path | None = None,
                   options: dict | None = None) -> Recording:
    """Open any supported recording. `frame_range` ("a:b") keeps frames [a, b) before images are checked.
    `options` are reader options (config section `reader:`), e.g. `full_lock_deg` and `skip_missing` for
    donkeycar tubs, `topics` for ROS bags, `log` for videos."""
    path = Path(path)
    if not path.exists():
        raise DataError(path, "recording not found")
    rng = parse_range(frame_range) if isinstance(frame_range, str) or frame_range is None else frame_range
    reader, known = _reader_of(path)
    options = dict(options or {})
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise DataError(path, f"unknown reader option(s) {unknown}; this recording's reader takes "
                              f"{', '.join(known) or 'none'}")
    if labels is not None:
        if reader is not read_ch2:
            raise DataError(path, "a label file (--labels) belongs to CH2 folders only")
        options["labels"] = labels
    return reader(path, rng, **options)


def _reader_of(path: Path):
    """The reader function for a path and the options it takes."""
    from steerlab.data import bag, tub, videolog

    if path.is_file() and path.suffix == ".csv":
        if path.name == "log.csv" and (path.parent / "recording.json").exists():
            return _native_folder, ()
        return read_sim_log, SIM_OPTIONS
    if path.is_file() and path.suffix.lower() in VIDEO_SUFFIXES:
        return videolog.read_video, videolog.OPTIONS
    if bag.is_bag(path):
        return bag.read_bag, bag.OPTIONS
    if path.is_dir() and (path / "recording.json").exists():
        return read_native, ()
    if path.is_dir() and (path / "driving_log.csv").exists():
        return _sim_folder, SIM_OPTIONS
    if path.is_dir() and tub.is_tub(path):
        return tub.read_tub, tub.OPTIONS
    if path.is_dir() and (path / "center").is_dir():
        return read_ch2, ()
    raise DataError(path, "not a recording: expected a CH2 folder (center/ + CSV), a driving_log.csv, a steerlab "
                          "recording (recording.json), a donkeycar tub (manifest.json + catalogs), a ROS bag "
                          f"(.bag, or a ROS 2 folder with metadata.yaml) or a video ({', '.join(VIDEO_SUFFIXES)})")


def _native_folder(log: Path, rng) -> Recording:
    return read_native(log.parent, rng)


def _sim_folder(folder: Path, rng, strict: bool = False) -> Recording:
    return read_sim_log(folder / "driving_log.csv", rng, strict)


def apply_range(n: int, rng, source: Path) -> slice:
    if rng is None:
        return slice(0, n)
    start = 0 if rng[0] is None else rng[0]
    stop = n if rng[1] is None else rng[1]
    if not (0 <= start < stop <= n):
        raise DataError(source, f"frame range {start}:{stop} is outside the {n} labelled frames (0:{n})")
    return slice(start, stop)


def _read_rows(path: Path) -> list[list[str]]:
    try:
        with open(path, newline="") as f:
            return [row for row in csv.reader(f) if row and any(c.strip() for c in row)]
    except UnicodeDecodeError:
        raise DataError(path, "not a text CSV file") from None


def _number(path: Path, row: int, column: str, text: str, allow_nan: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(path, f"column {column!r} must be a number, got {text!r}", row) from None
    if not allow_nan and not math.isfinite(value):
        raise DataError(path, f"column {column!r} is {text!r}; a finite number is expected", row)
    return value


def _check_images(paths: list[Path], source: Path, first_row: int) -> None:
    for i, p in enumerate(paths):
        if not p.is_file():
            raise DataError(source, f"image {p} is missing (use a frame range that covers only the frames that exist, "
                                    f"e.g. --range 0:{i})" if i else f"image {p} is missing", first_row + i)


def nearest(sorted_times: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Index of the entry of `sorted_times` nearest to each of `times` (the earlier one on a tie)."""
    if len(sorted_times) == 1:
        return np.zeros(len(times), dtype=np.int64)
    j = np.clip(np.searchsorted(sorted_times, times), 1, len(sorted_times) - 1)
    return np.where(np.abs(sorted_times[j - 1] - times) <= np.abs(sorted_times[j] - times), j - 1, j)


def _check_unique(ids: np.ndarray, path: Path, first_row: int) -> None:
    order = np.argsort(ids, kind="stable")
    dup = np.flatnonzero(np.diff(ids[order]) == 0)
    if dup.size:
        row = int(order[dup[0] + 1])
        raise DataError(path, f"duplicate frame id {ids[row]}", first_row + row)


# ---------------------------------------------------------------- Udacity CH2

def _ch2_label_file(folder: Path) -> Path:
    if (folder / "interpolated.csv").exists():
        return folder / "interpolated.csv"
    if (folder / "CH2_final_evaluation.csv").exists():
        return folder / "CH2_final_evaluation.csv"
    csvs = sorted(folder.glob("*.csv"))
    if len(csvs) == 1:
        return csvs[0]
    if not csvs:
        raise DataError(folder, "no label CSV found (expected interpolated.csv or frame_id,steering_angle CSV)")
    raise DataError(folder, f"several label CSVs ({', '.join(c.name for c in csvs)}); choose one with --labels")


def read_ch2(folder: str | Path, frame_range=None, labels: str | Path | None = None) -> Recording:
    folder = Path(folder)
    label_path = Path(labels) if labels else _ch2_label_file(folder)
    if not label_path.exists():
        raise DataError(label_path, "label file not found")
    rows = _read_rows(label_path)
    if not rows:
        raise DataError(label_path, "the label file is empty")
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    if "frame_id" in header and "steering_angle" in header:
        ids, steer, speed, cams = _ch2_answer_rows(label_path, header, body)
    elif {"timestamp", "frame_id", "filename", "angle"} <= set(header):
        ids, steer, speed, cams = _ch2_interpolated_rows(label_path, header, body)
    else:
        raise DataError(label_path, f"unknown columns {header}; expected 'frame_id,steering_angle[,public]' or "
                                    "the interpolated.csv layout 'index,timestamp,...,filename,angle,torque,speed,...'", 1)
    if len(ids) == 0:
        raise DataError(label_path, "no labelled frames")
    _check_unique(ids, label_path, 2)
    cut = apply_range(len(ids), frame_range, label_path)
    first_row = 2 + cut.start
    ids, steer = ids[cut], steer[cut]
    speed = None if speed is None else speed[cut]
    frames = {cam: [folder / p for p in names[cut]] for cam, names in cams.items()}
    for paths in frames.values():
        _check_images(paths, label_path, first_row)
    return Recording(
        name=folder.name, source=folder, frames=frames, timestamps_ns=ids.astype(np.int64), steering=steer,
        convention=CH2_CONVENTION, frame_ids=ids, speed=speed, preset="ch2",
    )


def _ch2_answer_rows(path: Path, header: list[str], body: list[list[str]]):
    i_id, i_st = header.index("frame_id"), header.index("steering_angle")
    ids, steer = [], []
    for r, row in enumerate(body, start=2):
        if len(row) <= max(i_id, i_st):
            raise DataError(path, f"expected {len(header)} columns, got {len(row)}", r)
        try:
            ids.append(int(row[i_id]))
        except ValueError:
            raise DataError(path, f"frame_id must be an integer (nanoseconds), got {row[i_id]!r}", r) from None
        steer.append(_number(path, r, "steering_angle", row[i_st]))
    ids_a = np.array(ids, dtype=np.int64)
    names = np.array([f"center/{i}.jpg" for i in ids], dtype=object)
    return ids_a, np.array(steer, dtype=np.float64), None, {"center": names}


def _ch2_interpolated_rows(path: Path, header: list[str], body: list[list[str]]):
    col = {h: i for i, h in enumerate(header)}
    by_cam: dict[str, list[tuple[int, str, float, float, int]]] = {}
    for r, row in enumerate(body, start=2):
        if len(row) < len(header):
            raise DataError(path, f"expected {len(header)} columns, got {len(row)}", r)
        cam = row[col["frame_id"]].replace("_camera", "")
        try:
            ts = int(row[col["timestamp"]])
        except ValueError:
            raise DataError(path, f"timestamp must be an integer (ns), got {row[col['timestamp']]!r}", r) from None
        angle = _number(path, r, "angle", row[col["angle"]])
        spd = _number(path, r, "speed", row[col["speed"]]) if "speed" in col else math.nan
        by_cam.setdefault(cam, []).append((ts, row[col["filename"]], angle, spd, r))
    if "center" not in by_cam:
        raise DataError(path, "no rows with frame_id 'center_camera'")
    center = sorted(by_cam["center"])
    ids = np.array([c[0] for c in center], dtype=np.int64)
    cams = {"center": np.array([c[1] for c in center], dtype=object)}
    for cam in ("left", "right"):
        if cam in by_cam:  # each side frame nearest in time to the centre frame
            side = sorted(by_cam[cam])
            j = nearest(np.array([s[0] for s in side]), ids)
            cams[cam] = np.array([side[k][1] for k in j], dtype=object)
    speed = np.array([c[3] for c in center])
    return ids, np.array([c[2] for c in center]), (speed if np.all(np.isfinite(speed)) else None), cams


# ---------------------------------------------------------------- Udacity simulator

SIM_COLUMNS = ["center", "left", "right", "steering", "throttle", "brake", "speed"]
SIM_OPTIONS = ("strict",)
# the physical range of each recorded value: steering +-1 = full lock, pedals 0..1, speed in mph
SIM_RANGES = {"steering": (-1.0, 1.0, "in [-1, 1]"), "throttle": (0.0, 1.0, "in [0, 1]"),
              "brake": (0.0, 1.0, "in [0, 1]"), "speed": (0.0, math.inf, "of at least 0 (mph)")}


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
        v, (lo, hi, expected) = _number(log, r, c, row[i]), SIM_RANGES[c]
        if not lo - 1e-6 <= v <= hi + 1e-6:
            raise DataError(log, f"column {c!r} is {row[i].strip()}; a number {expected} is expected", r)
        values.append(v)
    ts = _sim_timestamp(paths["center"].name)
    if ts is None:
        raise DataError(log, f"cannot read the capture time from image name {paths['center'].name!r} "
                             "(expected center_YYYY_MM_DD_HH_MM_SS_mmm.jpg)", r)
    return paths, values, ts


def _ends_torn(path: Path, row: list[str]) -> bool:
    """Whether the last line of a file was cut off mid-write: NUL bytes in it, or no line end after it."""
    with open(path, "rb") as f:
        f.seek(-1, 2)
        return any("\x00" in c for c in row) or f.read(1) not in (b"\n", b"\r")


def read_sim_log(log: str | Path, frame_range=None, strict: bool = False) -> Recording:
    """A simulator driving log. A torn last line (a recording cut off mid-write) is left out with a warning,
    or refused with `strict`; a bad line anywhere else is an error."""
    log = Path(log)
    rows = _read_rows(log)
    if rows and rows[0][0].strip() == "center":
        header = [h.strip() for h in rows[0]]
        missing = [c for c in SIM_COLUMNS if c not in header]
        if missing:
            raise DataError(log, f"header lacks columns {missing}; expected {','.join(SIM_COLUMNS)}", 1)
        idx = [header.index(c) for c in SIM_COLUMNS]
        rows, first = rows[1:], 2
    else:
        idx, first = list(range(7)), 1
    if rows and not strict and _ends_torn(log, rows[-1]):
        last = first + len(rows) - 1
        try:
            _sim_row(log, rows[-1], last, idx)
        except DataError as e:
            warn(f"{log}: row {last} is torn (the recording was cut off mid-write?): left out, 1 record lost "
                 f"({e.message}; reader option strict: true refuses such a log)")
            rows = rows[:-1]
    if not rows:
        raise DataError(log, "the driving log has no rows")
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
    _check_unique(stamps_a, log, first)
    for paths in frames.values():
        _check_images(paths, log, first)
    return Recording(
        name=log.parent.name, source=log, frames=frames, timestamps_ns=stamps_a,
        steering=np.array(vals["steering"]) * SIM_FULL_LOCK_RAD, convention=SIM_CONVENTION, frame_ids=stamps_a,
        speed=np.array(vals["speed"]) * MPH_TO_MS, throttle=np.array(vals["throttle"]),
        brake=np.array(vals["brake"]), preset="sim",
    )


# ---------------------------------------------------------------- steerlab native layout

def read_native(folder: str | Path, frame_range=None) -> Recording:
    folder = Path(folder)
    meta_path, log = folder / "recording.json", folder / "log.csv"
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise DataError(meta_path, f"cannot read recording metadata: {e}") from None
    rows = _read_rows(log) if log.exists() else []
    if not rows:
        raise DataError(log, "missing or empty log")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in NATIVE_COLUMNS if c not in header]
    if missing:
        raise DataError(log, f"header lacks columns {missing}; expected {','.join(NATIVE_COLUMNS)}", 1)
    col = {h: i for i, h in enumerate(header)}
    body = rows[1:]
    if not body:
        raise DataError(log, "the recording has no frames")
    cut = apply_range(len(body), frame_range, log)
    body, first = body[cut], 2 + cut.start
    cams = [c for c in ("center", "left", "right") if body[0][col[c]].strip()]
    frames = {c: [] for c in cams}
    num_cols = ["steering", "speed", "throttle", "brake", "lateral_offset", "heading_error", "curvature"]
    vals = {c: [] for c in num_cols}
    stamps, episodes = [], []
    for r, row in enumerate(body, start=first):
        if len(row) < len(header):
            raise DataError(log, f"expected {len(header)} columns, got {len(row)}", r)
        try:
            stamps.append(int(row[col["timestamp_ns"]]))
        except ValueError:
            raise DataError(log, f"timestamp_ns must be an integer, got {row[col['timestamp_ns']]!r}", r) from None
        for c in cams:
            frames[c].append(folder / row[col[c]])
        for c in num_cols:
            vals[c].append(_number(log, r, c, row[col[c]]))
        ep = row[col["episode"]]
        if ep not in EPISODES:
            raise DataError(log, f"episode must be one of {EPISODES}, got {ep!r}", r)
        episodes.append(ep)
    stamps_a = np.array(stamps, dtype=np.int64)
    _check_unique(stamps_a, log, first)
    for paths in frames.values():
        _check_images(paths, log, first)
    conv = meta.get("steering", {})
    return Recording(
        name=folder.name, source=folder, frames=frames, timestamps_ns=stamps_a,
        steering=np.array(vals["steering"]), convention=SteeringConvention(**conv), frame_ids=stamps_a,
        speed=np.array(vals["speed"]), throttle=np.array(vals["throttle"]), brake=np.array(vals["brake"]),
        extra={"lateral_offset": np.array(vals["lateral_offset"]), "heading_error": np.array(vals["heading_error"]),
               "curvature": np.array(vals["curvature"]), "episode": np.array(episodes)},
        preset=meta.get("preset", "sim"),
    )
