"""One exception type for every problem a user can fix, with the file and row that caused it."""

from __future__ import annotations

import sys
from pathlib import Path


class SteerlabError(Exception):
    """A problem with user input (files, configs, arguments). The CLI prints it without a traceback."""


class DataError(SteerlabError):
    """Bad input data. The message names the file, the row (1-based, as an editor shows it) and what was expected."""

    def __init__(self, path: str | Path, message: str, row: int | None = None):
        where = str(path) if row is None else f"{path}, row {row}"
        super().__init__(f"{where}: {message}")
        self.path = Path(path)
        self.row = row
        self.message = message


def warn(message: str) -> None:
    """Tell the user about something that works but probably not as they intend."""
    print(f"warning: {message}", file=sys.stderr)


_SAID: set[str] = set()  # what warn_once has said in this process


def warn_once(message: str) -> None:
    """`warn`, the first time in this process only: for what is read again within one command (a recording opened
    several times, a config parsed more than once)."""
    if message not in _SAID:
        _SAID.add(message)
        warn(message)
