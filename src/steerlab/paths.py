"""Paths a user names, checked where they enter with one-line errors: a file to read (`regular_file`), a folder to
write into (`folder_to_write`), and every output of a command (`check_outputs`): never one of its inputs under any
spelling, never a folder that belongs to something else, and writable before any work starts.

What a folder holds is told by the files that mark it (`KINDS`): a recording, a training run, an experiment, a
study, a suite... A command writes into a new folder, an empty one, or one of its own kind that it continues
(a run resumed, a suite whose drives are reused); a recording is never written into once it exists."""

from __future__ import annotations

import errno
import fnmatch
import os
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from steerlab.errors import DataError, SteerlabError


def a_path(value, what: str) -> Path:
    """`value` as a Path: the Python API takes a file or folder as a str or an os.PathLike (pathlib.Path), not
    empty; anything else (None, a number, a list of paths) is a one-line error naming `what`."""
    if not isinstance(value, (str, os.PathLike)) or not str(value):
        raise SteerlabError(f"{what} must be a path (a str or pathlib.Path), got {value!r}")
    return Path(value)


def name_fits(path: str | Path) -> Path:
    """`path`, whose every name fits the file system (255 bytes, mostly): a one-line error instead of the
    OSError that asking about it would raise."""
    path = Path(path)
    limit = os.pathconf(".", "PC_NAME_MAX")
    for part in path.parts:
        if len(part.encode()) > limit:
            raise DataError(f"{path.parent}/{part[:24]}...", f"a name of {len(part.encode())} bytes; the file system "
                                                             f"takes names of at most {limit}")
    return path


def _a(what: str) -> str:
    return f"an {what}" if what[0] in "aeiou" else f"a {what}"


def _dangling(path: Path, what: str) -> None:
    """A one-line error when `path` is a symbolic link to nothing (writing through it would make a file elsewhere,
    and making a folder there fails with "file exists")."""
    if path.is_symlink() and not path.exists():
        raise DataError(path, f"a symbolic link to {os.readlink(path)}, which does not exist, where {_a(what)} is "
                              "expected; remove the link or name another path")


def _special(path: Path, what: str) -> None:
    """A one-line error when `path` is neither a regular file nor a folder (a device such as /dev/null or
    /dev/full, a pipe, a socket) or a symbolic link to nothing: what a command writes is a file or a folder."""
    _dangling(path, what)
    if path.exists() and not path.is_dir() and not path.is_file():
        raise DataError(path, f"a device, a pipe or a socket, where {_a(what)} to write is expected; name a file "
                              "or a folder")


def regular_file(path: Path, what: str = "file") -> Path:
    """`path`, which must be a regular file: a one-line error for a missing path, a folder, or anything else that
    is not a regular file (a pipe or a device, which reading would wait on forever)."""
    path = name_fits(a_path(path, what))
    _dangling(path, what)
    if not path.exists():
        raise DataError(path, f"{what} not found: check the path")
    if path.is_dir():
        raise DataError(path, f"a folder, where a {what} is expected")
    if not path.is_file():
        raise DataError(path, f"not a regular file (a pipe or a device?), where a {what} is expected")
    return path


def folder_to_write(path: str | Path, what: str = "output folder") -> Path:
    """`path`, a folder to write into (it may not exist yet): a one-line error when it names a file, a device or a
    symbolic link to nothing."""
    path = name_fits(a_path(path, what))
    _special(path, what)
    if path.exists() and not path.is_dir():
        raise DataError(path, f"a file, where {_a(what)} is expected")
    return path


@dataclass(frozen=True)
class Kind:
    """A kind of folder that a command writes: `marks` are the names whose presence tells such a folder,
    `writes` the names (glob patterns) the command writes into it; `continued`: a command of this kind may write
    into one that exists (a run resumes, a suite reuses its drives, an evaluation is made again)."""

    name: str
    marks: tuple[str, ...]
    writes: tuple[str, ...]
    continued: bool = True


