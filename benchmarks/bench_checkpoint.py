"""What a checkpoint's seal costs: steerlab's save and load of a training run's last.pt (a 200x66 PilotNet with its
Adam state) against torch.save and torch.load of the same contents alone (the baseline, measured in the same run),
median of 15 each.

python benchmarks/bench_checkpoint.py [--json PATH]
"""

import tempfile
from pathlib import Path

import torch
from common import Report, arguments, machine, median_seconds, guarded

from steerlab.checkpoint import load_checkpoint, save_checkpoint
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.models.registry import create_model

RUNS = 15


def main() -> None:
    args = arguments(__doc__).parse_args()
    report = Report(__file__, {"model": "pilotnet 200x66 with its Adam state", "runs": RUNS}, args.json)
    torch.manual_seed(0)
    model = create_model("pilotnet")
    opt = torch.optim.Adam(model.parameters(), fused=True)
    model(torch.zeros(2, 1, 66, 200))["steering"].sum().backward()
    opt.step()  # the optimiser's state, as last.pt holds it
    with tempfile.TemporaryDirectory() as folder:
        sealed, plain = Path(folder) / "last.pt", Path(folder) / "plain.pt"

        def save():
            save_checkpoint(sealed, model, {}, PreprocessConfig(), {"mean": [0.0], "std": [1.0]},
                            SteeringConvention(), {"rmse": 0.1}, optimizer=opt.state_dict(), epoch=1)

        save()
        contents = torch.load(sealed, weights_only=True)
        torch.save(contents, plain)
        seconds = {"save": median_seconds(save, RUNS),
                   "torch_save": median_seconds(lambda: torch.save(contents, plain), RUNS),
                   "load": median_seconds(lambda: load_checkpoint(sealed), RUNS),
                   "torch_load": median_seconds(lambda: torch.load(plain, weights_only=True), RUNS)}
        mb = sealed.stat().st_size / 1e6
    ms = {k: 1000 * v for k, v in seconds.items()}
    print(f"machine: {machine()}; last.pt of a 200x66 PilotNet with its Adam state, {mb:.1f} MB")
    report.add("last.pt", megabytes=mb)
    for what, done, alone in (("save", "sealed", "torch.save"), ("load", "checked", "torch.load")):
        ratio = ms[what] / ms[f"torch_{what}"]
        print(f"{what}: {ms[what]:5.0f} ms {done:<7}  ({alone} alone {ms[f'torch_{what}']:4.0f} ms; x{ratio:.2f})")
        report.add(what, steerlab_ms=ms[what], torch_ms=ms[f"torch_{what}"], steerlab_vs_torch=ratio)
    report.write()


if __name__ == "__main__":
    guarded(main)
