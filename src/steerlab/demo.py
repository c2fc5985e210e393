"""The main job: synthetic recording on mixed roads -> compile -> train PilotNet -> one DAgger round ->
open-loop evaluation, closed-loop replay of the held-out frames and the closed-loop suite -> a Markdown report
with plots. Every step reuses what an interrupted earlier run already finished."""

from __future__ import annotations

import csv
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from steerlab.files import write_json
from steerlab.paths import check_outputs
from steerlab.options import AT_LEAST_1, FPS, MINUTES, Options, WORKERS, frames_held, frames_in, option

TRAIN_SEED = 1
ROADS = "country,twisty,highway,twisty"  # the recipe of configs/experiment_recipe.yaml: half the time on tight curves
# one DAgger round: the model drives a fresh twisty road (`dagger_minutes`; the expert steers a tick with
# probability 0.5), the expert labels every frame, 1 more epoch from the trained weights (docs/results/road-world.md)
DAGGER = {"iterations": 1, "roads": "twisty", "beta": 0.5, "epochs": 1, "suite": None}


@dataclass(frozen=True)
class DemoOptions(Options):
    """`steerlab demo`'s options; configs/recipe_pilotnet.yaml is the same recipe on the recording of road seed
    3, with batches of 64 where the demo takes 16 (four times the updates: the single-frame models drive twisty
    roads better with them, docs/results/closing-the-gap.md, "Batches of 16")."""

    out: str = option("runs/demo", help="output folder", path="folder", makes="demo")
    minutes: float = option(8.0, MINUTES, help="minutes of expert driving on mixed roads to train on")
    fps: float = option(10.0, FPS, help="frames per second of the recording (the DAgger round and the suite drive "
                        "at 20)")
    epochs: int = option(5, AT_LEAST_1, help="epochs of the first training")
    suite_minutes: float | None = option(None, MINUTES, help="minutes on each road of the closed-loop suite "
                                         "(default: the suite's 3)")
    dagger_minutes: float = option(2.0, MINUTES, help="minutes the trained model drives a fresh twisty road in its "
                                   "DAgger round")
    workers: int = option(2, WORKERS, help="roads driven in parallel")

    @classmethod
    def related(cls, v):
        yield from frames_held(v, "minutes")
        yield from frames_held(v, "suite_minutes", "dagger_minutes", fps=20.0)


def run_demo(o: DemoOptions = DemoOptions(), progress: bool = True) -> Path:
    """The whole pipeline; returns the report's path."""
    # its stages are imported here, not with the options above, which `steerlab --help` reads
    from steerlab.dagger import run_dagger
    from steerlab.data.readers import Source
    from steerlab.evaluate.offline import evaluate
    from steerlab.sim.road.suite import SuiteOptions, run_suite
    from steerlab.sim.replay.run import ReplayOptions, run_replay
    from steerlab.sim.road.run import record
    from steerlab.sim.road.world import RecordOptions
    from steerlab.train.config import load_config

    out, minutes, fps, epochs, suite_minutes, dagger_minutes, workers = (
        o.out, o.minutes, o.fps, o.epochs, o.suite_minutes, o.dagger_minutes, o.workers)
    out = Path(out)
    check_outputs({"output folder (out)": out}, kind="demo")
    out.mkdir(parents=True, exist_ok=True)
    rec_dir = out / "recording"
    stages = Stages()
    if not (rec_dir / "recording.json").exists():
        stages.start(f"[1/5] recording {minutes} min of expert driving on mixed roads (road seed {TRAIN_SEED})")
        record(rec_dir, RecordOptions(seed=TRAIN_SEED, minutes=minutes, road=ROADS, fps=fps), progress=progress)
    n = frames_in(minutes, fps)
    split = int(n * 0.8)
    cfg = load_config(None, base={
        "data": str(rec_dir), "cache": str(out / "cache"), "out": str(out / "pilotnet"),
        "preprocess": {"preset": "sim", "color": "gray"},
        "split": {"train": f"0:{split}", "val": f"{split}:{n}"},
        "model": {"name": "pilotnet", "dropout": 0.3},
        "train": {"epochs": epochs, "patience": 3, "batch_size": 16, "lr": 3e-4, "flip": True,
                  "exclude_episodes": ["drift-out"], "side_cameras": True},
        "dagger": {**DAGGER, "minutes": dagger_minutes, "workers": workers},
    })
    stages.start(f"[2/5] training PilotNet on frames 0:{split} (drift-out frames excluded), then one DAgger round")
    ckpt = run_dagger(cfg, progress=progress)
    stages.start(f"[3/5] open-loop evaluation on the held-out frames {split}:{n}")
    offline = evaluate(ckpt, Source(str(rec_dir), f"{split}:{n}"), out / "open-loop", progress=progress)
    stages.start("[4/5] closed-loop replay of the held-out frames (the recording's frames warped to the car's view)")
    replay = run_replay([ckpt], Source(str(rec_dir), f"{split}:{n}"), out / "replay", ReplayOptions(workers=1),
                        progress=progress)
    stages.start(f"[5/5] closed-loop suite: {suite_minutes or 3:g} min on each of its unseen roads")
    summary = run_suite([ckpt], out / "closed-loop", SuiteOptions(minutes=suite_minutes, workers=workers),
                        progress=progress)
    stages.start(None)
    with open(out / "pilotnet" / "dagger.csv") as f:
        rounds = list(csv.DictReader(f))
    report = out / "report.md"
    report.write_text(_report(offline, rounds, dagger_minutes, (out / "replay" / "replay.md").read_text(),
                              (out / "closed-loop" / "suite.md").read_text(), split, n))
    write_json(out / "summary.json", {"open_loop": offline, "dagger": rounds, "replay": replay,
                                      "closed_loop": [asdict(s) for s in summary], "seconds": stages.seconds})
    return report


