"""A fourth world, as docs/architecture/worlds.md ("Adding a world") says to add one: a toy world registered here, and
driven through the command line (record, drive, bench), DAgger and a suite with no line of steerlab naming it.

The toy world is an endless straight lane: the car keeps 10 m/s, steering turns it (a kinematic bicycle), its
camera sees the lane as a bright band that moves across the frame with the car's offset, and its expert steers back
to the lane centre. It renders the road world's camera ("sim"), so that the checkpoints of the tests' recordings
drive it."""

import csv
import json
import math
from dataclasses import dataclass

import numpy as np
import pytest

from steerlab.cli import build_parser, main
from steerlab.data.car import CARS, VehicleState
from steerlab.data.geometry import CAMERAS
from steerlab.data.writer import RecordingWriter
from steerlab.options import MINUTES, Options, SEED, WORKERS, frames_in, option
from steerlab.pilot import Controls, smoothing_option, steering_step_option
from steerlab.sim.core.driving import autonomy, drive_loop, rollout
from steerlab.sim.core.entry import (Column, DaggerEntry, Driver, Recorder, ReplayEntry, ReportEntry, SuiteEntry,
                                     WorldEntry)
from steerlab.sim.core.suite import Planned, close, entrants, run_drives, write_csv, write_json
from steerlab.sim.replay.run import ReplayOptions
from steerlab.sim.worlds import WORLDS, register

FPS, SPEED, CAM = 20.0, 10.0, CAMERAS["sim"]
SUITES = {"k1": {"minutes": 0.02, "seeds": [9901, 9902]}}


