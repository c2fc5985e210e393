"""steerlab side by side with donkeycar on the real tubs of ../shared/data/donkeycar.

For each tub, the records (minus deleted ones and those whose image is missing) are cut into contiguous
blocks: the first 80 % are training data for everyone, the last 20 % are the held-out validation block on
which every model is scored (steering MAE in the tub's own unit, [-1, 1], and, for the models that predict it,
throttle MAE against the recorded `user/throttle`). Every trainer runs `--seeds` times (steerlab with
`train.seed` 0, 1, ...; donkeycar's own trainer draws its own split and initialisation each run); the table
gives the mean and the spread over the runs. steerlab trains on the MAE
(`train.loss: mae`: the score, and the median suits the nearly binary steering of an RC car), picks the
number of epochs on the first 70 % / next 10 % (best validation MAE, patience 5) and then trains on the whole
first 80 % for that many epochs; donkeycar's trainer gets the whole first 80 % as a tub (the rest marked deleted)
and splits it itself, as its users run it (`donkey train`, default config: 80/20 random split, early
stopping). Training time is the wall-clock time of each trainer (for steerlab both of its runs). steerlab's
settings are its defaults for a tub (`TUB_DEFAULTS` in train/config.py: batch 32, Adam 3e-4, MAE loss, the
throttle learned with weight 0.5 where the model can), only the model is named; multimodal-lstm is the tub
default. `--models track-best` trains the recipe of configs/track_best.yaml (its input, network and training) on
the same blocks instead.

Each model, steerlab's and donkeycar's (its own part behind a pipe), is also replayed in closed loop on the held-out
block with the small cars' replay (`steerlab replay --world track`: the fisheye frames warped to the car's view, the
speed from the recorded throttle, an assumed full-lock angle of FULL_LOCK_DEG so that the tub's normalized steering
becomes a wheel angle; an intervention where the car's body leaves a 0.9 m lane around the human's path).

donkeycar is never a dependency of steerlab: it lives in its own virtual environment ($DONKEY_VENV, default
runs/donkeycar-venv, made on first use with `pip install donkeycar[pc]`) and `_donkey_eval.py` runs there.

python studies/donkeycar_tubs.py [--epochs 30] [--seeds 3] [--skip-donkey] [--models pilotnet,cg23,...]
    [--donkey-models linear,rnn]
Every finished run (trainer, model, seed) is kept in runs/donkeycar-tubs/<tub>/results.json and reused by a
later run (delete the file to train them again); the table shows every run kept there.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from common import ARG, ROOT, SHARED, DonkeycarPart, donkey_car, donkey_python, machine, guarded  # noqa: E402

from steerlab.data.readers import Source  # noqa: E402
from steerlab.evaluate.offline import evaluate  # noqa: E402
from steerlab.sim.replay.run import run_replay  # noqa: E402
from steerlab.sim.replay.track import TrackReplayOptions  # noqa: E402
from steerlab.train.config import load_config  # noqa: E402
from steerlab.train.loop import train  # noqa: E402

TUBS = SHARED / "donkeycar"
OUT = ROOT / "runs" / "donkeycar-tubs"
STEERLAB_MODELS = ["pilotnet", "cg23", "multimodal-lstm", "train-mean"]
# a steerlab "model" of this name is a recipe: the input, network and training of configs/track_best.yaml (the
# track world's closed loop chose it), on the tub's own blocks
TRACK_BEST = "track-best"
DONKEY_MODELS = ["linear"]
FULL_LOCK_DEG = 25.0  # assumed: the tubs do not record it
READER = {"skip_missing": True, "full_lock_deg": FULL_LOCK_DEG}


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
    from steerlab.sim.core.part import PartPilot
    from steerlab.sim.replay.run import replay_recording

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


def run_steerlab(tub: Path, n: int, epochs: int, work: Path, models: list[str], seeds: int, results: dict) -> None:
    """Each model and seed: pick the number of epochs on the selection block (train 0:a, validate a:b), then
    train again on all of 0:b for exactly that many epochs, score that last model on the held-out block and
    replay it there; runs already in `results` are kept."""
    a, b = blocks(n)
    for name in models:
        for seed in range(seeds):
            key = f"steerlab {name} {seed}"
            recipe = {"model": {"name": name}, "train": {"epochs": epochs, "patience": 5}}
            if name == TRACK_BEST:  # kept with its result: a result of another recipe is not reused
                best = yaml.safe_load((ROOT / "configs" / "track_best.yaml").read_text())
                recipe = {k: best[k] for k in ("preprocess", "model", "train")}
            done = results.get(key, {})
            if "mae" in done and (name != TRACK_BEST or done.get("recipe") == recipe):
                continue
            seconds, run = 0.0, None
            stages = (("select", {"train": f"0:{a}", "val": f"{a}:{b}"}, recipe["train"]["epochs"]),
                      ("refit", {"train": f"0:{b}", "val": f"{b}:{n}"}, None))
            for stage, split, n_epochs in stages:
                if stage == "refit" and run.get("epoch", 0) == 0:
                    break  # a baseline: nothing to select
                run_dir = work / f"{name}-{seed}-{stage}"
                shutil.rmtree(run_dir, ignore_errors=True)  # a fresh run: its time is what is measured
                cfg = load_config(None, base={
                    **recipe, "data": str(tub), "reader": READER, "cache": str(OUT / "cache"), "out": str(run_dir),
                    "split": split, "train": {**recipe["train"], "epochs": n_epochs or run["epoch"], "seed": seed,
                                              "keep": "best" if n_epochs else "last"}})
                t = time.time()
                run = train(cfg, progress=False)  # the refit keeps its last epoch: its validation block is held out
                seconds += time.time() - t
            ckpt, held_out = run_dir / "best.pt", Source(str(tub), f"{b}:{n}", reader=READER)
            m = evaluate(ckpt, held_out, run_dir / "test", progress=False)
            r = run_replay([ckpt], held_out, run_dir / "replay", TrackReplayOptions(workers=1),
                           progress=False)[0]
            results[key] = {"mae": m["mae"], "train_s": seconds, "interventions_per_km": r["interventions_per_km"],
                            "interventions": r["interventions"], "autonomy": r["autonomy"], "km": r["km"],
                            **({"throttle_mae": m["throttle_mae"]} if "throttle_mae" in m else {}),
                            **({"recipe": recipe} if name == TRACK_BEST else {})}
            throttle = f", throttle MAE {m['throttle_mae']:.4f}" if "throttle_mae" in m else ""
            print(f"  steerlab {name} seed {seed}: held-out MAE {m['mae']:.4f}{throttle}, {seconds:.0f} s; replay "
                  f"{r['interventions']} interventions in {r['km']:.2f} km", flush=True)
            (work / "results.json").write_text(json.dumps(results, indent=1))


def spread(values: list[float], digits: int = 4) -> str:
    """Mean and, over more than one run, the spread (the sample standard deviation)."""
    if not values:
        return "-"
    mean = f"{np.mean(values):.{digits}f}"
    return mean if len(values) == 1 else f"{mean} +- {np.std(values, ddof=1):.{digits}f}"


def table_rows(name: str, results: dict) -> list[str]:
    """One row per trainer and model: the mean (+- spread) over its runs, and the ratio of mean steering MAEs
    against donkeycar's linear model."""
    groups: dict[str, list[dict]] = {}
    for key, r in results.items():
        trainer, model, _ = key.rsplit(" ", 2)
        groups.setdefault(f"{trainer} {model}", []).append(r)
    linear = [r["mae"] for r in groups.get("donkeycar linear", []) if "mae" in r]
    rows = []
    for label, runs in groups.items():
        trainer, model = label.split(" ", 1)
        mae = [r["mae"] for r in runs]
        ratio = f"{np.mean(mae) / np.mean(linear):.2f}x" if linear else "-"
        throttle = spread([r["throttle_mae"] for r in runs if "throttle_mae" in r])
        replay = spread([r["interventions"] for r in runs if "interventions" in r], 1)
        train_s = f"{np.mean([r['train_s'] for r in runs]):.0f}"
        rows.append(f"| {name} | {model} | {trainer} | {len(runs)} | {spread(mae)} | {ratio} | {throttle} | "
                    f"{train_s} | {replay} |")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--epochs", type=ARG["count"], default=30, help="steerlab's epochs (early stopping after 5)")
    ap.add_argument("--seeds", type=ARG["count"], default=3, help="runs of every trainer and model")
    ap.add_argument("--skip-donkey", action="store_true", help="steerlab models only")
    ap.add_argument("--models", default=",".join(STEERLAB_MODELS), help="steerlab models (comma list; default "
                    f"{','.join(STEERLAB_MODELS)}; {TRACK_BEST}: configs/track_best.yaml's recipe)")
    ap.add_argument("--donkey-models", default=",".join(DONKEY_MODELS), help="donkeycar models (comma list; "
                    f"default {','.join(DONKEY_MODELS)})")
    ap.add_argument("--tubs", default="hall,taped-track", help="the shared tubs to run on")
    args = ap.parse_args()
    from steerlab.models.registry import model_class

    for name in args.tubs.split(","):  # every argument checked before any work
        Source(str(TUBS / name), reader=READER).open()
    for name in args.models.split(","):
        if name != TRACK_BEST:
            model_class(name)
    python = donkey_or_skip(args.skip_donkey)
    os.environ.setdefault("STEERLAB_CACHE", str(OUT / "cache"))
    lines = [f"machine: {machine()}", "", f"replay: held-out block as a small car (--world track), full lock "
             f"{FULL_LOCK_DEG} deg", "", "| tub | model | trainer | runs | held-out steering MAE [-1, 1] | vs "
             "donkeycar linear | held-out throttle MAE | train time [s] | replay: interventions |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name in args.tubs.split(","):
        tub = TUBS / name
        rec = Source(str(tub), reader=READER).open()
        n = len(rec)
        a, b = blocks(n)
        print(f"{name}: {n} records; steerlab selects epochs on 0:{a} | {a}:{b}, then trains on 0:{b}; donkeycar "
              f"trains on 0:{b}; everyone is scored on {b}:{n}", flush=True)
        work = OUT / name
        work.mkdir(parents=True, exist_ok=True)
        results = json.loads((work / "results.json").read_text()) if (work / "results.json").exists() else {}
        run_steerlab(tub, n, args.epochs, work, args.models.split(","), args.seeds, results)
        if python:
            run_donkey(python, tub, rec, b, n, work, args.donkey_models.split(","), args.seeds, results)
        lines += table_rows(name, results)
    table = "\n".join(lines) + "\n"
    (OUT / "table.md").write_text(table)
    print(table)
    print(f"wrote {OUT / 'table.md'}")


if __name__ == "__main__":
    guarded(main)
