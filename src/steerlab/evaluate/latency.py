"""`steerlab latency`: the Pilot's time per frame as a car's computer would see it, with the cores limited.

One frame at a time through the whole Pilot (optionally JPEG decoding, preprocessing, flow, model) and through
the model alone, on PyTorch or ONNX Runtime, with torch, OpenCV and ONNX Runtime held to N threads. The first
frames are warm-up and not counted. Frames come from a recording or are synthetic frames of a camera geometry's
size (a textured image sliding sideways, so that flow and frame differences have motion to work on).
Untrained models of a geometry cost what trained ones do: the weights do not change the work.

The verdict is for donkeycar's vehicle loop, 20 Hz by default: a model fits when its p99 is within the loop's
50 ms, and its headroom is 50 ms / p99.
"""

from __future__ import annotations

import csv
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import cycle, islice
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
from tqdm import tqdm

from steerlab.data.cameras import GEOMETRY
from steerlab.data.geometry import camera
from steerlab.data.readers import Source, a_source
from steerlab.options import AT_LEAST_1, Options, THREADS, names_from, option
from steerlab.errors import SteerlabError
from steerlab.export import export_onnx
from steerlab.paths import check_outputs
from steerlab.pilot import Pilot

WARMUP = 10  # frames run before the timing starts
DISTINCT_FRAMES = 100  # frames of a recording (its first, by default) or synthetic; the timed frames cycle
SPEED = 5.0  # m/s, fed to models with a speed history when the frames have none: the value does not change the cost
LOOP_HZ = (20, 10)  # donkeycar's vehicle loop rate (default 20), and half of it
RUNTIMES = ("torch", "onnx")
COLUMNS = ["model", "source", "runtime", "geometry", "width", "height", "threads", "frames", "decode",
           "pilot_median_ms", "pilot_p90_ms", "pilot_p99_ms", "pilot_fps", "model_median_ms", "model_p90_ms",
           "model_p99_ms", "model_fps", *(f"fits_{hz}hz" for hz in LOOP_HZ), "headroom_20hz"]


class TimedModel:
    """A Pilot's model that records the milliseconds of every call."""

    def __init__(self, net):
        self.net, self.ms = net, []

    def __getattr__(self, name):
        return getattr(self.net, name)

    def __call__(self, *args):
        t = time.perf_counter()
        out = self.net(*args)
        self.ms.append((time.perf_counter() - t) * 1000)
        return out


@contextmanager
def limited_threads(threads: int | None):
    """torch (when loaded), OpenCV and so the Pilot's preprocessing held to `threads` threads; None: unchanged."""
    torch = sys.modules.get("torch")
    before = cv2.getNumThreads(), torch and torch.get_num_threads()
    if threads is not None:
        cv2.setNumThreads(threads)
        if torch:
            torch.set_num_threads(threads)
    try:
        yield
    finally:
        cv2.setNumThreads(before[0])
        if torch:
            torch.set_num_threads(before[1])


def _stats(ms: np.ndarray) -> dict:
    return {"median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)),
            "p99_ms": float(np.percentile(ms, 99)), "fps": float(1000 / ms.mean())}


def measure(pilot: Pilot, frames: list[tuple], count: int | None = None, threads: int | None = None,
            warmup: int = WARMUP) -> dict:
    """Per-frame latency of `pilot` over `frames`, (BGR frame or its JPEG bytes, speed) pairs (bytes are decoded
    inside the timed step), cycled to `warmup` + `count` frames (default: the frames after the warm-up), from a
    reset Pilot. -> {"pilot": stats, "model": stats}, stats: median_ms, p90_ms, p99_ms and fps (1000 / mean ms)
    after the warm-up."""
    count = len(frames) - warmup if count is None else count
    if count < 1:
        raise SteerlabError(f"{len(frames)} frames leave none to time after {warmup} warm-up frames: give more "
                            "frames")
    pilot.reset()
    net = pilot.net = TimedModel(pilot.net)
    times = []
    try:
        with limited_threads(threads):
            for frame, speed in islice(cycle(frames), warmup + count):
                t = time.perf_counter()
                pilot.step(cv2.imdecode(frame, cv2.IMREAD_COLOR) if frame.ndim == 1 else frame, speed)
                times.append((time.perf_counter() - t) * 1000)
    finally:
        pilot.net = net.net
    return {"pilot": _stats(np.array(times[warmup:])), "model": _stats(np.array(net.ms[warmup:]))}


