"""The `steerlab` command: one module per group of subcommands (`data.py`, `training.py`, `driving.py`), each
registering its subcommands on the parser.

A subcommand's numeric and choice options are the fields of the options dataclasses it passes on
(`OPTIONS`): their flags, types, defaults, allowed values and help come from the fields (`add_options`), and
`from_args` parses them into the dataclass, so every option is checked before the command does anything, with
a one-line error (exit code 2) that names the flag; argparse's own errors are one line too. The scripts of studies/
and benchmarks/ take their options the same way (`script_parser`, `run_script`)."""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import MISSING
from functools import cache
from pathlib import Path

from steerlab.errors import SteerlabError
from steerlab.options import optional, options_of, parse

# subcommand -> the options dataclasses whose fields are its flags (filled by the modules below)
OPTIONS: dict[str, list[type]] = {}


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit code 2) that point to the command's --help, and every option of one
    value given once: argparse would take the last of two silently."""

    def error(self, message: str):
        print(f"error: {message} (see: {self.prog} --help)", file=sys.stderr)
        sys.exit(2)

    def parse_known_args(self, args=None, namespace=None):
        args = sys.argv[1:] if args is None else list(args)
        self._once(args)
        return super().parse_known_args(args, namespace)

    def _once(self, args: list[str]) -> None:
        """Refuses an option of this parser given twice (`--epochs 3 --epochs 5`, also as `--epochs=5` or an
        abbreviation argparse would take); options that collect a list (`--reader`) may repeat."""
        seen: dict[str, str] = {}
        for arg in args:
            if arg == "--":
                break
            name = arg.split("=", 1)[0]
            if not name.startswith("--"):
                continue
            found = [s for s in self._option_string_actions if s == name] or \
                [s for s in self._option_string_actions if s.startswith(name)]
            action = self._option_string_actions[found[0]] if len(found) == 1 else None
            if action is None or isinstance(action, (argparse._AppendAction, argparse._HelpAction)):
                continue
            if action.dest in seen:
                self.error(f"{found[0]} is given twice; give each option once")
            seen[action.dest] = found[0]


def flag(name: str) -> str:
    return "--" + name.replace("_", "-")


READ = {"checkpoint": "checkpoint", "checkpoints": "checkpoint", "config": "config file", "labels": "label file",
        "truth": "answer file", "pred": "predictions file"}  # what a file to read is called in messages


def path_option(q: argparse.ArgumentParser, *names: str, kind: str, makes: str | None = None, **kw) -> None:
    """An argument that names a path (`kind`: a file to read, a folder to write into, a file to write), checked
    before the command runs (`check_paths`); `makes`: the kind of folder the command writes there (`paths.KINDS`)."""
    action = q.add_argument(*names, **kw)
    q.set_defaults(paths={**(q.get_default("paths") or {}), action.dest: kind})
    if makes:
        q.set_defaults(makes=makes)


READ_AS_INPUT = ("data", "calib")  # arguments that name a recording the command reads (a file or a folder)


def check_paths(args: argparse.Namespace) -> None:
    """Every path argument: a file to read exists and is a regular file; a folder to write into is not a file;
    a file to write is not a folder; then every output together against every input (`paths.check_outputs`: no
    output over an input or into a folder of another kind, and writable). One line naming the path."""
    from steerlab.paths import check_outputs, distinct, regular_file

    inputs, folders, files = [], {}, {}
    for dest, kind in (getattr(args, "paths", None) or {}).items():
        values = getattr(args, dest, None)
        name = flag(dest)
        given = [v for v in (values if isinstance(values, list) else [values]) if v is not None]
        if kind == "file" and isinstance(values, list):
            distinct(given, READ.get(dest, "file"))
        for value in given:
            path = Path(value)
            if kind == "file":
                regular_file(path, READ.get(dest, f"file for {name}"))
                inputs.append(path)
            elif kind == "folder":
                folders[f"output folder ({name})"] = path
            elif kind == "new-file":
                if path.is_dir():
                    raise SteerlabError(f"{path}: {name} names a folder; it needs a file to write")
                if dest == "video" and path.suffix.lower() != ".mp4":
                    raise SteerlabError(f"{path}: {name} writes an MP4 video; its name must end in .mp4")
                files[f"output file ({name})"] = path
    inputs += [Path(getattr(args, d)) for d in READ_AS_INPUT if getattr(args, d, None)]
    inputs += [Path(r.split("=", 1)[1]) for r in getattr(args, "reader", None) or [] if r.startswith("log=")]
    check_outputs(folders, files, inputs, getattr(args, "makes", None))


def add_options(q: argparse.ArgumentParser, command: str | None, *classes: type, skip=(),
                label: str | None = None) -> None:
    """Flags for the fields of `classes` (a field `max_heading` is `--max-heading`; a boolean that defaults to
    true is `--no-NAME`), registered in `OPTIONS` under `command` (a script's, None, are not); every flag defaults
    to None, so that a flag not given keeps the field's default. A flag
    that a class of the command made already (the same option of another world; `label` names when these
    classes apply, e.g. "--world track") is made once: its choices grow by this field's, and its help adds this
    field's where it differs."""
    if command is not None:
        known = OPTIONS.setdefault(command, [])
        known.extend(c for c in classes if c not in known)  # a parser built again registers nothing twice
    for cls in classes:
        for o in options_of(cls):
            if o.key in skip:
                continue
            kind, _ = optional(o.kind)
            default = "" if o.default in (None, MISSING, "") else f" (default {o.default})"
            helptext = (o.help or o.expected) + default
            literal = getattr(kind, "__origin__", None) is not None and str(kind).startswith("typing.Literal")
            negated = kind is bool and o.default is True
            made = q._option_string_actions.get(flag(f"no_{o.key}" if negated else o.key))
            if made is not None:
                if literal:
                    made.choices = list(dict.fromkeys([*made.choices, *kind.__args__]))
                if kind is not bool and helptext not in made.help:
                    made.help += f"; {label or cls.__name__}: {helptext}"
                continue
            if o.path:
                q.add_argument(flag(o.key), dest=o.key, default=None, help=helptext)
                q.set_defaults(paths={**(q.get_default("paths") or {}), o.key: o.path})
                if o.makes:
                    q.set_defaults(makes=o.makes)
            elif kind is bool:
                q.add_argument(flag(f"no_{o.key}" if negated else o.key), dest=o.key, default=None,
                               action="store_false" if negated else "store_true",
                               help=f"without {o.help or o.key}" if negated else o.help or o.key)
            elif literal:
                q.add_argument(flag(o.key), dest=o.key, default=None, choices=list(kind.__args__), help=helptext)
            else:
                q.add_argument(flag(o.key), dest=o.key, default=None, type=kind if kind in (int, float) else str,
                               help=helptext)


def from_args(cls, args: argparse.Namespace):
    """The dataclass `cls` from the flags given on the command line, checked (errors name the flag)."""
    given = {o.key: getattr(args, o.key) for o in options_of(cls) if getattr(args, o.key, None) is not None}
    return parse(cls, given, name=flag)


def script_parser(module: str, doc: str, *classes: type) -> Parser:
    """The command line of a script run as `python -m MODULE` (the studies and timings of the repository) by the
    rules of the steerlab command's: the script's docstring as its help, a flag for each field of the options
    dataclasses `classes` (typed, checked against their ranges), more arguments added with `path_option` or
    `data_args`, every option given once. `script_args` parses it, `run_script` runs the script."""
    p = Parser(prog=f"python -m {module}", description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(p, None, *classes)
    p.set_defaults(options=list(classes))
    return p


def script_args(parser: argparse.ArgumentParser, argv=None) -> tuple[argparse.Namespace, list]:
    """A script's command line `argv` (default: the process's) by its `script_parser`: the arguments, and an
    instance of each of its options classes; every path and option is checked before the script does anything,
    and a bad one ends it with one line (exit code 2) that names the option and the script."""
    args = parser.parse_args(argv)
    try:
        check_paths(args)
        return args, [from_args(cls, args) for cls in parser.get_default("options")]
    except SteerlabError as e:
        parser.error(str(e))


def run_script(parser: argparse.ArgumentParser, work, argv=None) -> None:
    """A script: its command line (`script_args`), then `work(args, *options)`; what the work refuses on the way
    (a recording that is not there, an empty journal) ends it in one line as well, never a traceback."""
    args, options = script_args(parser, argv)
    try:
        work(args, *options)
    except SteerlabError as e:
        parser.error(str(e))


def data_args(q: argparse.ArgumentParser, range_help: str = "frames to use, START:STOP (e.g. 0:2400)",
              camera: bool = True, required: bool = True) -> None:
    """The flags that name a recording (`data.readers.Source`)."""
    q.add_argument("--data", required=required, help="recording: CH2 folder, driving_log.csv, steerlab recording, "
                   "donkeycar tub, ROS bag or video with a CSV log")
    q.add_argument("--range", help=range_help)
    path_option(q, "--labels", kind="file", help="CH2: label CSV when the folder holds several")
    q.add_argument("--reader", action="append", default=[], metavar="KEY=VALUE",
                   help="reader option, repeatable: full_lock_deg=25, skip_missing=true (tubs), log=FILE.csv "
                        "(videos), ... (docs/architecture/other-recordings.md lists them)")
    if camera:
        q.add_argument("--camera", default="center", help="camera to use (default center)")


def reader_options(items: list[str]) -> dict:
    """Reader options given as `--reader key=value` texts; values are read as YAML scalars (numbers, true/false,
    text)."""
    import yaml

    from steerlab.files import UniqueKeys

    out = {}
    for item in items:
        if "=" not in item:
            raise SteerlabError(f"--reader {item!r} must look like key=value, e.g. full_lock_deg=25")
        key, value = item.split("=", 1)
        if key.strip() in out:
            raise SteerlabError(f"--reader {key.strip()}= is given twice; give each reader option once")
        out[key.strip()] = yaml.load(value, Loader=UniqueKeys)
    return out


def source(args: argparse.Namespace):
    """The recording the data flags name."""
    from steerlab.data.readers import Source

    return Source(args.data, args.range, args.labels, reader_options(args.reader))


def print_table(metrics: dict, keys=None) -> None:
    for k in [k for k in keys if k in metrics] if keys else metrics:
        v = metrics[k]
        if isinstance(v, float) and math.isnan(v) and k.endswith("_deg"):
            print(f"  {k:<18} n/a (no full-lock angle: degrees unknown)")
        elif isinstance(v, float):
            print(f"  {k:<18} {v:.6f}")
        elif not isinstance(v, dict):
            print(f"  {k:<18} {v}")


@cache
def build_parser() -> argparse.ArgumentParser:
    """The command line's parser, built once per process (a parse leaves it as it was)."""
    from steerlab.cli import data, driving, training

    p = Parser(prog="steerlab", description="End-to-end driving models: camera in, steering out.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    for module in (data, training, driving):
        module.register(sub)
    return p


def parse_args(argv=None) -> argparse.Namespace:
    """The command line; `section.key=value` overrides may stand anywhere after the config, before or after
    the options (`steerlab tune CONFIG --trials 3 train.epochs=2`)."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    overrides = [x for x in extra if "=" in x and not x.startswith("-")]
    if extra and (len(overrides) < len(extra) or not hasattr(args, "overrides")):
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
    if overrides:
        args.overrides = [*args.overrides, *overrides]
    return args


def main(argv=None) -> int:
    try:
        args = parse_args(argv)
    except SystemExit as e:  # --help, or an argparse error (already printed)
        return int(e.code or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    try:
        check_paths(args)
        args.func(args)
    except SteerlabError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # a write that failed half-way (disk full, permissions changed) or a path the OS refused
        from steerlab.paths import os_error

        print(f"error: {os_error(e)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return 0
