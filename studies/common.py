"""What the studies share (each study is a module of this package, run from the repository root as
`python -m studies.NAME`; a study imports steerlab and this module, never another study nor the tests).

- Where things are: `ROOT`, `SHARED` (the real recordings of ../shared/data), `track_tubs`.
- A study's command line is typed as the steerlab command's (`steerlab.cli.script_parser`); `NumberList` is the
  check of an option that takes a comma list of numbers (`--seeds 0,1`).
- The machine a result is measured on, `machine`, and a study's start, `begin_study` (the timings of benchmarks/
  print the same machine line).
- donkeycar's own environment, in which the studies run donkeycar's trainer and parts (steerlab never imports
  donkeycar): `donkey_python`, `donkey_car`, `donkey_models` (`donkey train`'s linear models), and
  `DonkeycarPart`, donkeycar's pilot part behind a pipe.
- donkeycar's trainer on the shared tubs (`studies/donkeycar_tubs.py`, `studies/tub_pretraining.py`): `TubStudy`,
  their options, `TUBS`, `READER`, `blocks`, `donkey_or_skip`, `run_donkey`, `spread`.
- Replay against the truth of a world's suite (`studies/replay_vs_road_suite.py`, `studies/replay_vs_track_suite.py`):
  `record_expert`, `train_baseline`, `train_snapshots`, `replayed`, `replay_missing`, `r2`, `correlations`,
  `correlation_table`, `scatter_axes`, `write_table`.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_1, Options, Range, names_held, option

ROOT = Path(__file__).resolve().parents[1]
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
    return (f"{model_name()} ({instruction_sets()}; torch's kernels {kernels}), {torch.get_num_threads()} torch "
            f"threads, torch {torch.__version__}")


# a study's start

def begin_study(out: Path, workers: int) -> tuple[float, float]:
    """A study's start: one torch thread a process (its drives run `workers` at a time), `out` made, the machine
    said; returns the wall and CPU clocks to say its cost at the end."""
    import torch

    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    print(f"machine: {machine()}; workers {workers}", flush=True)
    return time.time(), time.process_time()


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


def donkey_models(out: Path, tubs: Path, runs: int, names: tuple[str, ...],
                  work: str = "donkey") -> tuple[Path, list[Path]]:
    """donkeycar's car folder and its first `runs` linear models, trained by `donkey train` on the tubs `names`
    (folders of `tubs`; once each: a model counts once `donkey train` has finished), in out/`work`."""
    python = donkey_python()
    work = out / work
    car = donkey_car(python, work / "car")
    models = []
    for k in range(runs):
        model, done = work / f"linear-{k}.h5", work / f"linear-{k}.done"  # donkey train saves every better epoch
        if not done.exists():
            print(f"== training donkeycar's linear model, run {k} (donkey train)", flush=True)
            with open(work / f"train-{k}.log", "w") as log:
                subprocess.run([str(python.parent / "donkey"), "train", "--tub", ",".join(str(tubs / t) for t in names),
                                "--model", str(model), "--type", "linear", "--framework", "tensorflow"], cwd=car,
                               check=True, stdout=log, stderr=subprocess.STDOUT)
            done.write_text("trained\n")
        models.append(model)
    return car, models


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


# donkeycar's trainer on the shared tubs

TUBS = SHARED / "donkeycar"
FULL_LOCK_DEG = 25.0  # assumed: the tubs do not record it
READER = {"skip_missing": True, "full_lock_deg": FULL_LOCK_DEG}
TUB_NAMES = ("hall", "taped-track", "wood-tape")  # the tubs of ../shared/data/donkeycar


@dataclass(frozen=True)
class TubStudy(Options):
    """The options of a study on the shared tubs."""

    seeds: int = option(3, AT_LEAST_1, help="runs of every trainer and model")
    skip_donkey: bool = option(False, help="steerlab's models only, without donkeycar's")
    tubs: str = option(",".join(TUB_NAMES), help=f"comma list of the shared tubs to run on, of {', '.join(TUB_NAMES)}")

    @classmethod
    def related(cls, v):
        return names_held(v, "tubs", TUB_NAMES, "shared tubs")


def blocks(n: int) -> tuple[int, int]:
    return int(0.7 * n), int(0.8 * n)


def donkey_or_skip(skip_donkey: bool) -> Path | None:
    """donkeycar's python (None with --skip-donkey); ends the study when the shared tubs are absent."""
    if not (TUBS / "hall" / "manifest.json").exists():
        print(f"skipped: {TUBS} not found")
        sys.exit(0)
    return None if skip_donkey else donkey_python()


def training_tub(tub: Path, keep: set[int], out: Path) -> Path:
    """The tub as donkeycar reads it, with every record outside `keep` (record `_index` values) marked deleted.
    donkeycar's reader counts deleted indexes by record position in the catalogs, which is the `_index` only in a
    tub whose indexes start at 0 (taped-track's start at 10000), so positions are written."""
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    lines = (tub / "manifest.json").read_text().splitlines()
    catalogs = json.loads(lines[4])
    indexes = [json.loads(line)["_index"] for name in catalogs["paths"]
               for line in (tub / name).read_text().splitlines() if line.strip()]
    catalogs["deleted_indexes"] = [pos for pos, index in enumerate(indexes) if index not in keep]
    (out / "manifest.json").write_text("\n".join(lines[:4] + [json.dumps(catalogs)]) + "\n")
    for item in tub.iterdir():
        if item.name != "manifest.json":
            (out / item.name).symlink_to(item.resolve())
    return out


