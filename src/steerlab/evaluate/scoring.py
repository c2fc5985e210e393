"""Score a predictions file against an answer file the way the Udacity Challenge 2 leaderboard did."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from steerlab.files import csv_header, read_csv
from steerlab.errors import DataError, warn
from steerlab.paths import a_path
from steerlab.evaluate.metrics import gamma_deg, mae_deg, rmse


def read_steering_csv(path: str | Path, need_public: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read `frame_id,steering_angle[,public]`; returns ids, angles and the public flags (or None)."""
    path = a_path(path, "the predictions file")
    rows = read_csv(path, "predictions file")
    if not rows:
        raise DataError(path, "the file is empty: give the predictions, a frame_id,steering_angle row per frame")
    header = csv_header(path, rows[0])
    if "frame_id" not in header or "steering_angle" not in header:
        raise DataError(path, f"expected columns 'frame_id,steering_angle', got {header}", 1)
    if need_public and "public" not in header:
        raise DataError(path, "the answer file needs a 'public' column", 1)
    i_id, i_st = header.index("frame_id"), header.index("steering_angle")
    i_pub = header.index("public") if "public" in header else None
    ids, vals, pub = [], [], []
    seen: dict[int, int] = {}
    for r, row in enumerate(rows[1:], start=2):
        try:
            fid = int(row[i_id])
        except (ValueError, IndexError):
            raise DataError(path, f"frame_id must be an integer, got {row[i_id] if len(row) > i_id else ''!r}", r) from None
        if fid in seen:
            raise DataError(path, f"duplicate frame_id {fid} (first on row {seen[fid]}): remove one of them", r)
        seen[fid] = r
        try:
            v = float(row[i_st])
        except (ValueError, IndexError):
            raise DataError(path, "steering_angle must be a number", r) from None
        if not math.isfinite(v):
            raise DataError(path, f"steering_angle is {row[i_st]!r} for frame {fid}; a finite number is expected", r)
        ids.append(fid)
        vals.append(v)
        if i_pub is not None:
            pub.append(row[i_pub].strip() in ("1", "True", "true"))
    if not ids:
        raise DataError(path, "no rows: give a frame_id,steering_angle row per frame")
    return np.array(ids, np.int64), np.array(vals), (np.array(pub) if i_pub is not None else None)


SPREAD = 10.0  # predictions spread this many times as far as the truth are in another unit, not just poor
MOST_RAD = 4 * math.pi  # a steering wheel turns at most two turns each way: larger angles are in another unit


def spread_said(pred: np.ndarray, truth: np.ndarray) -> str | None:
    """What to say of predictions whose spread is far beyond the truth's (degrees where radians are expected: 57
    times), or None."""
    p, t = float(np.std(pred)), float(np.std(truth))
    if t > 0 and p > SPREAD * t:
        return (f"the predictions spread {p / t:.0f} times as far as the answers (std {p:.4g} against {t:.4g}): "
                f"degrees where radians are expected{'' if p / t > 30 else ', or another unit'}?")
    return None


def score(truth_path: str | Path, pred_path: str | Path) -> dict[str, float]:
    """RMSE on all/public/private rows, MAE (deg), gamma of prediction and truth (deg).

    Every frame of the answer file must be predicted exactly once, and nothing else."""
    t_ids, truth, public = read_steering_csv(truth_path, need_public=True)
    p_ids, pred, _ = read_steering_csv(pred_path)
    pos = {int(f): i for i, f in enumerate(p_ids)}
    missing = [f for f in t_ids if int(f) not in pos]
    if missing:
        raise DataError(pred_path, f"{len(missing)} frame ids of the answer file are missing, "
                                   f"first {missing[0]}: give a prediction for each of its frames")
    extra = len(p_ids) - (len(t_ids) - len(missing))
    if extra:
        known = set(int(f) for f in t_ids)
        first = next(int(f) for f in p_ids if int(f) not in known)
        raise DataError(pred_path, f"{extra} frame ids are not in the answer file, first {first}: remove "
                                   "them, or give the answer file of these frames")
    aligned = pred[[pos[int(f)] for f in t_ids]]
    most = float(np.abs(truth).max())
    if most > MOST_RAD:
        warn(f"{truth_path}: steering angles up to {most:.4g} rad, beyond a steering wheel's two turns each way "
             f"({MOST_RAD:.4g} rad): degrees where radians are expected?")
    said = spread_said(aligned, truth)
    if said:
        warn(f"{pred_path}: {said}")
    return {
        "rmse": rmse(aligned, truth),
        "rmse_public": rmse(aligned[public], truth[public]) if public.any() else float("nan"),
        "rmse_private": rmse(aligned[~public], truth[~public]) if (~public).any() else float("nan"),
        "mae_deg": mae_deg(aligned, truth),
        "gamma_deg": gamma_deg(aligned),
        "truth_gamma_deg": gamma_deg(truth),
        "frames": int(len(truth)),
        "public_frames": int(public.sum()),
    }


def write_predictions(path: str | Path, frame_ids, steering, extra: dict | None = None) -> None:
    """Leaderboard format `frame_id,steering_angle` (radians), plus optional extra columns."""
    extra = extra or {}
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["frame_id", "steering_angle", *extra])
        cols = [np.asarray(v) for v in extra.values()]
        for i, (fid, v) in enumerate(zip(frame_ids, steering)):
            w.writerow([int(fid), repr(float(v)), *(c[i] for c in cols)])
