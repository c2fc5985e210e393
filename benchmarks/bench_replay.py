"""What closed-loop replay costs against an open-loop `steerlab evaluate` of the same frames: CH2 frames
1800-2399 (30 s), one process, one torch thread, untrained weights (the cost does not depend on them), for a
single-frame model and a recurrent flow model. Both write their whole report (CSV, plot).

python benchmarks/bench_replay.py
Target: replay <= 1.5 x evaluate.
"""

import tempfile
import time
from pathlib import Path

import torch

from _common import CH2, machine, need_ch2
from bench_pilot import checkpoint

from steerlab.data.readers import Source
from steerlab.evaluate.offline import evaluate
from steerlab.sim.replay.run import ReplayOptions, run_replay

LABELS, RANGE = CH2 / "CH2_final_evaluation.csv", "1800:2400"
SOURCE, WARM = Source(str(CH2), RANGE, str(LABELS)), Source(str(CH2), "1800:1820", str(LABELS))


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def main() -> None:
    need_ch2()
    torch.set_num_threads(1)
    print(f"machine: {machine()}; CH2 frames {RANGE}")
    print("| model | evaluate [s] | replay [s] | replay / evaluate |\n|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, flow in (("pilotnet", "farneback"), ("flow-lstm", "dis")):
            ckpt = checkpoint(tmp, name, flow)
            evaluate(ckpt, WARM, tmp / "warm", progress=False)  # imports, first decode
            ev = timed(lambda: evaluate(ckpt, SOURCE, tmp / f"eval-{name}", progress=False))
            rp = timed(lambda: run_replay([ckpt], SOURCE, tmp / f"replay-{name}", ReplayOptions(speed=15.0, workers=1),
                                          progress=False))
            print(f"| {name} | {ev:.1f} | {rp:.1f} | {rp / ev:.2f} |")


if __name__ == "__main__":
    main()