def run_donkey(python: Path, tub: Path, rec, a: int, n: int, work: Path, kinds: list[str], seeds: int,
               results: dict) -> None:
    """Train each donkeycar model `seeds` times on the first `a` records with `donkey train` and score it on the
    held-out block; runs already in `results` are kept."""
    car = donkey_car(python, work / "car")
    train_tub = training_tub(tub, set(int(i) for i in rec.frame_ids[:a]), work / "train-tub")
    test = {"images": [str(p) for p in rec.frames["center"][a:n]], "angles": rec.steering[a:n].tolist(),
            "throttles": rec.throttle[a:n].tolist()}
    (work / "test.json").write_text(json.dumps(test))
    for kind in kinds:
        for seed in range(seeds):
            key = f"donkeycar {kind} {seed}"
            if "mae" in results.get(key, {}):
                continue
            model, log = work / f"{kind}-{seed}.h5", work / f"{kind}-{seed}.log"
            t = time.time()
            with open(log, "w") as f:
                done = subprocess.run([str(python.parent / "donkey"), "train", "--tub", str(train_tub), "--model",
                                       str(model), "--type", kind, "--framework", "tensorflow"], cwd=car, stdout=f,
                                      stderr=subprocess.STDOUT)
            seconds = time.time() - t
            if done.returncode != 0 or not model.exists():
                print(f"  donkeycar {kind} run {seed}: donkey train failed, see {log}", flush=True)
                continue
            scores = work / f"{kind}-{seed}.json"
            subprocess.run([str(python), str(Path(__file__).with_name("_donkey_eval.py")), str(car / "config.py"),
                            str(model), kind, str(work / "test.json"), str(scores)], check=True, cwd=car,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            r = json.loads(scores.read_text())
            results[key] = {"mae": r["mae"], "throttle_mae": r["throttle_mae"], "train_s": seconds}
            print(f"  donkeycar {kind} run {seed}: held-out MAE {r['mae']:.4f}, throttle MAE "
                  f"{r['throttle_mae']:.4f}, {seconds:.0f} s", flush=True)
            (work / "results.json").write_text(json.dumps(results, indent=1))
    for kind in kinds:  # then each run in replay, as steerlab's models are
        for seed in range(seeds):
            key, model = f"donkeycar {kind} {seed}", work / f"{kind}-{seed}.h5"
            if "mae" in results.get(key, {}) and "interventions" not in results[key]:
                results[key].update(replay_donkey(python, car, model, kind, tub, a, n, work / f"{kind}-{seed}.log"))
                print(f"  donkeycar {kind} run {seed}: replay {results[key]['interventions']} interventions in "
                      f"{results[key]['km']:.2f} km", flush=True)
                (work / "results.json").write_text(json.dumps(results, indent=1))


def replay_donkey(python: Path, car: Path, model: Path, kind: str, tub: Path, b: int, n: int, log: Path) -> dict:
    """donkeycar's model, its own part behind a pipe, in the small cars' replay of the held-out block, as
    `steerlab replay --world track` replays steerlab's models (the throttle from the recording)."""
    from steerlab.data.readers import Source
    from steerlab.sim.core.part import PartPilot
    from steerlab.sim.replay.run import replay_recording
    from steerlab.sim.track.replay import TrackReplayOptions

    rec = Source(str(tub), reader=READER).open()
    replay = TrackReplayOptions(workers=1).setup(rec).replay
    part = DonkeycarPart(python, car, model, log.with_suffix(".part.log"), 1.0, kind=kind)
    try:
        rows, _ = replay_recording(PartPilot(part, FULL_LOCK_DEG, name=f"donkeycar {kind}", source=str(model)),
                                   replay, rec, np.arange(b, n))
    finally:
        part.close()
    r = rows[-1]
    return {"interventions": r["interventions"], "interventions_per_km": r["interventions_per_km"],
            "autonomy": r["autonomy"], "km": r["km"]}


def spread(values: list[float], digits: int = 4) -> str:
    """Mean and, over more than one run, the spread (the sample standard deviation)."""
    if not values:
        return "-"
    mean = f"{np.mean(values):.{digits}f}"
    return mean if len(values) == 1 else f"{mean} +- {np.std(values, ddof=1):.{digits}f}"


def mean_min_max(values: list, fmt: str) -> str:
    """The mean of the values given (None: a run without one) and, over more than one, their min-max: "0.90
    (0.85-0.95)"; "-" without any."""
    got = [v for v in values if v is not None]
    if not got:
        return "-"
    return format(float(np.mean(got)), fmt) + (f" ({min(got):{fmt}}-{max(got):{fmt}})" if len(got) > 1 else "")


# replay against the truth of a world's suite

def record_expert(world: str, out: Path, minutes: float) -> dict[tuple[str, int], Path]:
    """The expert on every place of the default suite of `world` ("road": its roads, "track": its tracks), for
    `minutes` each, recorded for evaluation: the suite's own road or track, as the suite's drives for those
    minutes see it (`record_options` of the world's suite options, `record(..., suite_ok=True)`), into
    out/expert/<kind>-<seed>. A recording of the same minutes is reused; one of other minutes is recorded anew, and
    its replays (out/replay/<kind>-<seed>) are deleted."""
    from steerlab.sim.worlds import WORLDS

    w = WORLDS[world]
    suite = w.suite.options(minutes=minutes)
    recs = {}
    for kind, seed in suite.drives():
        folder = out / "expert" / f"{kind}-{seed}"
        stamp = folder / "minutes.json"
        if not (stamp.exists() and json.loads(stamp.read_text())["minutes"] == minutes):
            shutil.rmtree(folder, ignore_errors=True)
            shutil.rmtree(out / "replay" / folder.name, ignore_errors=True)
            t0 = time.time()
            w.record.run(folder, suite.record_options(kind, seed), progress=False, suite_ok=True)
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
