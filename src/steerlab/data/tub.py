"""donkeycar "tub v2" folders: `manifest.json`, `catalog_N.catalog` (one JSON record a line) and `images/`.

The manifest's five JSON lines are: the record keys, their types, the user's metadata, the creation time with
the session ids, and the catalog files in order with `deleted_indexes` (records the user deleted; never used).
Each record holds `_index`, `_session_id`, `_timestamp_ms`, `cam/image_array` (a file in `images/`),
`user/angle` (servo command in [-1, 1], positive right) and `user/throttle` ([-1, 1]). The track world's
recordings add the lane the car is in (`LANE_FIELDS`, floats): `lane/offset`, the rear axle's lateral offset from
the lane centre in metres, positive left; `lane/heading`, the car's heading to the lane in radians, positive
turned left (counter-clockwise); `lane/curvature`, the lane's curvature at the car in 1/m, positive where it
turns left. They are read into `Recording.extra` under steerlab's own names (`lateral_offset`, `heading_error`,
`curvature`), only when the manifest declares all three.

`user/angle` keeps its own unit: the recording's convention is "normalized", positive right, with the car's
full-lock angle when the user gives it (reader option `full_lock_deg`); only then do degree metrics, viewpoint
shifts and closed-loop conversions have a meaning. Sessions become segments (`extra["session"]`) and can
be used for splits.

A car that loses power mid-write leaves torn catalog lines (a run of NUL bytes, half a JSON record). As
donkeycar's own reader does, they are read past, with one warning that names them and counts the records lost
(from the gaps in `_index`; said once a process, however often the tub is opened); reader option `strict: true`
refuses such a tub instead.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from steerlab.data.fisheye import DONKEY_FISHEYE, fisheye_from
from steerlab.data.rows import Reader, apply_range
from steerlab.data.recording import FULL_LOCK_DEG, Recording, SteeringConvention, said_full_lock
from steerlab.options import Options, option
from steerlab.paths import regular_file
from steerlab.errors import DataError, SteerlabError, warn_once
from steerlab.files import unique_pairs



@dataclass(frozen=True)
class TubOptions(Options):
    """A tub's reader options."""

    full_lock_deg: float | None = option(None, FULL_LOCK_DEG, help="the car's full-lock angle: user/angle 1 is this "
                                         "many degrees of road wheel (unknown to the tub)")
    skip_missing: bool = option(False, help="leave out the records whose image is missing (with a warning)")
    strict: bool = option(False, help="refuse torn catalog lines and lost records instead of reading past them")
    mirrored: bool = option(False, help="its frames turn against its steering (mirror images, or a steering whose "
                            "sign is the other way round): views and replay warp them mirrored (data/sense.py)")


OPTIONS = TubOptions
MANIFEST_LINES = ("record keys", "record types", "metadata", "sessions", "catalog list")
REQUIRED = ("_index", "_timestamp_ms", "cam/image_array", "user/angle")
LANE_FIELDS = {"lane/offset": "lateral_offset", "lane/heading": "heading_error", "lane/curvature": "curvature"}


def is_tub(folder: Path) -> bool:
    return (folder / "manifest.json").is_file() and any(folder.glob("catalog_*.catalog"))


def is_tub_v1(folder: Path) -> bool:
    """donkeycar's tub before 4.0: meta.json and a record_N.json a frame."""
    return (folder / "meta.json").is_file() and any(folder.glob("record_*.json"))


def _json_lines(path: Path, torn: list[int] | None = None) -> list[tuple[int, object]]:
    """(line number, parsed value) for every non-empty line. A broken line is an error naming it, or, given a
    list `torn`, its number is added there; a line with NUL bytes in it counts as torn (its record is kept
    when the rest of the line holds one)."""
    regular_file(path)
    out = []
    with open(path, encoding="utf-8-sig", errors="replace") as f:  # as people save it: a byte-order mark, CRLF
        for n, line in enumerate(f, start=1):
            text = line.strip().strip("\x00").strip()
            if "\x00" in line and torn is not None:
                torn.append(n)
            if not text:
                continue
            try:
                out.append((n, json.loads(text, object_pairs_hook=unique_pairs(path, n))))
            except json.JSONDecodeError as e:
                if torn is None:
                    raise DataError(path, f"broken JSON line ({e.msg} at column {e.colno}): remove the line or fix its "
                                          "JSON", n) from None
                if n not in torn:
                    torn.append(n)
    return out


