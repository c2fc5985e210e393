"""A video file (MP4, AVI, ...) with a CSV log, decoded lazily with OpenCV.

The log sits beside the video with the same name (`drive.mp4` + `drive.csv`) or is given as the reader option
`log`. Its columns: `steering` and optionally `speed` (m/s), and one of `timestamp_ns` (integer nanoseconds),
`timestamp` (seconds) or `frame` (the video frame each row labels; without a time column the video's frame
rate gives the times). Without `frame`, row i labels video frame i and the log must have as many rows as the
video has frames. The steering convention and the camera geometry are reader options too: `steering` (kind,
default "steering_wheel"), `positive` (default "left"), `full_lock_deg` (for normalized steering) and `geometry`
(default "ch2"; its crop preset of the same name is used).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from steerlab.data.cameras import GEOMETRY
from steerlab.data.rows import Reader, apply_range, check_increasing, check_unique, csv_header, number, read_rows
from steerlab.data.recording import FULL_LOCK_DEG, KINDS, Recording, SteeringConvention, VideoFrames, said_full_lock
from steerlab.errors import DataError
from steerlab.options import Options, option



@dataclass(frozen=True)
class VideoOptions(Options):
    """A video's reader options: its log and what its steering means."""

    log: str | None = option(None, help="the CSV log (default: the video's name with .csv)")
    steering: Literal[KINDS] = option("steering_wheel", help="what the log's steering is: steering_wheel, road_wheel "
                                      "or normalized")
    positive: Literal["left", "right"] = option("left", help="the side positive steering turns to")
    full_lock_deg: float | None = option(None, FULL_LOCK_DEG, help="normalized steering: the full-lock angle")
    geometry: str = option("ch2", GEOMETRY, help="the camera geometry of the video")


OPTIONS = VideoOptions


def read_video(path: str | Path, frame_range=None, log: str | Path | None = None, steering: str = "steering_wheel",
               positive: str = "left", full_lock_deg: float | None = None, geometry: str = "ch2") -> Recording:
    path = Path(path)
    log = Path(log) if log else path.with_suffix(".csv")
    if not log.is_file():
        raise DataError(log, f"the log of video {path.name} is missing (put {path.stem}.csv beside it or give the "
                             "reader option log)")
    capture = cv2.VideoCapture(str(path))
    count, fps = int(capture.get(cv2.CAP_PROP_FRAME_COUNT)), capture.get(cv2.CAP_PROP_FPS)
    ok = capture.isOpened() and capture.read()[0]
    capture.release()
    if not ok or count <= 0:
        raise DataError(path, "cannot decode this video with OpenCV: convert it to MP4 (H.264)")
    if not GEOMETRY(geometry):
        raise DataError(path, f"unknown camera geometry {geometry!r}; choose {GEOMETRY.words(str)}")
    try:
        convention = SteeringConvention(steering, positive,
                                        None if full_lock_deg is None else math.radians(float(full_lock_deg)))
    except ValueError as e:
        raise DataError(log, f"reader options steering/positive/full_lock_deg: {e}; fix them") from None
    said_full_lock(full_lock_deg, f"{log}: reader option")

    rows = read_rows(log)
    if len(rows) < 2:
        raise DataError(log, "the log has no rows: give the log of this video's frames")
    header = csv_header(log, rows[0])
    col = {h: i for i, h in enumerate(header)}
    time_col = next((c for c in ("timestamp_ns", "timestamp", "frame") if c in col), None)
    if "steering" not in col or time_col is None:
        raise DataError(log, f"columns {header}: expected 'steering' and one of 'timestamp_ns', 'timestamp' "
                             "(seconds) or 'frame'", 1)
    body = rows[1:]
    positions = np.arange(len(body))
    if "frame" in col:
        positions = np.array([_integer(log, r, "frame", row[col["frame"]]) for r, row in enumerate(body, 2)])
        bad = np.flatnonzero(np.diff(positions) <= 0)
        if bad.size:
            raise DataError(log, "frame numbers must increase", int(bad[0]) + 3)
        if positions[0] < 0 or positions[-1] >= count:
            raise DataError(log, f"the log labels video frame {positions[-1]} but {path.name} has only {count} "
                                 f"frames ({positions[-1] + 1 - count} too few): give the log of this "
                                 "video", len(body) + 1)
    elif len(body) != count:
        more = "more" if len(body) > count else "fewer"
        raise DataError(log, f"the log has {len(body)} rows but {path.name} has {count} frames "
                             f"({abs(len(body) - count)} {more} rows than frames): give the log "
                             "written with this video")
    for r, row in enumerate(body, start=2):
        if len(row) < len(header):
            raise DataError(log, f"expected {len(header)} columns, got {len(row)}", r)
    steer = np.array([number(log, r, "steering", row[col["steering"]]) for r, row in enumerate(body, 2)])
    speed = (np.array([number(log, r, "speed", row[col["speed"]]) for r, row in enumerate(body, 2)])
             if "speed" in col else None)
    if time_col == "timestamp_ns":
        stamps = np.array([_integer(log, r, time_col, row[col[time_col]]) for r, row in enumerate(body, 2)])
    elif time_col == "timestamp":
        stamps = np.round(np.array([number(log, r, time_col, row[col[time_col]]) for r, row in enumerate(body, 2)])
                          * 1e9).astype(np.int64)
    else:
        stamps = np.round(positions * 1e9 / (fps if fps > 0 else 30.0)).astype(np.int64)
    check_unique(stamps, log, 2)
    check_increasing(stamps, log, 2)
    cut = apply_range(len(body), frame_range, log)
    stamps, positions, steer = stamps[cut], positions[cut], steer[cut]
    return Recording(
        name=path.stem, source=path, frames={"center": [path] * len(stamps)}, timestamps_ns=stamps,
        steering=steer, convention=convention, frame_ids=stamps, speed=None if speed is None else speed[cut],
        geometry=geometry, video=VideoFrames(path, positions),
    )


def _integer(path: Path, row: int, column: str, text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise DataError(path, f"column {column!r} must be an integer, got {text!r}", row) from None


SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")
READER = Reader("video", f"a video ({', '.join(SUFFIXES)})",
                lambda path: path.is_file() and path.suffix.lower() in SUFFIXES, read_video, OPTIONS)
