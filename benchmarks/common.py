"""What the timings of benchmarks/ and the experiments of studies/ share. Every script runs from the repository root
(`python benchmarks/bench_render.py`, `python studies/speed_estimate.py`); a study finds this module by putting
benchmarks/ on sys.path in its first lines.

- Where things are: `ROOT`, `SHARED` (the real recordings of ../shared/data), `CH2`, `need_ch2`, `track_tubs`,
  `record_race_tubs`.
- Timing: `machine` (what every result is measured on), `timed`, `median_seconds`, `per_second`, `each_ms`; a
  study's start, `begin_study`.
- A timing's report: `arguments` (its command line, with `--json`) and `Report`, the numbers it prints as JSON.
- donkeycar's own environment, in which the studies run donkeycar's trainer and parts (steerlab never imports
  donkeycar): `donkey_python`, `donkey_car`, and `DonkeycarPart`, donkeycar's pilot part behind a pipe.
- Replay against the truth of a world's suite (`studies/replay_vs_road_suite.py`, `studies/replay_vs_track_suite.py`):
  `record_expert`, `train_baseline`, `train_snapshots`, `replayed`, `replay_missing`, `r2`, `correlations`,
  `correlation_table`, `scatter_axes`, `write_table`.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import torch

from steerlab.files import json_text, plain

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"
CH2 = SHARED / "udacity-ch2"


def need_ch2() -> None:
    if not (CH2 / "CH2_final_evaluation.csv").exists():
        print(f"skipped: {CH2} not found (the benchmark uses the real CH2 frames)")
        sys.exit(0)


def track_tubs() -> list[Path]:
    """The racing expert's tubs of the track world that configs/track_*.yaml train on (tracks 1-4, 3 minutes
    each, in runs/track), recorded first where they are missing."""
    tubs = [ROOT / "runs" / "track" / f"tub-{seed}" for seed in (1, 2, 3, 4)]
    for seed, tub in enumerate(tubs, 1):
        if not (tub / "manifest.json").exists():
            subprocess.run([sys.executable, "-m", "steerlab", "sim", "record", "--world", "track", "--seed", str(seed),
                            "--minutes", "3", "--out", str(tub)], check=True)
    return tubs


def record_race_tubs(config: Path) -> list[Path]:
    """The tubs a track config (configs/track_best.yaml) trains on, its `data` then its `extra_data`, each recorded
    as its header says where it is missing: a folder named <style>-<seed>-<minutes>min is `steerlab sim record
    --world track --style <style> --seed <seed> --minutes <minutes>`."""
    from steerlab.files import read_yaml

    cfg = read_yaml(config)
    tubs = [ROOT / t for t in [cfg["data"], *cfg.get("extra_data", [])]]
    for tub in tubs:
        if not (tub / "manifest.json").exists():
            style, seed, minutes = tub.name.removesuffix("min").split("-")
            subprocess.run([sys.executable, "-m", "steerlab", "sim", "record", "--world", "track", "--style", style,
                            "--seed", seed, "--minutes", minutes, "--out", str(tub)], check=True)
    return tubs


def machine() -> str:
    return (f"{platform.processor() or platform.machine()}, {torch.get_num_threads()} torch threads, "
            f"torch {torch.__version__}")


# timing

def begin_study(out: Path, workers: int) -> tuple[float, float]:
    """A study's start: one torch thread a process (its drives run `workers` at a time), `out` made, the machine
    said; returns the wall and CPU clocks to say its cost at the end."""
    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    print(f"machine: {machine()}; workers {workers}", flush=True)
    return time.time(), time.process_time()


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

# a script's command line: bad arguments refused before any work, in one line, as the steerlab command does

def guarded(main) -> None:
    """`main()` of a script: what it meets of bad input ends in one line (`error: ...`, exit code 2) as the steerlab
    command's does: a SteerlabError, an OSError, a steerlab command it ran that failed (which said why above it),
    Ctrl-C."""
    from steerlab.errors import SteerlabError
    from steerlab.paths import os_error

    try:
        main()
    except SteerlabError as e:
        sys.exit(f"error: {e}")
    except OSError as e:
        sys.exit(f"error: {os_error(e)}")
    except subprocess.CalledProcessError as e:
        cmd = [Path(str(c)).name if i == 0 else str(c) for i, c in enumerate(e.cmd)]
        sys.exit(f"error: {' '.join(cmd)[:160]} ended with exit code {e.returncode} (its message is above)")
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)


def checked(kind: type, check):
    """An argparse type: a `kind` (int or float) that `check` (a steerlab.options.Range) takes."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = None
        if value is None or not check(value):
            raise argparse.ArgumentTypeError(f"must be {check.words(kind)}, got {text!r}")
        return value
    parse.__name__ = kind.__name__
    return parse


