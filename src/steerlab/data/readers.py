"""`open_recording`: any recording on disk as a `Recording`, its layout detected from the path.

One module per layout, all below this one: Udacity CH2 folders (`ch2.py`), the Udacity simulator's
`driving_log.csv` (`simlog.py`), steerlab's native layout (`native.py`), donkeycar tub v2 folders (`tub.py`),
ROS 1/2 bags as Udacity released its data (`bag.py`) and video files with a CSV log (`videolog.py`); what they
share (frame ranges, CSV rows, checks that name the file and row) is in `rows.py`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from steerlab.data import bag, tub, videolog
from steerlab.data.ch2 import read_ch2
from steerlab.data.native import read_native
from steerlab.data.recording import Recording
from steerlab.data.rows import parse_range
from steerlab.data.simlog import SIM_OPTIONS, read_sim_log
from steerlab.errors import DataError, SteerlabError
from steerlab.options import options_of, parse
from steerlab.paths import a_path

VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")


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
    rng = parse_range(frame_range)
    reader, kind = _reader_of(path)
    known = [o.key for o in options_of(kind)] if kind else []
    if options is not None and not isinstance(options, dict):
        raise DataError(path, f"reader options must be a dict (e.g. {{'strict': True}}), got {options!r}")
    unknown = sorted(set(options or {}) - set(known))
    if unknown:
        raise DataError(path, f"unknown reader option(s) {unknown}; this recording's reader takes "
                              f"{', '.join(known) or 'none'}")
    try:  # typed and range-checked, as every option is (a boolean is a boolean: skip_missing=maybe is refused)
        typed = parse(kind, options, "reader") if kind else None
    except SteerlabError as e:
        raise DataError(path, str(e)) from None
    options = {k: getattr(typed, k) for k in known}
    if labels is not None:
        if reader is not read_ch2:
            raise DataError(path, "a label file (labels) belongs to CH2 folders only: leave it out")
        options["labels"] = a_path(labels, "labels")
    if reader is bag.read_bag:
        options["cache"] = cache
    return reader(path, rng, **options)


def _reader_of(path: Path):
    """The reader function for a path and the options it takes."""
    if path.is_file() and path.suffix == ".csv":
        if path.name == "log.csv" and (path.parent / "recording.json").exists():
            return _native_folder, None
        return read_sim_log, SIM_OPTIONS
    if path.is_file() and path.suffix.lower() in VIDEO_SUFFIXES:
        return videolog.read_video, videolog.OPTIONS
    if bag.is_bag(path):
        return bag.read_bag, bag.OPTIONS
    if path.is_dir() and (path / "recording.json").exists():
        return read_native, None
    if path.is_dir() and (path / "driving_log.csv").exists():
        return _sim_folder, SIM_OPTIONS
    if path.is_dir() and tub.is_tub(path):
        return tub.read_tub, tub.OPTIONS
    if path.is_dir() and (path / "center").is_dir():
        return read_ch2, None
    raise DataError(path, "not a recording: expected a CH2 folder (center/ + CSV), a driving_log.csv, a steerlab "
                          "recording (recording.json), a donkeycar tub (manifest.json + catalogs), a ROS bag "
                          f"(.bag, or a ROS 2 folder with metadata.yaml) or a video ({', '.join(VIDEO_SUFFIXES)})")


def _native_folder(log: Path, rng) -> Recording:
    return read_native(log.parent, rng)


def _sim_folder(folder: Path, rng, strict: bool = False) -> Recording:
    return read_sim_log(folder / "driving_log.csv", rng, strict)
