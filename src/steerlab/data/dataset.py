"""The compiled dataset cache (`steerlab compile`).

A Recording plus a PreprocessConfig is decoded, preprocessed and turned into its modalities once, into
memory-mapped .npy arrays under `<cache>/<key>/`, where the key hashes the source files and the config.
A second run with the same source and config reuses the arrays, once their checksums (sha1, in `meta.json`) show
they are the bytes that were written: a damaged entry (a truncated or changed file) is said and compiled again. Work is done in chunks on a pool of
threads (OpenCV releases the GIL), written straight into the memory maps, so the decoded recording is never
held in RAM. A cache entry is built in a temporary folder and renamed into place when complete, so an
interrupted compile never leaves a half-written cache behind; the temporary folders of killed compiles are
removed by the next one. A lock file beside the entry (`.<key>.lock`) makes a second process that needs the
same entry wait for the first one and reuse its result instead of compiling it again.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.data.cache import cache_root
from steerlab.data.fisheye import FisheyeCamera
from steerlab.data.geometry import CAMERAS
from steerlab.data.modalities import frame_difference, optical_flow
from steerlab.data.preprocess import PreprocessConfig, preprocess
from steerlab.data.recording import Recording
from steerlab.data.views import View, lens_name, lens_of, warp
from steerlab.errors import DataError, warn
from steerlab.locks import pid_alive, waiting_lock

CHUNK = 64


def source_key(rec: Recording, camera: str) -> str:
    """Hash of what the cache depends on: image files (path, size, mtime), every label, and the steering
    convention the reader gave them (a tub read with and without `full_lock_deg` are two entries)."""
    h = hashlib.sha1(b"layout 3\n")  # the entry's layout: a new one never reads an older entry
    h.update(json.dumps(rec.convention.as_dict(), sort_keys=True).encode())
    for p in rec.frames[camera]:
        st = os.stat(p)
        h.update(f"{p}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    for name, arr in sorted(_labels(rec).items()):
        h.update(name.encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()[:16]


def _labels(rec: Recording) -> dict[str, np.ndarray]:
    out = {"steering": rec.steering, "timestamps_ns": rec.timestamps_ns, "frame_ids": rec.frame_ids,
           "segment": rec.segment_ids()}
    for name in ("speed", "throttle", "brake"):
        if getattr(rec, name) is not None:
            out[name] = getattr(rec, name)
    out.update(rec.extra)
    return out


@dataclass
class CompiledDataset:
    """Memory-mapped arrays of one compiled recording.

    arrays: modality -> (N, H, W, C) array (image/diff uint8, flow float16).
    labels: per-frame columns (steering, segment, timestamps_ns, frame_ids, speed, ...).
    """

    path: Path
    config: PreprocessConfig
    arrays: dict[str, np.ndarray]
    labels: dict[str, np.ndarray]
    meta: dict

    def __len__(self) -> int:
        return len(self.labels["steering"])

    @property
    def steering(self) -> np.ndarray:
        return self.labels["steering"]

    def __getstate__(self) -> dict:
        """Pickled without its arrays (a worker process maps them again), so it never copies the cache."""
        return {**self.__dict__, "arrays": list(self.arrays)}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.arrays = {m: np.load(self.path / f"{m}.npy", mmap_mode="r") for m in state["arrays"]}

    @classmethod
    def load(cls, path: str | Path) -> "CompiledDataset":
        path = Path(path)
        meta = json.loads((path / "meta.json").read_text())
        cfg = PreprocessConfig.from_dict(meta["preprocess"])
        arrays = {m: np.load(path / f"{m}.npy", mmap_mode="r") for m in cfg.modalities}
        with np.load(path / "labels.npz") as z:
            labels = {k: z[k] for k in z.files}
        return cls(path, cfg, arrays, labels, meta)


def compile_recording(rec: Recording, cfg: PreprocessConfig, cache_dir: str | Path | None = None,
                      camera: str = "center", workers: int | None = None, progress: bool = True,
                      view: View | None = None, lens: FisheyeCamera | None = None) -> CompiledDataset:
    """Compile (or reuse) the cached arrays for `rec` under `cfg`.

    `view` compiles a virtual camera instead: every frame as seen from the camera moved shift_m to the left and
    turned yaw_deg to the left (`views.View`: fixed, or drawn for each frame), warped through `lens` (a
    fisheye, `views.lens_of`) or, without one, the pinhole of the recording's camera geometry. Frame stacking
    happens when batches are gathered, so the cache holds single frames whatever `cfg.stack` is; the returned
    dataset carries `cfg` itself."""
    user_cfg, cfg = cfg, replace(cfg, stack=1)
    if view is not None and lens is None:
        lens = lens_of(rec)  # the donkey camera's fisheye; None for a pinhole camera
    name = camera if view is None else f"{camera}@{view.name}" + (f"-lens{lens_name(lens)}" if lens else "")
    key = f"{rec.name}-{name}-{source_key(rec, camera)}-{cfg.key()}"
    final = cache_root(cache_dir) / key
    final.parent.mkdir(parents=True, exist_ok=True)
    with waiting_lock(final.parent / f".{key}.lock"):  # another process may be compiling or checking it
        damage = _damage(final) if final.is_dir() else None  # a folder without its meta.json: half removed
        if damage:
            warn(f"{final / damage}: the compiled cache entry is damaged (not the bytes that were written, or "
                 "missing); compiling it again")
            shutil.rmtree(final)
        if not (final / "meta.json").exists():
            remove_leftovers(final.parent)
            _build(rec, cfg, camera, view, lens, final, workers, progress, name)
    return replace(CompiledDataset.load(final), config=user_cfg)


def _sha1(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha1").hexdigest()


def _damage(entry: Path) -> str | None:
    """The first file of a cache entry that is not what was written (its checksum differs, or it is missing),
    or None."""
    try:
        sums = json.loads((entry / "meta.json").read_text())["checksums"]
    except (OSError, ValueError, KeyError, TypeError):
        return "meta.json"
    for name, digest in sums.items():
        if not (entry / name).is_file() or _sha1(entry / name) != digest:
            return name
    return None


def expected_size(rec: Recording, camera: str = "center") -> tuple[int, int]:
    """(height, width) every frame of a recording must have: its camera geometry's, or for a recording of a
    camera steerlab does not know, its first frame's."""
    cam = CAMERAS.get(rec.geometry)
    return (cam.height, cam.width) if cam is not None else rec.load_frame(0, camera).shape[:2]


