"""Paths a user names, checked where they enter with one-line errors: a file to read (`regular_file`) and a folder
to write into (`folder_to_write`)."""

from __future__ import annotations

from pathlib import Path

from steerlab.errors import DataError


def regular_file(path: Path, what: str = "file") -> Path:
    """`path`, which must be a regular file: a one-line error for a missing path, a folder, or anything else that
    is not a regular file (a pipe or a device, which reading would wait on forever)."""
    path = Path(path)
    if not path.exists():
        raise DataError(path, f"{what} not found")
    if path.is_dir():
        raise DataError(path, f"a folder, where a {what} is expected")
    if not path.is_file():
        raise DataError(path, f"not a regular file (a pipe or a device?), where a {what} is expected")
    return path


def folder_to_write(path: str | Path, what: str = "output folder") -> Path:
    """`path`, a folder to write into (it may not exist yet): a one-line error when it names a file."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise DataError(path, f"a file, where an {what} is expected" if what[0] in "aeiou" else
                        f"a file, where a {what} is expected")
    return path
