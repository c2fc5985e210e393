"""What a checkpoint's seal costs: steerlab's save and load of a training run's last.pt (a 200x66 PilotNet with its
Adam state) against torch.save and torch.load of the same contents alone, median of 15 each.

python benchmarks/bench_checkpoint.py
"""

import statistics
import tempfile
import time
from pathlib import Path

import torch
from _common import machine

from steerlab.checkpoint import load_checkpoint, save_checkpoint
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.models.registry import create_model


def median_ms(fn, runs: int = 15) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


def main() -> None:
    torch.manual_seed(0)
    model = create_model("pilotnet")
    opt = torch.optim.Adam(model.parameters(), fused=True)
    model(torch.zeros(2, 1, 66, 200))["steering"].sum().backward()
    opt.step()  # the optimiser's state, as last.pt holds it
    folder = Path(tempfile.mkdtemp())
    sealed, plain = folder / "last.pt", folder / "plain.pt"

    def save():
        save_checkpoint(sealed, model, {}, PreprocessConfig(), {"mean": [0.0], "std": [1.0]}, SteeringConvention(),
                        {"rmse": 0.1}, optimizer=opt.state_dict(), epoch=1)

    save()
    contents = torch.load(sealed, weights_only=True)
    torch.save(contents, plain)
    s, s0 = median_ms(save), median_ms(lambda: torch.save(contents, plain))
    load, load0 = median_ms(lambda: load_checkpoint(sealed)), median_ms(lambda: torch.load(plain, weights_only=True))
    print(f"machine: {machine()}; last.pt of a 200x66 PilotNet with its Adam state, {sealed.stat().st_size / 1e6:.1f} MB")
    print(f"save: {s:5.0f} ms sealed   (torch.save alone {s0:4.0f} ms; x{s / s0:.2f})")
    print(f"load: {load:5.0f} ms checked  (torch.load alone {load0:4.0f} ms; x{load / load0:.2f})")


if __name__ == "__main__":
    main()
