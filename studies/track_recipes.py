"""Racing the track world: recipes chosen in the closed loop, and donkeycar's own linear model beside them.

Every recipe trains on the same tubs: the racing expert recorded with `steerlab sim record --world track` on tracks
1-4 in both styles (taped and a painted centre line), 2 minutes each (recorded here where they are missing), or, for
a recipe with `tubs` and `only` (`rooms` and the recipes on it), on tracks 5-20 in rooms of their own, one minute
each (configs/track_best.yaml's header records these), or tracks 21-52, 30 s each (`rooms-32`). A recipe is the
config `BASE` (donkeycar linear's recipe written as a steerlab config) with a few `section.key=value` overrides
(`RECIPES`): one factor at a time from donkeycar's recipe towards steerlab's tub default, and the levers of
small-car racing. Each trains with every `--seeds` seed (`train.seed`) and races the track suite `--suite` (default
s1, the selection tracks; t1 scores) at every `--caps` throttle cap, through the donkeycar part. donkeycar's linear
model, trained by donkeycar's own trainer on the same tubs in its own environment (`donkey train --type linear`, its
default config: a random 80/20 split, early stopping; `--donkeycar-runs` runs, three by default: they are not
seeded), races the same tracks behind a pipe (`_donkey_part.py`). Like with like on the same records both ways:
`--donkeycar-ours` trains donkeycar's model on the records steerlab's recipe trains on (the first tub's validation
block deleted), and the recipe `mae-donkey-split` trains steerlab's on donkeycar's split (the tubs merged into one,
a random 20 % of all records validating).

Per cap, every checkpoint is summarised over the same tracks (`track.suite.summarize`): laps, clean laps and their
share, tracks finished, off-track events per lap and the pace over the tracks that every checkpoint compared
finished. `OUT/<--table>.md`, `.csv`, `.json` (default `table`): per recipe, the mean over its seeds and each
seed's values; `OUT/<suite>-max<cap>/`: the suite's own tables and every drive. Everything is kept and reused: a
rerun trains and drives only what is missing.

python -m studies.track_recipes [--recipes donkey,gray,...] [--seeds 0,1] [--suite s1] [--caps 1,0.5]
    [--donkeycar [--donkeycar-runs 3] [--donkeycar-tubs donkey] [--donkeycar-throttle-scale 1]
    [--donkeycar-throttle-floor 0] [--donkeycar-ours]]
    [--workers 2] [--out runs/race] [--table table]
"""

from __future__ import annotations

import csv
import json
import math
import shutil
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.data.car import CARS
from steerlab.data.readers import open_recording
from steerlab.options import AT_LEAST_1, SEED, WORKERS, Options, Range, names_from, names_held, option
from steerlab.sim.track.suite import TRACK_SUITES, TrackSuiteOptions, part_entrant, race, report, summarize
from steerlab.sim.track.world import throttle_floor_option, throttle_scale_option
from studies.common import ROOT, NumberList, machine, mean_min_max, track_tub
from studies.common.donkeycar import DonkeycarPart, donkey_models, donkey_python, training_tub

TUBS = [f"{style}-{seed}" for style in ("taped", "centre") for seed in (1, 2, 3, 4)]
TUB_MINUTES = 2.0
DONKEYCAR = "donkeycar"          # the label of donkeycar's own runs


def base(tubs: Path) -> dict:
    """donkeycar linear's recipe as a steerlab config: its network (`donkey-linear`) on the whole 160x120 RGB
    frame, the MSE of the steering plus the MAE of the throttle with weight 1 (donkeycar's trainer: the MSE of
    both), batches of 128, Adam 1e-3, early stopping with patience 3 (at most 15 epochs); validation on a block (the
    last 538 records of the first taped tub)."""
    return {"data": str(tubs / TUBS[0]), "extra_data": [str(tubs / t) for t in TUBS[1:]],
            "reader": {"full_lock_deg": CARS["donkey"].full_lock_deg}, "cache": str(tubs.parent / "cache"),
            "preprocess": {"crop": [0, 0, 0, 0], "width": 160, "height": 120, "color": "rgb"},
            "model": {"name": "donkey-linear"}, "split": {"train": "0:1800", "val": "1800:2338"},
            "train": {"epochs": 15, "patience": 3, "batch_size": 128, "lr": 1e-3, "loss": "mse",
                      "throttle_weight": 1.0}}


