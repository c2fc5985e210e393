"""Typed options: every config section and every command's options is a frozen dataclass whose fields carry
their type, default, allowed values and help. `parse` turns what YAML or the command line gives (numbers
written as text such as 1e-4 included) into one, with a one-line error that names the option; code that
receives the dataclass reads attributes and never casts or checks again.

    @dataclass(frozen=True)
    class Suite:
        minutes: float = option(3.0, Range(0, lo_open=True), help="minutes per road")

    parse(Suite, {"minutes": "2"}, "closed_loop")  ->  Suite(minutes=2.0)
    parse(Suite, {"minutes": -1}, "closed_loop")   ->  SteerlabError: closed_loop.minutes must be ... got -1

`options_of(cls)` lists a dataclass's options (key, type, check, default) for documentation and for the
bad-input sweeps of the tests."""

from __future__ import annotations

import copy
import dataclasses
import math
import numbers
import os
import types
from collections.abc import Callable, Iterator, Mapping
from dataclasses import MISSING, dataclass, field, fields
from functools import cache
from typing import Any, Literal, Union, get_args, get_origin, get_type_hints

from steerlab.errors import SteerlabError


@dataclass(frozen=True)
class Range:
    """A finite number in [lo, hi] (either bound open or absent)."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""

    def __call__(self, v) -> bool:
        if isinstance(v, bool) or not isinstance(v, numbers.Real):  # True is no number, "0.5" no number yet
            return False
        return (math.isfinite(v) and (self.lo is None or (self.lo < v if self.lo_open else self.lo <= v))
                and (self.hi is None or (v < self.hi if self.hi_open else v <= self.hi)))

    def words(self, kind: type) -> str:
        unit = f" {self.unit}" if self.unit else ""
        if kind is int and self.lo is not None and self.hi is not None and self.hi >= COUNT_MAX:
            return f"an integer of at least {_num(self.lo)} (at most {_num(self.hi)})"
        if self.lo is not None and self.hi is not None:
            return (f"{'an integer' if kind is int else 'a number'} in {'(' if self.lo_open else '['}{_num(self.lo)}, "
                    f"{_num(self.hi)}{')' if self.hi_open else ']'}{unit}")
        if kind is int:
            return "an integer" + (f" of at least {self.lo:g}" if self.lo is not None else "")
        if self.lo == 0 and self.lo_open:
            return "a positive finite number" + unit
        if self.lo is not None:
            return f"a finite number{unit} of at least {self.lo:g}"
        return f"a finite number{unit}"


class OneOf:
    """A name held by a registry (`mapping`, read when a value is checked, so that a name registered later is taken):
    the check of an option whose choices grow (the cameras of `data.cameras`)."""

    def __init__(self, mapping: Mapping, what: str):
        self.mapping, self.what = mapping, what

    def __call__(self, v) -> bool:
        return isinstance(v, str) and v in self.mapping

    def words(self, kind: type) -> str:
        return f"one of the {self.what} {', '.join(self.mapping)}"


CORES = os.cpu_count() or 1  # what "threads" may ask of this machine

def _num(x: float) -> str:
    """A bound as people write it: 0.5, 25, 4294967295."""
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


POSITIVE = Range(0, lo_open=True)
FRACTION = Range(0, 1, lo_open=True)  # (0, 1]: exponential smoothing's alpha
COUNT_MAX = 1_000_000  # epochs, trials, frames, batches...: more would run for ever, not mean more
AT_LEAST_0 = Range(0)
AT_LEAST_1 = Range(1, COUNT_MAX)  # a count
UNIT = Range(0, 1)
SEED = Range(0, 2**32 - 1)  # what numpy, torch and Python's random all take
THREADS = Range(1, CORES)  # threads beyond the machine's cores only slow it (and thousands crash it)
WORKERS = Range(1, max(8, 4 * CORES))  # worker processes: a few per core at most
PIXELS = Range(1, 4096)  # an image's width or height
FPS = Range(1, 240, unit="frames/s")  # a camera's frame rate
MINUTES = Range(0, 24 * 60, lo_open=True, unit="min")  # a drive or recording of at most a day
SPEED = Range(0, 100, lo_open=True, unit="m/s")  # a car's speed (100 m/s: 360 km/h, which no car here drives)
OFF_PATH = Range(0, 5, lo_open=True, unit="m")  # how far off its path a car may drift: beyond 5 m it is off the road


def frames_in(minutes: float, fps: float) -> int:
    """The frames of `minutes` at `fps` (the driving loop's count)."""
    return int(round(minutes * 60 * fps))


def one_frame(minutes: float | None, fps: float) -> str | None:
    """Why `minutes` at `fps` cannot be driven or recorded (no frame), or None."""
    if minutes is None or frames_in(minutes, fps) >= 1:
        return None
    return f"at least one frame's time: {1 / (60 * fps):.3g} min at {fps:g} frames/s"


def frames_held(v, *names: str, fps: float | None = None) -> Iterator[tuple[str, str]]:
    """(option, what it must be) for each of the minutes `names` of the options `v` that holds no frame at their
    `fps` option, or at the fixed frame rate `fps` (a suite's)."""
    for name in names:
        why = one_frame(getattr(v, name), fps or v.fps)
        if why:
            yield name, why


def holds_frames(*names: str, fps: float | None = None):
    """`related` for options whose minutes `names` must each hold a frame (see `frames_held`)."""
    return classmethod(lambda cls, v: frames_held(v, *names, fps=fps))


def names_from(text: str | None, choices, what: str, owner: str = "it") -> list[str] | None:
    """A comma list of names from the fixed set `choices` (road types, track styles; `owner` has them), each named
    once: a one-line error for an unknown name, one named twice, or none; None stays None (all of them)."""
    if text is None:
        return None
    names = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [t for t in names if t not in choices]
    twice = sorted({t for t in names if names.count(t) > 1})
    if unknown or twice or not names:
        problem = (f"{owner} has no {', '.join(unknown)} {what}" if unknown else
                   f"{', '.join(twice)} named twice" if twice else f"no {what} named")
        raise SteerlabError(f"{problem}; choose {what} of {', '.join(choices)}, each once")
    return names


def names_held(v, name: str, choices, what: str) -> Iterator[tuple[str, str]]:
    """(option, what it must be) when the comma list `name` of the options `v` is not `names_from` `choices`."""
    try:
        names_from(getattr(v, name), choices, what)
    except SteerlabError:
        yield name, f"a comma list of {what} of {', '.join(choices)}, each once"


class Options:
    """Base of the option dataclasses: made directly in Python (not through `parse`), every value is still
    checked (`ClassName.field must be ...`). `related(values)` states what several options must satisfy
    together (minutes that hold a frame at the frame rate): (option, what it must be) for each that does not."""

    @classmethod
    def related(cls, values) -> Iterator[tuple[str, str]]:
        return iter(())

    def __post_init__(self):
        hints = _hints(type(self))
        for f in fields(self):
            value, check = getattr(self, f.name), f.metadata.get("check")
            if value is None:
                continue
            try:
                ok = _of_type(hints[f.name], value) and (check is None or bool(check(value)))
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise _bad(f"{type(self).__name__}.{f.name}", f.metadata.get("expected") or words(hints[f.name], check),
                           value)
        for name, expected in self.related(self):
            raise _bad(f"{type(self).__name__}.{name}", expected, getattr(self, name))


def _of_type(kind, value) -> bool:
    """Whether `value` is of the field type `kind` as made in Python (no conversion: "25" is no number, 1 no
    boolean, "donkey" no choice of Literal["sim", "ch2"]); types it does not know hold anything."""
    kind = optional(kind)[0]
    if get_origin(kind) is Literal:
        return not isinstance(value, bool) and value in get_args(kind)
    if kind is bool:
        return isinstance(value, bool)
    if kind is int:
        return isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if kind is float:
        return isinstance(value, numbers.Real) and not isinstance(value, bool)
    if kind is str:
        return isinstance(value, str)
    return True


def option(default: Any = MISSING, check: Callable | None = None, expected: str | None = None, help: str = "",
           path: str | None = None, makes: str | None = None):
    """A dataclass field with its check (a `Range`, or any `check(value) -> bool` on the parsed value), the
    words an error uses for what is expected (derived from a Range when not given), its help, and for a path what
    it names (`path`: "file" to read, "folder" to write into, "new-file" to write; the command line checks it) and
    for a folder the kind of folder written there (`makes`, one of `paths.KINDS`)."""
    meta = {"check": check, "expected": expected, "help": help, "path": path, "makes": makes}
    if isinstance(default, (list, dict, set)):
        return field(default_factory=lambda: copy.deepcopy(default), metadata=meta)
    return field(default=default, metadata=meta)


@dataclass(frozen=True)
class OptionInfo:
    key: str
    kind: Any
    default: Any
    check: Callable | None
    expected: str
    help: str
    path: str | None = None
    makes: str | None = None


def _shown(value) -> str:
    return f"{value:g}" if isinstance(value, float) else repr(value)


def _bad(where: str, expected: str, value) -> SteerlabError:
    return SteerlabError(f"{where} must be {expected}, got {_shown(value)}")


def optional(kind) -> tuple[Any, bool]:
    """(the type inside Optional[...], whether None is allowed)."""
    if get_origin(kind) in (Union, types.UnionType):
        args = [a for a in get_args(kind) if a is not type(None)]
        if len(args) < len(get_args(kind)):
            return (args[0] if len(args) == 1 else Union[tuple(args)]), True
    return kind, False


def words(kind, check=None) -> str:
    """What a value of this type (and check) must be, in the words of an error message."""
    kind, _ = optional(kind)
    if isinstance(check, (Range, OneOf)):
        return check.words(kind)
    if get_origin(kind) is Literal:
        choices = [str(c) for c in get_args(kind)]
        return " or ".join(choices) if len(choices) < 3 else f"{', '.join(choices[:-1])} or {choices[-1]}"
    if kind is bool:
        return "true or false"
    if kind is int:
        return "an integer"
    if kind is float:
        return "a finite number"
    if kind is str:
        return "text"
    if get_origin(kind) is tuple:
        return "a list"
    if dataclasses.is_dataclass(kind):
        return "a mapping of options"
    return "a mapping" if kind in (dict, Mapping) else str(kind)


def value_of(kind, value, where: str, check=None, expected: str | None = None):
    """`value` as the type `kind` (and passing `check`), or a one-line error naming `where`."""
    inner, nullable = optional(kind)
    if value is None:
        if nullable:
            return None
        raise _bad(where, expected or words(inner, check), value)
    expected = expected or words(inner, check)
    if hasattr(inner, "parse_option"):  # a type that parses itself (a union of forms, say)
        return inner.parse_option(value, where)
    if dataclasses.is_dataclass(inner):
        return parse(inner, value, where)
    origin = get_origin(inner)
    if origin is Literal:
        if value not in get_args(inner) or isinstance(value, bool):
            raise _bad(where, expected, value)
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise _bad(where, expected, value)
        args = get_args(inner)
        if len(args) == 2 and args[1] is Ellipsis:
            out = tuple(value_of(args[0], v, f"{where}[{i}]", expected=expected if check else None)
                        for i, v in enumerate(value))
        elif len(args) != len(value):
            raise _bad(where, expected, value)
        else:
            out = tuple(value_of(a, v, f"{where}[{i}]") for i, (a, v) in enumerate(zip(args, value)))
    elif inner is bool:
        if not isinstance(value, bool):
            raise _bad(where, expected, value)
        out = value
    elif inner is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise _bad(where, expected, value)
        out = value
    elif inner is float:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise _bad(where, expected, value)  # text ('0.3') too: a number quoted is a mistake an int refuses
        out = float(value)
        if check is None and not math.isfinite(out):
            raise _bad(where, expected, value)
    elif inner is str:
        if not isinstance(value, str):
            raise _bad(where, expected, value)
        out = value
    elif inner in (dict, Mapping) or get_origin(inner) in (dict, Mapping):
        if not isinstance(value, Mapping):
            raise _bad(where, expected, value)
        out = dict(value)
    elif inner is Any:
        out = value
    else:
        raise TypeError(f"{where}: options of type {inner} are not supported")
    if check is not None and not check(out):
        raise _bad(where, expected, value)
    return out


@cache
def _hints(cls) -> dict:
    """A dataclass's field types, resolved once per class (callers only read them)."""
    return get_type_hints(cls, include_extras=False)


def parse(cls, data, where: str = "", name: Callable[[str], str] | None = None):
    """An instance of the dataclass `cls` from a mapping: every value converted to its field's type and
    checked; unknown keys and missing required ones are errors. `where` prefixes the option names in errors
    (`train` -> train.lr); `name(field)` names them instead (command-line options: --max-heading)."""
    if isinstance(data, cls):
        return data
    data = {} if data is None else data
    own = [f for f in fields(cls) if f.init]
    if not isinstance(data, Mapping):
        raise SteerlabError(f"{where or cls.__name__} must be a mapping of options "
                            f"({', '.join(f.name for f in own)}), got {data!r}")
    unknown = sorted(set(map(str, data)) - {f.name for f in own})
    if unknown:
        raise SteerlabError(f"unknown {where + ' ' if where else ''}options {unknown}; known: "
                            f"{sorted(f.name for f in own)}")
    hints, kwargs = _hints(cls), {}
    for f in own:
        key = name(f.name) if name else f"{where}.{f.name}" if where else f.name
        if f.name in data:
            kwargs[f.name] = value_of(hints[f.name], data[f.name], key, f.metadata.get("check"),
                                      f.metadata.get("expected"))
        elif f.default is MISSING and f.default_factory is MISSING:
            raise SteerlabError(f"{key} is missing: it must be {words(hints[f.name], f.metadata.get('check'))}")
    if issubclass(cls, Options):  # what several options must satisfy together, named as the caller names them
        values = types.SimpleNamespace(**{f.name: kwargs[f.name] if f.name in kwargs else
                                          f.default if f.default is not MISSING else f.default_factory()
                                          for f in own if f.name in kwargs or f.default is not MISSING
                                          or f.default_factory is not MISSING})
        for option_name, expected in cls.related(values):
            key = name(option_name) if name else f"{where}.{option_name}" if where else option_name
            raise _bad(key, expected, getattr(values, option_name))
    return cls(**kwargs)


def as_dict(obj) -> Any:
    """A dataclass (nested ones included) as plain values: dicts, lists, text and numbers (JSON and
    checkpoints keep this form)."""
    if hasattr(obj, "as_dict") and not isinstance(obj, type):
        return obj.as_dict()
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: as_dict(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [as_dict(v) for v in obj]
    if isinstance(obj, dict):
        return {k: as_dict(v) for k, v in obj.items()}
    return obj


def option_info(cls, name: str) -> OptionInfo | None:
    """The option `name` of the dataclass `cls` (None when it has none of that name)."""
    return next((o for o in options_of(cls) if o.key == name), None)


def options_of(cls, prefix: str = "") -> Iterator[OptionInfo]:
    """Every option of a dataclass, nested sections expanded: key (dotted), type, default, check, what is
    expected, help."""
    hints = _hints(cls)
    for f in fields(cls):
        if not f.init:
            continue
        key = f"{prefix}.{f.name}" if prefix else f.name
        kind = hints[f.name]
        inner, _ = optional(kind)
        if dataclasses.is_dataclass(inner) and not hasattr(inner, "parse_option"):
            yield from options_of(inner, key)
            continue
        default = f.default if f.default is not MISSING else (
            f.default_factory() if f.default_factory is not MISSING else MISSING)
        check = f.metadata.get("check")
        yield OptionInfo(key, kind, default, check, f.metadata.get("expected") or words(kind, check),
                         f.metadata.get("help", ""), f.metadata.get("path"), f.metadata.get("makes"))
