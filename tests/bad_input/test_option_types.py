"""Rule 1, each a sweep generated from the code: every option of every options dataclass refuses a value of
the wrong kind naming it, an option of another world is refused, the readers' options are typed, and a list of
road types whose repeat means nothing is refused."""

import pytest

from steerlab.cli import main
from steerlab.errors import SteerlabError
from tests.inputs import sim_log, tub

# Each generator lists its inputs, as those of rules 2 to 5 in their files do, so that `python -m
# tests.bad_input.counts` counts them (docs/results/bad-input.md, "Bad input").

def _option_classes():
    """Every options dataclass a user's values enter through: the commands' (cli.OPTIONS), the config's sections,
    the readers' option tables."""
    from steerlab.cli import OPTIONS, build_parser
    from steerlab.dagger import DaggerOptions, own_options, places
    from steerlab.data.readers import READERS
    from steerlab.train.config import TrainOptions

    build_parser()
    classes = {cls for group in OPTIONS.values() for cls in group}
    owns = {own_options(p) for p in places()}  # the options of a dagger section that one place takes
    readers = {r.options for r in READERS if r.options}  # every registered reader's option table
    return sorted(classes | owns | readers | {DaggerOptions, TrainOptions}, key=lambda c: c.__name__)


def _wrong_values(o):
    """Values of the wrong kind for the option `o`: what no option of its type takes."""
    from typing import Literal, get_origin

    from steerlab.options import OneOf, optional

    kind = optional(o.kind)[0]
    if isinstance(o.check, OneOf):  # a registered name: a camera
        return ["no-such-choice", 7, [next(iter(o.check.mapping))]]
    if kind is bool:
        return ["maybe", 1, 0, "true", [True], None if not optional(o.kind)[1] else "no"]
    if kind in (int, float):
        return [[1], {"a": 1}, "abc", True, "2", *(["nan", "inf", "0.3", "1e-3"] if kind is float else [1.5])]
    if get_origin(kind) is Literal:
        return ["no-such-choice", 7, [kind.__args__[0]]]
    if kind in (dict,):
        return [5, "text", [1]]
    if kind is str:
        return [5, [1], {"a": 1}]
    if get_origin(kind) is tuple:
        return ["text", 5, {"a": 1}]
    return []


def rule1_cases():
    """(class, option, value): every option of every options class, each value of a wrong kind, and each minutes that
    hold no frame; all refused by `parse` naming the option."""
    from steerlab.options import MINUTES, options_of

    cases = []
    for cls in _option_classes():
        for o in options_of(cls):
            if o.path:
                continue
            cases += [(cls, o.key, v) for v in _wrong_values(o)]
            if o.check is MINUTES:
                cases.append((cls, o.key, 1e-7))  # no frame at any frame rate
    return cases


@pytest.mark.parametrize("cls, key, value", rule1_cases(), ids=lambda v: getattr(v, "__name__", str(v))[:30])
def test_rule1_every_option_refuses_a_value_it_cannot_mean(cls, key, value):
    from steerlab.options import parse

    with pytest.raises(SteerlabError) as e:
        parse(cls, {key: value}, "x")
    assert f"x.{key}" in str(e.value) and "\n" not in str(e.value), str(e.value)


def _of_its_type(kind, value) -> bool:
    """Whether `value` is of the option type `kind` (None aside), in the test's own words: what a YAML config or a
    Python caller could mean by it."""
    from typing import Literal, get_origin

    if get_origin(kind) is Literal:
        return value in kind.__args__ and not isinstance(value, bool)
    if kind is float:  # a number, or text that is one (the command line gives text)
        try:
            number = float(value) if isinstance(value, (int, float, str)) and not isinstance(value, bool) else None
        except ValueError:
            number = None
        return number is not None and abs(number) != float("inf") and number == number
    return {bool: bool, str: str, dict: dict}.get(kind) is not None and isinstance(value, kind) or (
        kind is int and isinstance(value, int) and not isinstance(value, bool))


def test_rule1_any_value_not_of_an_options_type_is_refused_naming_it():
    """Rule 1 as a property: for every option of every options class whose type is a plain one (bool, int, float,
    text, a choice, a mapping), any value not of that type (drawn from numbers, text, lists, mappings, None) is
    refused naming the option, so an option is covered because of its type, whatever checks it has."""
    from typing import Literal, get_origin

    from hypothesis import given, settings
    from hypothesis import strategies as st

    from steerlab.options import optional, options_of, parse

    options = [(cls, o.key, *optional(o.kind)) for cls in _option_classes() for o in options_of(cls)
               if not o.path and "." not in o.key and (optional(o.kind)[0] in (bool, int, float, str, dict)
                                                       or get_origin(optional(o.kind)[0]) is Literal)]
    scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(), st.text(max_size=8),
                        st.text("0123456789.-+einfa", max_size=5))
    values = st.one_of(scalars, st.lists(scalars, max_size=3), st.dictionaries(st.text(max_size=3), scalars,
                                                                                max_size=2))

    @settings(max_examples=600, deadline=None, derandomize=True, database=None)
    @given(st.sampled_from(options), values)
    def check(option, value):
        cls, key, kind, nullable = option
        if (value is None and nullable) or _of_its_type(kind, value):
            return
        try:
            parse(cls, {key: value}, "x")
        except SteerlabError as e:
            assert f"x.{key}" in str(e) and "\n" not in str(e), str(e)
        else:
            raise AssertionError(f"{cls.__name__}.{key} took {value!r}")

    check()