def recording_frames(rec, decode: bool = False, limit: int | None = None) -> list[tuple]:
    """(frame, speed) pairs of a recording's frames (its first `limit`); speed: the recorded one, else SPEED."""
    speeds = rec.speed if rec.speed is not None else np.full(len(rec), SPEED)
    n = len(rec) if limit is None else min(limit, len(rec))
    return _encoded([(rec.load_frame(i), float(speeds[i])) for i in range(n)], decode)


def synthetic_frames(geometry: str, decode: bool = False) -> list[tuple]:
    """(frame, SPEED) pairs: a smooth random texture of the geometry's frame size sliding 2 pixels a frame."""
    cam = camera(geometry)
    texture = np.random.default_rng(0).integers(0, 256, (cam.height // 4, cam.width // 4 + DISTINCT_FRAMES, 3),
                                                 np.uint8)
    texture = cv2.resize(texture, (texture.shape[1] * 4, cam.height), interpolation=cv2.INTER_CUBIC)
    return _encoded([(texture[:, 2 * i:2 * i + cam.width].copy(), SPEED) for i in range(DISTINCT_FRAMES)], decode)


def _encoded(frames: list[tuple], decode: bool) -> list[tuple]:
    """The frames as JPEG bytes (quality 95) when `decode`, so that timing includes their decoding."""
    if not decode:
        return frames
    return [(cv2.imencode(".jpg", f, [cv2.IMWRITE_JPEG_QUALITY, 95])[1], s) for f, s in frames]


def untrained_checkpoint(folder: Path, name: str, geometry: str, **preprocess) -> Path:
    """A checkpoint of model `name` with untrained weights and unit statistics for the camera `geometry`
    (`preprocess`: options beside the model's own, e.g. flow="dis")."""
    from steerlab.checkpoint import save_checkpoint
    from steerlab.data.preprocess import PreprocessOptions
    from steerlab.data.recording import SteeringConvention
    from steerlab.models.registry import ModelSpec
    from steerlab.options import parse

    spec = ModelSpec(name, {})
    pre = spec.preprocess(parse(PreprocessOptions, {"preset": geometry, **preprocess}, "preprocess")).resolve()
    c = sum(pre.channels().values())
    model_cfg = spec.arguments(pre)
    path = folder / ("-".join([name, geometry, *map(str, preprocess.values())]) + ".pt")
    save_checkpoint(path, spec.build(pre), model_cfg, pre, {"mean": [0.0] * c, "std": [1.0] * c},
                    SteeringConvention(), {}, geometry=geometry)
    return path


@dataclass(frozen=True)
class LatencyOptions(Options):
    """`steerlab latency`'s options."""

    models: str | None = option(None, help="'all' or a comma list of registered models to time untrained (the "
                                "weights do not change the cost), each once, in one table with any checkpoints "
                                "given; default: all when no checkpoint is given")
    geometry: str | None = option(None, GEOMETRY, help="camera geometry of the untrained models "
                                                              "and the synthetic frames (default: the recording's "
                                                              "with --data, else donkey, 160x120)")
    threads: int = option(1, THREADS, help="threads of torch, OpenCV and ONNX Runtime (1: one core; at most the "
                          "machine's cores)")
    runtime: Literal["torch", "onnx", "both"] = option("both", help="PyTorch, ONNX Runtime (a .pt is exported "
                                                       "first) or both")
    frames: int = option(500, AT_LEAST_1, help="frames timed, after 10 warm-up frames")
    decode: bool = option(False, help="time JPEG decoding too (frames encoded once, quality 95)")

    def model_names(self, checkpoints) -> list[str]:
        """The registered models to time untrained (beside the checkpoints, if any), each once."""
        from steerlab.models import list_models

        if self.models is None:
            return [] if checkpoints else list_models()
        try:
            names = names_from(self.models, [*list_models(), "all"], "models", "steerlab")
        except SteerlabError as e:
            raise SteerlabError(f"models {self.models}: {e}") from None
        if "all" in names and len(names) > 1:
            raise SteerlabError(f"models {self.models}: 'all' names every model already; give 'all' or a list")
        return list_models() if names == ["all"] else names


def run_latency(checkpoints=(), o: LatencyOptions = LatencyOptions(), source: Source | None = None,
                out: str | Path | None = None, progress: bool = True) -> list[dict]:
    """Time checkpoints (.pt, .onnx) and untrained models (`o.models`, built for `o.geometry`: default the
    recording's, else donkey) on the runtimes asked for (torch, onnx or both; a .pt is exported for ONNX Runtime,
    an .onnx runs there only), on the frames of `source` (its first DISTINCT_FRAMES by default) or synthetic
    ones. Writes latency.csv and latency.md into `out` when given; returns the rows. Without models nothing here
    needs torch: exported models time on a car's computer with ONNX Runtime alone."""
    if out is not None:
        check_outputs({"output folder": out}, inputs=[*checkpoints, source and source.data], kind="latency")
    runtimes = RUNTIMES if o.runtime == "both" else (o.runtime,)
    models, threads, count, decode = o.model_names(checkpoints), o.threads, o.frames, o.decode
    if models:
        from steerlab.models import model_class

        for name in models:
            model_class(name)  # an unknown name fails here, before anything runs
    for path in map(Path, checkpoints):
        if not path.is_file():
            raise SteerlabError(f"{path}: checkpoint not found: check the path")
        if path.suffix == ".onnx" and "onnx" not in runtimes:
            raise SteerlabError(f"{path} runs on ONNX Runtime only: time it with steerlab latency "
                                "--runtime onnx or both")
    rec = None if source is None else a_source(source, "run_latency").open()
    limit = None if source is None or source.range else DISTINCT_FRAMES  # a recording shorter than that: all
    geometry = o.geometry or (rec.geometry if rec else "donkey")
    size = rec and rec.load_frame(0).shape[:2]
    frames = {}  # geometry -> frames
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [(str(p), p) for p in checkpoints] + [("untrained", n) for n in models]
        for source, item in tqdm(jobs, desc="latency", unit="model", disable=None if progress else True):
            pt = Path(item) if source != "untrained" else untrained_checkpoint(Path(tmp), item, geometry)
            for rt in ("onnx",) if pt.suffix == ".onnx" else runtimes:
                onnx = rt == "onnx" and pt.suffix != ".onnx"
                pilot = Pilot(export_onnx(pt, Path(tmp) / f"{len(rows)}.onnx") if onnx else pt, threads=threads)
                geo = pilot.geometry or geometry
                cam = camera(geo)
                if rec is not None and size != (cam.height, cam.width):
                    raise SteerlabError(f"{item}: the model takes frames of the {geo!r} camera geometry "
                                        f"({cam.width}x{cam.height}); the frames of {rec.source} are {size[1]}x{size[0]}")
                if geo not in frames:
                    frames[geo] = synthetic_frames(geo, decode) if rec is None else recording_frames(rec, decode, limit)
                r = measure(pilot, frames[geo], count, threads)
                p99 = r["pilot"]["p99_ms"]
                rows.append({"model": pilot.name, "source": source, "runtime": rt, "geometry": geo,
                             "width": cam.width, "height": cam.height, "threads": threads, "frames": count,
                             "decode": decode,
                             **{f"{part}_{k}": v for part in ("pilot", "model") for k, v in r[part].items()},
                             **{f"fits_{hz}hz": p99 <= 1000 / hz for hz in LOOP_HZ},
                             "headroom_20hz": 1000 / LOOP_HZ[0] / p99})
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "latency.csv", "w", newline="") as f:
            w = csv.DictWriter(f, COLUMNS)
            w.writeheader()
            w.writerows(rows)
        (out / "latency.md").write_text(latency_table(rows))
    return rows


def latency_table(rows: list[dict]) -> str:
    """The rows as a Markdown table: the whole pilot's median, p99 and frames/s, the model's median, and the
    verdict for a 20 Hz and a 10 Hz loop."""
    lines = ["| model | runtime | frame | threads | pilot median [ms] | pilot p99 [ms] | frames/s | model median [ms] "
             "| fits 20 Hz (50 ms) | headroom at 20 Hz | fits 10 Hz |", "|---" * 11 + "|"]
    for r in rows:
        model = r["model"] if r["source"] == "untrained" else f"{r['model']} ({Path(r['source']).name})"
        lines.append(f"| {model} | {r['runtime']} | {r['width']}x{r['height']} | {r['threads']} | "
                     f"{r['pilot_median_ms']:.2f} | {r['pilot_p99_ms']:.2f} | {r['pilot_fps']:.0f} | "
                     f"{r['model_median_ms']:.2f} | {'yes' if r['fits_20hz'] else 'no'} | "
                     f"x{r['headroom_20hz']:.1f} | {'yes' if r['fits_10hz'] else 'no'} |")
    return "\n".join(lines) + "\n"
