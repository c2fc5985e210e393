"""Rule 1 for numbers, generated from the schema: every numeric option of the config (train, preprocess, every
model's, dagger and closed_loop) and of every command's flags declares a range, and takes exactly the values in it:
the edges swept, and any value a user may type tried against the range's own words."""

import json

import pytest

from steerlab.cli import main
from steerlab.errors import SteerlabError
from tests.bad_input.builders import _a_range, _edges, _files, config
from tests.inputs import made, sim_log


def _numeric_options():
    """(key, kind, check, expected) of every option whose type is a number, whatever it checks: the training config's
    (train.*, preprocess.*, every model's options) and the other config sections' (dagger, closed_loop)."""
    from steerlab.dagger import DaggerOptions, own_options, places
    from steerlab.models import list_models
    from steerlab.models.registry import OPTION_CHECKS, model_option_types
    from steerlab.options import optional, options_of
    from steerlab.sim.road.suite import SuiteOptions
    from steerlab.train.config import TrainConfig

    out = []
    owns = [(own_options(p), "dagger") for p in places()]  # the options of a dagger section that one place takes
    for cls, section in ((TrainConfig, ""), (DaggerOptions, "dagger"), *owns, (SuiteOptions, "closed_loop")):
        for o in options_of(cls, section):
            kind = optional(o.kind)[0]
            if kind in (int, float):
                out.append((o.key, kind, o.check, o.expected))
    for name in list_models():
        for option, kind in model_option_types(name).items():
            if kind in (int, float):
                out.append((f"model.{option}@{name}", kind, OPTION_CHECKS.get(option), None))
    return out


@pytest.mark.parametrize("key, kind, check, expected", _numeric_options(), ids=lambda v: v if isinstance(v, str)
                         else None)
def test_every_numeric_config_option_is_range_checked(key, kind, check, expected, tmp_path):
    """From the schema, no hand-picked list: out of range, of the wrong type, and at the boundary."""
    from steerlab.dagger import dagger_options, taking
    from steerlab.errors import SteerlabError
    from steerlab.sim.worlds import closed_loop
    from steerlab.train.config import load_config

    check = _a_range(key, check)
    key, _, model = key.partition("@")
    base = {"data": str(tmp_path), **({"model": {"name": model}} if model else {})}
    if key == "train.smoothness":
        base["model"] = {"name": "lstm"}
    if key == "train.hue_deg":  # the hue of RGB inputs
        base["preprocess"] = {"color": "rgb"}
    if key.startswith("preprocess."):  # a model without layers: a 4096-pixel frame builds nothing large
        base["model"] = {"name": "zero"}
    worlds = taking(key.removeprefix("dagger.")) if key.startswith("dagger.") else ("road",)
    if "road" not in worlds:  # an option of another world than the default
        base["dagger"] = {"world": worlds[0]}

    def parse(value):
        cfg = load_config(None, [f"{key}={json.dumps(value)}"], base=base)
        if key.startswith("dagger."):
            dagger_options(cfg)
        if key.startswith("closed_loop."):
            closed_loop(cfg.closed_loop)

    for value, taken in _edges(check, kind):
        if taken:
            parse(value)
        else:
            with pytest.raises(SteerlabError) as e:
                parse(value)
            assert f"{key} must be" in str(e.value) and "\n" not in str(e.value), (value, str(e.value))


def test_a_range_takes_its_bounds_as_declared_and_says_them_in_words():
    """`options.Range` by hand: closed ends take their bound, open ends refuse it and take the next float inside,
    an absent end takes any finite number that way; NaN and infinities never. Its words, as errors print them."""
    from steerlab.options import Range

    closed, open_ = Range(-1.5, 2.5), Range(0, 1, lo_open=True, hi_open=True)
    assert [closed(v) for v in (-1.5, 2.5, -1.5000001, 2.5000001, 0.0)] == [True, True, False, False, True]
    assert [open_(v) for v in (0.0, 1.0, 1e-12, 1 - 1e-12, -1e-12, 1 + 1e-12)] == [False, False, True, True, False,
                                                                                   False]
    assert [Range(2)(v) for v in (2, 1.999, 1e300)] == [True, False, True]
    assert [Range(hi=3, hi_open=True)(v) for v in (3, 2.999, -1e300)] == [False, True, True]
    assert [Range()(v) for v in (0.0, -1e300, float("nan"), float("inf"), -float("inf"))] == [True, True, False, False,
                                                                                            False]
    assert [Range(0, 1)(v) for v in (float("nan"), float("inf"))] == [False, False]
    assert Range(1, 1_000_000).words(int) == "an integer of at least 1 (at most 1000000)"
    assert Range(1, 4096).words(int) == "an integer in [1, 4096]"
    assert Range(0, 1, lo_open=True).words(float) == "a number in (0, 1]"
    assert Range(-1.5, 2.5, hi_open=True, unit="m").words(float) == "a number in [-1.5, 2.5) m"
    assert Range(0, 4294967295).words(float) == "a number in [0, 4294967295]"
    assert Range(2).words(int) == "an integer of at least 2" and Range().words(int) == "an integer"
    assert Range(0, lo_open=True, unit="m/s").words(float) == "a positive finite number m/s"
    assert Range(0.5, unit="min").words(float) == "a finite number min of at least 0.5"
    assert Range(0).words(float) == "a finite number of at least 0"
    assert Range(unit="m").words(float) == "a finite number m" and Range().words(float) == "a finite number"


