"""Rule 1, each option once: an option of one value given twice (however it is written), an override or a
reader option given twice, the same checkpoint or recording named twice, and an experiment's seed given by hand are
refused in one line; what may repeat is taken."""

import argparse
import os

import pytest

from steerlab.cli import main
from steerlab.errors import SteerlabError
from tests.bad_input.builders import _command_parsers, _train, config, refused_in_one_line
from tests.inputs import made, sim_log


def _two_of(command):
    """`command` with the same checkpoint named twice by absolute paths."""
    def build(tmp_path, stack):
        ckpt = made(tmp_path).resolve()
        data = ["--data", str(sim_log(tmp_path / "sim"))] if command == "replay" else []
        return [*command.split(), str(ckpt), str(tmp_path / "." / "model.pt"), *data, "--out", str(tmp_path / "out")]
    return build


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    "bench the same checkpoint twice": (_two_of("sim bench"), "is named twice"),
    "replay the same checkpoint twice": (_two_of("replay"), "is named twice"),
    "ensemble of one checkpoint through a symlink": (
        lambda t, s: (os.symlink(made(t, name="a.pt"), t / "link.pt"),
                      ["ensemble", str(t / "a.pt"), str(t / "link.pt"), "--out", str(t / "e.pt")])[1],
        "link.pt is named twice (as "),
    "extra data that is the training recording": (lambda t, s: _train(f"extra_data=[{t / 'sim'}]")(t, s),
                                                  "is the training recording itself (data)"),
    "a fixed view given twice": (_train("train.views=[[0.5, 0], [0.2, 3], [0.5, 0.0]]"),
                                 "train.views names the fixed view [0.5, 0.0] twice"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


def _single_value_flags():
    """(command, flag, an abbreviation of it, takes a value) of every option of every command that holds one value
    (not a list)."""
    out = []
    for command, p in _command_parsers():
        for a in p._actions:
            if a.option_strings and not isinstance(a, (argparse._AppendAction, argparse._HelpAction)):
                name = a.option_strings[-1]
                short = name[:-1] if [s for s in p._option_string_actions if s.startswith(name[:-1])] == [name] \
                    else name  # an abbreviation that names this option alone
                out.append((command, name, short, a.nargs != 0))
    return out


@pytest.mark.parametrize("command, name, short, valued", _single_value_flags(),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_option_given_twice_is_refused(command, name, short, valued, capsys, tmp_path, monkeypatch):
    """Rule 1 (each option once): an option of one value given twice is refused in one line naming it, before
    anything runs, however the second is written (`--flag=value`, an abbreviation argparse takes)."""
    monkeypatch.chdir(tmp_path)  # were it not refused, what it wrote would land here
    first = [name, "1"] if valued else [name]
    for second in (first, [f"{name}=2"] if valued else [name], [short, "2"] if valued else [short]):
        assert main([*command.split(), *first, *second]) == 2, second
        err = capsys.readouterr().err
        assert err.startswith(f"error: {name} is given twice") and err.count("\n") == 1, err


def test_an_experiment_refuses_a_seed_override(tmp_path):
    """`steerlab experiment CONFIG --seeds 3 train.seed=5` would train every 'seed' with seed 5."""
    from steerlab.experiment import load_experiment

    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    cfg.write_text(cfg.read_text() + "models:\n  - {model: {name: zero}}\n")
    with pytest.raises(SteerlabError, match=r"override train.seed: an experiment's runs take the seeds 0..N-1 of "
                                            r"steerlab experiment --seeds; leave it out"):
        load_experiment(cfg, ["train.seed=5"])
    assert load_experiment(cfg, ["train.epochs=2"]).overrides == ("train.epochs=2",)


def test_options_that_may_repeat_are_not_refused():
    """What the each-once rule leaves alone: two options one of whose names begins the other's, an option that
    collects a list, a value after `--`; the same option twice is refused (SystemExit, after its one line)."""
    parsers = dict(_command_parsers())
    parsers["sim bench"]._once(["--throttle", "1", "--throttle-scale", "2"])
    parsers["evaluate"]._once(["--reader", "a=1", "--reader", "b=2"])
    parsers["sim bench"]._once(["--minutes", "1", "--", "--minutes"])
    with pytest.raises(SystemExit):
        parsers["sim bench"]._once(["--minutes", "1", "--minutes", "2"])


def test_overrides_and_reader_options_given_twice_are_refused(tmp_path, capsys):
    """The same key twice among `section.key=value` overrides or `--reader key=value` options is refused."""
    from steerlab.train.config import load_config

    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    assert main(["train", str(cfg), f"out={tmp_path / 'a'}", "train.epochs=1", f"out={tmp_path / 'b'}"]) == 2
    assert capsys.readouterr().err.startswith("error: override out= is given twice")
    with pytest.raises(SteerlabError, match=r"override train.epochs= is given twice \('train.epochs=1' and "):
        load_config(cfg, ["train.epochs=1", " train.epochs =2"])
    assert main(["compile", "--data", str(tmp_path / "sim"), "--reader", "camera=center", "--reader",
                 "camera=left"]) == 2
    assert capsys.readouterr().err == "error: --reader camera= is given twice; give each reader option once\n"
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
