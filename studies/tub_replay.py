"""Does replay on the real tubs tell models apart? The small cars' replay (`steerlab replay --world track`)
validated on the three shared tubs before it is used to choose anything.

Each tub (hall, taped-track, wood-tape) is cut into two folds of contiguous blocks: `last` trains on the first 70 %
of its records, keeps the epoch of the best steering MAE on the next 10 % and is scored on the last 20 %; `first`
is scored on the first 20 %, keeps its epoch on the next 10 % and trains on the last 70 %. So every tub has two
scored blocks no model of that fold trained on, each several laps of its track. On every scored block:

- open loop: the steering MAE in the tub's unit ([-1, 1] of the servo), the throttle MAE where the model learns
  it, and the steering's smoothness gamma (paper 000 Eq. 2, degrees at the assumed full lock) beside the human's;
- replay: the model drives a simulated small car along the human's path, rebuilt from the recorded steering
  (full lock FULL_LOCK_DEG, assumed: the tubs do not record it) and the speed the recorded throttle gives through
  the small car's motor model, seeing each recorded frame warped through the default Raspberry Pi fisheye to where
  its car is. The intervention rule: a corner of the car's 0.42 x 0.20 m body outside a 0.9 m lane centred on the
  human's path; the car is then put back on the path, heading along it, and the model's memory is cleared. The
  count per 100 m of the human's path is the measure.

The models: `zero` and `train-mean` (a model that learned nothing); `pilotnet` on the tub defaults (MAE loss, batch 32,
Adam 3e-4, the throttle learned where the tub varies it); `pilotnet-views`, the same with `train.views=[[[-0.15, 0.15],
[-15, 15]]]` and `train.recovery_s=0.3` (every frame also seen from a car moved up to 15 cm and turned up to 15 degrees,
labelled with the steering back to the path); and `other-track`: the `pilotnet-views` model of fold `last` of each other
tub (a model of another track, car and lens). `--models` adds `tub-default` (the tub default of earlier builds:
multimodal-lstm), `tub-default-views` (the same with those views), `track-best` (configs/track_best.yaml's input,
network and training) and `linear-views` (donkeycar linear's layout written in steerlab, `donkey-linear`, on the whole
160 x 120 RGB frame as donkeycar feeds it, on the tub defaults' training with the views: steerlab's trainer beside
donkeycar's on the same frames; chosen here, it is the tub defaults now, `TUB_DEFAULTS`), `linear` (the same without the
views: the tub defaults where a config lacks the full lock) and `linear-views-0.2`, `-0.6`, `-0.9` (the same, the views'
labels pursuing the point 0.2, 0.6 or 0.9 s ahead on the path instead of 0.3, `train.recovery_s`: sharper or gentler
returns; replay's own is 0.9 s); every trained model gets at most --epochs epochs and --patience (the runs of other
values in a folder of their own), and a finished run of another recipe is refused (delete its folder). `--donkeycar`
adds donkeycar's linear model by its own trainer (`donkey train --type linear`, donkeycar 5.3.0 in its own environment)
on each fold's training and validation blocks as one tub, which it splits 80/20 at random as its users train: the same
records as steerlab's, `--seeds` runs (its trainer is not seeded); `--donkeycar-views` adds it trained on
pilotnet-views's views of those records as well, written as a second tub it reads (`views_tub`: the extra frames
steerlab's views models see, so that what the frames give and what the trainer gives are apart). The check this study
exists for: on every scored block the best trained model needs at most half the interventions of the best of the models
that learned nothing and of the other tracks' models ("separates": yes / no in the table).

Choosing among the trained models is done on other blocks: every trained steerlab model is also scored, open loop
and in replay, on each fold's validation block (the selection blocks: the table's second part), and the choice is
the trained model with the fewest interventions per 100 m there (on each tub, both folds, over its best's, each
plus one; averaged over the tubs); the scored blocks only report. donkeycar's trainer trains on the validation
blocks (its own 80/20 split), so it has no selection score, and it chooses nothing.

python -m studies.tub_replay [--seeds 2] [--epochs 10] [--patience 3] [--tubs hall,taped-track,wood-tape]
    [--models pilotnet,pilotnet-views,tub-default,tub-default-views,track-best,linear,linear-views,
    linear-views-0.2,linear-views-0.6,linear-views-0.9] [--donkeycar]
    [--donkeycar-views]
Every finished run is kept in runs/tub-replay/epochs-N[-patience-P]/results.json and reused by a later run of the same
--epochs and --patience;
table.md and table.png are written there from all the runs kept. Runs on other --tubs may go at once, one a core
(`taskset -c 0 ... --tubs hall,taped-track` beside `taskset -c 1 ... --tubs wood-tape`): each keeps its runs in
that one file without losing the other's; a last run over all the tubs adds the other tracks' models and the table.
"""

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.files import read_yaml
from steerlab.data.readers import Source
from steerlab.evaluate.offline import evaluate
from steerlab.figures import COLORS, MANY_COLORS, figure
from steerlab.options import AT_LEAST_1, Options, names_from, names_held, option
from steerlab.sim.replay.run import run_replay
from steerlab.sim.track.replay import TrackReplayOptions
from steerlab.train.config import another_config, load_config
from steerlab.train.loop import run_changes, train
from studies._recipes import VIEW
from studies.common import ROOT, keep_result, machine, mean_min_max
from studies.common.donkeycar import (FULL_LOCK_DEG, TUB_NAMES, TUBS, donkey_car, donkey_python, donkey_scores,
                                      donkey_train, reader, replay_donkey, training_tub, views_tub)

