"""The rules a second new user's round (`python -m tests.rounds.run --round 2`) added to "Nothing silent", each with
its cases: the Python API checks the type of every value and every path where it enters (as the command line does),
Ctrl-C ends in one line at any moment, an error about a whole config or recording names the file and what to
do, a number in other units is refused where its range cannot hold it, and every script of studies/ and
benchmarks/ refuses bad arguments in one line before any work."""

import dataclasses
import importlib
import json
import pkgutil
import subprocess
import sys
from pathlib import Path
from typing import Literal, get_args, get_origin

import numpy as np
import pytest

import studies.common.donkeycar  # noqa: F401  (the options a study makes in Python, TubStudy's, among those swept)
from steerlab.cli import main
from steerlab.errors import SteerlabError
from steerlab.options import FRACTION, Options, optional
from tests.bad_input.builders import config
from tests.inputs import ch2, made, sim_log, tub

ROOT = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------- every option dataclass, made in Python

def _option_classes() -> list[type]:
    import steerlab

    for info in pkgutil.walk_packages(steerlab.__path__, "steerlab."):
        if not info.name.startswith(("steerlab.__main__", "steerlab.figures")):
            try:
                importlib.import_module(info.name)
            except ImportError:  # an optional dependency (a ROS bag reader, say)
                pass
    found, todo = [], list(Options.__subclasses__())
    while todo:
        cls = todo.pop()
        todo += cls.__subclasses__()
        if dataclasses.is_dataclass(cls):
            found.append(cls)
    return sorted(set(found), key=lambda c: f"{c.__module__}.{c.__name__}")


def _wrong_typed():
    """(class, field, a value of another type) for every typed field of every option dataclass that can be made
    with its defaults: a text for a number, a number for a boolean or a text, a boolean for a number, and a name
    that is not one of a Literal's choices."""
    for cls in _option_classes():
        if any(f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
               for f in dataclasses.fields(cls) if f.init):
            continue
        hints = __import__("typing").get_type_hints(cls)
        for f in dataclasses.fields(cls):
            kind = optional(hints[f.name])[0]
            if get_origin(kind) is Literal:
                yield cls, f.name, f"not-{get_args(kind)[0]}"
            elif kind in (int, float):
                yield cls, f.name, "1"
                yield cls, f.name, True
            elif kind is bool:
                yield cls, f.name, "no"
            elif kind is str:
                yield cls, f.name, 3


@pytest.mark.parametrize("cls, name, value", [pytest.param(*c, id=f"{c[0].__name__}.{c[1]}={c[2]!r}")
                                              for c in _wrong_typed()])
def test_an_option_dataclass_made_in_python_refuses_a_value_of_another_type(cls, name, value):
    with pytest.raises(SteerlabError, match=rf"^{cls.__name__}\.{name} must be "):
        cls(**{name: value})


def test_the_sweep_of_option_types_covers_the_cases_the_round_found():
    tried = {(c.__name__, n) for c, n, _ in _wrong_typed()}
    assert {("RecordOptions", "geometry"), ("ReplayOptions", "workers"), ("DriveOptions", "limit_m")} <= tried
    assert len(tried) > 100  # every command's options


def test_a_range_takes_real_numbers_only():
    assert FRACTION(0.5) and FRACTION(np.float32(0.5)) and FRACTION(1)
    assert not any(FRACTION(v) for v in (True, "0.5", None, [0.5], float("nan"), 0))


# ---------------------------------------------------------------- the Python API's other arguments

@pytest.fixture
def ckpt(tmp_path):
    return made(tmp_path)


@pytest.mark.parametrize("kw, message", [
    ({"smoothing": True}, "smoothing must be a number in (0, 1], got True"),
    ({"smoothing": "0.5"}, "smoothing must be a number in (0, 1], got '0.5'"),
    ({"steering_step": "0.1"}, "steering_step must be a positive finite number, got '0.1'"),
    ({"other_camera": "no"}, "other_camera must be True or False, got 'no'"),
])
def test_the_pilot_refuses_options_of_another_type(ckpt, kw, message):
    from steerlab.pilot import Pilot

    with pytest.raises(SteerlabError, match=f"^{message.replace('(', '[(]').replace(')', '[)]')}$"):
        Pilot(str(ckpt), **kw)


