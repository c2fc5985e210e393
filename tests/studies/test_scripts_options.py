"""The scripts of studies/ and benchmarks/, and the bad-input rounds' runner (tests/rounds/run.py), take their
options as the steerlab command does (`cli.script_parser`): every option of every script is swept by its declared
type, as tests/bad_input/ sweeps the commands' (numbers outside their range, paths that are not there or of
the wrong kind, an option given twice), and each bad value is refused in one line that names the option and the
script, exit code 2. Only the command lines are parsed: no script's work starts here."""

import argparse
import ast
import importlib
import os
from dataclasses import MISSING
from pathlib import Path

import cv2
import pytest

from steerlab.cli import Parser, flag, script_args
from steerlab.options import optional, options_of
from studies.common import ROOT, NumberList
from tests.bad_input.builders import _a_range, _edges

SCRIPTS = ["tests.rounds.run"] + [  # the rounds' runner, and every study and timing
    f"{folder}.{p.stem}" for folder in ("studies", "benchmarks") for p in sorted((ROOT / folder).glob("*.py"))
    if not p.stem.startswith("_") and p.stem != "common"]
_parsers = {}


def parser_of(script: str) -> Parser:
    """The script's parser, its module imported once; what an import of a timing sets for its own run (one OpenMP
    and one OpenCV thread) is undone, so that the tests' processes keep theirs."""
    if script not in _parsers:
        env, threads = dict(os.environ), cv2.getNumThreads()
        try:
            module = importlib.import_module(script)
        finally:
            os.environ.clear()
            os.environ.update(env)
            cv2.setNumThreads(threads)
        _parsers[script] = module.parser
    return _parsers[script]()


def _refused(script: str, argv: list[str], capsys) -> str:
    """The one line a script's command line `argv` is refused with (exit code 2, nothing run), naming the script."""
    with pytest.raises(SystemExit) as e:
        script_args(parser_of(script), argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.startswith("error: ") and err.count("\n") == 1, (argv, err)
    assert f"python -m {script} " in err, err
    return err


def _needed(script: str, tmp_path: Path, leave: str | None = None) -> list[str]:
    """The arguments a script needs besides the one under test (`leave`): an existing file or folder, as its kind
    asks, for every required argument and every option without a default."""
    p = parser_of(script)
    file, folder = tmp_path / "a-file", tmp_path / "a-folder"
    file.touch()
    folder.mkdir(exist_ok=True)
    paths = p.get_default("paths") or {}
    value = {"folder": str(folder), "new-file": str(tmp_path / "new-file"), "file": str(file)}
    argv = []
    for a in p._actions:
        if a.dest == leave or isinstance(a, argparse._HelpAction):
            continue
        if a.option_strings and a.required:
            argv += [a.option_strings[0], value.get(paths.get(a.dest), str(file))]
        elif not a.option_strings and a.nargs not in ("*", "?"):
            argv.append(value.get(paths.get(a.dest), str(folder)))
    for cls in p.get_default("options"):
        for o in options_of(cls):
            if o.default is MISSING and o.key != leave:
                argv += [flag(o.key), str(folder)]
    return argv


def _numeric_options():
    """(script, option, type, range) of every option of a script that takes a number or a comma list of them."""
    out = []
    for script in SCRIPTS:
        for cls in parser_of(script).get_default("options"):
            for o in options_of(cls):
                kind = optional(o.kind)[0]
                if kind in (int, float):
                    out.append((script, o.key, kind, _a_range(f"{script} {flag(o.key)}", o.check)))
                elif isinstance(o.check, NumberList):
                    out.append((script, o.key, "list", o.check))
    return out


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_script_runs_through_the_typed_command_line(script):
    """Each script's `__main__` runs `run_script(parser(), main)`: the parser the sweeps below try is the one the
    script parses its command line with, and what its work refuses ends in one line too."""
    path = ROOT / Path(*script.split(".")).with_suffix(".py")
    calls = [ast.unparse(n) for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.Call)]
    assert "run_script(parser(), main)" in calls, f"{path.name} does not run through steerlab.cli.run_script"
    assert isinstance(parser_of(script), Parser) and parser_of(script).prog == f"python -m {script}"