OUT = ROOT / "runs" / "tub-replay"
PILOTNET = {"model": {"name": "pilotnet"}}
WHOLE_FRAME = {"preprocess": {"crop": [0, 0, 0, 0], "width": 160, "height": 120, "color": "rgb"}}  # as donkeycar


def track_best() -> dict:
    """configs/track_best.yaml's input, network and training (the track world's closed loop chose them)."""
    best = read_yaml(ROOT / "configs" / "track_best.yaml")
    return {k: best[k] for k in ("preprocess", "model", "train")}


# the trained models: their config sections beside the tub defaults' training settings (a model named: no input or
# views of the defaults'); linear-views is the tub defaults, written out; --epochs and --patience for all
MULTIMODAL = {"model": {"name": "multimodal-lstm"}}  # the tub default of earlier builds
LINEAR = {**WHOLE_FRAME, "model": {"name": "donkey-linear"}}  # donkeycar linear's layout, as donkeycar feeds it
RECOVERY_S = (0.2, 0.6, 0.9)  # linear-views with the views' pursued point nearer (sharper returns) or further ahead
TRAINED = {"pilotnet": lambda: PILOTNET, "pilotnet-views": lambda: {**PILOTNET, "train": VIEW},
           "tub-default": lambda: MULTIMODAL, "tub-default-views": lambda: {**MULTIMODAL, "train": VIEW},
           "track-best": track_best, "linear": lambda: LINEAR,
           "linear-views": lambda: {**LINEAR, "train": VIEW},
           **{f"linear-views-{s}": lambda s=s: {**LINEAR, "train": {**VIEW, "recovery_s": s}} for s in RECOVERY_S}}
MODELS = "pilotnet,pilotnet-views"  # --models by default
DONKEY_LINEAR = "donkeycar-linear"  # donkeycar's linear model by its own trainer (--donkeycar)
DONKEY_VIEWS = "donkeycar-linear-views"  # the same, trained on pilotnet-views's views as well (--donkeycar-views)
NULL = ("zero", "train-mean")
FOLDS = ("last", "first")
SELECTION_RULE = ("the fewest replay interventions per 100 m on the selection blocks, each tub's count over its "
                  "best trained model's (both plus one), averaged over the tubs")


