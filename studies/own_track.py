"""Your own track, as a donkeycar owner races it: drive K minutes on one track, train, race that track.

For every K of `--minutes`, the racing expert drives K minutes on track `--track` (`steerlab sim record --world
track --seed TRACK --minutes K`: a tub, its drift-outs cut as an owner cuts them), and on that tub are trained
`--recipe` (a config, by default `configs/track_best.yaml`, its data replaced by the tub; every `--seeds` seed;
validation on the tub's last fifth) and, with
`--donkeycar`, donkeycar's linear model by its own trainer (`donkey train`, its default config: a random 80/20
split; `--donkeycar-runs` runs). Each races the same track for `--race-minutes` minutes uncapped, in the room's
own light and in another (`--light`: the room's light level instead of its own, drawn in 0.75-1.2), steerlab's
learned throttle times `--throttle-scale` and donkeycar's times `--donkeycar-throttle-scale` (each the scale chosen
for it on s1). Synthetic closed loop.

OUT/own-track.md, .csv, .json: per pilot, K and light the mean over its runs of laps, clean laps (their share),
off-track events and pace (the mean clean lap over the expert's on the same track, uncapped), each with the runs'
min-max; and the fewest minutes of driving to >= 95 % clean laps; steerlab's pilot is named by the recipe's file
(track_best). OUT/own-track.png: clean laps against K. Every tub, model and drive is kept and reused (a model while
the recipe is the same, else refused; a drive while its key, the model's sha256 and the options, holds); a rerun
into the same OUT with other race options (the track, its style, the race minutes, the light, the throttle scales)
is refused rather than written over the races (OUT/races.json keeps them); more minutes, seeds or runs are added.

python -m studies.own_track [--track 77] [--style taped] [--minutes 0.5,1,2,4] [--seeds 0,1] [--light 0.55]
    [--recipe configs/track_best.yaml]
    [--donkeycar [--donkeycar-runs 3] [--donkeycar-throttle-scale 1]] [--workers 2] [--out runs/own-track]
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.data.car import CARS
from steerlab.data.readers import open_recording
from steerlab.errors import SteerlabError
from steerlab.files import read_json, read_yaml
from steerlab.options import AT_LEAST_1, MINUTES, SEED, WORKERS, Options, Range, option
from steerlab.sim.core.part import PartPilot
from steerlab.sim.core.suite import Planned, as_stored, file_sha256, run_drives
from steerlab.sim.track import run
from steerlab.sim.track.world import TrackDriveOptions, TrackRecordOptions, part_throttle, throttle_scale_option
from studies.common import ROOT, NumberList, machine, mean_min_max
from studies.common.donkeycar import DonkeycarPart, donkey_models, donkey_python
from studies.common.truth import write_table

RECIPE = ROOT / "configs" / "track_best.yaml"
CLEAN = 95.0  # % of laps clean: the target
DONKEYCAR, STEERLAB, EXPERT = "donkeycar", "steerlab", "expert"  # the kinds of pilot a drive is of
# the options that shape every race: a rerun into the same --out with others is refused, not written over it
RACE_OPTIONS = ("track", "style", "race_minutes", "light", "throttle_scale", "donkeycar_throttle_scale")


def record(tubs: Path, track: int, style: str, minutes: float) -> Path:
    """The expert's K-minute tub of the track (recorded once)."""
    tub = tubs / f"{style}-{track}-{minutes:g}min"
    if not (tub / "manifest.json").exists():
        run.record(tub, TrackRecordOptions(seed=track, minutes=minutes, style=style), progress=False)
    return tub


def train(recipe: Path, tub: Path, seed: int, out: Path) -> Path:
    """The config `recipe` on the tub alone, validated on its last fifth (trained once; an interrupted training
    resumes; a finished run of another config is refused, not reused)."""
    from steerlab.train.config import another_config, load_config
    from steerlab.train.loop import run_changes, train as train_config

    raw = read_yaml(recipe, "the recipe (--recipe)")
    usable = len(open_recording(str(tub), options=raw["reader"]))
    cut = int(round(0.8 * usable))
    raw.update(data=str(tub), split={"train": f"0:{cut}", "val": f"{cut}:{usable}"})
    raw.pop("extra_data", None)
    cfg = load_config(None, base=raw, overrides=[f"train.seed={seed}", f"out={out}"])
    if (out / "done.json").exists():
        if changes := run_changes(out, cfg):
            raise another_config(out, changes)
    else:
        print(f"== training {recipe.stem} on {tub.name}, seed {seed}", flush=True)
        metrics = train_config(cfg, progress=False)
        (out / "done.json").write_text(json.dumps(metrics, indent=1, default=str))
    return out / "best.pt"