@pytest.mark.parametrize("script, name, kind, check", _numeric_options(),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_numeric_script_option_is_refused_out_of_range(script, name, kind, check, tmp_path, capsys):
    """Values out of the option's range, of the wrong type and at an open end, one line naming the flag; a comma
    list of numbers (`--seeds 0,1`) with one such value in it, or a value twice."""
    if kind == "list":  # after a value the list takes: the bad one is what is refused
        good = next(str(v) for v, taken in _edges(check.range, check.kind) if taken)
        bad = [f"{good},{v}" for v, taken in _edges(check.range, check.kind)
               if not taken and not isinstance(v, (bool, list))] + [f"{good},{good}"] + ([] if check("") else [""])
    else:
        bad = [v for v, taken in _edges(check, kind) if not taken and not isinstance(v, (bool, list))]
    argv = _needed(script, tmp_path)
    for value in bad:
        err = _refused(script, [*argv, f"{flag(name)}={value}"], capsys)
        assert flag(name) in err, err


def _path_arguments():
    return [(script, dest, kind) for script in SCRIPTS
            for dest, kind in (parser_of(script).get_default("paths") or {}).items()]


@pytest.mark.parametrize("script, dest, kind", _path_arguments(), ids=lambda v: v if isinstance(v, str) else None)
def test_every_script_path_argument_is_checked(script, dest, kind, tmp_path, capsys):
    """A missing file, a folder where a file is expected and a file where a folder is expected: one line naming
    the path."""
    file, folder = tmp_path / "a-file", tmp_path / "a-folder"
    argv = _needed(script, tmp_path, leave=dest)
    positional = next(a for a in parser_of(script)._actions if a.dest == dest).option_strings == []
    for path in {"file": [tmp_path / "missing.pt", folder], "folder": [file], "new-file": [folder]}[kind]:
        err = _refused(script, [*argv, str(path)] if positional else [*argv, flag(dest), str(path)], capsys)
        assert err.startswith(f"error: {path}: "), err


def _single_value_flags():
    """(script, flag, takes a value) of every option of a script that holds one value (not a list)."""
    return [(script, a.option_strings[-1], a.nargs != 0) for script in SCRIPTS for a in parser_of(script)._actions
            if a.option_strings and not isinstance(a, (argparse._AppendAction, argparse._HelpAction))]


@pytest.mark.parametrize("script, name, valued", _single_value_flags(), ids=lambda v: v if isinstance(v, str) else None)
def test_every_script_option_given_twice_is_refused(script, name, valued, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    first = [name, "1"] if valued else [name]
    for second in (first, [f"{name}=2"] if valued else [name]):
        err = _refused(script, [*first, *second], capsys)
        assert err.startswith(f"error: {name} is given twice"), err


def test_the_sweeps_reach_every_script():
    """Every script is swept; the numbers of the studies' and the timings' options are all there."""
    numeric = {(script, name) for script, name, *_ in _numeric_options()}
    assert {("studies.replay_vs_road_suite", "minutes"), ("studies.replay_references", "lane_width"),
            ("studies.replay_references", "speed"), ("studies.pruning_replay", "factors"),
            ("studies.track_recipes", "seeds"), ("studies.track_recipes", "caps"), ("studies.lane_drive", "seed"),
            ("benchmarks.bench_track_drive", "minutes"), ("benchmarks.bench_vs_donkeycar", "epochs")} <= numeric
    assert len(SCRIPTS) == 31 and len(_single_value_flags()) >= len(SCRIPTS)


def test_what_a_script_refuses_once_it_runs_ends_in_one_line_too(tmp_path, capsys):
    """Inputs that only the work can judge (a journal with no study in it, a recording that is not there) end the
    script in one line naming it, through `run_script`, before any long work."""
    from steerlab.cli import run_script

    from tests.inputs import made

    (tmp_path / "study.journal").touch()
    plain = made(tmp_path, "normalized", geometry="donkey", full_lock_deg=25.0)  # no lane head
    cases = [("studies.pruning_replay", [str(tmp_path)], f"error: {tmp_path / 'study.journal'}: holds no study"),
             ("studies.replay_references", ["--data", str(tmp_path / "nowhere")], f"error: {tmp_path / 'nowhere'}: "),
             ("studies.same_batches", ["--before", str(tmp_path)], f"error: --before {tmp_path}: no src/steerlab"),
             ("studies.lane_drive", [str(plain), "--steer-by", "lane", "--out", str(tmp_path / "a")],
              f"error: {plain}: steer_by lane steers by the lane a model's lane head sees; model 'pilotnet' has none"),
             ("studies.lane_drive", [str(tmp_path / "study.journal"), "--out", str(tmp_path / "b")],
              f"error: {tmp_path / 'study.journal'}: not a readable checkpoint"),
             ("studies.lane_drive", [str(plain), "--latency", "1", "--out", str(tmp_path / "c")],
              "error: --latency must be 0 here (the model's answers are compared with the lane and pose of the frame "
              "it saw)")]
    for script, argv, start in cases:
        with pytest.raises(SystemExit) as e:
            run_script(parser_of(script), importlib.import_module(script).main, argv)
        err = capsys.readouterr().err
        assert e.value.code == 2 and err.startswith(start) and err.count("\n") == 1, err
        assert f"(see: python -m {script} --help)" in err


def test_a_comma_list_of_numbers_gives_them_in_order():
    from steerlab.options import SEED, Range

    seeds, caps = NumberList(int, SEED), NumberList(float, Range(0, 1, lo_open=True))
    assert seeds.of("0,1,7") == [0, 1, 7] and caps.of("1,0.5") == [1.0, 0.5]
    assert seeds("3") and not seeds("1,1") and not seeds("-1") and not caps("0") and not caps("0.5,nan")
    assert caps.words == "a comma list of numbers in (0, 1], each once"


def test_no_recipes_is_taken_only_where_donkeycars_model_races_alone(capsys):
    """`--recipes ""` races donkeycar's model alone beside --donkeycar, and is refused without it."""
    assert _refused("studies.track_recipes", ["--recipes", ""], capsys).startswith("error: --recipes must be a comma")
    assert script_args(parser_of("studies.track_recipes"), ["--recipes", "", "--donkeycar"])[1][0].recipes == ""