def fold_blocks(fold: str, n: int) -> dict[str, str]:
    """The train, validation (epoch) and scored blocks of a fold of `n` records, as frame ranges."""
    a, b, c = int(0.2 * n), int(0.3 * n), int(0.7 * n)
    if fold == "last":
        return {"train": f"0:{c}", "val": f"{c}:{int(0.8 * n)}", "scored": f"{int(0.8 * n)}:{n}"}
    return {"train": f"{b}:{n}", "val": f"{a}:{b}", "scored": f"0:{a}"}


def fold_config(work, tub: str, fold: str, model: str, seed: int, epochs: int, n: int, patience: int = 3):
    """The training config of the model for this fold of `tub` (of `n` records), its run in `work`."""
    split = fold_blocks(fold, n)
    recipe = {"model": {"name": model}} if model in NULL else TRAINED[model]()
    return load_config(None, base={
        **recipe, "data": str(TUBS / tub), "reader": reader(tub), "cache": str(OUT / "cache"),
        "out": str(work / tub / fold / f"{model}-{seed}"), "split": {"train": split["train"], "val": split["val"]},
        "train": {**recipe.get("train", {}), "epochs": epochs, "patience": patience, "seed": seed}})


def checkpoint(work, tub: str, fold: str, model: str, seed: int, epochs: int, n: int, patience: int = 3):
    """The model's best.pt for this fold (trained in `work` once; a null model trains in no time)."""
    cfg = fold_config(work, tub, fold, model, seed, epochs, n, patience)
    run = Path(cfg.out)
    if (run / "best.pt").exists():
        if changes := run_changes(run, cfg):  # a finished run of another recipe is not this model's
            raise another_config(run, changes, f"{model}'s finished run")
        return run / "best.pt"
    train(cfg, progress=False)
    return run / "best.pt"


def score(ckpt, tub: str, fold: str, n: int, where, part: str = "scored") -> dict:
    """Open loop and replay of `ckpt` on the fold's block `part` of `tub` (its scored block, or `val`: the selection
    block)."""
    block = Source(str(TUBS / tub), fold_blocks(fold, n)[part], reader=reader(tub))
    m = evaluate(ckpt, block, where / "test", progress=False)
    r = run_replay([ckpt], block, where / "replay", TrackReplayOptions(workers=1), progress=False)[0]
    return {**{k: m[k] for k in ("mae", "throttle_mae", "gamma_deg", "target_gamma_deg") if k in m},
            **per_metre(r["interventions"], r["km"])}


def per_metre(interventions: int, km: float) -> dict:
    return {"interventions": interventions, "m": 1000 * km, "per_100m": 100 * interventions / max(1000 * km, 1e-9)}


def span(blocks: str) -> tuple[int, int]:
    start, stop = blocks.split(":")
    return int(start), int(stop)


def donkey_result(python, work, tub: str, fold: str, run: int, rec, views: bool = False) -> dict | None:
    """donkeycar's linear model of this fold, run `run` (its trainer draws its own split and initialisation),
    trained by `donkey train` on the fold's training and validation blocks as one tub (donkeycar splits it 80/20 at
    random, as its users train) and, with `views`, beside it pilotnet-views's views of the same records as a second
    tub (`views_tub`), scored on the scored block as `score` scores steerlab's models; None when `donkey train`
    failed."""
    where, blocks = work / tub / fold, fold_blocks(fold, len(rec))
    car = donkey_car(python, work / "donkeycar-car")
    keep = {int(rec.frame_ids[i]) for part in ("train", "val") for i in range(*span(blocks[part]))}
    tubs = str(training_tub(TUBS / tub, keep, where / "donkeycar-tub"))
    if views:
        cfg = fold_config(work, tub, fold, "pilotnet-views", 0, 1, len(rec))  # its data and views: no run of it
        tubs += f",{views_tub(cfg, keep, where / 'donkeycar-views-tub')}"
    name = DONKEY_VIEWS if views else DONKEY_LINEAR
    model = where / f"{name}-{run}.h5"
    seconds = donkey_train(python, car, tubs, model, "linear", where / f"{name}-{run}.log")
    if seconds is None:
        return None
    start, stop = span(blocks["scored"])
    scores = donkey_scores(python, car, model, "linear", rec, start, stop, where)
    r = replay_donkey(python, car, model, "linear", TUBS / tub, start, stop, where / f"{name}-{run}.log")
    return {**scores, "train_s": seconds, **per_metre(r["interventions"], r["km"])}