def _ranges():
    from steerlab.options import AT_LEAST_1, SEED, SPEED, WORKERS, Range

    return {"count": checked(int, AT_LEAST_1), "seed": checked(int, SEED), "workers": checked(int, WORKERS),
            "minutes": checked(float, Range(0, 1440, lo_open=True, unit="min")), "speed": checked(float, SPEED),
            "positive": checked(float, Range(0, lo_open=True))}


ARG = _ranges()  # the argument types of the scripts: ARG["count"] (at least 1), "minutes", "workers", ...


def existing(what: str):
    """An argparse type: the path of an existing file or folder (`what` it must be, in the message)."""
    def parse(text: str) -> Path:
        if not Path(text).exists():
            raise argparse.ArgumentTypeError(f"{text}: {what} not found")
        return Path(text)
    return parse


def output_folder(text: str) -> Path:
    """An argparse type: a study's output folder, checked as every steerlab command's output (not a file, not a
    recording, a run or another's folder, writable)."""
    from steerlab.errors import SteerlabError
    from steerlab.paths import check_outputs

    try:
        check_outputs({"output folder (--out)": text})
    except SteerlabError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return Path(text)


def json_output(text: str) -> Path:
    """An argparse type: where a timing writes its report: a .json file that is not a folder and, when it exists,
    an earlier report (a JSON object with "script"), never another file."""
    path = Path(text)
    if path.suffix != ".json" or path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: a .json file is expected (the report)")
    if path.exists():
        try:
            earlier = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, ValueError):
            earlier = None
        if not isinstance(earlier, dict) or "script" not in earlier:
            raise argparse.ArgumentTypeError(f"{text}: exists and is not a timing's report; writing it would destroy "
                                             "it: name another file")
    return path


def one_of(choices, what: str):
    """An argparse type: a comma list of names of `choices`, each once."""
    def parse(text: str) -> list[str]:
        names = text.split(",")
        wrong = [n for n in names if n not in choices]
        if wrong or len(set(names)) < len(names) or not text:
            raise argparse.ArgumentTypeError(f"must be a comma list of {what} of {', '.join(choices)}, each once, "
                                             f"got {text!r}")
        return names
    return parse


def comma(kind: type, name: str):
    """An argparse type: a comma list of `name`s (seed: integers in [0, 4294967295]; cap: numbers in (0, 1]),
    checked and kept as text."""
    from steerlab.options import SEED, Range

    check = {"seed": SEED, "cap": Range(0, 1, lo_open=True)}[name]
    one = checked(kind, check)

    def parse(text: str) -> str:
        try:
            for item in text.split(","):
                one(item)
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(f"must be a comma list of {name}s, each {check.words(kind)}, got "
                                             f"{text!r}") from None
        return text
    return parse


def arguments(doc: str) -> argparse.ArgumentParser:
    """A timing's command line: its docstring as the help, and `--json PATH` (where `Report` writes)."""
    p = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", metavar="PATH", type=json_output, help="where to write the results as JSON (default: "
                   "runs/benchmarks/<script>.json)")
    return p


class Report:
    """A timing's results as JSON, beside the prose it prints: the machine line, the commit measured, the load
    average at the start and at the end (above the number of cores, other work shared them), the settings, and
    every number measured and every ratio, under names (`add`). `write()` writes them to `path`, by default
    runs/benchmarks/<script>.json."""

    def __init__(self, script: str, settings: dict, path: str | Path | None = None):
        name = Path(script).stem
        self.path = Path(path) if path else ROOT / "runs" / "benchmarks" / f"{name}.json"
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


def _commit() -> str | None:
    """The commit of the checkout (with -dirty for uncommitted changes), None outside git."""
    try:
        done = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True,
                              text=True)
    except OSError:
        return None
    return done.stdout.strip() or None


# donkeycar's own environment

DONKEY_VENV = Path(os.environ.get("DONKEY_VENV", ROOT / "runs" / "donkeycar-venv"))
DONKEY = "donkeycar[pc]==5.3.0"  # 5.4 needs Python >= 3.12


