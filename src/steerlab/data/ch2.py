"""Udacity CH2 folders: `center/` (optional `left/`, `right/`) with `<ns>.jpg` frames plus a label CSV, either
`interpolated.csv` (`index,timestamp,width,height,frame_id,filename,angle,torque,speed,lat,long,alt`) or the
answer/submission layout (`frame_id,steering_angle[,public]`). Steering-wheel angle in radians, positive left."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from steerlab.data.recording import Recording, SteeringConvention
from steerlab.data.rows import (Reader, apply_range, check_images, check_increasing, check_unique, csv_header, nearest,
                                number, read_rows)
from steerlab.errors import DataError

CH2_CONVENTION = SteeringConvention("steering_wheel", "left")


def _ch2_label_file(folder: Path) -> Path:
    if (folder / "interpolated.csv").exists():
        return folder / "interpolated.csv"
    if (folder / "CH2_final_evaluation.csv").exists():
        return folder / "CH2_final_evaluation.csv"
    csvs = sorted(folder.glob("*.csv"))
    if len(csvs) == 1:
        return csvs[0]
    if not csvs and (folder / "center" / "000000.jpg").is_file():  # the first frame a steerlab recording writes
        raise DataError(folder, "a recording without its recording.json, as an interrupted recording (Ctrl-C) "
                                "leaves it: record it again")
    if not csvs:
        raise DataError(folder, "no label CSV found (expected interpolated.csv or frame_id,steering_angle CSV)")
    raise DataError(folder, f"several label CSVs ({', '.join(c.name for c in csvs)}); choose one "
                              "with the labels option")


def read_ch2(folder: str | Path, frame_range=None, labels: str | Path | None = None) -> Recording:
    folder = Path(folder)
    label_path = Path(labels) if labels else _ch2_label_file(folder)
    rows = read_rows(label_path, "label file")
    if not rows:
        raise DataError(label_path, "the label file is empty: label the frames (frame_id,steering_angle rows) "
                                    "or give the right file")
    header = csv_header(label_path, rows[0])
    body = rows[1:]
    if "frame_id" in header and "steering_angle" in header:
        ids, steer, speed, cams = _ch2_answer_rows(label_path, header, body)
    elif {"timestamp", "frame_id", "filename", "angle"} <= set(header):
        ids, steer, speed, cams = _ch2_interpolated_rows(label_path, header, body)
    else:
        raise DataError(label_path, f"unknown columns {header}; expected 'frame_id,steering_angle[,public]' or "
                                    "the interpolated.csv layout 'index,timestamp,...,filename,angle,torque,speed,...'", 1)
    if len(ids) == 0:
        raise DataError(label_path, "no labelled frames: give a label file with a row per frame")
    check_unique(ids, label_path, 2)
    check_increasing(ids, label_path, 2)
    cut = apply_range(len(ids), frame_range, label_path)
    first_row = 2 + cut.start
    ids, steer = ids[cut], steer[cut]
    speed = None if speed is None else speed[cut]
    frames = {cam: [folder / p for p in names[cut]] for cam, names in cams.items()}
    for paths in frames.values():
        check_images(paths, label_path, first_row, cut.start)
    return Recording(
        name=folder.name, source=folder, frames=frames, timestamps_ns=ids.astype(np.int64), steering=steer,
        convention=CH2_CONVENTION, frame_ids=ids, speed=speed, geometry="ch2",
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
        steer.append(number(path, r, "steering_angle", row[i_st]))
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
        angle = number(path, r, "angle", row[col["angle"]])
        spd = number(path, r, "speed", row[col["speed"]]) if "speed" in col else math.nan
        by_cam.setdefault(cam, []).append((ts, row[col["filename"]], angle, spd, r))
    if "center" not in by_cam:
        raise DataError(path, "no rows with frame_id 'center_camera': give the label file of the "
                              "center camera's frames")
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


READER = Reader("ch2", "a CH2 folder (center/ + CSV)", lambda path: path.is_dir() and (path / "center").is_dir(),
                read_ch2, labels=True)