KINDS = {
    "recording": Kind("recording", ("recording.json", "driving_log.csv", "manifest.json", "metadata.yaml", "center"),
                      ("recording.json", "log.csv", "driving_log.csv", "manifest.json", "catalog_*", "center",
                       "left", "right", "IMG", "images"), continued=False),
    "run": Kind("training run", ("last.pt",), ("best.pt", "last.pt", "config.json", "log.csv", "val_predictions.csv",
                                              "metrics.json", "tensorboard", "suite", "replay")),
    "experiment": Kind("experiment", ("table.md", "table.csv"),
                       ("table.md", "table.csv", "predictions.png", "roads", "open_vs_closed.png", "recovery.png")),
    "dagger": Kind("DAgger run", ("dagger.json",), ("dagger.json", "dagger.csv", "dagger.png", "round*", "best.pt",
                                                    "log.csv", "val_predictions.csv", "metrics.json")),
    "study": Kind("tuning study", ("study.journal", "trials.csv"),
                  ("study.journal", "trials.csv", "summary.md", "importance.*", "pareto.*", "slice.png",
                   "history.png", "best.yaml", "trials", "tensorboard")),
    "evaluation": Kind("evaluation", ("predictions.csv",), ("predictions.csv", "metrics.json", "steering.png")),
    "suite": Kind("closed-loop suite", ("suite.csv", "suite.md"), ("suite.csv", "summary.csv", "suite.md", "roads",
                                                                     "tracks")),
    "drive": Kind("drive", ("drive.json", "trajectory.csv"), ("drive.json", "trajectory.csv", "path.png", "track.png",
                                                              "frames.png")),
    "replay": Kind("replay", ("replay.md", "replay.json"), ("replay.md", "replay.json", "replay.csv", "segments.csv",
                                                            "replay.png", "path.png")),
    "latency": Kind("latency table", ("latency.csv",), ("latency.csv", "latency.md")),
    "demo": Kind("demo", ("report.md",), ("report.md", "summary.json", "recording", "cache", "pilotnet", "open-loop",
                                           "replay", "closed-loop")),
    "cache": Kind("cache", (), ()),
}


def kind_of(folder: Path) -> tuple[Kind, str] | None:
    """The kind of an existing folder and the name that marks it (None: no kind steerlab writes)."""
    if not folder.is_dir():
        return None
    for kind in KINDS.values():
        for mark in kind.marks:
            if (folder / mark).exists():
                return kind, mark
    return None


def same_path(a: str | Path, b: str | Path) -> bool:
    """Whether two spellings (relative, absolute, through a symlink) name one file or folder."""
    a, b = Path(a), Path(b)
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except OSError:
        return False


def _inside(path: Path, folder: Path) -> Path | None:
    """`path` relative to `folder` when it lies inside it (symlinks resolved), else None."""
    try:
        return path.resolve().relative_to(folder.resolve())
    except (OSError, ValueError):
        return None


def distinct(paths: Iterable[str | Path], what: str = "input") -> list[Path]:
    """`paths` with none named twice under another spelling (a symlink, a relative path): a one-line error for the
    second."""
    seen: dict[Path, Path] = {}
    out = []
    for p in map(Path, paths):
        real = p.resolve()
        if real in seen:
            also = "" if str(seen[real]) == str(p) else f" (as {seen[real]} too)"
            raise SteerlabError(f"{p} is named twice{also}: name each {what} once")
        seen[real] = p
        out.append(p)
    return out


REASONS = {errno.EACCES: "permission denied", errno.EPERM: "operation not permitted",
           errno.EROFS: "a read-only file system", errno.ENOSPC: "no space left on the device",
           errno.EDQUOT: "the disk quota is used up", errno.ENAMETOOLONG: "a file name too long for the file system",
           errno.ENOTDIR: "a part of the path is a file", errno.EISDIR: "a folder, where a file is written"}


def reason(e: OSError) -> str:
    """Why a write failed, in a few words."""
    return REASONS.get(e.errno, (e.strerror or type(e).__name__).lower())