def _records_lost(lines: list[tuple[int, object]], torn: list[int]) -> int:
    """The records lost at the torn lines of a catalog: each run of them between two records loses the gap in
    `_index` between those records, and at least one record per line it could not read."""
    good = [(n, rec["_index"]) for n, rec in lines if isinstance(rec, dict) and isinstance(rec.get("_index"), int)]
    runs: dict[tuple, int] = {}  # (record before, record after) -> lines not read
    for t in torn:
        before = next((g for g in reversed(good) if g[0] < t), None)
        after = next((g for g in good if g[0] >= t), None)  # a line with NUL bytes may hold a record after them
        runs[before, after] = runs.get((before, after), 0) + int(after is None or after[0] != t)
    return sum(max(unread, after[1] - before[1] - 1 if before and after else 0)
               for (before, after), unread in runs.items())


def _ranges(numbers: list[int]) -> str:
    """[3, 4, 5, 9] -> "3-5, 9"."""
    parts, start = [], None
    for i, n in enumerate(numbers):
        start = n if start is None else start
        if i + 1 == len(numbers) or numbers[i + 1] != n + 1:
            parts.append(str(n) if n == start else f"{start}-{n}")
            start = None
    return ", ".join(parts)


def _lane(recs: list[tuple[Path, int, dict]]) -> dict[str, np.ndarray]:
    """The lane values of the records (path, line, record) under steerlab's names; a record without one, or with
    one that is not a finite number, is an error naming it."""
    out = {name: np.empty(len(recs)) for name in LANE_FIELDS.values()}
    for i, (path, line, rec) in enumerate(recs):
        for key, name in LANE_FIELDS.items():
            value = rec.get(key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise DataError(path, f"record {rec['_index']}: {key} is {value!r}; the manifest declares it, so a "
                                      "finite number is expected", line)
            out[name][i] = value
    return out


def _manifest(folder: Path) -> tuple[list[str], list[str], set[int], dict]:
    path = folder / "manifest.json"
    lines = _json_lines(path)
    if len(lines) < len(MANIFEST_LINES):
        raise DataError(path, f"truncated manifest: {len(lines)} JSON lines, expected {len(MANIFEST_LINES)} "
                              f"({', '.join(MANIFEST_LINES)})")
    keys, catalogs = lines[0][1], lines[4][1]
    if not isinstance(keys, list) or "cam/image_array" not in keys or "user/angle" not in keys:
        raise DataError(path, f"the record keys {keys} lack 'cam/image_array' or 'user/angle': give a "
                              "tub that records both", lines[0][0])
    if not isinstance(catalogs, dict) or not isinstance(catalogs.get("paths"), list) \
            or not all(isinstance(p, str) and p for p in catalogs["paths"]):
        raise DataError(path, "the catalog line lacks 'paths' (the catalog files in order, by name): copy the "
                              "tub again", lines[4][0])
    deleted = catalogs.get("deleted_indexes", [])
    if not isinstance(deleted, list) or not all(_integer(i) for i in deleted):
        raise DataError(path, f"deleted_indexes must be a list of record indexes (integers), got {deleted!r}",
                        lines[4][0])
    metadata = lines[2][1] if isinstance(lines[2][1], dict) else {}
    return keys, catalogs["paths"], set(deleted), metadata


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _lines_cut_off(catalog: Path, read: int) -> int:
    """How many of the lines a catalog's `.catalog_manifest` lists (its `line_lengths`, which add up to the
    catalog's size) lie wholly beyond the catalog's end and were not read (`read`: the lines read from it): records
    lost when a copy or the car cut the catalog off at a line end, which no line shows. A catalog edited by hand
    (shorter values) ends before its lengths say, but every listed line is still read: none lost. 0 without a
    readable catalog manifest."""
    try:
        lengths = json.loads((catalog.parent / f"{catalog.name}_manifest").read_text().splitlines()[0])["line_lengths"]
        starts = np.cumsum([0] + [int(n) for n in lengths])[:-1]
    except (OSError, ValueError, KeyError, TypeError, IndexError):
        return 0
    return min(int(np.sum(starts >= catalog.stat().st_size)), max(len(lengths) - read, 0))


def _in_range(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            and abs(value) <= 1.0 + 1e-6)


def read_tub(folder: str | Path, frame_range=None, full_lock_deg: float | None = None,
             skip_missing: bool = False, strict: bool = False, mirrored: bool = False) -> Recording:
    """Read a tub. `frame_range` ("a:b" as a tuple) counts the records that remain after deletion; `mirrored`: its
    frames are mirror images of its car's world (kept with its lens, `FisheyeCamera.mirrored`)."""
    folder = Path(folder)
    keys, catalogs, deleted, metadata = _manifest(folder)
    records, seen = [], {}  # (catalog, line, record); _index -> (catalog, line)
    torn_at, cut_at, lost = {}, {}, 0  # torn lines and lines cut off at the end by catalog, records lost
    for name in catalogs:
        torn: list[int] = []
        lines = _json_lines(folder / name, torn)
        if torn and strict:
            raise DataError(folder / name, "a torn line (NUL bytes or half a JSON record: the car lost power "
                                           "mid-write?), refused as reader option strict is true (without it, torn "
                                           "lines are read past with a warning): remove the line, or leave strict "
                                           "out", torn[0])
        if torn:
            torn_at[name], lost = torn, lost + _records_lost(lines, torn)
        cut = _lines_cut_off(folder / name, len(lines) + len(set(torn) - {n for n, _ in lines}))
        if cut and strict:
            raise DataError(folder / name, f"the catalog ends {cut} line(s) before its catalog_manifest does (cut off), "
                                           "refused as reader option strict is true: copy the tub again, or leave "
                                           "strict out")
        if cut:
            cut_at[name], lost = cut, lost + cut
        for line, rec in lines:
            if not isinstance(rec, dict) or any(k not in rec for k in REQUIRED):
                raise DataError(folder / name, f"a record needs the keys {', '.join(REQUIRED)}", line)
            bad = next((k for k, ok in (("_index", _integer(rec["_index"])),
                                        ("_timestamp_ms", _integer(rec["_timestamp_ms"])),
                                        ("cam/image_array", isinstance(rec["cam/image_array"], str))) if not ok), None)
            if bad is not None:
                raise DataError(folder / name, f"{bad} is {rec[bad]!r}; "
                                               f"{'a file name' if bad == 'cam/image_array' else 'an integer'} is "
                                               "expected", line)
            if rec["_index"] in seen:  # two frames of one record: which is it?
                first = seen[rec["_index"]]
                raise DataError(folder / name, f"_index {rec['_index']} is given twice (first in {first[0]} row "
                                               f"{first[1]}); a tub numbers each record once: remove one of them",
                                line)
            seen[rec["_index"]] = (name, line)
            if rec["_index"] not in deleted:
                records.append((folder / name, line, rec))
    if torn_at or cut_at:
        where = "; ".join([f"{name} row(s) {_ranges(rows)}" for name, rows in torn_at.items()]
                          + [f"{name}: {n} line(s) cut off at its end" for name, n in cut_at.items()])
        warn_once(f"{folder}: read past torn catalog lines (a car that lost power mid-write?): {where}; {lost} "
                  "record(s) lost (reader option strict: true refuses such a tub)")
    if not records:
        raise DataError(folder, "the tub has no records (all deleted or empty catalogs): record it "
                                "again, or give another tub")
    records = records[apply_range(len(records), frame_range, folder)]
    kept, missing = [], []
    for path, line, rec in records:
        image = folder / "images" / str(rec["cam/image_array"])
        angle = rec["user/angle"]
        for key, value in (("user/angle", angle), ("user/throttle", rec.get("user/throttle"))):
            if not _in_range(value) and (key == "user/angle" or value is not None):
                raise DataError(path, f"record {rec['_index']}: {key} is {value!r}; a number in [-1, 1] is "
                                      "expected", line)
        if not image.is_file():
            if not skip_missing:
                raise DataError(path, f"record {rec['_index']}: image {image} is missing (reader option "
                                      "skip_missing: true leaves such records out): copy it back, or set "
                                      "skip_missing", line)
            missing.append(rec["_index"])
            continue
        kept.append((image, (path, line, rec)))
    if missing:
        warn_once(f"{folder}: skipped {len(missing)} record(s) whose image is missing (indexes "
                  f"{', '.join(map(str, missing[:10]))}{' ...' if len(missing) > 10 else ''})")
    if not kept:
        raise DataError(folder, "no record has its image: copy the tub's images folder with it")
    try:
        convention = SteeringConvention("normalized", "right",
                                        None if full_lock_deg is None else math.radians(float(full_lock_deg)))
    except ValueError as e:
        raise SteerlabError(f"{folder}: reader option full_lock_deg: {e}; give the full-lock angle in degrees, "
                            "e.g. full_lock_deg=25") from None
    said_full_lock(full_lock_deg, f"{folder}: reader option")
    lane = _lane([r for _, r in kept]) if all(k in keys for k in LANE_FIELDS) else {}
    recs = [r for _, (_, _, r) in kept]
    lens = fisheye_from(folder / "manifest.json", metadata["fisheye"]) if "fisheye" in metadata else None
    if mirrored:
        lens = replace(lens or DONKEY_FISHEYE, mirrored=True)
    throttle = np.array([math.nan if r.get("user/throttle") is None else float(r["user/throttle"]) for r in recs])
    return Recording(
        name=folder.name, source=folder, frames={"center": [p for p, _ in kept]},
        timestamps_ns=np.array([int(r["_timestamp_ms"]) * 1_000_000 for r in recs], dtype=np.int64),
        steering=np.array([float(r["user/angle"]) for r in recs]), convention=convention,
        frame_ids=np.array([int(r["_index"]) for r in recs], dtype=np.int64),
        throttle=throttle if np.all(np.isfinite(throttle)) else None,
        extra={"session": np.array([str(r.get("_session_id", "")) for r in recs]), **lane}, geometry="donkey",
        fisheye=lens,
    )


def _read(folder: Path, frame_range=None, **options) -> Recording:
    if is_tub_v1(folder) and not is_tub(folder):
        raise DataError(folder, "a donkeycar tub v1 (meta.json + record_*.json), which steerlab does not read: "
                                "convert it to a tub v2 with donkeycar 4.x's scripts/convert_to_tub_v2.py (this "
                                "folder its tub, a new folder its output), then give the new folder")
    return read_tub(folder, frame_range, **options)


def _near(path: Path) -> None:
    if (path / "manifest.json").is_file() and not any(path.glob("catalog_*.catalog")):
        try:
            listed = ", ".join(_manifest(path)[1])  # the catalogs the manifest names
        except SteerlabError:  # a manifest that cannot be read either: its own error once the catalogs are back
            listed = "catalog_N.catalog"
        raise DataError(path, f"not a recording: a donkeycar tub's manifest.json without its catalogs ({listed}, the "
                              "records, beside it): copy them with the tub")


READER = Reader("donkeycar-tub", "a donkeycar tub (manifest.json + catalogs)",
                lambda path: path.is_dir() and (is_tub(path) or is_tub_v1(path)), _read, OPTIONS, near=_near)