@pytest.mark.parametrize("frames, speeds, load, message", [
    (None, None, None, "frames must be a sequence .* got NoneType"),
    ("frames", None, None, "frames must be a sequence .* got str"),
    ([], 5.0, None, "speeds must be a sequence .* got float 5.0"),
    ([], "fast", None, "speeds must be a sequence .* got str 'fast'"),
    ([0, 1], None, 5, "load must be a function of an item that returns its BGR frame, got 5"),
])
def test_pilot_stream_refuses_what_is_not_a_sequence_or_a_function(ckpt, frames, speeds, load, message):
    from steerlab.pilot import Pilot

    with pytest.raises(SteerlabError, match=f"^Pilot.stream: {message}"):
        list(Pilot(str(ckpt)).stream(frames, speeds, load))


def test_pilot_stream_still_takes_an_array_of_frames_and_a_loader(ckpt):
    from steerlab.pilot import Pilot

    frames = np.zeros((2, 160, 320, 3), np.uint8)
    assert len(list(Pilot(str(ckpt)).stream(frames, np.array([3.0, 3.0])))) == 2
    assert len(list(Pilot(str(ckpt)).stream([0, 1], load=lambda i: frames[i]))) == 2


def _api(tmp_path, ckpt):
    """(call, the start of its message) for every path and structured argument of the Python API the round gave
    a value of another type."""
    from steerlab.checkpoint import load_checkpoint, save_ensemble
    from steerlab.data.readers import Source, open_recording
    from steerlab.donkey import SteerlabPilot
    from steerlab.evaluate.latency import run_latency
    from steerlab.evaluate.offline import evaluate
    from steerlab.evaluate.scoring import score
    from steerlab.export import export_onnx
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    sim = sim_log(tmp_path / "sim").parent
    labels = ch2(tmp_path / "ch2") / "labels.csv"
    cfg = config(tmp_path, sim)
    return [
        (lambda: open_recording(123), "the recording must be a path (a str or pathlib.Path), got 123"),
        (lambda: open_recording(None), "the recording must be a path"),
        (lambda: open_recording(str(labels.parent), labels=123), "labels must be a path (a str or pathlib.Path)"),
        (lambda: open_recording(str(sim), frame_range=5), f"{sim}: frame range 5 must be text like"),
        (lambda: open_recording(str(sim), options="strict=true"), f"{sim}: reader options must be a dict"),
        (lambda: load_checkpoint(None), "checkpoint must be a path"),
        (lambda: SteerlabPilot(None), "SteerlabPilot: model must be a path"),
        (lambda: evaluate(123, Source(str(sim)), str(tmp_path / "e")), "evaluate: checkpoint must be a path"),
        (lambda: evaluate(str(ckpt), str(sim), str(tmp_path / "e")),
         "evaluate: the recording must be given as a steerlab.data.readers.Source"),
        (lambda: evaluate(str(ckpt), Source(str(sim), range=5), str(tmp_path / "e")), f"{sim}: frame range 5"),
        (lambda: run_latency(source=str(sim)), "run_latency: the recording must be given as a"),
        (lambda: score(None, labels), "the predictions file must be a path"),
        (lambda: export_onnx(str(ckpt), None), "export_onnx: out must be a path"),
        (lambda: save_ensemble(str(ckpt), tmp_path / "e.pt"), "save_ensemble: checkpoints must be a list"),
        (lambda: load_config(123), "load_config: path must be a path"),
        (lambda: load_config(cfg, overrides="train.lr=1"), "load_config: overrides must be a list of"),
        (lambda: load_config(None, base=[1]), "load_config: base must be a dict of config sections, got [1]"),
        (lambda: train({"data": str(sim)}), "train takes a TrainConfig (steerlab.train.config.load_config(PATH))"),
        (lambda: train(str(cfg)), "train takes a TrainConfig"),
    ]