def drive(kind: str, model: str | None, car: str | None, folder: str, o: TrackDriveOptions, key: dict):
    """One drive (a worker's job): the expert's reference laps, a steerlab checkpoint through its donkeycar part,
    or donkeycar's model through donkeycar's own part (in donkeycar's environment)."""
    meta = {"cache_key": key}
    if kind == EXPERT:
        return run.drive_expert(folder, o, meta=meta)
    if kind == STEERLAB:
        return run.drive_checkpoint(model, folder, o, progress=False, plot=False, meta=meta)
    Path(folder).mkdir(parents=True, exist_ok=True)
    part = DonkeycarPart(donkey_python(), Path(car), Path(model), Path(folder) / "part.log", math.inf)
    pilot = PartPilot(part, CARS["donkey"].full_lock_deg, name=DONKEYCAR, source=model,
                      throttle=part_throttle(o))
    try:
        return run.drive(pilot, folder, o, progress=False, plot=False, meta=meta)
    finally:
        pilot.close()


def spread(values: list[float | None], fmt: str) -> str:
    """The mean and the min-max of the runs' values, and how many runs have one where some have none (no clean
    lap: no pace)."""
    got = sum(v is not None for v in values)
    return mean_min_max(values, fmt) + (f", {got} of {len(values)}" if 0 < got < len(values) else "")


def rows_of(results: dict, expert: dict, pilots: dict) -> list[dict]:
    """Per pilot, K and light: the runs' values (laps, clean laps, their share, off-track events, pace)."""
    rows = []
    for (who, minutes, light), runs in pilots.items():
        drives = [results[r] for r in runs]
        ref = expert[light].mean_lap_s
        rows.append({"pilot": who, "minutes": minutes, "light": light, "runs": len(drives),
                     "laps": [d.laps for d in drives], "clean_laps": [d.clean_laps for d in drives],
                     "clean_pct": [100.0 * d.clean_laps / d.laps if d.laps else 0.0 for d in drives],
                     "off_track": [d.off_track for d in drives],
                     "pace": [d.mean_lap_s / ref if d.mean_lap_s and ref else None for d in drives]})
    return rows


def fewest_minutes(rows: list[dict], who: str, light: str) -> float | None:
    """The fewest minutes of driving whose runs lap >= CLEAN % of their laps cleanly, on the mean."""
    ok = [r["minutes"] for r in rows if r["pilot"] == who and r["light"] == light and np.mean(r["clean_pct"]) >= CLEAN]
    return min(ok) if ok else None


def markdown(rows: list[dict], a: "OwnTrack") -> str:
    lines = [f"machine: {machine()}", "",
             f"Own track: {a.style} track {a.track}, K minutes of the racing expert's driving, raced {a.race_minutes:g} "
             f"min uncapped in the room's own light and at light {a.light:g} (synthetic closed loop); mean over the "
             "runs (min-max).", "",
             "| pilot | minutes driven | light | runs | laps | clean laps [%] | off track | pace |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['pilot']} | {r['minutes']:g} | {r['light']} | {r['runs']} | {spread(r['laps'], '.1f')} | "
              f"{spread(r['clean_pct'], '.1f')} | {spread(r['off_track'], '.1f')} | {spread(r['pace'], '.3f')} |"
              for r in rows]
    lines += ["", f"Fewest minutes of driving to >= {CLEAN:g} % clean laps (mean over the runs):", ""]
    for who in dict.fromkeys(r["pilot"] for r in rows):
        for light in dict.fromkeys(r["light"] for r in rows):
            k = fewest_minutes(rows, who, light)
            lines.append(f"- {who}, {light} light: " + (f"{k:g} min" if k is not None else
                                                         f"not reached within {max(r['minutes'] for r in rows):g}"))
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for who in dict.fromkeys(r["pilot"] for r in rows):
        for light, style in (("own", "-"), ("other", "--")):
            mine = sorted((r for r in rows if r["pilot"] == who and r["light"] == light), key=lambda r: r["minutes"])
            if mine:
                k = [r["minutes"] for r in mine]
                mean = np.array([np.mean(r["clean_pct"]) for r in mine])
                low, high = (np.array([f(r["clean_pct"]) for r in mine]) for f in (min, max))
                ax.errorbar(k, mean, yerr=[mean - low, high - mean], fmt="o" + style, capsize=3,
                            label=f"{who}, {light} light")
    ax.axhline(CLEAN, color="grey", lw=0.8, ls=":")
    ax.set(xscale="log", xlabel="minutes of driving on the track", ylabel="clean laps [%]", ylim=(-2, 102))
    ax.set_xticks(sorted({r["minutes"] for r in rows}), [f"{m:g}" for m in sorted({r["minutes"] for r in rows})])
    ax.minorticks_off()  # a log axis's minor labels (6e-1, 3e0) would sit among the minutes
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


MINUTES_LIST = NumberList(float, MINUTES)
SEEDS = NumberList(int, SEED)