@dataclass(frozen=True)
class TubReplay(Options):
    seeds: int = option(2, AT_LEAST_1, help="runs of every trained model")
    epochs: int = option(10, AT_LEAST_1, help="epochs at most (the best on the fold's validation block kept)")
    patience: int = option(3, AT_LEAST_1, help="epochs without a better validation MAE before training stops (the "
                           "tub defaults as shipped: --epochs 30 --patience 5)")
    tubs: str = option(",".join(TUB_NAMES), help=f"comma list of the shared tubs to run on, of {', '.join(TUB_NAMES)}")
    models: str = option(MODELS, help=f"comma list of the trained models, of {', '.join(TRAINED)} (the null "
                         "models and other-track, pilotnet-views of the other tubs, always)")
    donkeycar: bool = option(False, help="also donkeycar's linear model by its own trainer, in its own environment "
                             "(runs/donkeycar-venv, made on first use)")
    donkeycar_views: bool = option(False, help="also donkeycar's linear model trained on pilotnet-views's views of "
                                   "its records as well, written as a second tub (the same extra frames)")

    @classmethod
    def related(cls, v):
        yield from names_held(v, "tubs", TUB_NAMES, "shared tubs")
        yield from names_held(v, "models", list(TRAINED), "trained models")


def rows_of(results: dict, tubs: list[str]) -> tuple[list[str], dict]:
    """The table's rows (one per tub, fold and model: its runs' mean and min-max) and each block's check."""
    lines, checks = [], {}
    for tub in tubs:
        for fold in FOLDS:
            runs = {}
            for key, r in results.items():
                t, f, model, _ = key.split(" ")
                if (t, f) == (tub, fold):
                    runs.setdefault(model, []).append(r)
            if not runs:
                continue
            per = {m: float(np.mean([r["per_100m"] for r in rs])) for m, rs in runs.items()}
            trained = min((per[m] for m in (*TRAINED, DONKEY_LINEAR, DONKEY_VIEWS) if m in per), default=None)
            nothing = min((per[m] for m in (*NULL, "other-track") if m in per), default=None)
            ok = None if trained is None or nothing is None else nothing >= 2 * trained
            checks[(tub, fold)] = (trained, nothing, ok)
            metres = next(iter(runs.values()))[0]["m"]
            linear = float(np.mean([r["mae"] for r in runs[DONKEY_LINEAR]])) if DONKEY_LINEAR in runs else None
            for model, rs in runs.items():
                ratio = "-" if linear is None else f"{float(np.mean([r['mae'] for r in rs])) / linear:.2f}x"
                lines.append(f"| {tub} | {fold} ({metres:.0f} m) | {model} | {len(rs)} | "
                             f"{mean_min_max([r['mae'] for r in rs], '.4f')} | {ratio} | "
                             f"{mean_min_max([r.get('throttle_mae') for r in rs], '.4f')} | "
                             f"{mean_min_max([r.get('gamma_deg') for r in rs], '.3f')} | "
                             f"{mean_min_max([r['interventions'] for r in rs], '.1f')} | "
                             f"{mean_min_max([r['per_100m'] for r in rs], '.1f')} |")
            human = next((r["target_gamma_deg"] for rs in runs.values() for r in rs if "target_gamma_deg" in r), None)
            if human is not None:
                lines.append(f"| {tub} | {fold} | the human (recorded) | | | | | {human:.3f} | | |")
            said = "-" if ok is None else (f"{'yes' if ok else 'no'}: the best trained model {trained:.1f}, the best "
                                           f"that learned nothing or another track {nothing:.1f}")
            lines.append(f"| {tub} | {fold} | **separates** | | | | | | | {said} |")
    return lines, checks


