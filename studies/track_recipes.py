"""Racing the track world: recipes chosen in the closed loop, and donkeycar's own linear model beside them.

Every recipe trains on the same tubs: the racing expert recorded with `steerlab sim record --world track` on tracks
1-4 in both styles (taped and a painted centre line), 2 minutes each (recorded here where they are missing), or, for
a recipe with `tubs` and `only` (`rooms` and the recipes on it), on tracks 5-20 in rooms of their own, one minute
each (configs/track_best.yaml's header records these), or tracks 21-52, 30 s each (`rooms-32`). A recipe is the
config `BASE` (donkeycar linear's recipe written as a steerlab config) with a few `section.key=value` overrides
(`RECIPES`): one factor at a time from donkeycar's recipe towards steerlab's tub default, and the levers of
small-car racing. Each trains with every `--seeds` seed (`train.seed`) and races the track suite `--suite` (default
s1, the selection tracks; t2 and t3 score) at every `--caps` throttle cap, through the donkeycar part. donkeycar's
linear model, trained by donkeycar's own trainer on the same tubs in its own environment (`donkey train --type
linear`, its default config: a random 80/20 split, early stopping; its own levers, at most `--donkeycar-epochs`
epochs and `--donkeycar-patience`, in its car's myconfig.py; `--donkeycar-runs` runs, three by default: they are not
seeded), races the same tracks behind a pipe (`_donkey_part.py`). Like with like on the same records both ways:
`--donkeycar-ours` trains donkeycar's model on the records steerlab's recipe trains on (the first tub's validation
block deleted), and the recipe `mae-donkey-split` trains steerlab's on donkeycar's split (the tubs merged into one,
a random 20 % of all records validating); the same extra frames: `--donkeycar-views` trains it on the views
(`train.views`) of a recipe with views as well, written as a tub of each tub it reads, and `--donkeycar-flip` on the
mirror images of a recipe with `train.flip` (every record it reads, views included, mirrored left-right, its
steering negated). `--donkeycar-cv` races donkeycar's computer-vision line follower beside them, which needs no
training (its `cv_control` template, set for each track's tape colour as its owner sets it:
`studies/common/donkeycar.py` `cv_thresholds`).

The drive-time lever chosen for each side by one rule: `--scales 1,1.2,1.5` races every recipe and donkeycar's
model at each throttle scale of the grid (a recipe's own scale and --donkeycar-throttle-scale replaced, the floors
kept) and marks the scale `SCALE_RULE` chooses for each on the unrounded means, saying where the grid does not
bracket the choice.

Per cap, every checkpoint is summarised over the same tracks (`track.suite.summarize`): laps, clean laps and their
share, tracks finished, off-track events per lap and the pace over the tracks that every checkpoint compared
finished. `OUT/<--table>.md`, `.csv`, `.json` (default `table`): per recipe, the mean over its seeds and each
seed's values; `OUT/<suite>-max<cap>/`: the suite's own tables and every drive. Everything is kept and reused: a
rerun trains and drives only what is missing.

python -m studies.track_recipes [--recipes donkey,gray,...] [--seeds 0,1] [--suite s1] [--caps 1,0.5] [--scales ...]
    [--donkeycar [--donkeycar-runs 3] [--donkeycar-tubs donkey] [--donkeycar-throttle-scale 1]
    [--donkeycar-throttle-floor 0] [--donkeycar-ours] [--donkeycar-views] [--donkeycar-flip]
    [--donkeycar-epochs 100] [--donkeycar-patience 5]]
    [--donkeycar-cv]
    [--workers 2] [--out runs/race] [--table table]
"""

from __future__ import annotations

import csv
import json
import math
import re
import shutil
from dataclasses import asdict, dataclass, replace
from functools import partial
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.data.readers import open_recording
from steerlab.options import AT_LEAST_1, SEED, WORKERS, Options, Range, names_from, names_held, option
from steerlab.sim.track.suite import TRACK_SUITES, TrackSuiteOptions, part_entrant, race, report, summarize
from steerlab.sim.track.world import throttle_floor_option, throttle_scale_option
from studies._recipes import AUGMENT, DONKEYCAR, DONKEYCAR_CV, RECIPES, TUB_MINUTES, TUBS, base
from studies.common import ROOT, Grid, NumberList, machine, mean_min_max, mean_of, track_tub
from studies.common.donkeycar import (DONKEY_TRAINING, DonkeycarLineFollower, DonkeycarPart, cv_car, donkey_models,
                                      donkey_python, mirrored_tub, training_suffix, training_tub, views_tub)


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


