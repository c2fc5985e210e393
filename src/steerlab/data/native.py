"""steerlab's native recording layout, written by the road world: `recording.json` (metadata, steering
convention) + `log.csv` (one row per frame, NATIVE_COLUMNS) + one folder of JPEGs per camera."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from steerlab.data.fisheye import fisheye_from
from steerlab.data.recording import Recording, SteeringConvention
from steerlab.data.rows import Reader, apply_range, check_images, check_increasing, check_unique, csv_header, number, read_rows
from steerlab.errors import DataError
from steerlab.files import read_json

NATIVE_COLUMNS = ["frame", "timestamp_ns", "center", "left", "right", "steering", "speed", "throttle", "brake",
                  "lateral_offset", "heading_error", "curvature", "episode"]
EPISODES = ("normal", "drift-out", "recover", "rollout")  # rollout: a DAgger frame, labelled by the expert


def read_native(folder: str | Path, frame_range=None) -> Recording:
    folder = Path(folder)
    meta_path, log = folder / "recording.json", folder / "log.csv"
    meta = read_json(meta_path, "recording metadata")
    if not isinstance(meta, dict):
        raise DataError(meta_path, "recording metadata must be a JSON object")
    rows = read_rows(log, "log")
    if not rows:
        raise DataError(log, "missing or empty log: record it again, or give another recording")
    header = csv_header(log, rows[0])
    missing = [c for c in NATIVE_COLUMNS if c not in header]
    if missing:
        raise DataError(log, f"header lacks columns {missing}; expected {','.join(NATIVE_COLUMNS)}", 1)
    col = {h: i for i, h in enumerate(header)}
    body = rows[1:]
    if not body:
        raise DataError(log, "the recording has no frames: record it again, or give another recording")
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
            vals[c].append(number(log, r, c, row[col[c]]))
        ep = row[col["episode"]]
        if ep not in EPISODES:
            raise DataError(log, f"episode must be one of {EPISODES}, got {ep!r}", r)
        episodes.append(ep)
    stamps_a = np.array(stamps, dtype=np.int64)
    check_unique(stamps_a, log, first)
    check_increasing(stamps_a, log, first)
    for paths in frames.values():
        check_images(paths, log, first, cut.start)
    conv = meta.get("steering", {})
    return Recording(
        name=folder.name, source=folder, frames=frames, timestamps_ns=stamps_a,
        steering=np.array(vals["steering"]), convention=SteeringConvention(**conv), frame_ids=stamps_a,
        speed=np.array(vals["speed"]), throttle=np.array(vals["throttle"]), brake=np.array(vals["brake"]),
        extra={"lateral_offset": np.array(vals["lateral_offset"]), "heading_error": np.array(vals["heading_error"]),
               "curvature": np.array(vals["curvature"]), "episode": np.array(episodes)},
        geometry=meta.get("geometry", meta.get("preset", "sim")),  # "preset" in older recordings
        fisheye=fisheye_from(meta_path, meta["fisheye"]) if "fisheye" in meta else None,
    )


def _recognises(path: Path) -> bool:
    """A folder with recording.json, or its log.csv."""
    folder = path if path.is_dir() else path.parent
    return (folder / "recording.json").is_file() and (path.is_dir() or path.name == "log.csv")


READER = Reader("steerlab", "a steerlab recording (recording.json)", _recognises,
                lambda path, rng: read_native(path if path.is_dir() else path.parent, rng))
