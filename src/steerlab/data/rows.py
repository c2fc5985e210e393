"""What every reader shares: what a reader is (`Reader`, the one registration of a layout), frame ranges, CSV rows,
numbers and image checks that name the file and row, unique frame ids, and matching frames by time."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from steerlab.errors import DataError
from steerlab.files import csv_header, read_csv  # noqa: F401 - csv_header: the readers' header


@dataclass(frozen=True)
class Reader:
    """A recording layout, as `readers.READERS` registers it: `name` (what the docs and messages call it),
    `expects` (what it recognises, in the words of the "not a recording" message), `recognises(path)` (whether a
    path is of this layout; tried in the registry's order), `read(path, frame_range, **options)` (the
    `Recording`), `options` (the dataclass of its reader options, None: it takes none), whether it takes a
    label file (`labels`, CH2's) or the cache root (`cache`, where a ROS bag's frames are extracted), and `near(path)`:
    for a path nearly of this layout, the one-line error of what it lacks (else None: the "not a recording" message
    lists every layout)."""

    name: str
    expects: str
    recognises: Callable[[Path], bool]
    read: Callable
    options: type | None = None
    labels: bool = False
    cache: bool = False
    near: Callable[[Path], None] = lambda path: None


def parse_range(text: str | tuple | None, where: str | Path) -> tuple[int | None, int | None] | None:
    """Parse "a:b" (either side may be empty) into a tuple; None stays None, and a (start, stop) pair of
    integers or None (the Python API's form) is taken as it is. Errors name `where` (the recording, the option)."""
    if text is None:
        return None
    if isinstance(text, (tuple, list)) and len(text) == 2 and all(
            v is None or (isinstance(v, int) and not isinstance(v, bool)) for v in text):
        return tuple(text)  # type: ignore[return-value]
    if not isinstance(text, str):
        raise DataError(where, f"frame range {text!r} must be text like \"0:1800\" (quote it in YAML files) or "
                                   "a (start, stop) pair of integers")
    parts = str(text).split(":")
    if len(parts) != 2:
        raise DataError(where, f"frame range {text!r} must look like START:STOP, e.g. 0:1800")
    try:
        return tuple(int(p) if p.strip() else None for p in parts)  # type: ignore[return-value]
    except ValueError:
        raise DataError(where, f"frame range {text!r} must hold integers, e.g. 0:1800") from None


def apply_range(n: int, rng, source: Path) -> slice:
    if rng is None:
        return slice(0, n)
    start = 0 if rng[0] is None else rng[0]
    stop = n if rng[1] is None else rng[1]
    if start >= stop:
        raise DataError(source, f"frame range {start}:{stop} is empty: START must be below STOP")
    if not (0 <= start and stop <= n):
        raise DataError(source, f"frame range {start}:{stop} is outside the {n} labelled frames (0:{n}): "
                                "give a range inside it")
    return slice(start, stop)


def read_rows(path: Path, what: str = "CSV file") -> list[list[str]]:
    """The rows of a CSV file as people save it (`files.read_csv`)."""
    return read_csv(path, what)


def number(path: Path, row: int, column: str, text: str, allow_nan: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(path, f"column {column!r} must be a number, got {text!r}", row) from None
    if not allow_nan and not math.isfinite(value):
        raise DataError(path, f"column {column!r} is {text!r}; a finite number is expected", row)
    return value


def check_images(paths: list[Path], source: Path, first_row: int, start: int) -> None:
    """Every image of frames start.. exists (`paths`, listed from row `first_row` of `source`)."""
    for i, p in enumerate(paths):
        if not p.is_file():
            raise DataError(source, f"image {p} is missing (give a frame range that covers only the frames that exist, "
                                    f"e.g. range {start}:{start + i})" if i else
                            f"image {p} is missing: copy it back, or give a frame range that starts after it",
                            first_row + i)


def nearest(sorted_times: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Index of the entry of `sorted_times` nearest to each of `times` (the earlier one on a tie)."""
    if len(sorted_times) == 1:
        return np.zeros(len(times), dtype=np.int64)
    j = np.clip(np.searchsorted(sorted_times, times), 1, len(sorted_times) - 1)
    return np.where(np.abs(sorted_times[j - 1] - times) <= np.abs(sorted_times[j] - times), j - 1, j)


def check_increasing(times: np.ndarray, path: Path, first_row: int) -> None:
    """Capture times in row order: a time that goes back is a one-line error naming the file and its row."""
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise DataError(path, f"the time goes back ({int(times[i])} ns after {int(times[i - 1])} ns in the row "
                              "before): the rows must be in the order they were recorded", first_row + i)


def check_unique(ids: np.ndarray, path: Path, first_row: int) -> None:
    order = np.argsort(ids, kind="stable")
    dup = np.flatnonzero(np.diff(ids[order]) == 0)
    if dup.size:
        row = int(order[dup[0] + 1])
        raise DataError(path, f"duplicate frame id {ids[row]}: remove the repeated row", first_row + row)




def ends_torn(path: Path, row: list[str]) -> bool:
    """Whether the last line of a file was cut off mid-write: NUL bytes in it, or no line end after it."""
    with open(path, "rb") as f:
        f.seek(-1, 2)
        return any("\x00" in c for c in row) or f.read(1) not in (b"\n", b"\r")