def test_a_numeric_option_takes_exactly_the_values_its_range_declares():
    """Property-based (Hypothesis): for any option whose type is a number, in the config or on the command line, and
    any value a user may type (integers and floats of any size, NaN, infinities, booleans, number-like text), the
    parse takes the value exactly when it is of the option's type and inside its declared range, anywhere in it,
    not only at the ends the sweeps try."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from steerlab.options import value_of

    options = [(key, kind, check) for key, kind, check, _ in _numeric_options()] + \
        [(f"{command} {name}", kind, check) for command, name, kind, check in _cli_numeric_options()]
    values = st.one_of(st.integers(-2**40, 2**40), st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
                       st.text("0123456789.-+einfa", max_size=6))

    def takes(kind, r, value) -> bool:  # the range's own words, computed here: lo <= v <= hi, open ends excluded
        if isinstance(value, (bool, str)) or (kind is int and not isinstance(value, int)):
            return False  # a number given as text ('0.3') is refused as an int option refuses it
        v = float(value)
        above = r.lo is None or (v > r.lo if r.lo_open else v >= r.lo)
        below = r.hi is None or (v < r.hi if r.hi_open else v <= r.hi)
        return v == v and abs(v) != float("inf") and above and below

    @settings(max_examples=400, deadline=None, derandomize=True, database=None)
    @given(st.sampled_from(options), values)
    def check(option, value):
        key, kind, declared = option
        try:
            value_of(kind, value, key, declared)
            taken = True
        except SteerlabError:
            taken = False
        assert taken == takes(kind, _a_range(key, declared), value), (key, value)

    check()


def _cli_numeric_options():
    from steerlab.cli import OPTIONS, build_parser
    from steerlab.options import optional, options_of

    build_parser()  # fills OPTIONS
    return [(command, o.key, optional(o.kind)[0], o.check) for command, classes in OPTIONS.items()
            for cls in classes for o in options_of(cls) if optional(o.kind)[0] in (int, float)]


def _command_args(command, tmp_path):
    """The arguments a command needs besides the option under test: real inputs, so that only the option fails."""
    ckpt = str(made(tmp_path))
    cfg = str(config(tmp_path, sim_log(tmp_path / "sim")))
    return {"latency": ["--models", "zero"], "sim record": ["--out", str(tmp_path / "rec")],
            "sim drive": [ckpt], "sim bench": [ckpt], "replay": [ckpt, "--data", str(tmp_path / "sim")],
            "serve": [ckpt], "demo": ["--out", str(tmp_path / "demo")], "train": [cfg], "experiment": [cfg],
            "tune": [cfg]}[command]


@pytest.mark.parametrize("command, name, kind, check", _cli_numeric_options(),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_numeric_command_line_option_is_refused_out_of_range(command, name, kind, check, tmp_path, capsys):
    """From cli.OPTIONS (the options dataclasses behind every command's flags): values out of range, of the
    wrong type and at an open boundary are refused in one line naming the flag, before anything runs."""
    from steerlab.cli import flag

    check = _a_range(f"{command} {flag(name)}", check)
    argv = [*command.split(), *_command_args(command, tmp_path)]
    bad = [v for v, taken in _edges(check, kind) if not taken and not isinstance(v, (bool, list))]
    before = _files(tmp_path)
    for value in bad:
        assert main([*argv, flag(name), str(value)]) == 2, value
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and flag(name) in err, err
    assert _files(tmp_path) == before  # nothing written
