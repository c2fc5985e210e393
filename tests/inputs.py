"""Tiny inputs in every layout, made in a test's folder, for the tests and the bad-input rounds (tests/rounds/):
`sim_log`, `tub`, `ch2` (recordings of `ROWS` or 6 frames), `write_tub` (a tub of the records given),
`write_jpeg`, `made`, an untrained checkpoint of a kind of recording, and `flip_bytes`, a file damaged in its
middle. The tests import them from here or from conftest.py, which passes on `made`, `write_jpeg` and
`flip_bytes`; nothing here imports a test."""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import cv2
import numpy as np

ROWS = 8  # frames of the tiny driving log and tub


def sim_log(folder, rows=None, tail="\n"):
    """A driving_log.csv (no header) with ROWS frames; `rows` replaces the values of some rows by index."""
    (folder / "IMG").mkdir(parents=True, exist_ok=True)
    lines = []
    for i in range(ROWS):
        name = f"center_2020_01_01_00_00_00_{100 * i:03d}.jpg"
        write_jpeg(folder / "IMG" / name, 20 * i)
        values = (rows or {}).get(i, f"{0.1 * (i % 3):.1f},0.5,0,10")
        lines.append(f"/elsewhere/IMG/{name},,,{values}")
    (folder / "driving_log.csv").write_text("\n".join(lines) + tail)
    return folder / "driving_log.csv"


def tub(folder, records=None):
    """A donkeycar tub v2 with ROWS records; `records` changes fields of some records by index."""
    (folder / "images").mkdir(parents=True)
    lines = []
    for i in range(ROWS):
        name = f"{i}_cam_image_array_.jpg"
        write_jpeg(folder / "images" / name, 20 * i, (120, 160))
        rec = {"_index": i, "_session_id": "s", "_timestamp_ms": 1000 + 50 * i, "cam/image_array": name,
               "user/angle": 0.1 * (i % 3), "user/throttle": 0.3, "user/mode": "user", **(records or {}).get(i, {})}
        lines.append(json.dumps(rec))
    (folder / "catalog_0.catalog").write_text("\n".join(lines) + "\n")
    (folder / "catalog_0.catalog_manifest").write_text(json.dumps(  # as donkeycar writes it: each line's length
        {"created_at": 0.0, "line_lengths": [len(line) + 1 for line in lines], "path": "catalog_0.catalog",
         "start_index": 0}) + "\n")
    manifest = [["cam/image_array", "user/angle", "user/throttle", "user/mode"], ["image_array", "float", "float",
                "str"], {}, {"created_at": 0.0, "sessions": {"all_full_ids": ["s"]}},
                {"paths": ["catalog_0.catalog"], "current_index": ROWS, "max_len": 1000, "deleted_indexes": []}]
    (folder / "manifest.json").write_text("\n".join(json.dumps(m) for m in manifest) + "\n")
    return folder


def write_tub(folder, records, deleted=(), manifest_lines=None):
    """A tub v2 folder: records are (index, session, timestamp_ms, angle); images 160x120."""
    (folder / "images").mkdir(parents=True)
    lines = []
    for index, session, ms, angle in records:
        name = f"{index}_cam_image_array_.jpg"
        write_jpeg(folder / "images" / name, (index * 20) % 255, (120, 160))
        lines.append(json.dumps({"_index": index, "_session_id": session, "_timestamp_ms": ms,
                                 "cam/image_array": name, "user/angle": angle, "user/throttle": 0.3,
                                 "user/mode": "user"}))
    (folder / "catalog_0.catalog").write_text("\n".join(lines) + "\n")
    manifest = [["cam/image_array", "user/angle", "user/throttle", "user/mode"],
                ["image_array", "float", "float", "str"], {},
                {"created_at": 0.0, "sessions": {"all_full_ids": sorted({r[1] for r in records})}},
                {"paths": ["catalog_0.catalog"], "current_index": len(records), "max_len": 1000,
                 "deleted_indexes": list(deleted)}]
    text = "\n".join(json.dumps(m) for m in manifest[:manifest_lines]) + "\n"
    (folder / "manifest.json").write_text(text)
    return folder


def ch2(folder):
    """A CH2-layout folder: 6 frames of 640x480 (steering-wheel angle, positive left) and its label CSV."""
    (folder / "center").mkdir(parents=True)
    ids = [1_000_000_000 + i * 50_000_000 for i in range(6)]
    for i, fid in enumerate(ids):
        write_jpeg(folder / "center" / f"{fid}.jpg", 40 * i, (480, 640))
    (folder / "labels.csv").write_text("frame_id,steering_angle,public\n"
                                       + "".join(f"{fid},{0.01 * i},{i % 2}\n" for i, fid in enumerate(ids)))
    return folder


def write_jpeg(path: Path, value: int = 128, size=(160, 320)) -> None:
    path.write_bytes(_jpeg(value, tuple(size)))


@functools.lru_cache(maxsize=None)
def _jpeg(value: int, size: tuple) -> bytes:
    """A uniform frame of `value` with some texture, as JPEG bytes (made once per value and size)."""
    img = np.full((*size, 3), value, np.uint8)
    img[::7, ::5] = 255 - value
    return cv2.imencode(".jpg", img)[1].tobytes()


def made(folder, kind="road_wheel", positive="right", geometry="sim", name="model.pt", full_lock_deg=None,
         model="pilotnet", seed=0, **options):
    """folder/name: an untrained checkpoint of `model` (initialised with `seed`, built with `options`; per-modality
    statistics) with the steering convention and camera geometry of a kind of recording: road_wheel/right + sim (the
    simulator), normalized/right (donkeycar, with `full_lock_deg` if known), steering_wheel/left + ch2 (CH2)."""
    path = folder / name
    path.write_bytes(_checkpoint(kind, positive, geometry, full_lock_deg, model, seed, tuple(sorted(options.items()))))
    return path


@functools.lru_cache(maxsize=None)
def _checkpoint(kind, positive, geometry, full_lock_deg, model, seed, options) -> bytes:
    """The bytes of `made`'s checkpoint (built once per set of arguments)."""
    import tempfile

    import torch

    from steerlab.checkpoint import save_checkpoint
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.recording import SteeringConvention
    from steerlab.models import create_model, model_class

    options = dict(options)
    pre = PreprocessConfig.from_dict({"preset": geometry, **model_class(model).inputs})
    per = {"image": (100.0, 50.0), "diff": (128.0, 30.0), "flow": (0.0, 1.0)}
    stats = {"mean": [], "std": []}
    for modality, channels in pre.channels().items():
        stats["mean"] += [per[modality][0]] * channels
        stats["std"] += [per[modality][1]] * channels
    model_cfg = {"in_channels": len(stats["mean"]), "height": pre.height, "width": pre.width, **options}
    torch.manual_seed(seed)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "model.pt"
        save_checkpoint(path, create_model(model, **model_cfg), model_cfg, pre, stats,
                        SteeringConvention(kind, positive, full_lock_deg and math.radians(full_lock_deg)),
                        {"rmse": 0.1}, geometry=geometry, frame_rate=20.0)
        return path.read_bytes()


def flip_bytes(path: Path) -> Path:
    """The file with 16 bytes in its middle inverted (in a model's weights), as damage would."""
    data = bytearray(path.read_bytes())
    for i in range(len(data) // 2, len(data) // 2 + 16):
        data[i] ^= 0xFF
    path.write_bytes(bytes(data))
    return path