class ToyWorld:
    """The `core.contracts.World` of the toy lane (see the module's docstring)."""

    def __init__(self, seed: int):
        self.car = CARS["sim"]
        self.steering_ratio, self.s, self.done = self.car.steering_ratio, 0.0, False
        self.offset, self.heading = 0.3 * np.random.default_rng(seed).uniform(-1, 1), 0.0

    @property
    def state(self) -> VehicleState:
        return VehicleState(self.s, self.offset, self.heading, SPEED)

    def intervene(self, limit_m: float) -> tuple[bool, float, float]:
        put_back = abs(self.offset) > limit_m
        if put_back:
            self.offset, self.heading = 0.0, 0.0
        return put_back, self.offset, self.heading

    def render(self, lateral: float = 0.0) -> np.ndarray:
        frame = np.full((CAM.height, CAM.width, 3), 60, np.uint8)
        centre = int(CAM.width / 2 - 80 * (self.offset + lateral))
        frame[CAM.height // 2:, max(centre - 6, 0):max(centre + 6, 0)] = 230
        return frame

    def expert_steering(self) -> float:
        return float(np.clip(-0.2 * self.offset - self.heading, -0.3, 0.3))

    def step(self, road_wheel: float, throttle: float | None = None) -> None:
        self.heading += SPEED / self.car.wheelbase * math.tan(road_wheel) / FPS
        self.offset += SPEED * math.sin(self.heading) / FPS
        self.s += SPEED / FPS

    def record_row(self, tick: int) -> dict:
        return {"timestamp_ns": int(round(tick * 1e9 / FPS)), "speed": SPEED, "throttle": 0.0, "brake": 0.0,
                "curvature": 0.0}


class Expert:
    """The toy's expert as a pilot (it reads the world's state, not the frame)."""

    name, geometry, source = "expert", "sim", "the toy expert"

    def __init__(self, world: ToyWorld):
        from steerlab.data.recording import SteeringConvention

        self.world, self.convention = world, SteeringConvention("road_wheel", "left")

    def step(self, frame, speed=None) -> Controls:
        return Controls(self.world.expert_steering())

    def reset(self) -> None:
        pass


@dataclass(frozen=True)
class ToyDrive:
    label: str
    seed: int
    minutes: float
    autonomy: float
    interventions: int


@dataclass(frozen=True)
class RecordToy(Options):
    seed: int = option(0, SEED, help="lane seed")
    minutes: float = option(0.05, MINUTES, help="minutes of driving")


@dataclass(frozen=True)
class DriveToy(Options):
    seed: int = option(100, SEED, help="lane seed")
    minutes: float = option(0.05, MINUTES, help="minutes of driving")


@dataclass(frozen=True)
class ToySuite(Options):
    suite: str = option("k1", lambda v: v in SUITES, "k1", help="toy suite version")
    minutes: float | None = option(None, MINUTES, help="minutes per lane")
    workers: int = option(1, WORKERS, help="lanes driven in parallel")
    smoothing: float | None = smoothing_option()
    steering_step: float | None = steering_step_option()

    @property
    def place_minutes(self) -> float:
        return SUITES[self.suite]["minutes"] if self.minutes is None else self.minutes

    def drives(self) -> list[tuple[str, int]]:
        return [("lane", seed) for seed in SUITES[self.suite]["seeds"]]


@dataclass(frozen=True)
class ToyDagger(Options):
    suite_keys, suite_places = {}, "suite"

    def kinds(self) -> list[str]:
        return ["lane"]


def record(out, o: RecordToy, progress: bool = True):
    """The expert's drive, as a steerlab recording: a rollout in which the expert drives every tick."""
    world = ToyWorld(o.seed)
    writer = RecordingWriter(out, ["center"], geometry="sim")
    rollout(Expert(world), [(world, frames_in(o.minutes, FPS))], writer, writer.convention, 1.0,
            np.random.default_rng(0), 1.0, FPS)
    return writer.close({"world": "toy", "seed": o.seed, "fps": FPS})


def drive(pilot, out, seed: int, minutes: float, meta: dict | None = None) -> ToyDrive:
    world = ToyWorld(seed)
    t = drive_loop(world, pilot, frames_in(minutes, FPS), 1.0, FPS, progress=False)
    result = ToyDrive(pilot.name, seed, minutes, autonomy(t.interventions, len(t) / FPS), t.interventions)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_json(out / "drive.json", result, meta)
    return result


def drive_checkpoint(checkpoint, out, o: DriveToy, w, video=None) -> ToyDrive:
    from pathlib import Path

    from steerlab.pilot import Pilot

    return drive(Pilot(checkpoint, smoothing=w.smoothing), Path(out), o.seed, o.minutes)


def suite_pilot(checkpoint: str, o: ToySuite):
    from steerlab.pilot import Pilot

    return Pilot(checkpoint, smoothing=o.smoothing, steering_step=o.steering_step)


def _job(entrant, o: ToySuite, seed: int, out, key: dict) -> ToyDrive:
    pilot = entrant.make(o)
    try:
        return drive(pilot, out, seed, o.place_minutes, {"cache_key": key})
    finally:
        close(pilot)


def run_suite(pilots, out, o: ToySuite = ToySuite(), progress: bool = True, plots: bool = True) -> list[ToyDrive]:
    """Every pilot on every lane of the suite: suite.csv, one row per drive, which are the summary."""
    from pathlib import Path

    racing, out = entrants(pilots, suite_pilot), Path(out)
    planned = [Planned((e.label, seed), out / e.label / f"lane-{seed}", {**e.identity, "minutes": o.place_minutes},
                       (e, o, seed, out / e.label / f"lane-{seed}", {**e.identity, "minutes": o.place_minutes}))
               for e in racing for _, seed in o.drives()]
    results = run_drives(_job, ToyDrive, planned, o.workers, frames_in(o.place_minutes, FPS), progress, "toy suite")
    drives = [ToyDrive(e.label, seed, r.minutes, r.autonomy, r.interventions)
              for e in racing for _, seed in o.drives() for r in [results[(e.label, seed)]]]
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "suite.csv", drives)
    (out / "suite.md").write_text(f"toy suite {o.suite}: {len(drives)} drives\n")
    return drives


def rollout_job(checkpoint, out, seed, minutes, kind, beta, camera, suite) -> ToyDrive:
    from steerlab.pilot import Pilot

    pilot, world = Pilot(checkpoint), ToyWorld(seed)
    writer = RecordingWriter(out, ["center"], geometry=camera)
    t = rollout(pilot, [(world, frames_in(minutes, FPS))], writer, writer.convention, beta,
                np.random.default_rng(seed), 1.0, FPS)
    writer.close({"world": "toy", "seed": seed, "fps": FPS, "beta": beta})
    return ToyDrive(pilot.name, seed, minutes, autonomy(t.interventions, len(t) / FPS), t.interventions)


def round_columns(summary: list[ToyDrive]) -> dict:
    return {"toy_autonomy": float(np.mean([d.autonomy for d in summary]))}