def usable_records(tub: Path) -> list[int]:
    """The `_index` of every record of a tub that is not deleted, in the catalogs' order: the records donkeycar's
    trainer reads."""
    catalogs = json.loads((tub / "manifest.json").read_text().splitlines()[4])
    gone = set(catalogs["deleted_indexes"])
    return [i for c in catalogs["paths"] for line in (tub / c).read_text().splitlines()
            if line.strip() and (i := json.loads(line)["_index"]) not in gone]


def without_validation(tubs: Path, name: str, only: int) -> Path:
    """The tub `name` as steerlab's recipe trains on it: its last `only` usable records (the recipe's validation)
    deleted (`training_tub`: the images linked), so that donkeycar's trainer gets the records steerlab's does."""
    out = tubs / f"{name}-train"
    keep = set(usable_records(tubs / name)[:-only])
    return out if (out / "manifest.json").exists() else training_tub(tubs / name, keep, out)


def recipe_overrides(name: str) -> list[str]:
    """The `train.` overrides of a recipe, those of the recipe it starts from (and so on) first."""
    recipes = [name]
    while RECIPES[recipes[-1]].starts:
        recipes.append(RECIPES[recipes[-1]].starts)
    return [o for r in reversed(recipes) for o in RECIPES[r].overrides if o.startswith("train.")]


def recipe_views(name: str) -> bool:
    """Whether the recipe trains on views (`train.views`) of its frames."""
    return any(o.startswith("train.views=") for o in recipe_overrides(name))


def recipe_flips(name: str) -> bool:
    """Whether the recipe trains on mirror images of its frames (`train.flip`)."""
    return "train.flip=true" in recipe_overrides(name)


def views_tubs(tubs: Path, names, recipe: str) -> tuple[str, ...]:
    """The views the recipe `recipe` trains on (its `train.views`, through the track world's fisheye) of the records
    donkeycar's trainer reads of each tub `names` (folders of `tubs`), written as a tub of each beside it, once
    (`views_tub`): the same extra frames for donkeycar's trainer. Each view's draw is made over that tub's records."""
    from steerlab.train.config import load_config

    out = []
    for name in names:
        cfg = load_config(None, base=base(tubs) | {"data": str(tubs / name), "extra_data": []},
                          overrides=recipe_overrides(recipe))
        out.append(views_tub(cfg, set(usable_records(tubs / name)), tubs / f"{name}-views-{recipe}").name)
    return tuple(out)


def mirrored_tubs(tubs: Path, names) -> tuple[str, ...]:
    """The records donkeycar's trainer reads of each tub `names` (folders of `tubs`: the recorded ones and their
    views) mirrored left-right, their steering negated, written as a tub of each beside it, once (`mirrored_tub`):
    the mirror images a recipe with `train.flip` trains on, for donkeycar's trainer."""
    return tuple(mirrored_tub(tubs / n, set(usable_records(tubs / n)), tubs / f"{n}-mirrored").name for n in names)


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


def training_minutes(name: str, seed: int, out: Path) -> float | None:
    """The minutes the recipe's checkpoint for `seed` took to train, with the recipe it starts from: the seconds of
    its epochs (each run's log.csv, every DAgger round's; recording its tubs and DAgger's rollouts not counted);
    None if not trained here."""
    recipe = RECIPES[name]
    if recipe.starts and not recipe.overrides and not recipe.tubs:
        return training_minutes(recipe.starts, seed, out)
    run = out / "recipes" / name / f"seed{seed}"
    logs = sorted(run.glob("round*/log.csv")) or [run / "log.csv"]  # DAgger's rounds each train
    before = training_minutes(recipe.starts, seed, out) if recipe.starts else 0.0
    if not all(log.exists() for log in logs) or before is None:
        return None
    seconds = 0.0
    for log in logs:
        with open(log, newline="") as f:
            seconds += sum(float(row["seconds"]) for row in csv.DictReader(f))
    return before + seconds / 60


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


