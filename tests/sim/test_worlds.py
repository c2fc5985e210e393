"""The contracts of the driving loop (`sim/core/contracts.py`) and the registry of worlds (`sim/worlds.py`): every
world and pilot steerlab has is what the loop asks for, a world that is not is refused before it drives, and every
command finds a world's options and functions through its registry entry."""

import json

import numpy as np
import pytest

from conftest import made
from steerlab.cli import main
from steerlab.data.car import CARS
from steerlab.data.geometry import CAMERAS
from steerlab.data.readers import open_recording
from steerlab.pilot import Controls, Pilot
from steerlab.sim.core.contracts import Pilot as PilotContract, World as WorldContract
from steerlab.sim.core.driving import drive_loop
from steerlab.sim.core.part import PartPilot
from steerlab.data.path import human_path
from steerlab.sim.track.replay import TrackReplay
from steerlab.sim.replay.world import Replay
from steerlab.sim.road.world import World
from steerlab.sim.track.world import RacerPilot, TrackWorld
from steerlab.sim.worlds import WORLDS, world_of


class Part:
    def run(self, img_arr):
        return 0.0, 0.2


def test_every_world_and_pilot_keeps_the_contract(tiny_recording, tiny_checkpoint):
    rec = open_recording(tiny_recording)
    path = human_path(np.zeros(40), np.full(40, 1.5), np.arange(40) * 0.05, CARS["donkey"])
    worlds = [World(1, "country", "sim", 10.0), TrackWorld(1, camera=None),
              Replay(CAMERAS["sim"], CARS["sim"]).world(rec, 0, path),
              TrackReplay(CAMERAS["donkey"], CARS["donkey"]).world(rec, 0, path)]
    assert all(isinstance(w, WorldContract) for w in worlds)
    pilots = [Pilot(tiny_checkpoint), PartPilot(Part(), 25.0), RacerPilot(worlds[1], 1)]
    assert all(isinstance(p, PilotContract) for p in pilots)


def test_the_loop_refuses_what_is_not_a_world_or_a_pilot():
    class Wheel:  # a world without a renderer, state or lane
        car, steering_ratio, s, done = CARS["sim"], 1.0, 0.0, False

        def step(self, road_wheel, throttle=None):
            pass

    class Silent:  # answers frames, but nothing says what it is
        def step(self, frame, speed=None):
            return Controls(0.0)

    with pytest.raises(TypeError, match="Wheel is not a World of the driving loop: it lacks expert_steering, "
                                        "intervene, record_row, render, state"):
        drive_loop(Wheel(), PartPilot(Part(), 25.0), 10, 1.0, 20.0, progress=False)
    with pytest.raises(TypeError, match="Silent is not a Pilot of the driving loop: it lacks convention, geometry, "
                                        "name, reset, source"):
        drive_loop(TrackWorld(1, camera=None), Silent(), 10, 0.0, 20.0, progress=False)


def test_each_world_is_found_by_its_camera_and_its_suites():
    assert world_of("donkey").name == "track" and world_of("sim").name == world_of("ch2").name == "road"
    for name, w in WORLDS.items():
        assert w.name == name and w.cameras and w.suite.versions
        for cls in (w.record.options, w.drive.options, w.suite.options, w.replay.options):
            cls()  # every option of a world has a default
        kinds = w.dagger.options().kinds()  # a world's own options of a dagger section name its rollouts' places
        assert kinds and w.dagger.options(**{k: ",".join(kinds) for k in ("roads", "styles")
                                             if k in w.dagger.options.__dataclass_fields__}).kinds() == kinds
        assert w.suite.options().drives()  # the default suite has places to drive


def test_a_config_that_names_the_road_world_synthetic_still_loads(tmp_path, capsys):
    from steerlab.dagger import dagger_options
    from steerlab.train.config import load_config

    cfg = load_config(None, base={"data": str(tmp_path), "dagger": {"world": "synthetic", "iterations": 1}})
    o = dagger_options(cfg)
    assert o.world == "road" and o.iterations == 1
    assert capsys.readouterr().out == "notice: dagger.world: synthetic is the road world's earlier name; read as road\n"


def test_sim_drive_of_each_world_prints_its_result(tmp_path, tiny_checkpoint, capsys):
    tub_model = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    for world, ckpt in (("road", tiny_checkpoint), ("track", tub_model)):
        out = tmp_path / world
        assert main(["sim", "drive", str(ckpt), "--world", world, "--minutes", "0.01", "--out", str(out)]) == 0
        printed = capsys.readouterr().out
        result = json.loads((out / "drive.json").read_text())
        assert result["label"] == "pilotnet" and f"wrote {out}/{WORLDS[world].drive.files}" in printed
        assert all(name in printed for name in result)  # every field of the typed result in the table