def os_error(e: OSError) -> SteerlabError:
    """An OSError (a write that failed half-way: the disk full, permissions changed) as one line naming the path
    and the reason."""
    return SteerlabError(f"{e.filename}: {reason(e)}: fix that and run the command again" if e.filename
                         else f"{reason(e)}: fix that and run the command again")


def writable(path: Path, what: str = "output folder") -> None:
    """That `path` (a folder to make or fill, or a file to write) can be written: its name fits the file system, and
    a file can be made in the nearest folder that exists. Checked before any work, so that nothing is computed
    for an output that cannot be kept."""
    if path.is_file():  # a file written again: opened for appending, which changes nothing
        try:
            open(path, "ab").close()
        except OSError as e:
            raise DataError(path, f"cannot be written ({reason(e)}): choose another path") from None
        return
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise DataError(path, f"cannot be written: {existing} is a file; choose another path")
    try:
        fd, probe = tempfile.mkstemp(dir=existing, prefix=".steerlab-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise DataError(existing, f"cannot be written ({reason(e)})" + (
            "" if existing == path else f", so the {what} {path} cannot be made there") + "; choose another path"
        ) from None


def check_outputs(folders: dict[str, str | Path | None] | None = None,
                  files: dict[str, str | Path | None] | None = None, inputs: Iterable[str | Path | None] = (),
                  kind: str | None = None) -> None:
    """The one check that every command's outputs go through, before any work: `folders` and `files` (what they
    are called in messages -> path) are the command's outputs, `inputs` every path it reads, `kind` the kind of
    folder it writes (`KINDS`). Refused in one line naming the path: an output that is an input (any spelling) or
    would write over one inside its folder; a folder of another kind (a run's folder for an evaluation, a
    recording for anything), or an existing recording for a recording; a file inside a recording, or one that
    another kind of folder writes (a run's best.pt); an output that cannot be written."""
    inputs = [a_path(p, "an input") for p in inputs if p is not None]
    own = KINDS[kind] if kind else None
    for what, folder in (folders or {}).items():
        if folder is None:
            continue
        folder = folder_to_write(folder, what)
        for p in inputs:
            if same_path(p, folder):
                raise DataError(folder, f"the {what} is an input of this command ({p}); choose another folder")
        for place in (folder, folder.parent):
            held = kind_of(place)
            if held is None or (held[0] is own and own.continued and place == folder) or (
                    place != folder and held[0].continued):  # a run's own subfolders (its suite, its replay)
                continue
            where = "holds" if place == folder else "lies inside a folder that holds"
            if held == (KINDS["recording"], "center") and (place / "center" / "000000.jpg").is_file():  # cut short
                raise DataError(folder, f"the {what} {where} a recording without its recording.json ({place}), "
                                        "as an interrupted recording (Ctrl-C) leaves it: remove that folder to record "
                                        "again, or choose another")
            raise DataError(folder, f"the {what} {where} {_a(held[0].name)} ({place / held[1]}); "
                                    f"{_a(own.name) if own else 'this command'} "
                                    f"{'goes' if own else 'writes'} into a new folder"
                                    f"{' or one of its own' if own and own.continued else ''}: choose one")
        for p in inputs:
            rel = _inside(p, folder)
            if rel is not None and rel.parts and own and any(fnmatch.fnmatch(rel.parts[0], w) for w in own.writes):
                raise DataError(folder, f"the {what} would write over its input {p}; choose another folder")
        writable(folder, what)
    for what, file in (files or {}).items():
        if file is None:
            continue
        file = name_fits(a_path(file, what))
        _special(file, what)
        if file.is_dir():
            raise DataError(file, f"a folder, where {_a(what)} to write is expected")
        for p in inputs:
            if same_path(p, file):
                raise DataError(file, f"the {what} is an input of this command; writing it would destroy it: "
                                      "choose another file")
        held = kind_of(file.parent)
        if held and held[0] is not own and (not held[0].continued or any(fnmatch.fnmatch(file.name, w)
                                                                          for w in held[0].writes)):
            raise DataError(file, f"the {what} would write into {_a(held[0].name)} ({file.parent / held[1]}); "
                                  "write it elsewhere")
        writable(file, what)