def race_line_follower(work: Path, out: Path, o: TrackSuiteOptions) -> list:
    """donkeycar's computer-vision line follower (`DonkeycarLineFollower`, its car folder in `work`) on every track
    of the suite, as suite rows: one run (it learns nothing and draws nothing), its drives in `out/run0`."""
    python = donkey_python()
    car, rule = cv_car(python, work)
    out.mkdir(parents=True, exist_ok=True)
    racing = [part_entrant("run0", rule, partial(DonkeycarLineFollower, python, car, rule, out / "part.log"))]
    return [replace(r, label=f"{DONKEYCAR_CV}/{r.label}") for r in race(racing, out, o)]


def suite_options(name: str, suite: str, cap: float, workers: int) -> TrackSuiteOptions:
    """The suite a recipe races: `suite` under the throttle cap `cap`, with the recipe's own race options."""
    return TrackSuiteOptions(suite=suite, max_throttle=cap, workers=workers, **RECIPES[name].race)


def recipe_races(name: str, folder: Path, o: TrackSuiteOptions, grid: list[float]) -> list[tuple]:
    """(label, folder, options) of each race of a recipe (its suite options `o`, its drives in `folder`/name): at
    its own scale, or at each scale of `grid`, named for it (the drives at the recipe's own scale kept where they
    are)."""
    if not grid:
        return [(name, folder / name, o)]
    return [(f"{name}-x{k:g}", folder / (name if k == o.throttle_scale else f"{name}-x{k:g}"),
             replace(o, throttle_scale=k)) for k in grid]


def table(rows: list, cap: float, minutes: dict) -> list[dict]:
    """Per recipe (the label's first part): the mean over its runs of each overall summary value, and the runs';
    `minutes`: each recipe's training minutes, a run's each (`training_minutes`)."""
    overall = [s for s in summarize(rows) if s.style == "all"]
    by_recipe = {}
    for s in overall:
        by_recipe.setdefault(s.label.split("/")[0], []).append(s)
    out = []
    for name, runs in by_recipe.items():
        def mean(key):
            return mean_of([getattr(r, key) for r in runs])

        out.append({"recipe": name, "cap": cap, "runs": len(runs), "laps": mean("laps"),
                    "clean_pct": mean("clean_pct"), "finished": mean("finished"), "tracks": runs[0].tracks,
                    "off_track_per_lap": mean("off_track_per_lap"), "off_track": mean("off_track"),
                    "pace": mean("pace"), "pace_tracks": runs[0].pace_tracks,
                    "training_min": mean_of(minutes.get(name, [])), "training_each": minutes.get(name, []),
                    "each": [asdict(r) for r in runs]})
    return out


def chosen(rows: list[dict], grids: dict[str, dict[float, str]]) -> list[dict]:
    """The `table` rows of one cap, each row of a model raced over a grid of scales (`grids`: per model, the label of
    each scale's row) marked with its scale, whether SCALE_RULE chooses it, and whether the grid brackets the
    choice."""
    by_label = {r["recipe"]: r for r in rows}
    for labels in grids.values():
        k, bracketed = scale_choice({s: by_label[label] for s, label in labels.items()})
        for s, label in labels.items():
            by_label[label] |= {"scale": s, "chosen": s == k, "bracketed": bracketed}
    return rows


