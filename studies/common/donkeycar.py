"""donkeycar's own environment, in which the studies run donkeycar's trainer and parts (steerlab never imports
donkeycar): `donkey_python`, `donkey_car`, `donkey_models` (`donkey train`'s linear models), `DonkeycarPart`,
donkeycar's pilot part behind a pipe, and `DonkeycarLineFollower` (`cv_car`, `cv_thresholds`), its computer-vision
line follower; donkeycar's trainer on the shared tubs (`studies/donkeycar_tubs.py`, `studies/tub_pretraining.py`,
`studies/tub_replay.py`): `TubStudy`, their options, `TUBS`, `reader`, `blocks`, `donkey_or_skip`, `donkey_train`,
`donkey_scores`, `run_donkey`, `replay_donkey`."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.evaluate.metrics import gamma_deg
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


# donkeycar's trainer's own levers as its template sets them (cfg_complete.py): at most 100 epochs, early stopping
# after 5 without a better validation loss
DONKEY_TRAINING = {"MAX_EPOCHS": 100, "EARLY_STOP_PATIENCE": 5}


def donkey_car(python: Path, car: Path, training: dict | None = None) -> Path:
    """A donkeycar car folder (`donkey createcar`, made once) whose config trains without plots and saves .h5
    models, as `donkey train` and donkeycar's parts read them; `training`: settings of its trainer written into
    its myconfig.py (`DONKEY_TRAINING`'s names), its own defaults otherwise."""
    if not car.exists():
        subprocess.run([str(python.parent / "donkey"), "createcar", "--path", str(car)], check=True,
                       stdout=subprocess.DEVNULL)
        with open(car / "myconfig.py", "a") as f:
            f.write("\nSHOW_PLOT = False\nCREATE_TF_LITE = False\nSAVE_MODEL_AS_H5 = True\n" +
                    "".join(f"{k} = {v!r}\n" for k, v in (training or {}).items()))
    return car


def training_suffix(training: dict) -> str:
    """The folder suffix of donkeycar's runs trained with `training` (the settings that differ from its
    defaults): "" or e.g. "-epochs-20-patience-3"."""
    names = {"MAX_EPOCHS": "epochs", "EARLY_STOP_PATIENCE": "patience"}
    return "".join(f"-{names[k]}-{v:g}" for k, v in training.items() if v != DONKEY_TRAINING[k])


def donkey_models(out: Path, tubs: Path, runs: int, names: tuple[str, ...],
                  work: str = "donkey", training: dict | None = None) -> tuple[Path, list[Path]]:
    """donkeycar's car folder and its first `runs` linear models, trained by `donkey train` on the tubs `names`
    (folders of `tubs`; once each: a model counts once `donkey train` has finished), in out/`work`; `training`:
    its trainer's settings (`donkey_car`), the same for every run in that folder."""
    python = donkey_python()
    work = out / work
    car = donkey_car(python, work / "car", training)
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
                 throttle_scale: float = 1.0, kind: str = "linear", more: tuple[str, ...] = ()):
        self.log, self.max_throttle, self.throttle_scale = log, max_throttle, throttle_scale
        self.stderr = open(log, "wb")
        self.process = subprocess.Popen([str(python), str(ROOT / "studies" / "_donkey_part.py"),
                                         str(car / "config.py"), str(model), kind, *more], cwd=car,
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


# donkeycar's computer-vision line follower: the colour thresholds (OpenCV HSV: hue 0-179) its owner sets for the tape
# on their floor, as read off a picture of both: a coloured tape by its hue +- HUE, with at least FROM of its
# saturation and of its value (a room's light and its drift along the lap darken it to about 0.6 of its colour),
# its saturation cut halfway to the floor's where the floor's hue lies in that window; a grey one (saturation under
# GREY: white, black) by its value, cut halfway between the tape's and the floor's
CV_RULE = {"hue": 10, "from": 0.6, "grey": 60}


def cv_thresholds(tape_bgr, floor_bgr) -> tuple[list[int], list[int]]:
    """The HSV range (low, high) an owner sets donkeycar's line follower to for a tape of the colour `tape_bgr` on a
    floor of the colour `floor_bgr` (CV_RULE)."""
    import cv2

    def hsv(bgr):
        pixel = np.clip(np.round(np.asarray(bgr, float)), 0, 255).astype(np.uint8).reshape(1, 1, 3)
        return (int(x) for x in cv2.cvtColor(pixel, cv2.COLOR_BGR2HSV)[0, 0])

    (h, s, v), (floor_h, floor_s, floor_v) = hsv(tape_bgr), hsv(floor_bgr)
    if s < CV_RULE["grey"]:
        cut = (v + floor_v) // 2
        return ([0, 0, cut + 1], [179, CV_RULE["grey"], 255]) if v > floor_v else ([0, 0, 0], [179, 255, cut])
    low = [max(h - CV_RULE["hue"], 0), int(CV_RULE["from"] * s), int(CV_RULE["from"] * v)]
    if low[0] <= floor_h <= h + CV_RULE["hue"] and floor_s >= low[1]:  # a floor of the tape's hue: by saturation
        low[1] = (s + floor_s) // 2 + 1
    return low, [min(h + CV_RULE["hue"], 179), 255, 255]


def cv_car(python: Path, car: Path) -> tuple[Path, Path]:
    """A car folder of donkeycar's `cv_control` template (`donkey createcar --template cv_control`, once) and the
    file of the thresholds' rule in it (CV_RULE: the file whose sha256 names the line follower's drives)."""
    if not car.exists():
        subprocess.run([str(python.parent / "donkey"), "createcar", "--path", str(car), "--template", "cv_control"],
                       check=True, stdout=subprocess.DEVNULL)
    rule = car / "cv-thresholds-rule.json"
    rule.write_text(json.dumps(CV_RULE, indent=1))
    return car, rule


class DonkeycarLineFollower:
    """donkeycar's computer-vision line follower (the `cv_control` template's LineFollower and PID, its config as
    the template writes it) behind a pipe, set up for each track as its owner would (`on_track`: the colour
    thresholds for the tape of the track's room, `cv_thresholds`), steering and throttling by itself (its throttle
    between the template's THROTTLE_MIN and THROTTLE_MAX). The process starts once it is told its track."""

    def __init__(self, python: Path, car: Path, rule: Path, log: Path):
        self.python, self.car, self.rule, self.log, self.part = python, car, rule, log, None

    def on_track(self, drive) -> None:
        from steerlab.sim.track.world import LOOK, Look, camera_of, renderer_of

        camera = camera_of(drive.calibration)
        look = LOOK if drive.light is None else Look(light=drive.light)
        room = renderer_of(drive.seed, drive.lane_width, drive.style, camera, None, look).room
        low, high = cv_thresholds(room.tape_bgr, room.floor_bgr)
        log = self.log.with_name(f"{self.log.stem}-{drive.style}-{drive.seed}.log")  # a log a drive
        self.part = DonkeycarPart(self.python, self.car, self.rule, log, math.inf, kind="cv",
                                  more=(json.dumps([low, high]), str(camera.width), str(camera.height)))

    def run(self, img_arr: np.ndarray):
        if self.part is None:
            raise RuntimeError("donkeycar's line follower drives a track it was told (on_track) only")
        return self.part.run(img_arr)

    def close(self) -> None:
        if self.part is not None:
            self.part.close()


# donkeycar's trainer on the shared tubs

TUBS = SHARED / "donkeycar"
FULL_LOCK_DEG = 25.0  # assumed: the tubs do not record it
TUB_NAMES = ("hall", "taped-track", "wood-tape")  # the tubs of ../shared/data/donkeycar
MIRRORED = ("taped-track",)  # its frames turn against its steering (r = -0.87, `sense.frame_turn`): read mirrored


def reader(tub: str | Path) -> dict:
    """The reader options of a shared tub (its folder or name)."""
    return {"skip_missing": True, "full_lock_deg": FULL_LOCK_DEG, **({"mirrored": True} if Path(tub).name in MIRRORED
                                                                      else {})}


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


def views_tub(cfg, keep: set[int], out: Path) -> Path:
    """The views steerlab trains on of the records `keep` (record `_index` values) as a tub donkeycar's trainer reads
    beside the tub itself (`write_views_tub`: the same extra frames for both trainers). Written once (the draws are
    fixed by the view's place in the list); a finished tub is kept."""
    from steerlab.train.views_tub import write_views_tub

    return out if (out / "manifest.json").exists() else write_views_tub(cfg, out, keep, progress=False)


def mirrored_tub(tub: Path, keep: set[int], out: Path) -> Path:
    """The records `keep` (record `_index` values) of a tub mirrored left-right, their steering negated and their
    throttle kept, as a tub donkeycar's trainer reads beside the tub itself: the mirror images steerlab's
    `train.flip` trains on (each sample mirrored with probability 0.5), which donkeycar's trainer cannot make. Its
    sessions and times are the tub's. Written once; a finished tub is kept."""
    from steerlab.data.car import CARS
    from steerlab.data.readers import open_recording
    from steerlab.data.writer import TubWriter

    if (out / "manifest.json").exists():
        return out
    lock = CARS["donkey"].full_lock_deg  # the writer's unit; the servo value is negated whatever it is
    rec = open_recording(str(tub), options={"full_lock_deg": lock})
    left = rec.convention.to_road_wheel_left(np.asarray(rec.steering, np.float64), 1.0)
    segments, t0 = rec.segment_ids(), int(rec.timestamps_ns[0])
    writer, last = TubWriter(out, lock), None
    for i in range(len(rec)):
        if int(rec.frame_ids[i]) in keep:
            writer.add(np.ascontiguousarray(rec.load_frame(i)[:, ::-1]), int(rec.timestamps_ns[i]) - t0,
                       -float(left[i]), float(rec.throttle[i]), new_session=last is None or segments[i] != last)
            last = segments[i]
    return writer.close()


def donkey_train(python: Path, car: Path, tub: Path | str, model: Path, kind: str, log: Path) -> float | None:
    """`donkey train` of a `kind` model on `tub` (a comma list of tubs trains on all; their deleted records left
    out, as donkeycar reads a tub) into `model`, as its users run it; its wall-clock seconds, or None (said) when
    it failed. A model whose training finished (`model`.done, holding its seconds) is kept: a rerun goes on where
    an interrupted one stopped."""
    done = model.with_suffix(".done")
    if done.exists() and model.exists():
        return float(done.read_text())
    t = time.time()
    with open(log, "w") as f:
        finished = subprocess.run([str(python.parent / "donkey"), "train", "--tub", str(tub), "--model", str(model),
                                   "--type", kind, "--framework", "tensorflow"], cwd=car, stdout=f,
                                  stderr=subprocess.STDOUT)
    if finished.returncode != 0 or not model.exists():
        print(f"  donkey train of {model.name} failed, see {log}", flush=True)
        return None
    done.write_text(f"{time.time() - t:.1f}\n")
    return float(done.read_text())


def donkey_scores(python: Path, car: Path, model: Path, kind: str, rec, start: int, stop: int, work: Path) -> dict:
    """Open loop: the steering and throttle MAE and the steering's smoothness gamma of donkeycar's `model` on the
    records `start:stop` of `rec`, each frame through donkeycar's own model class as a car runs it
    (`_donkey_eval.py`)."""
    records, scores = work / f"{model.stem}-records.json", work / f"{model.stem}.json"
    records.write_text(json.dumps({"images": [str(p) for p in rec.frames["center"][start:stop]],
                                   "angles": rec.steering[start:stop].tolist(),
                                   "throttles": rec.throttle[start:stop].tolist()}))
    subprocess.run([str(python), str(ROOT / "studies" / "_donkey_eval.py"), str(car / "config.py"),
                    str(model), kind, str(records), str(scores)], check=True, cwd=car, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    r = json.loads(scores.read_text())
    return {"mae": r["mae"], "throttle_mae": r["throttle_mae"],
            "gamma_deg": gamma_deg(r["pred"], rec.convention.degrees_per_unit)}  # as `steerlab evaluate` gives it


def run_donkey(python: Path, tub: Path, rec, a: int, n: int, work: Path, kinds: list[str], seeds: int,
               results: dict) -> None:
    """Train each donkeycar model `seeds` times on the first `a` records with `donkey train` and score it on the
    held-out block; runs already in `results` are kept."""
    car = donkey_car(python, work / "car")
    train_tub = training_tub(tub, set(int(i) for i in rec.frame_ids[:a]), work / "train-tub")
    for kind in kinds:
        for seed in range(seeds):
            key = f"donkeycar {kind} {seed}"
            if "mae" in results.get(key, {}):
                continue
            model = work / f"{kind}-{seed}.h5"
            seconds = donkey_train(python, car, train_tub, model, kind, work / f"{kind}-{seed}.log")
            if seconds is None:
                continue
            results[key] = {**donkey_scores(python, car, model, kind, rec, a, n, work), "train_s": seconds}
            print(f"  donkeycar {kind} run {seed}: held-out MAE {results[key]['mae']:.4f}, throttle MAE "
                  f"{results[key]['throttle_mae']:.4f}, {seconds:.0f} s", flush=True)
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

    rec = Source(str(tub), reader=reader(tub)).open()
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