@dataclass(frozen=True)
class Recipe:
    """What differs from donkeycar's recipe (`what`): config overrides (`{init}` in one stands for the checkpoint of
    the recipe `starts` with the same seed), options of the suite it races with (`race`: a steering step, a
    latency), more tubs to train on (`tubs`: names of `AUGMENT`; with `only`, these tubs instead of `TUBS`, the
    first validating on its last `only` records; with `merged`, these tubs as one, `merged_tub`, split as the
    overrides say), and `starts`: the recipe it builds on (with no overrides it races
    that recipe's checkpoint as it is)."""

    what: str
    overrides: tuple[str, ...] = ()
    race: dict = field(default_factory=dict)
    tubs: tuple[str, ...] = ()
    only: int = 0
    starts: str | None = None
    merged: bool = False


# the same tracks 1-4 in other rooms (floor, light, clutter) and seen from other camera mounts
AUGMENT = {f"{style}-{seed}-room": [style, str(seed), "--room", str(100 + seed), "--mount-height",
                                    str(round(0.15 + 0.02 * (seed - 2.5), 3)), "--pitch", str(20 + 2 * (seed - 2.5))]
           for style in ("taped", "centre") for seed in (1, 2, 3, 4)}
# sixteen other tracks, each in its own room, one minute each: the same 16 minutes as TUBS from 16 rooms, not 4
AUGMENT |= {f"{style}-{seed}-1min": [style, str(seed), "--minutes", "1"]
            for style, seeds in (("taped", range(5, 17)), ("centre", range(17, 21))) for seed in seeds}
ROOMS = tuple(name for name in AUGMENT if name.endswith("-1min"))
# thirty-two more tracks, each in its own room, 30 s each: again 16 minutes, from 32 rooms
AUGMENT |= {f"{style}-{seed}-30s": [style, str(seed), "--minutes", "0.5"]
            for style, seeds in (("taped", range(21, 45)), ("centre", range(45, 53))) for seed in seeds}
ROOMS_32 = tuple(name for name in AUGMENT if name.endswith("-30s"))
# the sixteen rooms' tracks driven without drift-and-recover episodes: no recovery shown
AUGMENT |= {f"{style}-{seed}-1min-no-drift": [style, str(seed), "--minutes", "1", "--no-drift"]
            for style, seeds in (("taped", range(5, 17)), ("centre", range(17, 21))) for seed in seeds}
ROOMS_NO_DRIFT = tuple(name for name in AUGMENT if name.endswith("-no-drift"))
# up to 64 more tracks, a minute each, each in a varied room (`sim record --vary`): three taped to one centre-line,
# the first 16 and 32 of them the smaller sets of the data-scale curve
AUGMENT |= {f"{style}-{seed}-vary": [style, str(seed), "--minutes", "1", "--vary"]
            for style, seeds in (("taped", range(200, 248)), ("centre", range(248, 264))) for seed in seeds}

# frames from poses drawn around the expert's line (`sim record --poses`) on the sixteen rooms' tracks, in their rooms:
# the places and speeds of M minutes of its drive, the rear axle within +-1.25 half lane widths, turned within +-30 deg
POSE_MINUTES = (0.25, 0.5, 1.0)
AUGMENT |= {f"{style}-{seed}-poses-{m:g}": [style, str(seed), "--minutes", f"{m:g}", "--poses"]
            for m in POSE_MINUTES for style, seeds in (("taped", range(5, 17)), ("centre", range(17, 21)))
            for seed in seeds}



def with_poses(minutes: float) -> tuple[str, ...]:
    """The sixteen rooms' tubs and their pose frames of `minutes` each (the first validates)."""
    return (*ROOMS, *(n for n in AUGMENT if n.endswith(f"-poses-{minutes:g}")))


