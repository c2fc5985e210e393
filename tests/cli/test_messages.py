"""Every error message says what to do, and suggests only options the command has.

The templates are read from the source: every call constructing a `SteerlabError` or a `DataError` under
src/steerlab, its message's constant text (each branch of a conditional on its own). A message that wraps a
SteerlabError caught around it (`except SteerlabError as e: raise SteerlabError(f"{path}: {e}")`) carries the fix
of the wrapped message, which is checked where that one is written.
"""

from __future__ import annotations

import argparse
import ast
import itertools
import re
from pathlib import Path

import pytest

import steerlab
from conftest import made, write_jpeg
from steerlab.cli import Parser, build_parser, data, driving, main, training

SRC = Path(steerlab.__file__).parent
ERRORS = {"SteerlabError", "DataError"}

# A fix is either an instruction (a verb of this list opening a clause: after ":", ";", "(", "," or "or"/"and"/"then",
# and not a config key such as train.lr) or a statement of what is expected ("expected ...", "must ...", "one of ...").
VERBS = ("give|use|choose|name|remove|delete|copy|set|add|pass|leave|keep|quote|save|write|fix|make|convert|check|"
         "run|record|train|pretrain|export|calibrate|replay|evaluate|time|split|install|pip|free|lower|raise|wait|"
         "start")
FIX = re.compile(rf"(?:[:;(,]\s*|\b(?:or|and|then)\s+)(?:{VERBS})\b(?![.(_=])"
                 r"|\b(?:expected|expects?|must|needs?|takes?|one of|known:|available:|at least|at most|e\.g\.)",
                 re.I)
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def texts(node: ast.AST) -> list[str]:
    """The constant text of a message expression, one per branch of its conditionals ("{}" for a value)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, ast.IfExp):
        return texts(node.body) + texts(node.orelse)
    if isinstance(node, ast.FormattedValue):
        return texts(node.value) if isinstance(node.value, (ast.IfExp, ast.JoinedStr, ast.Constant)) else ["{}"]
    parts = node.values if isinstance(node, ast.JoinedStr) else [node.left, node.right] \
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add) else None
    if parts is None:
        return ["{}"]
    return ["".join(p) for p in itertools.product(*(texts(p) for p in parts))]


class Templates(ast.NodeVisitor):
    """(file, line, text, wraps a caught SteerlabError) of every error a module constructs."""

    def __init__(self, path: Path):
        self.path, self.caught, self.found = path, [], []

    def visit_ExceptHandler(self, node: ast.ExceptHandler):
        types = node.type.elts if isinstance(node.type, ast.Tuple) else [node.type]
        ours = node.name and all(getattr(t, "id", None) in ERRORS for t in types)
        self.caught.append(node.name if ours else None)
        self.generic_visit(node)
        self.caught.pop()

    def visit_Call(self, node: ast.Call):
        name = getattr(node.func, "id", getattr(node.func, "attr", None))
        message = node.args[1] if name == "DataError" and len(node.args) > 1 else node.args[0] if node.args else None
        if name in ERRORS and message is not None:
            wraps = any(isinstance(n, ast.Name) and n.id in self.caught for n in ast.walk(message))
            self.found += [(self.path, node.lineno, t, wraps) for t in texts(message)]
        self.generic_visit(node)


def templates() -> list[tuple[Path, int, str, bool]]:
    out = []
    for path in sorted(SRC.rglob("*.py")):
        visitor = Templates(path.relative_to(SRC.parent))
        visitor.visit(ast.parse(path.read_text(encoding="utf-8")))
        out += visitor.found
    return out


def test_the_templates_are_found():
    found = templates()
    assert len(found) > 300
    texts_of = {(str(p), t) for p, _, t, _ in found}
    assert ("steerlab/data/ch2.py", "the label file is empty: label the frames (frame_id,steering_angle rows) "
            "or give the right file") in texts_of  # a plain DataError
    branches = {t for p, _, t, _ in found if p.name == "rows.py" and t.startswith("image {} is missing")}
    assert branches == {"image {} is missing: copy it back, or give a frame range that starts after it",
                        "image {} is missing (give a frame range that covers only the frames that exist, e.g. range "
                        "{}:{})"}  # each branch of a conditional on its own


def test_the_fix_rule():
    for good in ("not a steerlab checkpoint: give best.pt of a training run", "unknown model {}; available: {}",
                 "frame {}: expected 3 channels", "the file is damaged (export the checkpoint again)",
                 "the split must be a mapping", "unknown options {}; known: {}", "remove the line or fix its JSON"):
        assert FIX.search(good), good
    for bad in ("the label file is empty", "the frame name {} is not a name", "cannot decode image (corrupt)",
                "the training run failed", "a data set of {} frames", "only {} frames", "train split {} overlaps",
                "(train.lr {} may be too high)", "run() after shutdown()", "none to time after {} frames"):
        assert not FIX.search(bad), bad


def test_every_message_says_what_to_do():
    missing = [f"{p}:{line}: {t}" for p, line, t, wraps in templates() if not wraps and not FIX.search(t)]
    assert not missing, "messages that say what is wrong but not what to do:\n" + "\n".join(missing)


def commands(parser: argparse.ArgumentParser, name: str = "") -> dict[str, set[str]]:
    """Each command of the parser ("sim drive") and its flags."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        return {name: {o for a in parser._actions for o in a.option_strings}}
    return {k: v for n, q in subs[0].choices.items() for k, v in commands(q, f"{name} {n}".strip()).items()}


