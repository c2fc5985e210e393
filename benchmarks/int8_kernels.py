"""int8 against fp32 on this CPU's kernels, from files alone: ONNX Runtime and NumPy, no torch, so that it runs on
another CPU, a Raspberry Pi with steerlab installed without torch, or under emulation (docs/results/latency.md,
"int8 on every CPU"):

python -m benchmarks.int8_kernels runs/benchmarks/int8 [--cpu NAME] [--json PATH]
qemu-x86_64 -cpu Haswell .venv/bin/python -m benchmarks.int8_kernels runs/benchmarks/int8 --cpu "AVX2 (qemu Haswell)"

The folder is what `python -m benchmarks.bench_int8` writes: a folder a case, each with `fp32.onnx`, one
`<scheme>.onnx` a quantization scheme and `feeds.npz`, the inputs the Pilot fed the fp32 graph frame by frame (a
recurrent model's state where it starts from zero marks a segment start: both graphs then start from zero, and
carry their own state otherwise). Prints, a case and scheme a line, the steering's largest and mean difference from
fp32 (rad) and the milliseconds a frame (one thread, the median of the frames after the first), and writes them as
JSON (by default to `<folder>/kernels-<cpu>.json`).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnxruntime as ort
from benchmarks.common import Report, arguments

from steerlab.cli import run_script
from steerlab.cpu import instruction_sets
from steerlab.errors import DataError
from steerlab.options import Options, option


def steering(path: Path, feeds: dict[str, np.ndarray]) -> tuple[np.ndarray, float]:
    """The model's steering on every frame of `feeds`, and its median milliseconds a frame on one thread."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    outputs = [o.name for o in session.get_outputs()]
    recurrent = "h" in feeds
    state, values, ms = None, [], []
    for i in range(len(feeds["x"])):
        feed = {k: v[i] for k, v in feeds.items()}
        if recurrent:
            if not (feed["h"].any() or feed["c"].any()):
                state = None  # a segment starts
            if state is not None:
                feed["h"], feed["c"] = state
        start = time.perf_counter()
        out = dict(zip(outputs, session.run(outputs, feed)))
        ms.append(1000 * (time.perf_counter() - start))
        if recurrent:
            state = out["h_out"], out["c_out"]
        values.append(float(out["steering"].ravel()[0]))
    return np.array(values), float(np.median(ms[1:] or ms))


def measure(folder: Path) -> list[dict]:
    """Every case of `folder`, each int8 scheme against fp32, a row each (printed as it is measured)."""
    rows = []
    for case in sorted(p for p in folder.iterdir() if (p / "feeds.npz").exists()):
        with np.load(case / "feeds.npz") as data:
            feeds = dict(data)
        reference, fp32_ms = steering(case / "fp32.onnx", feeds)
        for model in sorted(case.glob("*.onnx")):
            if model.stem == "fp32":
                continue
            values, ms = steering(model, feeds)
            error = np.abs(values - reference)
            row = {"case": case.name, "scheme": model.stem, "frames": len(values), "max_error": float(error.max()),
                   "mean_error": float(error.mean()), "fp32_ms": round(fp32_ms, 3), "int8_ms": round(ms, 3)}
            rows.append(row)
            print(f"{case.name:24} {model.stem:10} max {row['max_error']:.2e} mean {row['mean_error']:.2e} rad   "
                  f"fp32 {fp32_ms:7.3f} ms  int8 {ms:7.3f} ms", flush=True)
    return rows


@dataclass(frozen=True)
class Kernels(Options):
    cpu: str | None = option(None, help="what the CPU is, for the report (default: its instruction sets as Linux "
                             "reports them, which under user-mode emulation are the host's: name the emulated CPU)")


def parser():
    p = arguments(__spec__.name, __doc__, Kernels)
    p.add_argument("folder", help="the folder python -m benchmarks.bench_int8 wrote")
    return p


def main(a, args: Kernels) -> None:
    folder = Path(a.folder)
    if not folder.is_dir() or not any((p / "feeds.npz").exists() for p in folder.iterdir()):
        raise DataError(folder, "not a folder of cases (folders with feeds.npz): make it with python -m "
                        "benchmarks.bench_int8")
    cpu = args.cpu or instruction_sets()
    name = re.sub(r"[^A-Za-z0-9.-]+", "-", cpu).strip("-")
    report = Report(__file__, {"folder": str(folder), "cpu": cpu, "onnxruntime": ort.__version__},
                    a.json or folder / f"kernels-{name}.json")
    print(f"cpu: {cpu}; onnxruntime {ort.__version__}", flush=True)
    for row in measure(folder):
        report.add(f"{row['case']} {row['scheme']}", **{k: v for k, v in row.items() if k not in ("case", "scheme")})
    report.write()


if __name__ == "__main__":
    run_script(parser(), main)
