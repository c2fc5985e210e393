"""What the timings of benchmarks/ share. Every timing is a module of this package, run from the repository root
(`python -m benchmarks.bench_render`; `make bench` runs them all).

- Where things are: `ROOT`, `SHARED` (the real recordings of ../shared/data), `CH2`, `need_ch2`,
  `record_race_tubs`.
- Timing: `machine` (what every result is measured on; the studies print the same line), `timed`,
  `median_seconds`, `per_second`, `each_ms`.
- A timing's command line, `arguments` (typed as the steerlab command's, with `--json`), and its report, `Report`,
  the numbers it prints as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from steerlab.cli import path_option, script_parser
from steerlab.errors import DataError
from steerlab.files import json_text, plain
from studies.common import ROOT, SHARED, machine, track_tub

CH2 = SHARED / "udacity-ch2"


def need_ch2() -> None:
    if not (CH2 / "CH2_final_evaluation.csv").exists():
        print(f"skipped: {CH2} not found (the benchmark uses the real CH2 frames)")
        sys.exit(0)


def record_race_tubs(config: Path) -> list[Path]:
    """The tubs a track config (configs/track_best.yaml) trains on, its `data` then its `extra_data`, each recorded
    as its header says where it is missing: a folder named <style>-<seed>-<minutes>min is `steerlab sim record
    --world track --style <style> --seed <seed> --minutes <minutes>`."""
    from steerlab.files import read_yaml

    cfg = read_yaml(config)
    tubs = [ROOT / t for t in [cfg["data"], *cfg.get("extra_data", [])]]
    for tub in tubs:
        style, seed, minutes = tub.name.removesuffix("min").split("-")
        track_tub(tub, "--style", style, "--seed", seed, "--minutes", minutes)
    return tubs


# timing

def timed(fn) -> float:
    """Seconds that one call of `fn` takes."""
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def median_seconds(fn, runs: int = 5, warmup: int = 1) -> float:
    """The median seconds of `runs` calls of `fn` after `warmup` calls that are not counted (they fill the page
    cache, pick oneDNN's kernels, import lazily). The median, since other work on the machine only ever makes a
    call slower."""
    for _ in range(warmup):
        fn()
    return statistics.median(timed(fn) for _ in range(runs))


def per_second(fn, count: int, runs: int = 5, warmup: int = 1) -> float:
    """How many things a second (frames/s) a call of `fn` that handles `count` of them gets through: `count` over
    `median_seconds`."""
    return count / median_seconds(fn, runs, warmup)


def each_ms(fn, items) -> tuple[np.ndarray, list]:
    """Milliseconds of `fn(item)` for each item in turn (the latency of each frame, not their median) and what
    each call returned."""
    ms, out = [], []
    for item in items:
        t = time.perf_counter()
        out.append(fn(item))
        ms.append(1000 * (time.perf_counter() - t))
    return np.array(ms), out


# a timing's report

def arguments(module: str, doc: str, *classes: type) -> argparse.ArgumentParser:
    """The command line of the timing `module` (`steerlab.cli.script_parser`: its docstring as the help, the typed
    options of `classes`) with `--json PATH`, where `Report` writes."""
    p = script_parser(module, doc, *classes)
    path_option(p, "--json", kind="new-file", metavar="PATH", help="where to write the results as JSON (default: "
                "runs/benchmarks/<script>.json)")
    return p


class Report:
    """A timing's results as JSON, beside the prose it prints: the machine line, the commit measured, the load
    average at the start and at the end (above the number of cores, other work shared them), the settings, and
    every number measured and every ratio, under names (`add`). `write()` writes them to `path`, by default
    runs/benchmarks/<script>.json: a .json file, new or an earlier report (never another file written over)."""

    def __init__(self, script: str, settings: dict, path: str | Path | None = None):
        name = Path(script).stem
        self.path = Path(path) if path else ROOT / "runs" / "benchmarks" / f"{name}.json"
        _a_report(self.path)
        self.data = {"script": name, "machine": machine(), "commit": _commit(),
                     "load_average": {"start": os.getloadavg()[0]}, "settings": plain(settings), "results": {}}

    def add(self, name: str, **numbers) -> None:
        """Numbers under `name`, e.g. `add("country", render_fps=1051.0, decode_fps=700.0, render_vs_decode=1.5)`;
        a number that is not finite (not measured) is written as null."""
        self.data["results"].setdefault(name, {}).update(plain(numbers))

    def write(self) -> Path:
        self.data["load_average"]["end"] = os.getloadavg()[0]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.path.write_text(json_text(self.data, indent=1) + "\n")
        print(f"wrote {self.path}")
        return self.path


def _a_report(path: Path) -> None:
    """A one-line error, before any timing, when `path` is not a .json file or exists and is not a timing's report."""
    if path.suffix != ".json":
        raise DataError(path, "a .json file is expected for the report (--json): give a name ending in .json")
    if path.is_file():
        try:
            earlier = json.loads(path.read_text())
        except (OSError, ValueError):
            earlier = None
        if not (isinstance(earlier, dict) and "script" in earlier and "results" in earlier):
            raise DataError(path, "exists and is not a timing's report: give a new name for the report (--json)")


def _commit() -> str | None:
    """The commit of the checkout (with -dirty for uncommitted changes), None outside git."""
    try:
        done = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True,
                              text=True)
    except OSError:
        return None
    return done.stdout.strip() or None