def varied(n: int) -> tuple[str, ...]:
    """The first n varied tubs, three of every four taped (the first validates)."""
    taped, centre = [f"taped-{s}-vary" for s in range(200, 248)], [f"centre-{s}-vary" for s in range(248, 264)]
    return (*taped[: n * 3 // 4], *centre[: n // 4])
COLOUR = ("train.hue_deg=180", "train.brightness=0.25")  # the colours and light of other rooms
BEST = (*COLOUR, "train.flip=true", "train.loss=mae", "train.epoch_samples=3700")  # configs/track_best.yaml
RACE_BEST = {"throttle_scale": 1.2}  # its scale uncapped (and its floor at rest: best-floor-0.2)


def dagger_rounds(epochs: int) -> tuple[str, ...]:
    """The overrides of DAgger in the track world from the recipe a recipe `starts` with: one more epoch, then 3
    rounds of 4 minutes of uncapped rollouts on fresh tracks, `epochs` epochs a round, s1 at 1 minute a track after
    each."""
    return ("train.init={init}", "train.epochs=1",
            "dagger={world: track, suite: s1, suite_minutes: 1.0, iterations: 3, minutes: 4.0, beta: 0.5, "
            f"beta_decay: 0.5, epochs: {epochs}, max_throttle: 1.0, seeds_from: 6000}}")


CROP, GRAY_200x66 = ["preprocess.crop=[40,0,0,0]", "preprocess.height=80"], ["preprocess.width=200",
                                                                             "preprocess.height=66"]
RECIPES = {
    # one factor at a time from donkeycar linear's recipe
    "donkey": Recipe("donkeycar linear's recipe"),
    "crop": Recipe("the donkey crop (the top 40 rows off: 160x80)", tuple(CROP)),
    "gray": Recipe("gray instead of RGB", ("preprocess.color=gray",)),
    "200x66": Recipe("resized to 200x66", tuple(GRAY_200x66)),
    "pilotnet": Recipe("PilotNet's network", ("model.name=pilotnet",)),
    "mae": Recipe("the MAE of the steering", ("train.loss=mae",)),
    "random-split": Recipe("a random 20 % of the first tub validates", ("split={random: 0.2}",)),
    "throttle-0.5": Recipe("the throttle's weight 0.5", ("train.throttle_weight=0.5",)),
    "batch-32": Recipe("batches of 32, Adam 3e-4", ("train.batch_size=32", "train.lr=3.0e-4")),
    "lstm": Recipe("recurrent: the CNN-LSTM", ("model.name=lstm",)),
    "tub-default": Recipe("steerlab's tub default (multimodal-lstm, gray 200x66 crop, MAE, batch 32, Adam 3e-4, "
                          "throttle weight 0.5)",
                          ("model.name=multimodal-lstm", "preprocess.crop=[40,0,0,0]", *GRAY_200x66,
                           "preprocess.color=gray", "train.loss=mae", "train.batch_size=32", "train.lr=3.0e-4",
                           "train.throttle_weight=0.5")),
    # the levers of small-car racing, on donkeycar's recipe
    "dagger": Recipe("+ DAgger in the track world: 3 rounds of 4 minutes of rollouts, uncapped, the expert's labels "
                     "at the car's speed", dagger_rounds(3), starts="donkey"),
    "steering-step": Recipe("+ the steering's change limited to 0.1 of full lock per frame",
                            race={"steering_step": 0.1}, starts="donkey"),
    "latency": Recipe("+ a frame one tick old (a real part's latency), labels not shifted", race={"latency": 1},
                      starts="donkey"),
    "latency-matched": Recipe("+ a frame one tick old, trained on the steering one tick later",
                              ("train.target_shift_s=0.05",), race={"latency": 1}),
    "stack-3": Recipe("+ three stacked frames", ("preprocess.stack=3",)),
    "augment": Recipe("+ the same tracks in other rooms and from other camera mounts (8 more tubs)",
                      tubs=tuple(name for name in AUGMENT if name.endswith("-room"))),
    "rooms": Recipe("16 tracks in 16 rooms, 1 minute each, instead of 4 tracks in 4 rooms, 2 minutes each (12 taped, "
                    "4 centre-line; as many records)", tubs=ROOMS, only=240),
    "rooms-colour": Recipe("rooms + the colours and light of other rooms: the hue turned within +-180 degrees and "
                           "the brightness scaled within 1 +- 0.25 (train.hue_deg, train.brightness)",
                           COLOUR, tubs=ROOMS, only=240),
    "rooms-colour-flip": Recipe("rooms-colour + each sample mirrored left-right with probability 0.5, its steering "
                                "negated (paper 002 IV-B1's flips; train.flip): each tub turns one way round its "
                                "loop, 10 of the 16 to the right",
                                (*COLOUR, "train.flip=true"), tubs=ROOMS, only=240),
    "flip-smooth-0.5": Recipe("rooms-colour-flip driven with its steering smoothed, s = 0.5 y + 0.5 s' (paper 002's "
                              "exponential smoothing; --smoothing 0.5)", race={"smoothing": 0.5},
                              starts="rooms-colour-flip"),
    "flip-smooth-0.7": Recipe("rooms-colour-flip driven with its steering smoothed, s = 0.7 y + 0.3 s' "
                              "(--smoothing 0.7)", race={"smoothing": 0.7}, starts="rooms-colour-flip"),
    "flip-step": Recipe("rooms-colour-flip driven with the steering's change limited to 0.1 of full lock per frame",
                        race={"steering_step": 0.1}, starts="rooms-colour-flip"),
    "flip-mae": Recipe("rooms-colour-flip trained on the MAE of the steering (the tub default's loss) instead of "
                       "its MSE (the throttle's error is the MAE in both)",
                       BEST, tubs=ROOMS, only=240),
    "mae-throttle-1.2": Recipe("flip-mae driven with its learned throttle times 1.2 before the cap "
                               "(--throttle-scale 1.2)", race={"throttle_scale": 1.2}, starts="flip-mae"),
    "mae-throttle-1.5": Recipe("flip-mae driven with its learned throttle times 1.5 before the cap "
                               "(--throttle-scale 1.5)", race={"throttle_scale": 1.5}, starts="flip-mae"),
    "mae-throttle-2": Recipe("flip-mae driven with its learned throttle times 2 before the cap "
                             "(--throttle-scale 2)", race={"throttle_scale": 2.0}, starts="flip-mae"),
    "flip-throttle-1.2": Recipe("rooms-colour-flip driven with its learned throttle times 1.2 before the cap "
                                "(--throttle-scale 1.2, as donkeycar's AI_THROTTLE_MULT)", race={"throttle_scale": 1.2},
                                starts="rooms-colour-flip"),
    "flip-throttle-1.5": Recipe("rooms-colour-flip driven with its learned throttle times 1.5 before the cap "
                                "(--throttle-scale 1.5)", race={"throttle_scale": 1.5}, starts="rooms-colour-flip"),
    "rooms-colour-15": Recipe("rooms-colour trained all 15 epochs and the last kept, not stopped early on the "
                              "240-record validation block (donkeycar's trainer stops on a random 20 % of every "
                              "tub, which keeps falling: it trains 30 epochs)",
                              (*COLOUR, "train.keep=last"), tubs=ROOMS, only=240),
    "rooms-32": Recipe("rooms-colour-15 on 32 tracks in 32 rooms, 30 s each (24 taped, 8 centre-line; as many "
                       "records), instead of 16 in 16, a minute each",
                       (*COLOUR, "train.keep=last"), tubs=ROOMS_32, only=240),
    "mae-donkey-split": Recipe("flip-mae on donkeycar's split: the sixteen tubs as one, a random 20 % of all its "
                               "records validating (donkeycar's trainer: a random 80/20 split of every record), "
                               "at track_best's scale (--throttle-scale 1.2)",
                               (*BEST, "split={random: 0.2}"),
                               race={"throttle_scale": 1.2}, tubs=ROOMS, merged=True),
    "donkey-split-floor-0.2": Recipe("mae-donkey-split driven as track_best is: with a throttle of at least 0.2 while "
                                     "the car stands (--throttle-floor 0.2)",
                                     race={**RACE_BEST, "throttle_floor": 0.2}, starts="mae-donkey-split"),
    # the levers of recovery and racing on track_best (flip-mae, x 1.2 uncapped; each alone, without the floor)
    "best-no-drift": Recipe("track_best on the same tracks driven without drift-and-recover episodes (the "
                            "recovery the expert shows left out)", BEST, RACE_BEST, ROOMS_NO_DRIFT, only=240),
    "best-no-drift-floor-0.2": Recipe("best-no-drift driven as track_best is (--throttle-floor 0.2)",
                                      race={**RACE_BEST, "throttle_floor": 0.2}, starts="best-no-drift"),
    # views (train.views through the fisheye, labelled by replay's return to the path, pursuing the point 0.3 s
    # ahead as the expert does: docs/results/views.md) buying back the drift episodes' recovery
    "best-no-drift-views": Recipe("best-no-drift + one view of every frame, its camera moved within +-0.15 m and "
                                  "turned within +-15 degrees (train.views, train.recovery_s 0.3), driven as "
                                  "best-floor-0.2", (*BEST, "train.views=[[[-0.15, 0.15], [-15, 15]]]",
                                                     "train.recovery_s=0.3"),
                                  {**RACE_BEST, "throttle_floor": 0.2}, ROOMS_NO_DRIFT, only=240),
    "best-dagger": Recipe("track_best + DAgger in the track world: 3 rounds of 4 minutes of rollouts on fresh tracks, "
                          "uncapped, the expert's labels at the car's speed, 2 epochs a round",
                          dagger_rounds(2), RACE_BEST, ROOMS, only=240, starts="flip-mae"),
    "best-latency-matched": Recipe("track_best on a frame one tick old (a real part's latency), trained on the "
                                   "steering one tick later", (*BEST, "train.target_shift_s=0.05"),
                                   {**RACE_BEST, "latency": 1}, ROOMS, only=240),
    "best-stack-3": Recipe("track_best on three stacked frames (the motion: whether the car moves at all)",
                           (*BEST, "preprocess.stack=3"), RACE_BEST, ROOMS, only=240),
    "best-floor-0.2": Recipe("track_best driven with a throttle of at least 0.2 while the car stands "
                             "(--throttle-floor 0.2)", race={**RACE_BEST, "throttle_floor": 0.2}, starts="flip-mae"),
    # frames from every pose: track_best's tubs and M minutes of pose frames of each of their tracks
    **{f"best-poses-{m:g}": Recipe(f"track_best + {m:g} min of pose frames of each of its sixteen tracks in its room "
                                   "(sim record --poses: the rear axle within +-1.25 half lane widths, turned within "
                                   "+-30 degrees, the expert's controls from there), driven as best-floor-0.2",
                                   BEST, {**RACE_BEST, "throttle_floor": 0.2},
                                   with_poses(m), only=240)
       for m in POSE_MINUTES},
    # the lane head (train.lane_weight 0.5) on track_best's tubs without and with pose frames, driven by its steering
    # head and by the lane controller on the lane it sees (--steer-by lane)
    "best-lane": Recipe("track_best + a lane head (train.lane_weight 0.5), driven by its steering head as "
                        "best-floor-0.2", (*BEST, "train.lane_weight=0.5"), {**RACE_BEST, "throttle_floor": 0.2},
                        ROOMS, only=240),
    "best-poses-0.5-lane": Recipe("best-poses-0.5 + a lane head (train.lane_weight 0.5), driven by its steering head",
                                  (*BEST, "train.lane_weight=0.5"), {**RACE_BEST, "throttle_floor": 0.2},
                                  with_poses(0.5), only=240),
    **{f"{name}-by-lane": Recipe(f"{name} steering by the lane it sees (--steer-by lane: the lane controller, "
                                 "Stanley's law)", race={**RACE_BEST, "throttle_floor": 0.2, "steer_by": "lane"},
                                 starts=name) for name in ("best-lane", "best-poses-0.5-lane")},
    # the data-scale curve of varied rooms (docs/results/racing.md, "Rooms that cannot be memorised")
    **{f"vary-{n}": Recipe(f"track_best on {n} tracks in {n} varied rooms (sim record --vary), a minute each",
                           BEST, RACE_BEST, varied(n), only=240) for n in (16, 32, 64)},
    "rooms-dagger": Recipe("rooms + DAgger in the track world: 3 rounds of 4 minutes of rollouts on fresh tracks, "
                           "uncapped, the expert's labels at the car's speed, 2 epochs a round",
                           dagger_rounds(2), tubs=ROOMS, only=240, starts="rooms"),
}


def record_tubs(tubs: Path, names) -> None:
    """The tubs `names` (of TUBS and AUGMENT), recorded where they are missing."""
    for name in names:
        style, seed, *extra = AUGMENT.get(name) or name.split("-")
        minutes = [] if "--minutes" in extra else ["--minutes", str(TUB_MINUTES)]
        track_tub(tubs / name, "--style", style, "--seed", seed, *minutes, *extra)


def recipe_base(name: str, tubs: Path) -> dict:
    """`base` on the tubs the recipe trains on (`recipe_tubs`), or on them merged into one; with `only`, the split is
    set where they are recorded."""
    if RECIPES[name].merged:
        merged = merged_tub(tubs, RECIPES[name].tubs, tubs / f"{name}-merged")
        return base(tubs) | {"data": str(merged), "extra_data": []}
    first, *rest = recipe_tubs(name)
    return base(tubs) | {"data": str(tubs / first), "extra_data": [str(tubs / t) for t in rest]}


def without_validation(tubs: Path, name: str, only: int) -> Path:
    """The tub `name` as steerlab's recipe trains on it: its last `only` usable records (the recipe's validation)
    deleted (`training_tub`: the images linked), so that donkeycar's trainer gets the records steerlab's does."""
    lines = (tubs / name / "manifest.json").read_text().splitlines()
    catalogs = json.loads(lines[4])
    gone = set(catalogs["deleted_indexes"])
    usable = [json.loads(line)["_index"] for c in catalogs["paths"] for line in (tubs / name / c).read_text().splitlines()
              if line.strip() and json.loads(line)["_index"] not in gone]
    out = tubs / f"{name}-train"
    return out if (out / "manifest.json").exists() else training_tub(tubs / name, set(usable[:-only]), out)


def merged_tub(tubs: Path, names, out: Path) -> Path:
    """The tubs `names` as one tub (made once): their records one after another, each tub's sessions its own and its
    timestamps an hour after the tub before, its deleted records deleted, its images linked, not copied. A random
    split of it draws from every tub's records, as donkeycar's trainer splits the tubs it is given."""
    if (out / "manifest.json").exists():
        return out
    part = out.with_name(out.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    (part / "images").mkdir(parents=True)
    records, deleted, sessions = [], [], []
    for k, name in enumerate(names):
        lines = (tubs / name / "manifest.json").read_text().splitlines()
        catalogs = json.loads(lines[4])
        gone = set(catalogs["deleted_indexes"])
        for rec in (json.loads(line) for c in catalogs["paths"] for line in (tubs / name / c).read_text().splitlines()
                    if line.strip()):
            image = f"{k}_{rec['cam/image_array']}"
            (part / "images" / image).symlink_to((tubs / name / "images" / rec["cam/image_array"]).resolve())
            if rec["_index"] in gone:
                deleted.append(len(records))
            session = f"{k}-{rec['_session_id']}"
            sessions += [] if session in sessions else [session]
            records.append({**rec, "_index": len(records), "_session_id": session, "cam/image_array": image,
                            "_timestamp_ms": rec["_timestamp_ms"] + k * 3_600_000})
    (part / "catalog_0.catalog").write_text("".join(json.dumps(r) + "\n" for r in records))
    first = (tubs / names[0] / "manifest.json").read_text().splitlines()
    header = json.loads(first[3]) | {"sessions": {"all_full_ids": sessions, "last_id": len(sessions) - 1,
                                                  "last_full_id": sessions[-1]}}
    lines = first[:3] + [json.dumps(header), json.dumps({"paths": ["catalog_0.catalog"], "current_index": len(records),
                                                         "max_len": len(records), "deleted_indexes": deleted})]
    (part / "manifest.json").write_text("\n".join(lines) + "\n")
    part.rename(out)
    return out


def train_recipe(name: str, seed: int, out: Path, tubs: Path) -> Path:
    """The recipe's checkpoint for `seed` (trained once; an interrupted training resumes; DAgger where the recipe
    has a `dagger` section; a finished run of another config, the recipe changed since, is refused, not reused)."""
    from steerlab.dagger import run_dagger
    from steerlab.train.config import another_config, load_config
    from steerlab.train.loop import run_changes, train

    recipe = RECIPES[name]
    if recipe.starts and not recipe.overrides and not recipe.tubs:
        return train_recipe(recipe.starts, seed, out, tubs)
    init = train_recipe(recipe.starts, seed, out, tubs) if recipe.starts else None
    run = out / "recipes" / name / f"seed{seed}"
    record_tubs(tubs, recipe.tubs)
    cfg = recipe_base(name, tubs)
    if recipe.only:
        usable = len(open_recording(cfg["data"], options=cfg["reader"]))
        cfg["split"] = {"train": f"0:{usable - recipe.only}", "val": f"{usable - recipe.only}:{usable}"}
    cfg = load_config(None, base=cfg, overrides=[*(o.replace("{init}", str(init)) for o in recipe.overrides),
                                                 f"train.seed={seed}", f"out={run}"])
    if (run / "done.json").exists():
        if not cfg.dagger and (changes := run_changes(run, cfg)):
            raise another_config(run, changes, f"recipe {name}'s run")
    else:
        print(f"== training {name}, seed {seed}", flush=True)
        metrics = run_dagger(cfg, progress=False) if cfg.dagger else train(cfg, progress=False)
        (run / "done.json").write_text(json.dumps(metrics if isinstance(metrics, dict) else str(metrics), indent=1))
    return run / "best.pt"


def recipe_tubs(name: str) -> tuple[str, ...]:
    """The tubs a recipe trains on."""
    recipe = RECIPES[name]
    return recipe.tubs if recipe.only or recipe.merged else (*TUBS, *recipe.tubs)


def race_donkeycar(car: Path, models: list[Path], out: Path, o: TrackSuiteOptions, label: str = DONKEYCAR) -> list:
    """donkeycar's models on every track of the suite, as suite rows against the expert's drives under the same
    cap: the suite races each behind its part (`track.suite.part_entrant`; drives kept in `out/run<k>` and reused
    while the model file and the options are the same), its throttle times `o.throttle_scale` before the cap. One
    drive at a time: each part is a process of donkeycar's environment."""
    python = donkey_python()
    racing = [part_entrant(f"run{k}", model, partial(DonkeycarPart, python, car, model, out / "part.log", math.inf))
              for k, model in enumerate(models)]
    return [replace(r, label=f"{label}/{r.label}") for r in race(racing, out, replace(o, workers=1))]


def suite_options(name: str, suite: str, cap: float, workers: int) -> TrackSuiteOptions:
    """The suite a recipe races: `suite` under the throttle cap `cap`, with the recipe's own race options."""
    return TrackSuiteOptions(suite=suite, max_throttle=cap, workers=workers, **RECIPES[name].race)


def table(rows: list, cap: float) -> list[dict]:
    """Per recipe (the label's first part): the mean over its runs of each overall summary value, and the runs'."""
    overall = [s for s in summarize(rows) if s.style == "all"]
    by_recipe = {}
    for s in overall:
        by_recipe.setdefault(s.label.split("/")[0], []).append(s)
    out = []
    for name, runs in by_recipe.items():
        def mean(key):
            values = [getattr(r, key) for r in runs if getattr(r, key) is not None]
            return float(np.mean(values)) if values else None

        out.append({"recipe": name, "cap": cap, "runs": len(runs), "laps": mean("laps"),
                    "clean_pct": mean("clean_pct"), "finished": mean("finished"), "tracks": runs[0].tracks,
                    "off_track_per_lap": mean("off_track_per_lap"), "off_track": mean("off_track"),
                    "pace": mean("pace"), "pace_tracks": runs[0].pace_tracks,
                    "each": [asdict(r) for r in runs]})
    return out


def markdown(rows: list[dict], suite: str) -> str:
    what = {**{n: r.what for n, r in RECIPES.items()}, DONKEYCAR: "donkeycar's own trainer and part",
            **{f"{DONKEYCAR}-{n}": f"donkeycar's own trainer and part, on the tubs of {n}" for n in RECIPES}}
    lines = [f"Track suite {suite}, every checkpoint over the same tracks (pace: over the tracks every checkpoint of "
             "the same cap finished, their number beside it). Means over the runs (seeds), their min-max beside.", "",
             "| recipe | what differs from donkeycar's recipe | cap | runs | laps | clean laps [%] | finished | "
             "off track / lap | off track | pace (tracks) |", "|---" * 10 + "|"]

    def describe(recipe):  # donkeycar's runs: ...[-ours][-throttle-K][-floor-F] (--donkeycar-ours, its scale, floor)
        if not recipe.startswith(DONKEYCAR):
            return what.get(recipe, "")
        recipe, _, floor = recipe.partition("-floor-")
        base, _, scale = recipe.partition("-throttle-")
        ours = base.endswith("-ours")
        return (what.get(base.removesuffix("-ours"), "") + (", on steerlab's training records" if ours else "") +
                (f", its throttle times {scale} before the cap" if scale else "") +
                (f", at least {floor} while the car stands" if floor else ""))

    for r in rows:
        def f(key, fmt):  # the mean, and the runs' min-max beside it
            return "-" if r[key] is None else mean_min_max([e[key] for e in r["each"]] or [r[key]], fmt)

        lines.append(f"| {r['recipe']} | {describe(r['recipe'])} | {r['cap']:g} | {r['runs']} | "
                     f"{f('laps', '.1f')} | {f('clean_pct', '.1f')} | {f('finished', '.1f')} of "
                     f"{r['tracks']} | {f('off_track_per_lap', '.2f')} | {f('off_track', '.1f')} | "
                     f"{f('pace', '.3f')} ({r['pace_tracks']}) |")
    return "\n".join(lines) + "\n"


SEEDS = NumberList(int, SEED)
CAPS = NumberList(float, Range(0, 1, lo_open=True))  # as --max-throttle of the track commands


@dataclass(frozen=True)
class Races(Options):
    recipes: str = option(",".join(RECIPES), help="comma list of the recipes raced (empty with --donkeycar: "
                          "donkeycar's model alone)")
    seeds: str = option("0,1", SEEDS, SEEDS.words, help="training seeds (train.seed) of every recipe")
    suite: str = option("s1", lambda v: v in TRACK_SUITES, " or ".join(TRACK_SUITES),
                        help="the track suite raced (s1: selection tracks; t1 scores)")
    caps: str = option("1,0.5", CAPS, CAPS.words, help="throttle caps (the learned throttle's and the expert's)")
    donkeycar: bool = option(False, help="also donkeycar's linear model (its own trainer)")
    donkeycar_runs: int = option(3, AT_LEAST_1, help="how many runs of donkeycar's trainer race")
    donkeycar_tubs: str = option("donkey", lambda v: v in RECIPES, "a recipe", help="the recipe whose tubs donkeycar's "
                                 "trainer trains on (default: the 8 tubs of donkeycar's recipe)")
    donkeycar_throttle_scale: float = throttle_scale_option()
    donkeycar_throttle_floor: float = throttle_floor_option()
    donkeycar_ours: bool = option(False, help="donkeycar's trainer on the records steerlab's recipe trains on: the "
                                  "first tub's validation records (--donkeycar-tubs' recipe's `only`) deleted")
    workers: int = option(2, WORKERS, help="tracks driven in parallel")
    out: str = option(str(ROOT / "runs" / "race"), path="folder", help="the study's folder")
    table: str = option("table", lambda v: v and "/" not in v, "a file name without a folder",
                        help="the name of the table files in OUT (.md, .csv, .json)")

    @classmethod
    def related(cls, v):
        if v.recipes.strip() or not v.donkeycar:
            yield from names_held(v, "recipes", RECIPES, "recipes")
        if v.donkeycar_ours and not (v.donkeycar_tubs in RECIPES and RECIPES[v.donkeycar_tubs].only):
            yield "donkeycar_ours", ("given with --donkeycar-tubs of a recipe that validates on a block of its first "
                                     f"tub ({', '.join(n for n, r in RECIPES.items() if r.only)})")


def parser():
    return script_parser(__spec__.name, __doc__, Races)


def main(_, a: Races) -> None:
    recipes = names_from(a.recipes, RECIPES, "recipes") if a.recipes.strip() else []
    out = Path(a.out)
    tubs = out / "tubs"
    record_tubs(tubs, TUBS)
    caps, seeds = CAPS.of(a.caps), SEEDS.of(a.seeds)
    for name in recipes:  # each recipe races as soon as it is trained
        ckpts = [train_recipe(name, seed, out, tubs) for seed in seeds]
        for cap in caps:
            race(ckpts, out / f"{a.suite}-max{cap:g}" / name, suite_options(name, a.suite, cap, a.workers))
    suffix = "" if a.donkeycar_tubs == "donkey" else f"-{a.donkeycar_tubs}"  # donkeycar on another recipe's tubs
    suffix += "-ours" if a.donkeycar_ours else ""
    scaled = "" if a.donkeycar_throttle_scale == 1 else f"-throttle-{a.donkeycar_throttle_scale:g}"
    scaled += f"-floor-{a.donkeycar_throttle_floor:g}" if a.donkeycar_throttle_floor else ""
    folder, donkey = f"{DONKEYCAR}{suffix}{scaled}", None
    if a.donkeycar:
        record_tubs(tubs, recipe_tubs(a.donkeycar_tubs))
        names = recipe_tubs(a.donkeycar_tubs)
        if a.donkeycar_ours:
            names = (without_validation(tubs, names[0], RECIPES[a.donkeycar_tubs].only).name, *names[1:])
        donkey = donkey_models(out, tubs, a.donkeycar_runs, names, f"donkey{suffix}")
    results = []
    for cap in caps:
        o = TrackSuiteOptions(suite=a.suite, max_throttle=cap, workers=a.workers)
        suite = out / f"{a.suite}-max{cap:g}"
        rows = [replace(r, label=f"{name}/{r.label}") for name in recipes
                for r in race([train_recipe(name, seed, out, tubs) for seed in seeds],
                              suite / name, suite_options(name, a.suite, cap, a.workers))]
        if donkey:
            rows += race_donkeycar(*donkey, suite / folder, replace(o, throttle_scale=a.donkeycar_throttle_scale,
                                                                  throttle_floor=a.donkeycar_throttle_floor),
                                   folder)
        report(rows, suite, o, plots=False)
        results += table(rows, cap)
    (out / f"{a.table}.md").write_text(f"machine: {machine()}\n\n" + markdown(results, a.suite))
    (out / f"{a.table}.json").write_text(json.dumps(results, indent=1))
    with open(out / f"{a.table}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, [k for k in results[0] if k != "each"])
        w.writeheader()
        w.writerows([{k: v for k, v in r.items() if k != "each"} for r in results])
    print((out / f"{a.table}.md").read_text())


if __name__ == "__main__":
    run_script(parser(), main)