class Stages:
    """The demo's stages as they start: each is announced, and the one before it ends with its wall time
    (`seconds`, by stage number; a stage that an earlier run finished is not timed)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self._current: tuple[str, float] | None = None

    def start(self, line: str | None) -> None:
        now = time.perf_counter()
        if self._current:
            name, began = self._current
            self.seconds[name] = round(now - began, 1)
            print(f"      {name} took {now - began:.0f} s")
        self._current = (line.split("]")[0].lstrip("["), now) if line else None
        if line:
            print(line)


def _report(m: dict, rounds: list[dict], dagger_minutes: float, replay_table: str, suite_table: str, split: int,
            n: int) -> str:
    sm = m["smoothed_a0.2"]
    lines = [
        "# steerlab demo report", "",
        f"PilotNet trained on a synthetic recording (road seed {TRAIN_SEED}, frames 0:{split}) and by one DAgger "
        f"round, evaluated open loop on frames {split}:{n} and driven in closed loop on unseen roads.", "",
        "## DAgger", "",
        f"Round 1: the trained model drove {dagger_minutes:g} minutes of a fresh {DAGGER['roads']} road (the "
        f"expert steering a tick with probability {DAGGER['beta']}), the expert labelled every frame it saw, and "
        f"{DAGGER['epochs']} more epoch{'s' * (DAGGER['epochs'] > 1)} trained on the recording and that drive.", "",
        "| round | recordings | rollout autonomy [%] | val RMSE [rad] |", "|---|---|---|---|",
        *[f"| {r['round']} | {r['recordings']} | {_pct(r['rollout_autonomy'])} | {float(r['val_rmse']):.4f} |"
          for r in rounds], "",
        "## Open loop (held-out frames)", "",
        "| | RMSE [rad] | MAE [deg] | gamma [deg] | target gamma [deg] |", "|---|---|---|---|---|",
        f"| PilotNet | {m['rmse']:.4f} | {m['mae_deg']:.3f} | {m['gamma_deg']:.3f} | {m['target_gamma_deg']:.3f} |",
        f"| PilotNet + smoothing a=0.2 | {sm['rmse']:.4f} | {sm['mae_deg']:.3f} | {sm['gamma_deg']:.3f} | "
        f"{sm['target_gamma_deg']:.3f} |", "",
        "Steering is the steering-wheel angle (positive left).", "",
        "![steering](open-loop/steering.png)", "",
        "## Closed-loop replay (the held-out frames)", "", replay_table, "", "![replay](replay/replay.png)", "",
        "## Closed loop (the suite's unseen roads)", "", suite_table,
        "Trajectories: closed-loop/roads/*.png", "",
    ]
    return "\n".join(lines)


def _pct(value: str) -> str:
    return f"{float(value):.1f}" if value else "-"