def _valid_value(o):
    """A value the option `o` takes (its default, or a number in its range), as the command line writes it."""
    from dataclasses import MISSING
    from typing import Literal, get_origin

    from steerlab.options import OneOf, optional

    kind = optional(o.kind)[0]
    if o.default not in (None, MISSING) and kind is not bool:
        return str(o.default)
    if isinstance(o.check, OneOf):
        return next(iter(o.check.mapping))
    if get_origin(kind) is Literal:
        return str(kind.__args__[0])
    if kind in (int, float):
        lo, hi = getattr(o.check, "lo", None) or 0, getattr(o.check, "hi", None)
        return str(kind(lo + 1 if hi is None or lo + 1 <= hi else (lo + hi) / 2))  # inside the option's range
    return None if kind is bool else "x"


def rule1_world_cases():
    """(command, world, flag, value): every flag of every world's options, given in another world that lacks it."""
    from steerlab.cli import flag
    from steerlab.options import optional, options_of
    from steerlab.sim.worlds import WORLDS

    cases = []
    for command, sub in (("record", "sim record"), ("drive", "sim drive"), ("suite", "sim bench"),
                         ("replay", "replay")):
        for world in WORLDS.values():
            own = {o.key for o in options_of(getattr(world, command).options)}
            for other in WORLDS.values():
                for o in options_of(getattr(other, command).options):
                    if o.key in own or o.path:
                        continue
                    kind = optional(o.kind)[0]
                    name = flag(f"no_{o.key}" if kind is bool and o.default is True else o.key)
                    cases.append((sub, world.name, name, _valid_value(o)))
    return sorted(set(cases))


@pytest.mark.parametrize("command, world, name, value", rule1_world_cases(), ids=str)
def test_rule1_an_option_of_another_world_is_refused(command, world, name, value, tmp_path, capsys):
    (tmp_path / "model.pt").write_bytes(b"refused before it is read")
    ckpt = [] if command == "sim record" else [str(tmp_path / "model.pt")]
    data = ["--data", str(sim_log(tmp_path / "sim") if world == "road" else tub(tmp_path / "tub"))] \
        if command == "replay" else []
    argv = [*command.split(), *ckpt, *data, "--world", world, "--out", str(tmp_path / "out"), name,
            *([] if value is None else [value])]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{name} is an option of the" in err, err
    assert not (tmp_path / "out").exists()


def rule1_reader_cases():
    """(layout, option, value): a wrong value of every option of the readers of a driving log and a tub, through
    `--reader` on the command line (the option tables of the other readers are swept by rule1_cases)."""
    from steerlab.data import tub as tubs
    from steerlab.data.simlog import SIM_OPTIONS
    from steerlab.options import options_of

    out = []
    for layout, cls in (("sim", SIM_OPTIONS), ("tub", tubs.OPTIONS)):
        for o in options_of(cls):
            out += [(layout, o.key, v) for v in ("maybe", "[25]", "{a: 1}", "-1", "1e400") if v != "-1" or
                    getattr(o.check, "lo", None) is not None]
    return out


@pytest.mark.parametrize("layout, key, value", rule1_reader_cases(), ids=str)
def test_rule1_reader_options_are_typed(layout, key, value, tmp_path, capsys):
    data = sim_log(tmp_path / "sim") if layout == "sim" else tub(tmp_path / "tub")
    assert main(["compile", "--data", str(data), "--reader", f"{key}={value}", "--cache", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"reader.{key} must be" in err, err
    assert not (tmp_path / "c").exists()


def rule1_named_set_cases():
    """(class, option, value): a comma list of a fixed set's names with a name twice, an unknown one, or none."""
    from steerlab.sim.road.suite import SUITES, SuiteOptions
    from steerlab.sim.track.suite import TRACK_SUITES, TrackSuiteOptions

    out = []
    for cls, key, suites, part in ((SuiteOptions, "roads", SUITES, "roads"),
                                   (TrackSuiteOptions, "styles", TRACK_SUITES, "tracks")):
        for suite, spec in suites.items():
            for name in spec[part]:
                out += [(cls, suite, key, f"{name},{name}"), (cls, suite, key, f"{name},{name}x"),
                        (cls, suite, key, ",")]
    return out


def rule1_road_list_cases():
    """(class, value): a road list naming one road type twice and nothing else, unknown types, or none."""
    from steerlab.sim.road.road import ROAD_TYPES
    from steerlab.sim.road.world import DriveOptions, RecordOptions

    return [(cls, value) for cls in (RecordOptions, DriveOptions) for name in ROAD_TYPES
            for value in (f"{name},{name}", f"{name},{name},{name}", f"{name},{name}x", ",")]


@pytest.mark.parametrize("cls, value", rule1_road_list_cases(), ids=str)
def test_rule1_a_road_list_whose_repeat_means_nothing_is_refused(cls, value):
    from steerlab.options import parse

    with pytest.raises(SteerlabError, match=r"^--road must be .* \(not one name alone, repeated\)"):
        parse(cls, {"road": value}, name=lambda f: f"--{f}")
    assert parse(cls, {"road": "country,twisty,twisty"}).road == "country,twisty,twisty"  # a repeat that means more