def markdown(rows: list[dict], suite: str) -> str:
    what = {**{n: r.what for n, r in RECIPES.items()}, DONKEYCAR: "donkeycar's own trainer and part",
            DONKEYCAR_CV: "donkeycar's computer-vision line follower (cv_control), set for each track's tape colour",
            **{f"{DONKEYCAR}-{n}": f"donkeycar's own trainer and part, on the tubs of {n}" for n in RECIPES}}
    lines = [f"Track suite {suite}, every checkpoint over the same tracks (pace: over the tracks every checkpoint of "
             "the same cap finished, their number beside it). Means over the runs (seeds), their min-max beside. "
             "Training: the minutes of its epochs (log.csv), on the machine and load it was trained under.", "",
             "| recipe | what differs from donkeycar's recipe | cap | runs | laps | clean laps [%] | finished | "
             "off track / lap | off track | pace (tracks) | training [min] |", "|---" * 11 + "|"]

    def describe(recipe):  # donkeycar's runs: donkeycar[-TUBS][-ours][-views][-mirrored][-epochs-E][-patience-P]
        # [-throttle-K][-floor-F]
        if not recipe.startswith(DONKEYCAR):
            return what.get(recipe, "")
        names = "|".join(re.escape(n) for n in sorted(what, key=len, reverse=True))
        number = r"[\d.e+-]+"
        m = re.fullmatch(rf"(?P<base>{names})(?P<ours>-ours)?(?P<views>-views)?(?P<flip>-mirrored)?"
                         rf"(-epochs-(?P<epochs>{number}))?(-patience-(?P<patience>{number}))?"
                         rf"(-throttle-(?P<scale>{number}))?(-floor-(?P<floor>{number}))?", recipe)
        if m is None:
            return ""
        return (what.get(m["base"], "") + (", on steerlab's training records" if m["ours"] else "") +
                (", and their views as the recipe's" if m["views"] else "") +
                (", and their mirror images" if m["flip"] else "") +
                (f", at most {m['epochs']} epochs" if m["epochs"] else "") +
                (f", early stopping after {m['patience']} epochs without a better loss" if m["patience"] else "") +
                (f", its throttle times {m['scale']} before the cap" if m["scale"] else "") +
                (f", at least {m['floor']} while the car stands" if m["floor"] else ""))

    for r in rows:
        def f(key, fmt):  # the mean, and the runs' min-max beside it
            return "-" if r[key] is None else mean_min_max([e[key] for e in r["each"]] or [r[key]], fmt)

        lines.append(f"| {r['recipe']} | {describe(r['recipe'])} | {r['cap']:g} | {r['runs']} | "
                     f"{f('laps', '.1f')} | {f('clean_pct', '.1f')} | {f('finished', '.1f')} of "
                     f"{r['tracks']} | {f('off_track_per_lap', '.2f')} | {f('off_track', '.1f')} | "
                     f"{f('pace', '.3f')} ({r['pace_tracks']}) | {mean_min_max(r['training_each'], '.1f')} |")
    picks = [r for r in rows if r.get("chosen")]
    if picks:
        lines += ["", f"Throttle scales chosen by the rule ({SCALE_RULE}):", ""]
        lines += [f"- cap {r['cap']:g}: **{r['recipe']}**" + ("" if r["bracketed"] else
                  " (the grid's largest scale: not bracketed, race a larger one)") for r in picks]
    return "\n".join(lines) + "\n"


SEEDS = NumberList(int, SEED)
CAPS = NumberList(float, Range(0, 1, lo_open=True))  # as --max-throttle of the track commands
SCALES = Grid(float, Range(0, 10, lo_open=True))  # as --throttle-scale of the track commands, x 1 among them
SCALE_POINTS, SCALE_OFF_TRACK = 1.3, 0.05
SCALE_RULE = (f"the largest throttle scale of the grid whose clean-lap share (the mean over the runs, unrounded) is at "
              f"most {SCALE_POINTS:g} points below x 1's and whose off-track events per lap are at most "
              f"{SCALE_OFF_TRACK:.0%} above x 1's; bracketed where a larger scale of the grid fails")


def scale_choice(grid: dict[float, dict]) -> tuple[float, bool]:
    """SCALE_RULE over one model's `table` rows by throttle scale (x 1 among them): the scale chosen, and whether the
    grid brackets it (a larger scale of it fails)."""
    def share(r):
        return r["clean_pct"] or 0.0

    def per_lap(r):
        return math.inf if r["off_track_per_lap"] is None else r["off_track_per_lap"]

    ref = grid[1.0]
    chosen = max(k for k, r in grid.items() if share(r) >= share(ref) - SCALE_POINTS
                 and per_lap(r) <= per_lap(ref) * (1 + SCALE_OFF_TRACK))
    return chosen, any(k > chosen for k in grid)


