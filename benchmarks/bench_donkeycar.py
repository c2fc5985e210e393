"""steerlab side by side with donkeycar on the real tubs of ../shared/data/donkeycar.

For each tub, the records (minus deleted ones and those whose image is missing) are cut into contiguous
blocks: the first 80 % are training data for everyone, the last 20 % are the held-out validation block on
which every model is scored (steering MAE in the tub's own unit, [-1, 1]). steerlab trains on the MAE
(`train.loss: mae`: the score, and the median suits the nearly binary steering of an RC car), picks the
number of epochs on the first 70 % / next 10 % (best validation MAE, patience 5) and then trains on the whole
first 80 % for that many epochs; donkeycar's trainer gets the whole first 80 % as a tub (the rest marked deleted)
and splits it itself, as its users run it (`donkey train`, default config: 80/20 random split, early
stopping). Training time is the wall-clock time of each trainer (for steerlab both of its runs). steerlab's
settings are its defaults for a tub (`TUB_DEFAULTS` in train/config.py: batch 32, Adam 3e-4, MAE loss), only the
model is named; multimodal-lstm is the tub default.

Each steerlab model is also replayed in closed loop on the held-out block (`steerlab replay`: the recorded
frames warped to the simulated car's view, at an assumed REPLAY_SPEED, with an assumed full-lock angle of
FULL_LOCK_DEG so that the tub's normalized steering becomes a wheel angle; lane limit 0.3 m).

donkeycar is never a dependency of steerlab: it lives in its own virtual environment ($DONKEY_VENV, default
runs/donkeycar-venv, made on first use with `pip install donkeycar[pc]`) and `_donkey_eval.py` runs there.

python benchmarks/bench_donkeycar.py [--epochs 30] [--skip-donkey] [--models pilotnet,cg23,...]
donkeycar's models are trained once; a later run reuses their results (delete runs/bench-donkeycar/<tub> to
train them again). The table shows every result kept in runs/bench-donkeycar/<tub>/results.json, the models of
this run replacing their earlier rows.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from _common import ROOT, SHARED, machine

from steerlab.data.readers import Source
from steerlab.evaluate.offline import evaluate
from steerlab.sim.replay_run import ReplayOptions, run_replay
from steerlab.train.config import load_config
from steerlab.train.loop import train

TUBS = SHARED / "donkeycar"
OUT = ROOT / "runs" / "bench-donkeycar"
VENV = Path(os.environ.get("DONKEY_VENV", ROOT / "runs" / "donkeycar-venv"))
DONKEY = "donkeycar[pc]==5.3.0"  # 5.4 needs Python >= 3.12
STEERLAB_MODELS = ["pilotnet", "cg23", "multimodal-lstm", "train-mean"]
DONKEY_MODELS = ["linear", "rnn"]
FULL_LOCK_DEG = 25.0  # assumed: the tubs do not record it
READER = {"skip_missing": True, "full_lock_deg": FULL_LOCK_DEG}
REPLAY_SPEED = 2.0    # m/s, assumed: the tubs record no speed, and the frames' flow cannot tell it on a plain floor


def blocks(n: int) -> tuple[int, int]:
    return int(0.7 * n), int(0.8 * n)


def donkey_python() -> Path:
    python = VENV / "bin" / "python"
    if not python.exists():
        print(f"creating {VENV} with {DONKEY} (once)", flush=True)
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", DONKEY], check=True)
    return python


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


def run_donkey(python: Path, tub: Path, rec, a: int, n: int, work: Path) -> dict:
    car = work / "car"
    if not car.exists():
        subprocess.run([str(python.parent / "donkey"), "createcar", "--path", str(car)], check=True,
                       stdout=subprocess.DEVNULL)
        with open(car / "myconfig.py", "a") as f:
            f.write("\nSHOW_PLOT = False\nCREATE_TF_LITE = False\nSAVE_MODEL_AS_H5 = True\n")
    train_tub = training_tub(tub, set(int(i) for i in rec.frame_ids[:a]), work / "train-tub")
    test = {"images": [str(p) for p in rec.frames["center"][a:n]], "angles": rec.steering[a:n].tolist()}
    (work / "test.json").write_text(json.dumps(test))
    results = {}
    previous = json.loads((work / "results.json").read_text()) if (work / "results.json").exists() else {}
    for kind in DONKEY_MODELS:
        model = work / f"{kind}.h5"
        if "mae" in previous.get(f"donkeycar {kind}", {}) and model.exists():  # trained in an earlier run
            results[kind] = previous[f"donkeycar {kind}"]
            print(f"  donkeycar {kind}: reused from {work / 'results.json'}", flush=True)
            continue
        t = time.time()
        log = work / f"{kind}.log"
        with open(log, "w") as f:
            done = subprocess.run([str(python.parent / "donkey"), "train", "--tub", str(train_tub), "--model",
                                   str(model), "--type", kind, "--framework", "tensorflow"], cwd=car, stdout=f,
                                  stderr=subprocess.STDOUT)
        seconds = time.time() - t
        if done.returncode != 0 or not model.exists():
            results[kind] = {"error": f"donkey train failed, see {log}"}
            continue
        subprocess.run([str(python), str(Path(__file__).with_name("_donkey_eval.py")), str(car / "config.py"),
                        str(model), kind, str(work / "test.json"), str(work / f"{kind}.json")], check=True, cwd=car,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        results[kind] = {"mae": json.loads((work / f"{kind}.json").read_text())["mae"], "train_s": seconds}
        print(f"  donkeycar {kind}: held-out MAE {results[kind]['mae']:.4f}, {seconds:.0f} s", flush=True)
    return results


def run_steerlab(tub: Path, n: int, epochs: int, work: Path, models: list[str]) -> dict:
    """Each model: pick the number of epochs on the selection block (train 0:a, validate a:b), then train again
    on all of 0:b for exactly that many epochs, score that last model on the held-out block and replay it there."""
    a, b = blocks(n)
    results = {}
    for name in models:
        seconds, run = 0.0, None
        for stage, split, n_epochs in (("select", {"train": f"0:{a}", "val": f"{a}:{b}"}, epochs),
                                       ("refit", {"train": f"0:{b}", "val": f"{b}:{n}"}, None)):
            if stage == "refit" and run.get("epoch", 0) == 0:
                break  # a baseline: nothing to select
            run_dir = work / f"{name}-{stage}"
            shutil.rmtree(run_dir, ignore_errors=True)  # a fresh run: its time is what is measured
            cfg = load_config(None, base={
                "data": str(tub), "reader": READER, "cache": str(OUT / "cache"), "out": str(run_dir),
                "split": split, "model": {"name": name},
                "train": {"epochs": n_epochs or run["epoch"], "patience": 5, "keep": "best" if n_epochs else "last"}})
            t = time.time()
            run = train(cfg, progress=False)  # the refit keeps its last epoch: its validation block is held out
            seconds += time.time() - t
        ckpt, held_out = run_dir / "best.pt", Source(str(tub), f"{b}:{n}", reader=READER)
        m = evaluate(ckpt, held_out, run_dir / "test", progress=False)
        r = run_replay([ckpt], held_out, run_dir / "replay", ReplayOptions(speed=REPLAY_SPEED, workers=1),
                       progress=False)[0]
        results[name] = {"mae": m["mae"], "train_s": seconds, "interventions_per_km": r["interventions_per_km"],
                         "interventions": r["interventions"], "autonomy": r["autonomy"], "km": r["km"]}
        print(f"  steerlab {name}: held-out MAE {m['mae']:.4f}, {seconds:.0f} s; replay {r['interventions']} "
              f"interventions in {r['km']:.2f} km", flush=True)
    return results


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--epochs", type=int, default=30, help="steerlab's epochs (early stopping after 5)")
    ap.add_argument("--skip-donkey", action="store_true", help="steerlab models only")
    ap.add_argument("--models", default=",".join(STEERLAB_MODELS), help="steerlab models (comma list; default "
                    f"{','.join(STEERLAB_MODELS)})")
    args = ap.parse_args()
    if not (TUBS / "hall" / "manifest.json").exists():
        print(f"skipped: {TUBS} not found")
        return
    python = None if args.skip_donkey else donkey_python()
    os.environ.setdefault("STEERLAB_CACHE", str(OUT / "cache"))
    lines = [f"machine: {machine()}", "", f"replay: held-out block at an assumed {REPLAY_SPEED} m/s, full lock "
             f"{FULL_LOCK_DEG} deg", "", "| tub | model | trainer | held-out MAE [-1, 1] | train time [s] | "
             "replay: interventions (per km) | replay autonomy [%] |", "|---|---|---|---|---|---|---|"]
    for name in ("hall", "taped-track"):
        tub = TUBS / name
        rec = Source(str(tub), reader=READER).open()
        n = len(rec)
        a, b = blocks(n)
        print(f"{name}: {n} records; steerlab selects epochs on 0:{a} | {a}:{b}, then trains on 0:{b}; donkeycar "
              f"trains on 0:{b}; everyone is scored on {b}:{n}", flush=True)
        work = OUT / name
        work.mkdir(parents=True, exist_ok=True)
        results = json.loads((work / "results.json").read_text()) if (work / "results.json").exists() else {}
        results.update({f"steerlab {k}": v for k, v in run_steerlab(tub, n, args.epochs, work,
                                                                     args.models.split(",")).items()})
        if python:
            results.update({f"donkeycar {k}": v for k, v in run_donkey(python, tub, rec, b, n, work).items()})
        for label, r in results.items():
            trainer, model = label.split(" ", 1)
            mae = f"{r['mae']:.4f}" if "mae" in r else r["error"]
            replay = (f"{r['interventions']} ({r['interventions_per_km']:.1f}) | {r['autonomy']:.1f}"
                      if "autonomy" in r else "- | -")
            lines.append(f"| {name} | {model} | {trainer} | {mae} | {r.get('train_s', float('nan')):.0f} | {replay} |")
        (work / "results.json").write_text(json.dumps(results, indent=1))
    table = "\n".join(lines) + "\n"
    (OUT / "table.md").write_text(table)
    print(table)
    print(f"wrote {OUT / 'table.md'}")


if __name__ == "__main__":
    main()
