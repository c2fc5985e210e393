"""Sim-to-real for donkeycar tubs: the tub default of then (multimodal-lstm) pretrained in the track world, then
trained on a real tub, against the same training on the tub alone and against donkeycar's own linear model, on both
shared tubs.

Pretraining: the tub default trained for 3 epochs on the track world's four expert tubs
(`configs/track_default.yaml train.epochs=3`; the tubs are recorded first where they are missing). On each real tub and seed, the recipe of
`configs/donkey_best.yaml` (the tub defaults of then, the epochs chosen on each tub's selection block: hall 25,
taped-track 12, keeping the last epoch) is trained twice: from scratch and from the pretrained checkpoint
(`train.init`; taped-track's constant throttle drops the throttle output). donkeycar's linear model is trained
with its own trainer on the same first 80 % (`run_donkey` of `donkeycar_tubs.py`, in donkeycar's own
environment). Everyone is scored on the held-out last 20 %: the steering MAE in degrees of the servo's +-25 deg
and the throttle MAE (open loop), and the interventions of the small cars' replay (`steerlab replay --world
track`: the body leaving a 0.9 m lane around the human's path, the speed from the recorded throttle).

python -m studies.tub_pretraining [--seeds 3] [--skip-donkey] [--tubs hall,taped-track]
Every finished run is kept in runs/tub-pretraining/<tub>/results.json and reused by a later run.
"""

import json
from dataclasses import dataclass

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.data.readers import Source
from steerlab.evaluate.offline import evaluate
from steerlab.options import names_from, names_held, option
from steerlab.sim.replay.run import run_replay
from steerlab.sim.track.replay import TrackReplayOptions
from steerlab.train.config import load_config
from steerlab.train.loop import train
from studies.common import ROOT, machine, spread, track_tubs
from studies.common.donkeycar import FULL_LOCK_DEG, TUBS, TubStudy, blocks, donkey_or_skip, reader, run_donkey

OUT = ROOT / "runs" / "tub-pretraining"
EPOCHS = {"hall": 25, "taped-track": 12}  # configs/donkey_best.yaml, and its note for taped-track
ARMS = {"alone": "tub default, the tub alone", "pretrained": "tub default, pretrained in the track world"}


def pretrained():
    """The tub default pretrained on the track world's expert tubs (made once)."""
    ckpt = OUT / "pretrain" / "best.pt"
    if not ckpt.exists():
        tubs = track_tubs()
        train(load_config(ROOT / "configs" / "track_default.yaml", [
            "train.epochs=3", f"data={tubs[0]}", f"extra_data=[{', '.join(map(str, tubs[1:]))}]",
            f"cache={OUT / 'cache'}", f"out={OUT / 'pretrain'}"]), progress=False)
    return ckpt


def run_arm(name: str, arm: str, seed: int, n: int, results: dict) -> None:
    key = f"steerlab {arm} {seed}"
    if "mae" in results.get(key, {}):
        return
    tub, b = TUBS / name, blocks(n)[1]
    run = OUT / name / f"{arm}-{seed}"
    init = [f"train.init={pretrained()}"] if arm == "pretrained" else []
    train(load_config(ROOT / "configs" / "donkey_best.yaml", [
        f"data={tub}", f"split.train=0:{b}", f"split.val={b}:{n}", f"train.epochs={EPOCHS[name]}",
        f"train.seed={seed}", f"cache={OUT / 'cache'}", f"out={run}", *init]), progress=False)
    held_out = Source(str(tub), f"{b}:{n}", reader=reader(tub))
    m = evaluate(run / "best.pt", held_out, run / "test", progress=False)
    r = run_replay([run / "best.pt"], held_out, run / "replay", TrackReplayOptions(workers=1), progress=False)[0]
    results[key] = {"mae": m["mae"], "mae_deg": m["mae"] * FULL_LOCK_DEG,
                    "interventions": r["interventions"], "km": r["km"],
                    **({"throttle_mae": m["throttle_mae"]} if "throttle_mae" in m else {})}
    print(f"  {name} {arm} seed {seed}: MAE {results[key]['mae_deg']:.2f} deg, replay {r['interventions']} "
          "interventions", flush=True)


def rows(name: str, results: dict) -> list[str]:
    groups: dict[str, list[dict]] = {}
    for key, r in results.items():
        groups.setdefault(key.rsplit(" ", 1)[0], []).append(r)
    linear = [r["mae"] for r in groups.get("donkeycar linear", [])]
    out = []
    for label, runs in sorted(groups.items()):
        arm = label.split(" ", 1)[1]
        mae = [r["mae"] for r in runs]
        ratio = f"{np.mean(mae) / np.mean(linear):.2f}x" if linear else "-"
        out.append(f"| {name} | {ARMS.get(arm, 'donkeycar ' + arm)} | {len(runs)} | "
                   f"{spread([FULL_LOCK_DEG * v for v in mae], 2)} | {ratio} | "
                   f"{spread([r['throttle_mae'] for r in runs if 'throttle_mae' in r])} | "
                   f"{spread([r['interventions'] for r in runs if 'interventions' in r], 1)} |")
    return out


@dataclass(frozen=True)
class Pretraining(TubStudy):
    tubs: str = option(",".join(EPOCHS), help=f"comma list of the shared tubs to run on, of {', '.join(EPOCHS)} (the "
                       "tubs whose epochs configs/donkey_best.yaml chose)")

    @classmethod
    def related(cls, v):
        return names_held(v, "tubs", tuple(EPOCHS), "shared tubs whose epochs were chosen")


def parser():
    return script_parser(__spec__.name, __doc__, Pretraining)


def main(_, args: Pretraining) -> None:
    python = donkey_or_skip(args.skip_donkey)
    lines = [f"machine: {machine()}", "", "| tub | model | runs | held-out steering MAE [deg] | vs donkeycar linear | "
             "held-out throttle MAE | replay: interventions |", "|---|---|---|---|---|---|---|"]
    for name in names_from(args.tubs, tuple(EPOCHS), "shared tubs whose epochs were chosen"):
        rec = Source(str(TUBS / name), reader=reader(name)).open()
        n, work = len(rec), OUT / name
        work.mkdir(parents=True, exist_ok=True)
        file = work / "results.json"
        results = json.loads(file.read_text()) if file.exists() else {}
        for seed in range(args.seeds):
            for arm in ARMS:
                run_arm(name, arm, seed, n, results)
                file.write_text(json.dumps(results, indent=1))
        if python:
            run_donkey(python, TUBS / name, rec, blocks(n)[1], n, work, ["linear"], args.seeds, results)
        lines += rows(name, results)
    table = "\n".join(lines) + "\n"
    (OUT / "table.md").write_text(table)
    print(table)


if __name__ == "__main__":
    run_script(parser(), main)
