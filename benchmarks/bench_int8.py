"""int8 on every CPU: each quantization scheme of steerlab.export.INT8_SCHEMES against the fp32 export, on the cases
tests/pilot/test_int8.py checks (PilotNet trained an epoch on a road-world recording, an untrained LSTM over a segment
start, every registered model with a convolution, untrained, on 64x64 frames where it takes a size) and donkeycar's
linear model on track-world frames; each case written as files (fp32.onnx, <scheme>.onnx, feeds.npz: the inputs
the Pilot fed the fp32 graph) and measured by benchmarks/int8_kernels.py, which runs on any CPU with ONNX Runtime
and no torch, or under emulation (its docstring):

python -m benchmarks.bench_int8 [--out runs/benchmarks/int8] [--json PATH]
qemu-x86_64 -cpu Haswell .venv/bin/python -m benchmarks.int8_kernels runs/benchmarks/int8 --cpu "AVX2 (qemu Haswell)"

Target: every scheme's steering within one bound of fp32 on every CPU; the shipped scheme (INT8_SCHEME) the same
on every CPU (no 16-bit saturation), its int8 frames a second on this CPU beside fp32's.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from benchmarks.common import ROOT, Report, arguments, machine
from benchmarks.int8_kernels import measure

from steerlab.cli import path_option, run_script
from steerlab.data.readers import open_recording
from steerlab.errors import DataError
from steerlab.export import INT8_SCHEMES, calibration_inputs, export_onnx, quantize_int8
from steerlab.models import list_models, model_class

SIZE = {"width": 64, "height": 64}


def parser():
    p = arguments(__spec__.name, __doc__)
    path_option(p, "--out", kind="folder", default=str(ROOT / "runs" / "benchmarks" / "int8"),
                help="where the cases are written (made anew)")
    return p


def recordings(folder: Path) -> dict[str, Path]:
    """The recordings the tests use: the road world's seed 3 for 15 s (tests/conftest.py's tiny_recording), and a
    track-world tub of as long for donkeycar's camera."""
    from steerlab.sim.road.run import record
    from steerlab.sim.road.world import RecordOptions
    from steerlab.sim.track.run import record as record_tub
    from steerlab.sim.track.world import TrackRecordOptions

    road, track = folder / "road", folder / "track"
    record(road, RecordOptions(seed=3, minutes=0.25), progress=False)
    record_tub(track, TrackRecordOptions(seed=1, minutes=0.25), progress=False)
    return {"road": road, "track": track}


def trained_pilotnet(folder: Path, rec: Path) -> Path:
    """tests/conftest.py's tiny_checkpoint: PilotNet trained one epoch on the road recording's frames 0:240."""
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    train(load_config(None, base={"data": str(rec), "cache": str(folder / "cache"), "out": str(folder / "run"),
                                  "split": {"train": "0:240", "val": "240:300"},
                                  "train": {"epochs": 1, "batch_size": 32}}), progress=False)
    return folder / "run" / "best.pt"


def untrained(path: Path, name: str, geometry: str = "sim", size: dict | None = None) -> Path:
    """tests/pilot/samples.py's untrained checkpoint: `name` with seed 0's random weights, mean 100 and
    standard deviation 50 on every channel, on frames of `size` (default: the geometry's)."""
    import torch

    from steerlab.checkpoint import save_checkpoint
    from steerlab.data.preprocess import PreprocessOptions
    from steerlab.data.recording import SteeringConvention
    from steerlab.models import create_model
    from steerlab.models.registry import ModelSpec

    pre = ModelSpec(name, {}).preprocess(PreprocessOptions(preset=geometry, **(size or {}))).resolve()
    c = sum(pre.channels().values())
    cfg = {"in_channels": c, "height": pre.height, "width": pre.width}
    torch.manual_seed(0)
    save_checkpoint(path, create_model(name, **cfg), cfg, pre, {"mean": [100.0] * c, "std": [50.0] * c},
                    SteeringConvention(), {"rmse": 0.1}, geometry=geometry, frame_rate=20.0)
    return path


def write_case(out: Path, ckpt: Path, rec: Path, calib: str | None, scored: list[str]) -> None:
    """A case: the fp32 export, one int8 export a scheme calibrated on `calib`, and the fp32 graph's inputs on the
    recording's frames `scored` (ranges, each a segment from a zero state)."""
    out.mkdir(parents=True)
    fp32 = export_onnx(ckpt, out / "fp32.onnx")
    calib_rec = open_recording(rec, calib)
    for scheme in INT8_SCHEMES:
        data, _ = quantize_int8(fp32.read_bytes(), calib_rec, calib, scheme)
        (out / f"{scheme}.onnx").write_bytes(data)
    feeds = []
    for block in scored:
        part = open_recording(rec, block)
        feeds += calibration_inputs(fp32, part, len(part))
    np.savez(out / "feeds.npz", **{k: np.stack([f[k] for f in feeds]) for k in feeds[0]})


def main(args) -> None:
    args.out = Path(args.out)
    mark = args.out / ".bench_int8"
    if args.out.is_dir() and any(args.out.iterdir()) and not mark.exists():
        raise DataError(args.out, "exists and is not python -m benchmarks.bench_int8's folder: give a new --out")
    report = Report(__file__, {"out": str(args.out), "schemes": list(INT8_SCHEMES)}, args.json)
    print(f"machine: {machine()}; int8 schemes {', '.join(INT8_SCHEMES)}")
    shutil.rmtree(args.out, ignore_errors=True)  # an earlier run's cases, made anew
    args.out.mkdir(parents=True)
    mark.touch()
    work = args.out / "work"
    work.mkdir(parents=True)
    rec = recordings(work)
    write_case(args.out / "pilotnet-trained", trained_pilotnet(work / "pilotnet", rec["road"]), rec["road"],
               "0:240", ["240:300"])
    write_case(args.out / "lstm-untrained", untrained(work / "lstm.pt", "lstm"), rec["road"], None,
               ["0:30", "30:60"])
    write_case(args.out / "donkey-linear-track", untrained(work / "donkey.pt", "donkey-linear",
                                                                     "donkey"), rec["track"], "0:240", ["240:300"])
    for name in list_models():
        if name in ("zero", "train-mean"):
            continue  # nothing to quantize (refused: tests/pilot/test_int8.py)
        size = {} if "width" in model_class(name).inputs else SIZE
        write_case(args.out / name, untrained(work / f"{name}.pt", name, "sim", size), rec["road"], "0:8", ["0:8"])
    shutil.rmtree(work)
    for row in measure(args.out):
        report.add(f"{row['case']} {row['scheme']}", **{k: v for k, v in row.items() if k not in ("case", "scheme")})
    report.write()


if __name__ == "__main__":
    run_script(parser(), main)
