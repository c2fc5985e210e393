"""What closed-loop replay costs against an open-loop `steerlab evaluate` of the same frames (the baseline,
measured in the same run): CH2 frames 1800-2399 (30 s), one process, one torch thread, untrained weights (the cost
does not depend on them), for a single-frame model and a recurrent flow model. Both write their whole report
(CSV, plot).

python benchmarks/bench_replay.py [--json PATH]
Target: replay <= 1.5 x evaluate.
"""

import tempfile
from pathlib import Path

import torch
from bench_pilot import checkpoint
from common import CH2, Report, arguments, machine, need_ch2, guarded, timed

from steerlab.data.readers import Source
from steerlab.evaluate.offline import evaluate
from steerlab.sim.replay.run import ReplayOptions, run_replay

LABELS, RANGE = CH2 / "CH2_final_evaluation.csv", "1800:2400"
SOURCE, WARM = Source(str(CH2), RANGE, str(LABELS)), Source(str(CH2), "1800:1820", str(LABELS))


def main() -> None:
    args = arguments(__doc__).parse_args()
    need_ch2()
    report = Report(__file__, {"frames": RANGE, "torch_threads": 1, "replay_speed_mps": 15.0, "target": 1.5},
                    args.json)
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
            report.add(name, evaluate_s=ev, replay_s=rp, replay_vs_evaluate=rp / ev)
    report.write()


if __name__ == "__main__":
    guarded(main)