def test_every_path_and_structured_argument_of_the_api_is_checked_where_it_enters(tmp_path, ckpt):
    for call, message in _api(tmp_path, ckpt):
        with pytest.raises(SteerlabError) as e:
            call()
        assert str(e.value).startswith(message), (message, str(e.value))


def test_a_frame_range_as_a_pair_of_integers_is_taken(tmp_path):
    from steerlab.data.readers import open_recording

    sim = sim_log(tmp_path / "sim").parent
    assert len(open_recording(str(sim), frame_range=[2, 6])) == 4
    assert len(open_recording(str(sim), frame_range=(None, 3))) == 3
    with pytest.raises(SteerlabError, match="frame range"):
        open_recording(str(sim), frame_range=(True, 3))


# ---------------------------------------------------------------- Ctrl-C, and messages that say where and what to do

def test_ctrl_c_while_the_command_starts_ends_in_one_line(monkeypatch, capsys):
    """The imports take seconds; Ctrl-C during them, or while the command line is read, ends as Ctrl-C later
    does (exit code 130, `interrupted`, no traceback)."""
    code = ("import builtins, runpy\nreal = builtins.__import__\n"
            "def imp(name, *a, **k):\n"
            "    if name == 'steerlab.cli':\n        raise KeyboardInterrupt\n"
            "    return real(name, *a, **k)\n"
            "builtins.__import__ = imp\nrunpy.run_module('steerlab', run_name='__main__')\n")
    p = subprocess.run([sys.executable, "-c", code, "models"], capture_output=True, text=True, timeout=120)
    assert (p.returncode, p.stderr) == (130, "interrupted\n")
    import steerlab.cli

    def interrupted(argv):
        raise KeyboardInterrupt

    monkeypatch.setattr(steerlab.cli, "parse_args", interrupted)
    assert main(["models"]) == 130
    assert capsys.readouterr().err == "interrupted\n"


@pytest.mark.parametrize("content, message", [
    ("", "{cfg}: the config names no data (set data: PATH or pass data=PATH)"),
    ('{"image_size": [160, 120], "K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}',
     "{cfg}: unknown config sections ['K', 'image_size']; known: "),
])
def test_a_file_that_is_no_config_is_named(tmp_path, capsys, content, message):
    cfg = tmp_path / "calib.json"
    cfg.write_text(content)
    assert main(["train", str(cfg)]) == 2
    assert capsys.readouterr().err.startswith(f"error: {message.format(cfg=cfg)}")


def test_a_split_outside_the_recording_says_its_frames_and_what_to_give(tmp_path, capsys):
    cfg = config(tmp_path, ch2(tmp_path / "ch2"))  # 6 frames; the config's split.val is 6:8
    assert main(["train", str(cfg), f"out={tmp_path / 'run'}"]) == 2
    assert "error: split.val range '6:8' is empty or outside the recording's 6 frames: give a range START:STOP " \
           "within 0:6" in capsys.readouterr().err


def test_a_recording_too_short_for_a_recurrent_model_is_named(tmp_path, capsys):
    cfg = config(tmp_path, tub(tmp_path / "tub"))
    assert main(["train", str(cfg), "model.name=lstm", "model.seq_len=10", f"out={tmp_path / 'run'}"]) == 2
    err = capsys.readouterr().err
    assert f"error: {tmp_path / 'tub'}: no training window of 10 consecutive frames" in err
    assert "set model.seq_len below 10" in err


def test_latency_on_a_recording_shorter_than_its_default_frames_times_them_all(tmp_path, capsys):
    sim = sim_log(tmp_path / "sim").parent  # 8 frames; latency takes the first 100 of a recording by default
    assert main(["latency", "--models", "zero", "--data", str(sim), "--frames", "3", "--out",
                 str(tmp_path / "lat")]) == 0
    assert (tmp_path / "lat" / "latency.csv").exists()


# ---------------------------------------------------------------- numbers in other units