def selection_rows(results: dict, tubs: list[str]) -> tuple[list[str], str]:
    """The selection blocks' table (per tub and trained model scored on both folds' validation blocks: the mean over
    the folds of the mean over its runs of the steering MAE and of the interventions per 100 m, and that count over
    the tub's best, each plus one: a best of 0 stays a number) and the choice: the trained model of the lowest mean
    over the tubs of that ratio (`SELECTION_RULE`), among those scored on every tub."""
    lines, ratios = [], {}
    for tub in tubs:
        runs = {}
        for key, r in results.items():
            t, fold, model, _ = key.split(" ")
            if t == tub and model in TRAINED and "selection" in r:
                runs.setdefault(model, {}).setdefault(fold, []).append(r["selection"])
        runs = {m: folds for m, folds in runs.items() if set(folds) == set(FOLDS)}
        if not runs:
            continue

        def over_folds(folds, key):
            return float(np.mean([np.mean([r[key] for r in folds[f]]) for f in FOLDS]))

        per = {m: over_folds(folds, "per_100m") for m, folds in runs.items()}
        best = min(per.values())
        for model, folds in runs.items():
            ratios.setdefault(model, {})[tub] = (per[model] + 1) / (best + 1)
            every = [r for f in FOLDS for r in folds[f]]
            lines.append(f"| {tub} | {model} | {len(every)} | {over_folds(folds, 'mae'):.4f} "
                         f"({min(r['mae'] for r in every):.4f}-{max(r['mae'] for r in every):.4f}) | "
                         f"{per[model]:.1f} ({min(r['per_100m'] for r in every):.1f}-"
                         f"{max(r['per_100m'] for r in every):.1f}) | {ratios[model][tub]:.2f} |")
    scored = [t for t in tubs if any(t in r for r in ratios.values())]
    complete = {m: float(np.mean([r[t] for t in scored])) for m, r in ratios.items() if all(t in r for t in scored)}
    if not complete:
        return lines, "Chosen: - (no trained model has selection scores on every tub)"
    pick = min(complete, key=complete.get)
    return lines, (f"Chosen ({SELECTION_RULE}): **{pick}**, {complete[pick]:.2f}x the best on average over "
                   f"{', '.join(scored)}; " + ", ".join(f"{m} {v:.2f}x" for m, v in sorted(complete.items(),
                                                                                          key=lambda kv: kv[1])))


def plot(path, results: dict, tubs: list[str]) -> None:
    """Interventions per 100 m of every model on every scored block, one group of bars a block."""
    models = [m for m in (*NULL, *TRAINED, DONKEY_LINEAR, DONKEY_VIEWS, "other-track")
              if any(k.split(" ")[2] == m for k in results)]
    blocks = [(t, f) for t in tubs for f in FOLDS if any(k.startswith(f"{t} {f} ") for k in results)]
    with figure(path, 1, 1, figsize=(1.8 * max(len(blocks), 1) + 4, 4.5)) as (fig, ax):
        width = 0.8 / len(models)
        for i, (model, color) in enumerate(zip(models, COLORS if len(models) <= len(COLORS) else MANY_COLORS)):
            values = [np.mean([r["per_100m"] for k, r in results.items() if k.startswith(f"{t} {f} {model} ")] or
                              [np.nan]) for t, f in blocks]
            ax.bar(np.arange(len(blocks)) + (i - len(models) / 2 + 0.5) * width, values, width, color=color,
                   label=model)
        ax.set_xticks(np.arange(len(blocks)), [f"{t}\n{f} block" for t, f in blocks])
        ax.set_ylabel("replay: interventions per 100 m")
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
        ax.set_title(f"the small cars' replay on the shared tubs' scored blocks\n(full lock {FULL_LOCK_DEG:g} deg, "
                     "0.9 m lane)", fontsize=9)