def donkey_python() -> Path:
    """The python of donkeycar's virtual environment ($DONKEY_VENV, default runs/donkeycar-venv), made with
    `pip install donkeycar[pc]` on first use."""
    python = DONKEY_VENV / "bin" / "python"
    if not python.exists():
        print(f"creating {DONKEY_VENV} with {DONKEY} (once)", flush=True)
        subprocess.run([sys.executable, "-m", "venv", str(DONKEY_VENV)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", DONKEY], check=True)
    return python


def donkey_car(python: Path, car: Path) -> Path:
    """A donkeycar car folder (`donkey createcar`, made once) whose config trains without plots and saves .h5
    models, as `donkey train` and donkeycar's parts read them."""
    if not car.exists():
        subprocess.run([str(python.parent / "donkey"), "createcar", "--path", str(car)], check=True,
                       stdout=subprocess.DEVNULL)
        with open(car / "myconfig.py", "a") as f:
            f.write("\nSHOW_PLOT = False\nCREATE_TF_LITE = False\nSAVE_MODEL_AS_H5 = True\n")
    return car


class DonkeycarPart:
    """donkeycar's own pilot part for a model of `kind` trained by `donkey train`, run in donkeycar's environment:
    `run(img_arr)` sends the frame down a pipe and returns the part's (angle, throttle), the throttle times
    `throttle_scale` (as donkeycar's AI_THROTTLE_MULT, but before the cap) and capped."""

    def __init__(self, python: Path, car: Path, model: Path, log: Path, max_throttle: float,
                 throttle_scale: float = 1.0, kind: str = "linear"):
        self.log, self.max_throttle, self.throttle_scale = log, max_throttle, throttle_scale
        self.stderr = open(log, "wb")
        self.process = subprocess.Popen([str(python), str(ROOT / "studies" / "_donkey_part.py"),
                                         str(car / "config.py"), str(model), kind], cwd=car,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.stderr)
        if self.process.stdout.readline() != b"ready\n":
            raise RuntimeError(f"donkeycar's part did not start; see {log}")

    def run(self, img_arr: np.ndarray):
        self.process.stdin.write(np.ascontiguousarray(img_arr, np.uint8).tobytes())
        self.process.stdin.flush()
        answer = self.process.stdout.read(16)
        if len(answer) != 16:
            raise RuntimeError(f"donkeycar's part stopped; see {self.log}")
        angle, throttle = (float(v) for v in np.frombuffer(answer, np.float64))
        return angle, float(np.clip(self.throttle_scale * throttle, -self.max_throttle, self.max_throttle))

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()
        self.stderr.close()


# replay against the truth of a world's suite

def record_expert(world: str, out: Path, minutes: float) -> dict[tuple[str, int], Path]:
    """The expert on every place of the default suite of `world` ("road": its roads, "track": its tracks), for
    `minutes` each, recorded for evaluation: the suite's own road or track, as the suite's drives for those
    minutes see it (`record_options` of the world's suite options, `record(..., suite_ok=True)`), into
    out/expert/<kind>-<seed>. A recording of the same minutes is reused; one of other minutes is recorded anew, and
    its replays (out/replay/<kind>-<seed>) are deleted."""
    from steerlab.sim.worlds import WORLDS

    w = WORLDS[world]
    suite = w.suite_options(minutes=minutes)
    recs = {}
    for kind, seed in suite.drives():
        folder = out / "expert" / f"{kind}-{seed}"
        stamp = folder / "minutes.json"
        if not (stamp.exists() and json.loads(stamp.read_text())["minutes"] == minutes):
            shutil.rmtree(folder, ignore_errors=True)
            shutil.rmtree(out / "replay" / folder.name, ignore_errors=True)
            t0 = time.time()
            w.record(folder, suite.record_options(kind, seed), progress=False, suite_ok=True)
            stamp.write_text(json.dumps({"minutes": minutes}))
            print(f"recorded the expert on {kind}-{seed} ({minutes:g} min) in {time.time() - t0:.0f} s", flush=True)
        recs[(kind, seed)] = folder
    return recs


def train_baseline(name: str, config, folder: Path) -> Path:
    """A baseline model (zero, train-mean) trained by `config` (a `TrainConfig`) and its best.pt copied to
    folder/<name>.pt; reused when there."""
    from steerlab.train.loop import train

    target = folder / f"{name}.pt"
    if not target.exists():
        folder.mkdir(parents=True, exist_ok=True)
        train(config, progress=False)
        shutil.copy(Path(config.out) / "best.pt", target)
    return target


def train_snapshots(name: str, config, keep: list[int], folder: Path) -> list[Path]:
    """Checkpoints of one training run at several stages: `config` (a `TrainConfig` of max(keep) epochs) trained
    once, the weights after each epoch of `keep` copied to folder/<name>-e<epoch>.pt; reused when all are there.
    A run interrupted between two snapshots resumes; one that cannot give a missing snapshot any more ends the
    study with the folder to delete."""
    from steerlab.train.loop import train

    targets = {e: folder / f"{name}-e{e}.pt" for e in keep}
    if all(t.exists() for t in targets.values()):
        return list(targets.values())
    folder.mkdir(parents=True, exist_ok=True)
    run, t0 = Path(config.out), time.time()

    def on_epoch(epoch, metrics):
        print(f"  {name} epoch {epoch}: val rmse {metrics['rmse']:.4f} ({time.time() - t0:.0f} s)", flush=True)
        if epoch in targets:
            shutil.copy(run / "last.pt", targets[epoch])

    train(config, progress=False, on_epoch=on_epoch)
    if not targets[max(keep)].exists():  # the run had already finished its epochs before it was stopped
        shutil.copy(run / "last.pt", targets[max(keep)])
    missing = [str(t) for t in targets.values() if not t.exists()]
    if missing:
        sys.exit(f"{name}: the snapshots {', '.join(missing)} are missing; delete {run} to train it again")
    print(f"trained {name} ({max(keep)} epochs) in {time.time() - t0:.0f} s", flush=True)
    return list(targets.values())


def replayed(where: Path) -> dict[str, dict]:
    """The rows of every replay.csv in the sub-folders of `where`, by checkpoint label."""
    rows = {}
    for f in sorted(where.glob("*/replay.csv")):
        with open(f, newline="") as table:
            rows.update({r["checkpoint"]: r for r in csv.DictReader(table)})
    return rows


def replay_missing(ckpts: list[Path], labels: list[str], source, where: Path, options, what: str) -> dict[str, dict]:
    """Replay on the recording of `source` (a `Source`) with `options` (a world's replay options) the checkpoints
    whose label is not replayed in `where` yet, together, into a new numbered sub-folder of `where` (so that a
    later run with more checkpoints adds a batch); `what` names the recording in the line printed. Returns
    `replayed(where)`."""
    from steerlab.sim.replay.run import run_replay

    done = replayed(where)
    missing = [c for c, label in zip(ckpts, labels) if label not in done]
    if missing:
        t0 = time.time()
        run_replay(missing, source, where / str(len(list(where.glob("*/replay.csv")))), options, progress=False)
        print(f"replayed {len(missing)} checkpoints on {what} in {time.time() - t0:.0f} s", flush=True)
    return replayed(where)


def r2(x, y) -> float:
    """The squared Pearson correlation (a straight line's fit); NaN for fewer than three points or a constant."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan")
    return float(np.corrcoef(x, y)[0, 1] ** 2)


def correlations(truth, replay) -> dict:
    """Spearman's rank correlation (tied values share their mean rank), R^2 and the number of points."""
    from steerlab.evaluate.plots import rank_correlation

    return {"spearman": rank_correlation(replay, truth), "r2": r2(replay, truth), "n": len(truth)}


def correlation_table(groups: dict[str, list[tuple[float, float]]], place: str, truth: str,
                      replay: str) -> list[str]:
    """A Markdown table of replay against truth in groups of places (a road type, a track style, "all"), one
    (truth, replay) pair per checkpoint and place: the pairs, Spearman, R^2 and the means. `place` names a place
    ("road"), `truth` and `replay` the two measures ("int/km")."""
    lines = [f"| {place}s | pairs (checkpoint x {place}) | Spearman | R^2 | true {truth} (mean) | "
             f"replay {replay} (mean) |", "|---|---|---|---|---|---|"]
    for group, pairs in groups.items():
        t, p = np.array(pairs, float).T
        c = correlations(t, p)
        lines.append(f"| {group} | {len(pairs)} | {c['spearman']:.3f} | {c['r2']:.3f} | {t.mean():.2f} | "
                     f"{p.mean():.2f} |")
    return lines


def scatter_axes(ax, labels: list[str], truth, replay, corr: dict, xlabel: str, ylabel: str, title: str = "",
                 fit: bool = False) -> None:
    """One panel of replay against truth: a point per checkpoint with its label, the correlations (`corr`) in the
    title after `title`, and the line y = x or, with `fit` (two measures of different scales), the least-squares
    line."""
    t, p = np.asarray(truth, float), np.asarray(replay, float)
    ax.scatter(t, p, s=25)
    for label, x, y in zip(labels, t, p):
        ax.annotate(label, (x, y), fontsize=6, alpha=0.8, xytext=(2, 2), textcoords="offset points")
    if fit:
        slope, icept = np.polyfit(t, p, 1) if np.ptp(t) > 0 else (0.0, float(p.mean()))
        xs = np.array([t.min(), t.max()])
        ax.plot(xs, slope * xs + icept, "k:", lw=0.8, label=f"fit: replay = {slope:.2f} x truth + {icept:.2f}")
        ax.legend(loc="upper left", fontsize=8)
    else:
        lo, hi = min(t.min(), p.min()), max(t.max(), p.max())
        pad = 0.05 * (hi - lo + 1e-9)
        ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k:", lw=0.8)
    ax.set_title(f"{title}Spearman {corr['spearman']:.2f}, R$^2$ {corr['r2']:.2f} ({corr['n']} checkpoints)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)


def write_table(path: Path, rows: list[dict]) -> None:
    """Rows of a study's results as CSV, floats to 6 significant digits."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows([{k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows])