@dataclass(frozen=True)
class Races(Options):
    recipes: str = option(",".join(RECIPES), help="comma list of the recipes raced (empty with --donkeycar: "
                          "donkeycar's model alone)")
    seeds: str = option("0,1", SEEDS, SEEDS.words, help="training seeds (train.seed) of every recipe")
    suite: str = option("s1", lambda v: v in TRACK_SUITES, " or ".join(TRACK_SUITES),
                        help="the track suite raced (s1: selection tracks; t2 and t3 score)")
    caps: str = option("1,0.5", CAPS, CAPS.words, help="throttle caps (the learned throttle's and the expert's)")
    scales: str = option("", SCALES, SCALES.words, help="a grid of drive-time throttle scales: every recipe and "
                         "donkeycar's model raced at each (a recipe's own scale and --donkeycar-throttle-scale "
                         "replaced), each one's chosen by the rule of the table (largest within 1.3 points of x 1's "
                         "clean laps and 5 %% of its off-track events per lap); empty: each at its own")
    donkeycar: bool = option(False, help="also donkeycar's linear model (its own trainer)")
    donkeycar_cv: bool = option(False, help="also donkeycar's computer-vision line follower (its cv_control "
                                "template's LineFollower, set for each track's tape colour; no training), at "
                                "--donkeycar-throttle-scale and --donkeycar-throttle-floor")
    donkeycar_runs: int = option(3, AT_LEAST_1, help="how many runs of donkeycar's trainer race")
    donkeycar_tubs: str = option("donkey", lambda v: v in RECIPES, "a recipe", help="the recipe whose tubs donkeycar's "
                                 "trainer trains on (default: the 8 tubs of donkeycar's recipe)")
    donkeycar_throttle_scale: float = throttle_scale_option()
    donkeycar_throttle_floor: float = throttle_floor_option()
    donkeycar_epochs: int = option(DONKEY_TRAINING["MAX_EPOCHS"], AT_LEAST_1, help="donkeycar's trainer's most "
                                   "epochs (its MAX_EPOCHS; default its own)")
    donkeycar_patience: int = option(DONKEY_TRAINING["EARLY_STOP_PATIENCE"], AT_LEAST_1, help="donkeycar's trainer "
                                     "stops after this many epochs without a better validation loss (its "
                                     "EARLY_STOP_PATIENCE; default its own)")
    donkeycar_ours: bool = option(False, help="donkeycar's trainer on the records steerlab's recipe trains on: the "
                                  "first tub's validation records (--donkeycar-tubs' recipe's `only`) deleted")
    donkeycar_views: bool = option(False, help="donkeycar's trainer also on the views --donkeycar-tubs' recipe trains "
                                   "on (its train.views) of the records it reads, written as a tub of each: the "
                                   "same extra frames")
    donkeycar_flip: bool = option(False, help="donkeycar's trainer also on the mirror images (left-right, the "
                                  "steering negated) of every record it reads, views included, written as a tub of "
                                  "each: the frames --donkeycar-tubs' recipe's train.flip trains on")
    workers: int = option(2, WORKERS, help="tracks driven in parallel")
    out: str = option(str(ROOT / "runs" / "race"), path="folder", help="the study's folder")
    table: str = option("table", lambda v: v and "/" not in v, "a file name without a folder",
                        help="the name of the table files in OUT (.md, .csv, .json)")

    @classmethod
    def related(cls, v):
        if v.recipes.strip() or not (v.donkeycar or v.donkeycar_cv):
            yield from names_held(v, "recipes", RECIPES, "recipes")
        for flag in ("donkeycar_ours", "donkeycar_views", "donkeycar_flip"):  # nothing without it
            if getattr(v, flag) and not v.donkeycar:
                yield flag, "given with --donkeycar (a lever of donkeycar's trainer, which races only with it)"
        if v.donkeycar_ours and not (v.donkeycar_tubs in RECIPES and RECIPES[v.donkeycar_tubs].only):
            yield "donkeycar_ours", ("given with --donkeycar-tubs of a recipe that validates on a block of its first "
                                     f"tub ({', '.join(n for n, r in RECIPES.items() if r.only)})")
        if v.donkeycar_views and not (v.donkeycar_tubs in RECIPES and recipe_views(v.donkeycar_tubs)):
            yield "donkeycar_views", ("given with --donkeycar-tubs of a recipe that trains on views "
                                      f"({', '.join(n for n in RECIPES if recipe_views(n))})")
        if v.donkeycar_flip and not (v.donkeycar_tubs in RECIPES and recipe_flips(v.donkeycar_tubs)):
            yield "donkeycar_flip", ("given with --donkeycar-tubs of a recipe that trains on mirror images "
                                     f"(train.flip: {', '.join(n for n in RECIPES if recipe_flips(n))})")


def parser():
    return script_parser(__spec__.name, __doc__, Races)