def parser():
    return script_parser(__spec__.name, __doc__, TubReplay)


def main(_, args: TubReplay) -> None:
    tubs = names_from(args.tubs, TUB_NAMES, "shared tubs")
    models = names_from(args.models, list(TRAINED), "trained models")
    if not (TUBS / "hall" / "manifest.json").exists():
        print(f"skipped: {TUBS} not found")
        return
    print(f"machine: {machine()}", flush=True)
    work = OUT / (f"epochs-{args.epochs}" + (f"-patience-{args.patience}" if args.patience != 3 else ""))  # others
    work.mkdir(parents=True, exist_ok=True)
    file = work / "results.json"
    results = json.loads(file.read_text()) if file.exists() else {}
    recs = {t: Source(str(TUBS / t), reader=reader(t)).open() for t in tubs}
    sizes = {t: len(rec) for t, rec in recs.items()}
    python = donkey_python() if args.donkeycar or args.donkeycar_views else None

    def run(tub, fold, model, seed, ckpt):
        key = f"{tub} {fold} {model} {seed}"
        if key not in results:
            r = (donkey_result(python, work, tub, fold, seed, recs[tub], model == DONKEY_VIEWS)
                 if model in (DONKEY_LINEAR, DONKEY_VIEWS) else
                 score(ckpt(), tub, fold, sizes[tub], work / tub / fold / f"scored-{model}-{seed}"))
            if r is None:
                return
            results.update(keep_result(file, key, r))
            print(f"  {key}: MAE {r['mae']:.4f}, {r['interventions']} interventions in {r['m']:.0f} m", flush=True)
        if model in TRAINED and "selection" not in results[key]:  # the block the recipe is chosen on
            r = score(ckpt(), tub, fold, sizes[tub], work / tub / fold / f"selection-{model}-{seed}", "val")
            results.update(keep_result(file, key, {**results[key], "selection": r}))
            print(f"  {key}, selection block: MAE {r['mae']:.4f}, {r['interventions']} interventions in "
                  f"{r['m']:.0f} m", flush=True)

    for seed in range(args.seeds):
        for tub in tubs:
            for fold in FOLDS:
                donkey = [m for m, on in ((DONKEY_LINEAR, args.donkeycar), (DONKEY_VIEWS, args.donkeycar_views)) if on]
                for model in (*NULL, *models, *donkey):
                    if model in NULL and seed > 0:
                        continue  # a null model is the same every run
                    run(tub, fold, model, seed, lambda: checkpoint(work, tub, fold, model, seed, args.epochs,
                                                                     sizes[tub], args.patience))
        for tub in tubs:  # the views model of each other tub's fold `last`
            for other in tubs:
                if other != tub:
                    for fold in FOLDS:
                        run(tub, fold, "other-track", f"{other}-{seed}", lambda: checkpoint(
                            work, other, "last", "pilotnet-views", seed, args.epochs, sizes[other], args.patience))
    lines, _ = rows_of(results, tubs)
    table = "\n".join([f"machine: {machine()}", "", "| tub | scored block | model | runs | steering MAE (open loop) | "
                       "/ donkeycar linear's | throttle MAE | gamma [deg] | replay: interventions | per 100 m |",
                       "|---|---|---|---|---|---|---|---|---|---|", *lines]) + "\n"
    picked, chosen = selection_rows(results, tubs)
    table += "\n".join(["", "Selection blocks (each fold's validation block: the recipe is chosen here, never on the "
                         "scored blocks):", "", "| tub | model | runs | steering MAE (open loop) | replay: per 100 m | "
                         "/ the tub's best |", "|---|---|---|---|---|---|", *picked, "", chosen]) + "\n"
    (work / "table.md").write_text(table)
    plot(work / "table.png", results, tubs)
    print(table)
    print(f"wrote {work / 'table.md'} and {work / 'table.png'}")


if __name__ == "__main__":
    run_script(parser(), main)