def test_a_replay_speed_the_car_cannot_drive_is_refused(tmp_path, capsys):
    ckpt = made(tmp_path)
    sim = sim_log(tmp_path / "sim").parent
    assert main(["replay", str(ckpt), "--data", str(sim), "--speed", "60", "--out", str(tmp_path / "rp")]) == 2
    assert "the speed 60 m/s (steerlab replay --speed) is beyond what this recording's car drives (1-45 m/s): km/h " \
           "or mph where m/s is expected? give it in m/s" in capsys.readouterr().err


def test_a_field_of_view_in_radians_is_refused():
    from steerlab.sim.replay.run import ReplayOptions

    with pytest.raises(SteerlabError, match=r"ReplayOptions.fov must be a number in \[10, 180\) degrees, got 1.2"):
        ReplayOptions(fov=1.2)
    assert ReplayOptions(fov=10.0).fov == 10.0


# ---------------------------------------------------------------- the scripts of studies/ and benchmarks/

def test_a_timings_report_never_writes_over_another_file(tmp_path):
    from benchmarks.common import Report

    other = tmp_path / "calibration.json"
    other.write_text('{"K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}')
    with pytest.raises(SteerlabError, match="exists and is not a timing's report"):
        Report("bench_x", {}, other)
    with pytest.raises(SteerlabError, match="a .json file is expected"):
        Report("bench_x", {}, made(tmp_path))
    earlier = tmp_path / "r.json"
    earlier.write_text(json.dumps({"script": "bench_x", "results": {}}))
    assert Report("bench_x", {}, earlier).path == earlier  # a timing's own report is written again


SCRIPTS = [(module, argv, said) for module, argv, said in [
    ("benchmarks.bench_checkpoint", ["--json", "{ckpt}"], "a .json file is expected for the report"),
    ("benchmarks.bench_ddp", ["--model", "pilot-net"], "pilot-net"),
    ("studies.replay_vs_road_suite", ["--minutes", "-1"], "--minutes must be a number in (0, 1440]"),
    ("studies.track_recipes", ["--caps", "2"], "--caps"),
    ("studies.speed_estimate", ["--minutes", "1"], "unrecognized arguments: --minutes 1"),
    ("studies.pruning_replay", ["{tmp}"], "study.journal"),
    ("studies.tub_replay", ["--models", "pilotnet,pilotnet"], "--models must be a comma list of trained models"),
]]


@pytest.mark.parametrize("module, argv, said", SCRIPTS, ids=[f"{m} {' '.join(a)}" for m, a, _ in SCRIPTS])
@pytest.mark.filterwarnings("ignore:.*found in sys.modules after import of package:RuntimeWarning")  # imported here
def test_a_script_refuses_a_bad_argument_in_one_line_before_any_work(tmp_path, monkeypatch, capsys, module, argv,
                                                                      said):
    """Each script run as `python -m` runs it (its module as __main__), here in this process; the first instead as a
    process of its own, as a user starts it."""
    import runpy

    ckpt = made(tmp_path)
    before = ckpt.read_bytes()
    argv = [a.format(ckpt=ckpt, tmp=tmp_path) for a in argv]
    if module == SCRIPTS[0][0]:
        p = subprocess.run([sys.executable, "-m", module, *argv], capture_output=True, text=True, timeout=60, cwd=ROOT)
        code, err = p.returncode, p.stderr
    else:
        monkeypatch.chdir(ROOT)
        monkeypatch.setattr(sys, "argv", [module, *argv])
        with pytest.raises(SystemExit) as ended:
            runpy.run_module(module, run_name="__main__", alter_sys=True)
        code, err = ended.value.code, capsys.readouterr().err
    lines = [line for line in err.splitlines() if not line.startswith("usage:") and line.strip()
             and not line.startswith(" ")]
    assert code == 2 if "argument" in said or "unrecognized" in said else code in (1, 2)
    assert len(lines) == 1 and "error: " in lines[0] and said in lines[0], err
    assert ckpt.read_bytes() == before
