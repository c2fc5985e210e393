"""donkeycar's own environment, in which the studies run donkeycar's trainer and parts (steerlab never imports
donkeycar): `donkey_python`, `donkey_car`, `donkey_models` (`donkey train`'s linear models), and `DonkeycarPart`,
donkeycar's pilot part behind a pipe; donkeycar's trainer on the shared tubs (`studies/donkeycar_tubs.py`,
`studies/tub_pretraining.py`): `TubStudy`, their options, `TUBS`, `READER`, `blocks`, `donkey_or_skip`,
`run_donkey`, `replay_donkey`."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.options import AT_LEAST_1, Options, names_held, option
from studies.common import ROOT, SHARED

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