@dataclass(frozen=True)
class OwnTrack(Options):
    track: int = option(77, Range(0, 8999), help="the track's seed (not one of the suites', 9000-9999)")
    style: str = option("taped", lambda v: v in ("taped", "centre"), "taped or centre", help="the track's style")
    minutes: str = option("0.5,1,2,4", MINUTES_LIST, MINUTES_LIST.words, help="the minutes of driving K, each a tub")
    seeds: str = option("0,1", SEEDS, SEEDS.words, help="training seeds of the recipe (train.seed)")
    race_minutes: float = option(2.0, MINUTES, help="minutes of each race of the track")
    light: float = option(0.55, Range(0.2, 2), help="the other light: the room's light level instead of its own")
    throttle_scale: float = option(1.2, Range(0, 10, lo_open=True), help="steerlab's learned throttle times this "
                                   "(default: track_best's scale uncapped, chosen on s1)")
    donkeycar: bool = option(False, help="also donkeycar's linear model by its own trainer on the same tubs")
    donkeycar_runs: int = option(3, AT_LEAST_1, help="how many runs of donkeycar's trainer race")
    donkeycar_throttle_scale: float = throttle_scale_option()
    workers: int = option(2, WORKERS, help="steerlab's drives in parallel (donkeycar's run one at a time)")
    recipe: str = option(str(RECIPE), path="file", help="the config trained on each tub (its data replaced)")
    out: str = option(str(ROOT / "runs" / "own-track"), path="folder", help="the study's folder")


def parser():
    return script_parser(__spec__.name, __doc__, OwnTrack)


def same_races(out: Path, a: "OwnTrack") -> None:
    """The race options of the study in `out` (`RACE_OPTIONS`, kept in OUT/races.json by its first run) are `a`'s,
    or a one-line error: its races and table would be written over. More minutes, seeds or runs are welcome."""
    mine = {k: getattr(a, k) for k in RACE_OPTIONS}
    path = out / "races.json"
    if path.exists():
        stored = read_json(path, "the study's race options")
        stored = stored if isinstance(stored, dict) else {}
        changed = [f"--{k.replace('_', '-')} {stored.get(k):g}" if isinstance(stored.get(k), (int, float)) else
                   f"--{k.replace('_', '-')} {stored.get(k)}" for k in RACE_OPTIONS if stored.get(k) != mine[k]]
        if changed:
            raise SteerlabError(f"{out} holds the races of {', '.join(changed)}, which these options would write "
                                "over: give another --out, or those options")
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(mine, indent=1))


def main(_, a: OwnTrack) -> None:
    out = Path(a.out)
    same_races(out, a)
    label = Path(a.recipe).stem  # what the table, the plot and the folders call steerlab's pilot
    lights = {"own": None, "other": a.light}
    base = TrackDriveOptions(seed=a.track, minutes=a.race_minutes, style=a.style, max_throttle=1.0)
    expert = {name: TrackDriveOptions(**{**asdict(base), "light": light}) for name, light in lights.items()}
    planned = {EXPERT: [Planned(name, out / "expert" / name, as_stored(asdict(o)),
                                (EXPERT, None, None, str(out / "expert" / name), o, as_stored(asdict(o))))
                        for name, o in expert.items()]}
    pilots = {}
    for minutes in MINUTES_LIST.of(a.minutes):
        tub = record(out / "tubs", a.track, a.style, minutes)
        racing = [(STEERLAB, label, f"seed{s}", train(Path(a.recipe), tub, s, out / f"{minutes:g}min" / f"seed{s}"),
                   None, a.throttle_scale)
                  for s in SEEDS.of(a.seeds)]
        if a.donkeycar:
            car, models = donkey_models(out, tub.parent, a.donkeycar_runs, (tub.name,), f"donkey-{minutes:g}min")
            racing += [(DONKEYCAR, DONKEYCAR, f"run{k}", m, car, a.donkeycar_throttle_scale)
                       for k, m in enumerate(models)]
        for kind, who, name, model, car, scale in racing:
            for light_name, light in lights.items():
                o = TrackDriveOptions(**{**asdict(base), "light": light, "throttle_scale": scale})
                key = as_stored({"model_sha256": file_sha256(Path(model)), **asdict(o)})
                where = (who, minutes, light_name, name)
                folder = out / f"{minutes:g}min" / f"{who}-{name}" / light_name
                planned.setdefault(kind, []).append(Planned(where, folder, key, (kind, str(model), car and str(car),
                                                                                   str(folder), o, key)))
                pilots.setdefault((who, minutes, light_name), []).append(where)
    results = {}
    ticks = int(a.race_minutes * 60 * base.fps)
    for who, workers in ((EXPERT, a.workers), (STEERLAB, a.workers), (DONKEYCAR, 1)):
        if planned.get(who):
            results.update(run_drives(drive, run.TrackDrive, planned[who], workers, ticks, True, who))
    rows = rows_of(results, {name: results[name] for name in lights}, pilots)
    (out / "own-track.md").write_text(markdown(rows, a))
    (out / "own-track.json").write_text(json.dumps(rows, indent=1))
    write_table(out / "own-track.csv", [{k: (json.dumps(v) if isinstance(v, list) else v) for k, v in r.items()}
                                        for r in rows])
    plot(rows, out / "own-track.png")
    print((out / "own-track.md").read_text())


if __name__ == "__main__":
    run_script(parser(), main)