def module_flags(module) -> set[str]:
    """The flags of the commands one CLI module registers."""
    parser = Parser(prog="steerlab")
    module.register(parser.add_subparsers(dest="command", parser_class=Parser))
    return set().union(*commands(parser).values())


def wrong_flags(path: Path, text: str, every: dict[str, set[str]], cli: dict[str, set[str]]) -> list[str]:
    """The flags a template names that the command it is reached from does not have: in cli/, a command of
    that module; elsewhere, the command named before the flag ("steerlab replay --speed 8")."""
    if path.parts[1] == "cli":
        return [f for f in FLAG.findall(text) if f not in cli.get(path.stem, set().union(*every.values()))]
    names = "|".join(sorted(map(re.escape, every), key=len, reverse=True))
    wrong, command = [], None
    for m in re.finditer(rf"\bsteerlab ({names})\b|{FLAG.pattern}", text):
        if m.group(1):
            command = m.group(1)
        elif command is None or m.group() not in every[command]:
            wrong.append(f"{m.group()} (of {'no command named before it' if command is None else command})")
    return wrong


def test_the_flag_rule():
    every = commands(build_parser())
    cli = {m.__name__.rsplit(".", 1)[1]: module_flags(m) for m in (data, training, driving)}
    below, in_cli = Path("steerlab/data/x.py"), Path("steerlab/cli/training.py")
    assert wrong_flags(below, "give it with steerlab replay --speed M/S", every, cli) == []
    assert wrong_flags(below, "e.g. --range 0:{}", every, cli) == ["--range (of no command named before it)"]
    assert wrong_flags(below, "steerlab train --range 0:9", every, cli) == ["--range (of train)"]
    assert wrong_flags(below, "steerlab sim record --world track", every, cli) == []
    assert wrong_flags(in_cli, "--nproc {} and --seeds", every, cli) == []
    assert wrong_flags(in_cli, "use --geometry", every, cli) == ["--geometry"]


def test_messages_suggest_only_options_the_command_has():
    every = commands(build_parser())
    cli = {m.__name__.rsplit(".", 1)[1]: module_flags(m) for m in (data, training, driving)}
    wrong = [f"{p}:{line}: {', '.join(w)}: {t}" for p, line, t, _ in templates()
             if (w := wrong_flags(p, t, every, cli))]
    assert not wrong, "flags the command does not have (below the CLI, name a config key or argument, or the " \
                      "command with its flag):\n" + "\n".join(wrong)


def test_only_a_caught_steerlab_error_carries_its_own_fix():
    code = ("try:\n    f()\nexcept SteerlabError as e:\n    raise SteerlabError(f'{p}: {e}')\n"
            "try:\n    f()\nexcept (SteerlabError, ValueError) as e:\n    raise DataError(p, f'{e}')\n")
    visitor = Templates(Path("steerlab/x.py"))
    visitor.visit(ast.parse(code))
    assert [(line, text, wraps) for _, line, text, wraps in visitor.found] == [(4, "{}: {}", True), (8, "{}", False)]


# the three messages the issue found unclear


def test_a_checkpoint_given_as_a_config_is_named_so(capsys):
    run = Path(__file__).parents[1] / "fixtures" / "run-0.1.0"
    assert main(["train", str(run / "best.pt")]) == 2
    assert capsys.readouterr().err == (f"error: {run / 'best.pt'}: a steerlab checkpoint, where the config file is "
                                       f"expected (YAML text): give the config file, e.g. {run / 'config.json'}, the "
                                       "config its run trained with\n")


def test_a_frame_of_another_size_is_named_by_its_file(tmp_path, capsys):
    img = tmp_path / "sim" / "IMG"
    img.mkdir(parents=True)
    names = [f"center_2020_01_01_00_00_00_{100 * i:03d}.jpg" for i in range(4)]
    for i, name in enumerate(names):
        write_jpeg(img / name, 20 * i, (240, 320) if i == 2 else (160, 320))
    (img.parent / "driving_log.csv").write_text("".join(f"{img / name},,,0.0,0.5,0,10\n" for name in names))
    assert main(["evaluate", str(made(tmp_path)), "--data", str(img.parent / "driving_log.csv"), "--out",
                 str(tmp_path / "e")]) == 2
    assert capsys.readouterr().err == (f"error: {img / names[2]}: a 240x320 frame (height x width); model "
                                       "'pilotnet' was trained on the 'sim' camera (160x320): give it that camera's frames "
                                       "(other_camera: crop and resize any frame)\n")


def test_a_recording_cut_short_says_so(tmp_path, capsys):
    out = tmp_path / "rec"
    (out / "center").mkdir(parents=True)  # what `steerlab sim record` leaves when Ctrl-C stops it
    write_jpeg(out / "center" / "000000.jpg")
    assert main(["sim", "record", "--out", str(out), "--minutes", "0.01"]) == 2
    assert capsys.readouterr().err == (f"error: {out}: the output folder (--out) holds a recording without its "
                                       f"recording.json ({out}), as an interrupted recording (Ctrl-C) leaves it: "
                                       "remove that folder to record again, or choose another\n")
    assert main(["compile", "--data", str(out)]) == 2
    assert capsys.readouterr().err == (f"error: {out}: a recording without its recording.json, as an interrupted "
                                       "recording (Ctrl-C) leaves it: record it again\n")
