"""Paths: a file or a recording that is not there, or of another kind than the argument takes (a folder for a
file, a file for a folder, a pipe, a link to nothing, a storage that cannot be opened), is refused in one line
naming it, before any work."""

import argparse
import os
from pathlib import Path

import pytest

from steerlab.cli import main
from tests.bad_input.builders import (_command_parsers, _says_what_it_is, _train, _tune_storage, config,
                                      refused_in_one_line)
from tests.inputs import ch2, made, sim_log


def _fifo_labels(tmp_path, stack):
    folder = ch2(tmp_path / "ch2")
    os.mkfifo(tmp_path / "fifo.csv")
    return ["compile", "--data", str(folder), "--labels", str(tmp_path / "fifo.csv"), "--cache", str(tmp_path / "c")]


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    "replay missing recording": (lambda t, s: ["replay", str(made(t)), "--data", str(t / "nothere"), "--out",
                                               str(t / "out")], "nothere: recording not found"),
    # pretraining (train.init): a checkpoint that is not there, or of another camera geometry
    "train init missing": (lambda t, s: _train(f"train.init={t / 'pretrained.pt'}")(t, s),
                           "pretrained.pt: checkpoint not found"),
    # distillation (train.teacher): a checkpoint that is not there, or that predicts in other units
    "train teacher missing": (lambda t, s: _train(f"train.teacher={t / 'teacher.pt'}")(t, s),
                              "teacher.pt: checkpoint not found"),
    "latency missing checkpoint": (lambda t, s: ["latency", str(t / "gone.pt"), "--out", str(t / "out")],
                                   "gone.pt: checkpoint not found"),
    "export int8 calibration data missing": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.onnx"),
                                                           "--int8", "--calib", str(t / "nothere")],
                                             "nothere: recording not found"),
    "track recipe whose tubs were not recorded": (
        lambda t, s: ["train", str(config(t, t / "tubs" / "taped-1"))], "taped-1: recording not found"),
    "compile labels from a pipe": (_fifo_labels, "fifo.csv: not a regular file (a pipe or a device?), where a label "
                                                 "file is expected"),
    "train with a folder as config": (lambda t, s: ["train", str(t)], ": a folder, where a config file is expected"),
    "evaluate a folder as checkpoint": (lambda t, s: ["evaluate", str(t), "--data", str(sim_log(t / "sim"))],
                                        ": a folder, where a checkpoint is expected"),
    "tune join a study that does not exist": (
        lambda t, s: _tune_storage("{tmp}/s.journal")(t, s) + ["--join"],
        "s.journal: no such file, so no study to join; check steerlab tune --storage, or start the study "
        "without --join"),
    # k) a study's storage that cannot be opened: the URL without its password, what the server or driver said
    "tune unreachable postgres": (_tune_storage("postgresql://tuner:secret@127.0.0.1:1/steerlab"),
                                  "cannot open storage postgresql://tuner:***@127.0.0.1:1/steerlab: OperationalError: "
                                  'connection failed: connection to server at "127.0.0.1", port 1 failed: Connection '
                                  "refused"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


def _path_arguments():
    return [(command, dest, kind) for command, p in _command_parsers()
            for dest, kind in (p.get_default("paths") or {}).items()]


@pytest.mark.parametrize("command, dest, kind", _path_arguments(), ids=lambda v: v if isinstance(v, str) else None)
def test_every_path_argument_is_checked(command, dest, kind, tmp_path, capsys):
    """Every path an argument names: a missing file, a folder where a file is expected and a file where a folder
    is expected are refused in one line naming the path, before anything runs."""
    from steerlab.cli import build_parser, flag

    parser = build_parser()
    file, folder = tmp_path / "a-file", tmp_path / "a-folder"
    file.write_text("x")
    folder.mkdir()
    for sub in command.split():
        parser = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[sub]
    argv = [*command.split()]
    for a in parser._actions:  # every other required argument, a harmless value of its kind
        if a.required and a.dest != dest and a.option_strings:
            argv += [a.option_strings[0], str(folder if (parser.get_default("paths") or {}).get(a.dest) == "folder"
                                              else file)]
        elif not a.option_strings and a.dest not in (dest, "help") and a.nargs != "*":
            argv.append(str(file))
    dangling = tmp_path / "a-link-to-nothing"
    dangling.symlink_to(tmp_path / "nowhere")
    cases = {"file": [tmp_path / "missing.pt", folder, dangling], "folder": [file, Path("/dev/null"), dangling],
             "new-file": [folder, Path("/dev/full"), dangling]}[kind]
    positional = next(a for a in parser._actions if a.dest == dest).option_strings == []
    for path in cases:
        args = [*argv, str(path)] if positional else [*argv, flag(dest), str(path)]
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert err.startswith(f"error: {path}: ") and err.count("\n") == 1, err
        assert _says_what_it_is(path, err), err
