"""`open_recording`: any recording on disk as a `Recording`, its layout detected from the path by the registry of
readers (`READERS`).

One module per layout, all below this one, each defining its `READER` (a `rows.Reader`: how it recognises a path,
its options, how it reads) and registered by one line of `READERS`: steerlab's native layout (`native.py`), the
Udacity simulator's `driving_log.csv` (`simlog.py`), video files with a CSV log (`videolog.py`), ROS 1/2 bags as
Udacity released its data (`bag.py`), donkeycar tubs (`tub.py`) and Udacity CH2 folders (`ch2.py`); what they
share (frame ranges, CSV rows, checks that name the file and row) is in `rows.py`. A layout of one's own is a
module with a `Reader` and `register(READER)`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from steerlab.data import bag, ch2, native, simlog, tub, videolog
from steerlab.data.recording import Recording
from steerlab.data.rows import Reader, parse_range
from steerlab.errors import DataError, SteerlabError
from steerlab.options import options_of, parse
from steerlab.paths import a_path

# Every layout steerlab reads, in the order a path is tried: one line each (a layout's module defines its READER).
READERS: list[Reader] = [native.READER, simlog.READER, videolog.READER, bag.READER, tub.READER, ch2.READER]


def register(reader: Reader) -> Reader:
    """Add a layout (a `rows.Reader`) to the registry, tried after the others; its name must be new."""
    if not isinstance(reader, Reader):
        raise SteerlabError(f"register: a steerlab.data.rows.Reader is expected, got {reader!r}")
    if any(r.name == reader.name for r in READERS):
        raise SteerlabError(f"register: a reader named {reader.name!r} is registered already; choose another name")
    READERS.append(reader)
    return reader


@dataclass(frozen=True)
class Source:
    """A recording as a command or a config names it: its path, frame range, CH2 label file, reader options,
    and (for a split) which of its frames to use."""

    data: str
    range: str | None = None
    labels: str | None = None
    reader: dict | None = None
    frames: tuple[int, ...] | None = None

    def open(self, cache: str | Path | None = None) -> Recording:
        return open_recording(self.data, self.range, self.labels, self.reader, cache)


def a_source(source, where: str) -> Source:
    """`source` when it is a Source: what the Python API's functions on a recording take (a path is wrapped by the
    caller, Source(PATH, range=...)); anything else a one-line error."""
    if not isinstance(source, Source):
        raise SteerlabError(f"{where}: the recording must be given as a steerlab.data.readers.Source "
                            f"(Source(PATH, range=...)), got {source!r}")
    return source


def open_recording(path: str | Path, frame_range: str | tuple | None = None, labels: str | Path | None = None,
                   options: dict | None = None, cache: str | Path | None = None) -> Recording:
    """Open any supported recording. `frame_range` ("a:b") keeps frames [a, b) before images are checked.
    `options` are reader options (config section `reader:`), e.g. `full_lock_deg` and `skip_missing` for
    donkeycar tubs, `topics` for ROS bags, `log` for videos. `cache`: the cache root (`data.cache`), where a ROS
    bag's frames are extracted to."""
    path = a_path(path, "the recording")
    if not path.exists():
        raise DataError(path, "recording not found: check the path")
    rng = parse_range(frame_range, path)
    reader = reader_of(path)
    kind = reader.options
    known = [o.key for o in options_of(kind)] if kind else []
    if options is not None and not isinstance(options, dict):
        raise DataError(path, f"reader options must be a dict (e.g. {{'strict': True}}), got {options!r}")
    unknown = sorted(set(options or {}) - set(known))
    if unknown:
        raise DataError(path, f"unknown reader option(s) {unknown}; this recording's reader ({reader.name}) takes "
                              f"{', '.join(known) or 'none'}")
    try:  # typed and range-checked, as every option is (a boolean is a boolean: skip_missing=maybe is refused)
        typed = parse(kind, options, "reader") if kind else None
    except SteerlabError as e:
        raise DataError(path, str(e)) from None
    options = {k: getattr(typed, k) for k in known}
    if labels is not None:
        if not reader.labels:
            raise DataError(path, "a label file (labels) belongs to CH2 folders only: leave it out")
        options["labels"] = a_path(labels, "labels")
    if reader.cache:
        options["cache"] = cache
    return reader.read(path, rng, **options)


def reader_of(path: Path) -> Reader:
    """The registered reader that recognises `path` (the first in `READERS`' order); else a one-line error that
    lists what each expects."""
    for reader in READERS:
        if reader.recognises(path):
            return reader
    for reader in READERS:
        reader.near(path)
    raise DataError(path, "not a recording: expected " + ", ".join(r.expects for r in READERS[:-1])
                    + f" or {READERS[-1].expects}")