def main(_, a: Races) -> None:
    recipes = names_from(a.recipes, RECIPES, "recipes") if a.recipes.strip() else []
    out = Path(a.out)
    tubs = out / "tubs"
    record_tubs(tubs, TUBS)
    caps, seeds = CAPS.of(a.caps), SEEDS.of(a.seeds)
    grid = SCALES.of(a.scales)
    for name in recipes:  # each recipe races as soon as it is trained
        ckpts = [train_recipe(name, seed, out, tubs) for seed in seeds]
        for cap in caps:
            for _, folder, o in recipe_races(name, out / f"{a.suite}-max{cap:g}", suite_options(name, a.suite, cap,
                                                                                                 a.workers), grid):
                race(ckpts, folder, o)
    training = {"MAX_EPOCHS": a.donkeycar_epochs, "EARLY_STOP_PATIENCE": a.donkeycar_patience}
    suffix = "" if a.donkeycar_tubs == "donkey" else f"-{a.donkeycar_tubs}"  # donkeycar on another recipe's tubs
    suffix += ("-ours" if a.donkeycar_ours else "") + ("-views" if a.donkeycar_views else "")
    suffix += "-mirrored" if a.donkeycar_flip else ""  # not -flip: a recipe's name ends so
    suffix += training_suffix(training)

    def scaled(k):  # the folder suffix of a drive at the throttle scale k and the floor
        return ("" if k == 1 else f"-throttle-{k:g}") + (f"-floor-{a.donkeycar_throttle_floor:g}"
                                                          if a.donkeycar_throttle_floor else "")
    donkey = None
    if a.donkeycar:
        record_tubs(tubs, recipe_tubs(a.donkeycar_tubs))
        names = recipe_tubs(a.donkeycar_tubs)
        if a.donkeycar_ours:
            names = (without_validation(tubs, names[0], RECIPES[a.donkeycar_tubs].only).name, *names[1:])
        if a.donkeycar_views:
            names = (*names, *views_tubs(tubs, names, a.donkeycar_tubs))
        if a.donkeycar_flip:
            names = (*names, *mirrored_tubs(tubs, names))
        donkey = donkey_models(out, tubs, a.donkeycar_runs, names, f"donkey{suffix}", training)
    results, minutes = [], {name: [training_minutes(name, seed, out) for seed in seeds] for name in recipes}
    for cap in caps:
        o = TrackSuiteOptions(suite=a.suite, max_throttle=cap, workers=a.workers)
        suite = out / f"{a.suite}-max{cap:g}"
        rows, grids = [], {}  # grids: per model raced over the grid, the label of each scale's rows
        for name in recipes:
            ckpts = [train_recipe(name, seed, out, tubs) for seed in seeds]
            for label, folder, ro in recipe_races(name, suite, suite_options(name, a.suite, cap, a.workers), grid):
                rows += [replace(r, label=f"{label}/{r.label}") for r in race(ckpts, folder, ro)]
                grids.setdefault(name, {})[ro.throttle_scale] = label
                minutes[label] = minutes[name]  # the same checkpoints at every scale of the grid
        if a.donkeycar_cv:
            rows += race_line_follower(out / "donkey-cv", suite / f"{DONKEYCAR_CV}{scaled(a.donkeycar_throttle_scale)}",
                                       replace(o, throttle_scale=a.donkeycar_throttle_scale,
                                               throttle_floor=a.donkeycar_throttle_floor))
        for k in (grid or [a.donkeycar_throttle_scale]) if donkey else []:
            folder = f"{DONKEYCAR}{suffix}{scaled(k)}"
            rows += race_donkeycar(*donkey, suite / folder, replace(o, throttle_scale=k,
                                                                  throttle_floor=a.donkeycar_throttle_floor), folder)
            grids.setdefault(f"{DONKEYCAR}{suffix}", {})[k] = folder
        report(rows, suite, o, plots=False)
        results += chosen(table(rows, cap, minutes), grids if grid else {})
    (out / f"{a.table}.md").write_text(f"machine: {machine()}\n\n" + markdown(results, a.suite))
    (out / f"{a.table}.json").write_text(json.dumps(results, indent=1))
    with open(out / f"{a.table}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, list(dict.fromkeys(k for r in results for k in r if k not in ("each", "training_each"))))
        w.writeheader()
        w.writerows([{k: v for k, v in r.items() if k not in ("each", "training_each")} for r in results])
    print((out / f"{a.table}.md").read_text())


if __name__ == "__main__":
    run_script(parser(), main)