TOY = WorldEntry(
    name="toy", help="an endless straight lane", cameras=("sim",),
    record=Recorder(options=RecordToy, run=record),
    drive=Driver(options=DriveToy, run=drive_checkpoint, files="drive.json"),
    suite=SuiteEntry(options=ToySuite, versions=SUITES, run=run_suite, figures="none"),
    replay=ReplayEntry(options=ReplayOptions),
    dagger=DaggerEntry(options=ToyDagger, rollout=rollout_job, camera=lambda rec: rec.geometry, done="recording.json",
                       round_columns=round_columns, columns=("toy_autonomy",),
                       series=(("toy_autonomy", "k.-", "toy lanes"),)),
    report=ReportEntry(metrics=lambda checkpoint, o, progress, plots=True: round_columns(run_suite([checkpoint], o)),
                       table=(Column(header="toy autonomy [%]", keys=("toy_autonomy",), digits=1),),
                       worst=Column(header="worst seed [%]", keys=("toy_autonomy",), digits=1),
                       plot_drives=lambda *a: None))


@pytest.fixture
def toy():
    build_parser.cache_clear()  # the command line is built with the worlds registered when it is built
    register(TOY)
    yield TOY
    del WORLDS["toy"]
    build_parser.cache_clear()


def test_the_toy_world_through_the_command_line(toy, tmp_path, tiny_checkpoint, capsys):
    """sim record, sim drive and sim bench --world toy, with the toy's own options; a road option is refused."""
    assert main(["sim", "record", "--world", "toy", "--seed", "4", "--minutes", "0.02", "--out",
                 str(tmp_path / "rec")]) == 0
    assert json.loads((tmp_path / "rec" / "recording.json").read_text())["world"] == "toy"
    with open(tmp_path / "rec" / "log.csv") as f:
        assert len(list(csv.DictReader(f))) == frames_in(0.02, FPS)
    assert main(["sim", "drive", str(tiny_checkpoint), "--world", "toy", "--minutes", "0.02", "--out",
                 str(tmp_path / "drive")]) == 0
    drive = json.loads((tmp_path / "drive" / "drive.json").read_text())
    assert drive["label"] == "pilotnet" and drive["seed"] == 100 and f"wrote {tmp_path / 'drive'}/drive.json" in \
        capsys.readouterr().out
    assert main(["sim", "bench", str(tiny_checkpoint), "--world", "toy", "--out", str(tmp_path / "bench")]) == 0
    with open(tmp_path / "bench" / "suite.csv") as f:
        assert [(r["label"], r["seed"]) for r in csv.DictReader(f)] == [("run", "9901"), ("run", "9902")]
    assert main(["sim", "drive", str(tiny_checkpoint), "--world", "toy", "--road", "twisty", "--out",
                 str(tmp_path / "x")]) == 2
    assert "--road is an option of the road world (--world road); the toy world does not take it" in \
        capsys.readouterr().err


def test_dagger_in_the_toy_world(toy, tiny_recording, tmp_path, saved_figures):
    """A round of DAgger rolls out in the toy world, trains on its rollout and drives the toy suite; dagger.csv has
    the toy's column, dagger.png its line."""
    from steerlab.dagger import run_dagger
    from steerlab.train.config import load_config

    cfg = load_config(None, base={
        "data": str(tiny_recording), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "dagger"),
        "split": {"train": "0:60", "val": "240:300"}, "train": {"epochs": 1, "batch_size": 32},
        "dagger": {"world": "toy", "iterations": 1, "minutes": 0.02, "epochs": 1, "workers": 1}})
    assert run_dagger(cfg, progress=False).exists()
    with open(tmp_path / "dagger" / "dagger.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["round", "beta", "recordings", "rollout_autonomy", "val_rmse", "toy_autonomy"]
    assert [r["round"] for r in rows] == ["0", "1"] and rows[1]["recordings"] == "2"
    assert rows[0]["toy_autonomy"] != "" and rows[1]["toy_autonomy"] != ""
    assert (tmp_path / "dagger" / "round1" / "rollouts" / "lane-5100" / "recording.json").exists()
    with open(tmp_path / "dagger" / "round1" / "suite" / "suite.csv") as f:
        assert len(list(csv.DictReader(f))) == 2
    with pytest.raises(Exception, match="dagger.roads is an option of dagger.world road; dagger.world toy does not"):
        from steerlab.dagger import dagger_options

        dagger_options(load_config(None, base={"data": "x", "dagger": {"world": "toy", "roads": "twisty"}}))