def test_dagger_drives_the_suite_of_its_own_world_unless_told():
    from steerlab.dagger import dagger_options
    from steerlab.train.config import load_config

    def suite(**dagger):
        return dagger_options(load_config(None, base={"data": "x", "dagger": dagger})).suite

    assert suite() == "v1" and suite(world="track") == "t1" and suite(world="track", suite="s1") == "s1"
    assert suite(world="track", suite=None) is None and suite(world="replay") is None


def test_dagger_and_experiments_replay_a_recording_in_the_world_of_its_camera(tmp_path, tiny_recording):
    """A track-world tub is replayed as `steerlab replay` replays it (the fisheye, the body in the lane), a
    road-world recording as a road."""
    from steerlab.sim.track.run import record
    from steerlab.sim.track.world import TrackRecordOptions
    from steerlab.split_replay import SplitReplay
    from steerlab.train.config import load_config

    tub = record(tmp_path / "tub", TrackRecordOptions(seed=3, minutes=0.05), progress=False)
    for data, kind in ((tub, TrackReplay), (tiny_recording, Replay)):
        cfg = load_config(None, base={"data": str(data), "split": {"train": "0:40", "val": "40:60"},
                                      **({"reader": {"full_lock_deg": 25}} if data == tub else {})})
        replay = SplitReplay(cfg, speed=1.5).replay
        assert type(replay) is kind and replay.speed == 1.5


def test_closed_loop_drives_the_suite_of_either_world(tmp_path, saved_figures):
    """`closed_loop:` names a world's suite, by its version ({suite: t1}) or its world ({world: track}): an experiment
    tabulates the track suite's columns and draws its tracks, and tune's autonomy objective is the track suite's
    autonomy over all its tracks."""
    import csv

    import yaml

    from steerlab.errors import SteerlabError
    from steerlab.experiment import run_experiment
    from steerlab.sim.road.suite import SuiteOptions
    from steerlab.sim.track.run import record
    from steerlab.sim.track.suite import TrackSuiteOptions
    from steerlab.sim.track.world import TrackRecordOptions
    from steerlab.sim.worlds import closed_loop
    from tests.tune.tuning import rows, run_tune

    assert closed_loop(None) == (WORLDS["road"], SuiteOptions())
    assert closed_loop({"suite": "t1", "minutes": 0.5}) == (WORLDS["track"], TrackSuiteOptions(minutes=0.5))
    assert closed_loop({"world": "track", "suite": "s1"}) == (WORLDS["track"], TrackSuiteOptions(suite="s1"))
    with pytest.raises(SteerlabError, match=r"^closed_loop.suite must be t1 or s1 or t2 or t3, got 'v1'$"):
        closed_loop({"world": "track", "suite": "v1"})
    with pytest.raises(SteerlabError, match=r"^closed_loop.world must be one of road, track, got 'boat'$"):
        closed_loop({"world": "boat"})
    tub = record(tmp_path / "tub", TrackRecordOptions(seed=3, minutes=0.05), progress=False)
    base = {"data": str(tub), "reader": {"full_lock_deg": 25}, "cache": str(tmp_path / "cache"),
            "split": {"train": "0:40", "val": "40:60"}, "preprocess": {"preset": "donkey", "color": "gray"},
            "train": {"epochs": 1, "batch_size": 16},
            "closed_loop": {"world": "track", "minutes": 0.01, "workers": 1, "styles": "centre"}}
    (tmp_path / "exp.yaml").write_text(yaml.safe_dump({**base, "out": str(tmp_path / "exp"),
                                                       "models": [{"model": {"name": "pilotnet"}}]}))
    table = run_experiment(tmp_path / "exp.yaml", seeds=1, progress=False).read_text()
    assert ("| autonomy [%] | taped / centre [%] | clean laps [%] | pace | off track / lap | command gamma [deg] |"
            in table)
    assert sorted(p.name for p in (tmp_path / "exp" / "tracks").iterdir()) == ["centre-9451.png", "centre-9452.png"]
    with open(tmp_path / "exp" / "pilotnet" / "seed0" / "suite" / "summary.csv") as f:
        overall = next(r for r in csv.DictReader(f) if r["style"] == "all")
    with open(tmp_path / "exp" / "table.csv") as f:
        assert float(next(csv.DictReader(f))["autonomy_mean"]) == pytest.approx(float(overall["autonomy"]))
    by_suite = {"suite": "t1", "minutes": 0.01, "workers": 1, "styles": "centre"}  # the track world by its suite
    (tmp_path / "tune.yaml").write_text(yaml.safe_dump({**base, "out": str(tmp_path / "tune"), "closed_loop": by_suite,
                                                        "tune": {"train.lr": {"low": 1e-4, "high": 1e-2}}}))
    run_tune(tmp_path / "tune.yaml", trials=1, objective="autonomy", seed=0, progress=False)
    (trial,) = rows(tmp_path / "tune")
    with open(tmp_path / "tune" / "trials" / "0000" / "suite" / "summary.csv") as f:
        overall = next(r for r in csv.DictReader(f) if r["style"] == "all")
    assert float(trial["value_0"]) == pytest.approx(float(overall["autonomy"]))
