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
throttle learned with weight 0.5 where the model can), only the model is named; multimodal-lstm was the tub
default then. `--models track-best` trains the recipe of configs/track_best.yaml (its input, network and training) on
the same blocks instead.

Each model, steerlab's and donkeycar's (its own part behind a pipe), is also replayed in closed loop on the held-out
block with the small cars' replay (`steerlab replay --world track`: the fisheye frames warped to the car's view, the
speed from the recorded throttle, an assumed full-lock angle of FULL_LOCK_DEG so that the tub's normalized steering
becomes a wheel angle; an intervention where the car's body leaves a 0.9 m lane around the human's path).

donkeycar is never a dependency of steerlab: it lives in its own virtual environment ($DONKEY_VENV, default
runs/donkeycar-venv, made on first use with `pip install donkeycar[pc]`) and `_donkey_eval.py` runs there.

python -m studies.donkeycar_tubs [--epochs 30] [--seeds 3] [--skip-donkey] [--models pilotnet,cg23,...]
    [--donkey-models linear,rnn]
Every finished run (trainer, model, seed) is kept in runs/donkeycar-tubs/<tub>/results.json and reused by a
later run (delete the file to train them again); the table shows every run kept there.
"""

import json
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from steerlab.cli import run_script, script_parser
from steerlab.data.readers import Source
from steerlab.evaluate.offline import evaluate
from steerlab.sim.replay.run import run_replay
from steerlab.sim.track.replay import TrackReplayOptions
from steerlab.train.config import load_config
from steerlab.models import list_models
from steerlab.options import AT_LEAST_1, names_from, names_held, option
from steerlab.train.loop import train
from studies.common import ROOT, machine, spread
from studies.common.donkeycar import (FULL_LOCK_DEG, TUB_NAMES, TUBS, TubStudy, blocks, donkey_or_skip, reader,
                                      run_donkey)

OUT = ROOT / "runs" / "donkeycar-tubs"
STEERLAB_MODELS = ["pilotnet", "cg23", "multimodal-lstm", "train-mean"]
# a steerlab "model" of this name is a recipe: the input, network and training of configs/track_best.yaml (the
# track world's closed loop chose it), on the tub's own blocks
TRACK_BEST = "track-best"
DONKEY_MODELS = ["linear"]
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
                    **recipe, "data": str(tub), "reader": reader(tub), "cache": str(OUT / "cache"), "out": str(run_dir),
                    "split": split, "train": {**recipe["train"], "epochs": n_epochs or run["epoch"], "seed": seed,
                                              "keep": "best" if n_epochs else "last"}})
                t = time.time()
                run = train(cfg, progress=False)  # the refit keeps its last epoch: its validation block is held out
                seconds += time.time() - t
            ckpt, held_out = run_dir / "best.pt", Source(str(tub), f"{b}:{n}", reader=reader(tub))
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


@dataclass(frozen=True)
class TubsSideBySide(TubStudy):
    epochs: int = option(30, AT_LEAST_1, help="steerlab's epochs (early stopping after 5)")
    models: str = option(",".join(STEERLAB_MODELS), help="steerlab models (comma list of registered models; "
                         f"{TRACK_BEST}: configs/track_best.yaml's recipe)")
    donkey_models: str = option(",".join(DONKEY_MODELS), help="donkeycar's models (comma list of its model types)")

    @classmethod
    def related(cls, v):
        yield from super().related(v)
        yield from names_held(v, "models", [*list_models(), TRACK_BEST], "models")


def parser():
    return script_parser(__spec__.name, __doc__, TubsSideBySide)


def main(_, args: TubsSideBySide) -> None:
    models = names_from(args.models, [*list_models(), TRACK_BEST], "models")
    donkey_models = [m for m in args.donkey_models.split(",") if m]
    python = donkey_or_skip(args.skip_donkey)
    os.environ.setdefault("STEERLAB_CACHE", str(OUT / "cache"))
    lines = [f"machine: {machine()}", "", f"replay: held-out block as a small car (--world track), full lock "
             f"{FULL_LOCK_DEG} deg", "", "| tub | model | trainer | runs | held-out steering MAE [-1, 1] | vs "
             "donkeycar linear | held-out throttle MAE | train time [s] | replay: interventions |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name in names_from(args.tubs, TUB_NAMES, "shared tubs"):
        tub = TUBS / name
        rec = Source(str(tub), reader=reader(tub)).open()
        n = len(rec)
        a, b = blocks(n)
        print(f"{name}: {n} records; steerlab selects epochs on 0:{a} | {a}:{b}, then trains on 0:{b}; donkeycar "
              f"trains on 0:{b}; everyone is scored on {b}:{n}", flush=True)
        work = OUT / name
        work.mkdir(parents=True, exist_ok=True)
        results = json.loads((work / "results.json").read_text()) if (work / "results.json").exists() else {}
        run_steerlab(tub, n, args.epochs, work, models, args.seeds, results)
        if python:
            run_donkey(python, tub, rec, b, n, work, donkey_models, args.seeds, results)
        lines += table_rows(name, results)
    table = "\n".join(lines) + "\n"
    (OUT / "table.md").write_text(table)
    print(table)
    print(f"wrote {OUT / 'table.md'}")


if __name__ == "__main__":
    run_script(parser(), main)
