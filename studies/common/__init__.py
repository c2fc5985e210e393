"""What the studies share (each study is a module of this package, run from the repository root as
`python -m studies.NAME`; a study imports steerlab and this package, never another study nor the tests).

- Here: where things are, `ROOT`, `SHARED` (the real recordings of ../shared/data), `track_tub`, `track_tubs`; a
  study's command line is typed as the steerlab command's (`steerlab.cli.script_parser`), and `NumberList` is the
  check of an option that takes a comma list of numbers (`--seeds 0,1`); the machine a result is measured on,
  `machine`, and a study's start, `begin_study` (the timings of benchmarks/ print the same machine line); a result
  over runs, `spread`, `mean_min_max`.
- `common.donkeycar`: donkeycar's own environment, in which the studies run donkeycar's trainer and parts
  (steerlab never imports donkeycar), and donkeycar's trainer on the shared tubs.
- `common.truth`: replay against the truth of a world's suite (`studies/replay_vs_road_suite.py`,
  `studies/replay_vs_track_suite.py`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.locks import waiting_lock
from steerlab.options import Range

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"


def track_tub(out: Path, *args: str) -> Path:
    """The tub `steerlab sim record --world track ARGS --out OUT` writes, recorded where it is missing (an
    interrupted recording leaves no folder behind, so a rerun records it again); one that fails ends the study in
    one line, after the command's own message."""
    if not (out / "manifest.json").exists():
        command = ["sim", "record", "--world", "track", *args, "--out", str(out)]
        done = subprocess.run([sys.executable, "-m", "steerlab", *command])
        if done.returncode:
            raise SteerlabError(f"steerlab {' '.join(command)} failed (exit status {done.returncode}; its message is "
                                "above): fix what it says, then run the study again")
    return out


def track_tubs() -> list[Path]:
    """The racing expert's tubs of the track world that configs/track_*.yaml train on (tracks 1-4, 3 minutes
    each, in runs/track), recorded first where they are missing."""
    return [track_tub(ROOT / "runs" / "track" / f"tub-{seed}", "--seed", str(seed), "--minutes", "3")
            for seed in (1, 2, 3, 4)]


@dataclass(frozen=True)
class NumberList:
    """The check of an option that takes a comma list of numbers (`--seeds 0,1`, `--caps 1,0.5`): each of `kind`
    inside `range`, none twice; `of(text)` gives them."""

    kind: type
    range: Range

    def of(self, text: str) -> list:
        values = [self.kind(v) for v in text.split(",")]
        if not values or len(set(values)) < len(values) or not all(map(self.range, values)):
            raise ValueError(text)
        return values

    def __call__(self, text: str) -> bool:
        try:
            return bool(self.of(text))
        except (ValueError, TypeError):
            return False

    @property
    def words(self) -> str:
        each = self.range.words(self.kind).replace("a number", "numbers").replace("an integer", "integers")
        return f"a comma list of {each}, each once"


@dataclass(frozen=True)
class Grid(NumberList):
    """A NumberList that may be empty (no grid) and, given, holds `needs` (`--scales 1,1.2,1.5`: x 1 is the rule's
    reference); `of("")` is []."""

    needs: float = 1.0

    def of(self, text: str) -> list:
        values = super().of(text) if text else []
        if values and self.needs not in values:
            raise ValueError(text)
        return values

    def __call__(self, text: str) -> bool:
        return text == "" or super().__call__(text)

    @property
    def words(self) -> str:
        return f"empty or {super().words}, {self.needs:g} among them"


def machine() -> str:
    """The machine a result is measured on: the processor and its instruction sets, the kernels torch dispatches to
    (with oneDNN's limit where ONEDNN_MAX_CPU_ISA sets one), torch's threads and version (or that torch is not
    installed, as on a Raspberry Pi that runs ONNX models only)."""
    from steerlab.cpu import instruction_sets, model_name

    try:
        import torch
    except ImportError:
        return f"{model_name()} ({instruction_sets()}), no torch"
    limit = os.environ.get("ONEDNN_MAX_CPU_ISA")
    kernels = torch.backends.cpu.get_cpu_capability() + (f", oneDNN up to {limit}" if limit else "")
    threads = torch.get_num_threads()
    return (f"{model_name()} ({instruction_sets()}; torch's kernels {kernels}), {threads} torch "
            f"thread{'s' * (threads != 1)}, torch {torch.__version__}")


# a study's start

def begin_study(out: Path, workers: int) -> tuple[float, float]:
    """A study's start: one torch thread a process (its drives run `workers` at a time), `out` made, the machine
    said; returns the wall and CPU clocks to say its cost at the end."""
    import torch

    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    print(f"machine: {machine()}; workers {workers}", flush=True)
    return time.time(), time.process_time()


def keep_result(file: Path, key: str, value: dict) -> dict:
    """Write one finished run into a study's results file and return all the runs it holds: read, updated and
    replaced under a lock, so studies run at once (on other tubs, one a core) into one file lose none of each
    other's runs, and a killed study never leaves half a file."""
    with waiting_lock(file.with_name(file.name + ".lock")):
        results = json.loads(file.read_text()) if file.exists() else {}
        results[key] = value
        tmp = file.with_name(file.name + f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(results, indent=1))
        os.replace(tmp, file)
    return results


def spread(values: list[float], digits: int = 4) -> str:
    """Mean and, over more than one run, the spread (the sample standard deviation)."""
    if not values:
        return "-"
    mean = f"{np.mean(values):.{digits}f}"
    return mean if len(values) == 1 else f"{mean} +- {np.std(values, ddof=1):.{digits}f}"


def mean_of(values: list) -> float | None:
    """The mean of the values that are not None (a run without one); None without any."""
    got = [v for v in values if v is not None]
    return float(np.mean(got)) if got else None


def mean_min_max(values: list, fmt: str) -> str:
    """The mean of the values given (None: a run without one) and, over more than one, their min-max: "0.90
    (0.85-0.95)"; "-" without any."""
    got = [v for v in values if v is not None]
    if not got:
        return "-"
    return format(mean_of(got), fmt) + (f" ({min(got):{fmt}}-{max(got):{fmt}})" if len(got) > 1 else "")