def remove_leftovers(cache: Path) -> None:
    """Remove the temporary folders (`.<key>.tmp-<pid>`) of compiles whose process has ended."""
    for tmp in cache.glob(".*.tmp-*"):
        pid = tmp.name.rsplit("-", 1)[1]
        if tmp.is_dir() and pid.isdigit() and not pid_alive(int(pid)):
            shutil.rmtree(tmp, ignore_errors=True)


BLACK = 8  # of 255: a frame whose every pixel is darker is black


def _build(rec: Recording, cfg: PreprocessConfig, camera: str, view: View | None, lens: FisheyeCamera | None,
           final: Path, workers: int | None, progress: bool, name: str) -> None:
    """Compile the cache entry `final` in a temporary folder beside it, renamed into place when complete."""
    tmp = final.parent / f".{final.name}.tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    n, h, w = len(rec), cfg.height, cfg.width
    ch = cfg.channels()
    arrays = {m: np.lib.format.open_memmap(tmp / f"{m}.npy", mode="w+", shape=(n, h, w, c),
                                           dtype=np.float16 if m == "flow" else np.uint8)
              for m, c in ch.items()}
    seg = rec.segment_ids()
    shifts, yaws = (None, None) if view is None else view.offsets(n)

    size = expected_size(rec, camera)
    lit = []  # frames brighter than black: a recording with none recorded nothing

    def load(i: int) -> np.ndarray:
        frame = rec.load_frame(i, camera)
        if frame.shape[:2] != size:
            raise DataError(rec.frames[camera][i], f"the frame is {frame.shape[0]}x{frame.shape[1]} (height x width); "
                                                   f"the recording's frames are {size[0]}x{size[1]} (frame {i}): "
                                                   "resize it, or give a frame range without it")
        if not lit and frame.max() >= BLACK:
            lit.append(i)
        return frame if view is None else warp(frame, rec.geometry, lens, float(shifts[i]), float(yaws[i]))

    def work(start: int) -> int:
        stop = min(start + CHUNK, n)
        prev_img = prev_gray = None
        if start > 0 and seg[start - 1] == seg[start]:  # predecessor within the same segment
            prev_img, prev_gray = preprocess(load(start - 1), cfg)
        for i in range(start, stop):
            img, gray = preprocess(load(i), cfg)
            if prev_img is None or seg[i - 1] != seg[i]:
                prev_img, prev_gray = img, gray
            arrays["image"][i] = img
            if "diff" in arrays:
                arrays["diff"][i] = frame_difference(prev_img, img)
            if "flow" in arrays:
                arrays["flow"][i] = optical_flow(prev_gray, gray, cfg.flow)
            prev_img, prev_gray = img, gray
        return stop - start

    workers = workers or min(2, os.cpu_count() or 1)
    try:
        with ThreadPoolExecutor(workers) as pool, tqdm(total=n, desc=f"compile {rec.name} {name}", unit="frame",
                                                       disable=None if progress else True) as bar:
            for done in pool.map(work, range(0, n, CHUNK)):
                bar.update(done)
        if not lit:
            raise DataError(rec.source, f"all {n} frames of camera {camera!r} are black (no pixel reaches {BLACK} of "
                                        "255): the camera recorded nothing (a lens cap, no exposure?); record it "
                                        "again, or give another recording")
        for a in arrays.values():
            a.flush()
        arrays.clear()  # close the memory maps before the folder is renamed
        offsets = {} if view is None else {"view_shift_m": shifts, "view_yaw_deg": yaws}  # the frames' own draws
        np.savez(tmp / "labels.npz", **_labels(rec), **offsets)
        meta = {"preprocess": cfg.as_dict(), "source": str(rec.source), "name": rec.name, "camera": camera,
                "view": None if view is None else view.as_dict(), "lens": None if lens is None else lens_name(lens),
                "frames": n, "convention": rec.convention.as_dict(), "geometry": rec.geometry,
                "frame_rate": rec.frame_rate(),
                "checksums": {f.name: _sha1(f) for f in sorted(tmp.iterdir())}}
        (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
        try:
            tmp.rename(final)
        except OSError:
            if not (final / "meta.json").exists():
                raise
            shutil.rmtree(tmp)  # another process finished the same entry first
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
