"""Text files read and written one way: the CSV, YAML and JSON files people give steerlab are read as they save
them (UTF-8 with or without a byte-order mark, LF or CRLF line ends, a trailing blank line), anything else is
refused naming the encoding, the file and the row; a CSV header that names a column twice, and a YAML or JSON
mapping that names a key twice, are refused (which of the two would count?); what steerlab writes is valid JSON
(a number that is not finite becomes null, as JSON has no NaN)."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import secrets
import zipfile
from pathlib import Path
from typing import Any

import yaml

from steerlab.errors import DataError, SteerlabError
from steerlab.paths import regular_file

BOMS = {b"\xff\xfe\x00\x00": "UTF-32", b"\x00\x00\xfe\xff": "UTF-32", b"\xff\xfe": "UTF-16", b"\xfe\xff": "UTF-16"}
# files that are not text, by their first bytes: given where a text file is expected, they are named as what they are
BINARY = {b"PK\x03\x04": "a zip archive (a steerlab checkpoint .pt is one)", b"\x89PNG": "a PNG image",
          b"\xff\xd8\xff": "a JPEG image", b"\x1a\x45\xdf\xa3": "a Matroska or WebM video",
          b"\x93NUMPY": "a NumPy array (.npy)"}


def decode(data: bytes, path: str | Path) -> str:
    """The text of a file's bytes: UTF-8, a byte-order mark dropped. Another encoding is a one-line error that
    names it where it can be told (UTF-16 and UTF-32 by their marks), else the first byte that is not UTF-8 and its
    row."""
    for mark, name in BOMS.items():
        if data.startswith(mark):
            raise DataError(path, f"{name} text (its byte-order mark says so); steerlab reads UTF-8: save it as UTF-8")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        row = data[:e.start].count(b"\n") + 1
        try:
            data.decode("cp1252")
            guess = " (Latin-1 or Windows-1252?)"
        except UnicodeDecodeError:
            guess = ""
        raise DataError(path, f"byte 0x{data[e.start]:02x} is not UTF-8 text{guess}; save the file as UTF-8",
                        row) from None


def read_text(path: str | Path, what: str = "file", form: str = "text") -> str:
    """A text file as people save it (see `decode`); line ends stay as they are (the readers split lines)."""
    path = regular_file(Path(path), what)
    data = path.read_bytes()
    kind = next((name for magic, name in BINARY.items() if data.startswith(magic)), None)
    if kind is None and data[4:8] in (b"ftyp", b"moov"):
        kind = "an MP4 or MOV video"
    if kind is not None and kind.startswith("a zip") and _torch_zip(data):
        beside = path.parent / "config.json"
        raise DataError(path, f"a steerlab checkpoint, where the {what} is expected ({form}): give the {what}"
                              + (f", e.g. {beside}, the config its run trained with" if beside.is_file() else ""))
    if kind is not None:
        raise DataError(path, f"{kind}, where the {what} is expected ({form}): give the {what}")
    return decode(data, path)


def _torch_zip(data: bytes) -> bool:
    """Whether a zip archive is what torch.save writes (every steerlab checkpoint): its pickle is data.pkl."""
    try:
        return any(n.endswith("/data.pkl") for n in zipfile.ZipFile(io.BytesIO(data)).namelist())
    except (zipfile.BadZipFile, OSError, ValueError):
        return False


def read_csv(path: str | Path, what: str = "CSV file") -> list[list[str]]:
    """The rows of a CSV file that hold something (blank lines and rows of empty cells left out): LF or CRLF,
    with or without a byte-order mark."""
    text = read_text(path, what)
    body = text.rstrip("\r\n")
    if "\0" in body[:body.rfind("\n") + 1]:  # in the last line, NUL bytes are a torn write the readers read past
        raise DataError(path, "NUL bytes in a line before the last: not text (torn by a crash, or not a CSV file): "
                        "remove the line, or give the CSV file",
                        text[:text.index("\0")].count("\n") + 1)
    return [row for row in csv.reader(io.StringIO(text, newline="")) if row and any(c.strip() for c in row)]


def csv_header(path: str | Path, row: list[str]) -> list[str]:
    """A CSV header's column names, stripped; a name given twice is a one-line error (which column would it
    be?)."""
    names = [h.strip() for h in row]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise DataError(path, f"the header names column(s) {twice} twice; every column needs a name of its own", 1)
    return names


class UniqueKeys(yaml.SafeLoader):
    """YAML's safe loader that refuses a mapping naming a key twice (YAML says keys are unique; PyYAML keeps the
    last silently, dropping the first block) and reads 1e-3 as the number YAML 1.2 says it is (PyYAML's YAML 1.1
    wants 1.0e-3 and reads 1e-3 as text), so that a number written as text ('0.3') is the one refused."""


EXPONENT_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$")  # 1e-3, 2.5E+4
UniqueKeys.add_implicit_resolver("tag:yaml.org,2002:float", EXPONENT_FLOAT, list("-+0123456789."))


def exponents_read(value):
    """`value` (plain values) with every text that YAML 1.1 left a number in exponent form as text ('3e-4') read as
    the number: what runs of earlier versions stored in their config.json before such texts were refused."""
    if isinstance(value, dict):
        return {k: exponents_read(v) for k, v in value.items()}
    if isinstance(value, list):
        return [exponents_read(v) for v in value]
    return float(value.replace("_", "")) if isinstance(value, str) and EXPONENT_FLOAT.match(value) else value


class KeyTwice(yaml.constructor.ConstructorError):
    """A YAML mapping that names a key twice."""


def _mapping(loader: UniqueKeys, node: yaml.MappingNode, deep: bool = False):
    seen = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            if key in seen:
                raise KeyTwice(None, None, f"key {key!r} is given twice (lines {seen[key] + 1} and "
                               f"{key_node.start_mark.line + 1})")
            seen[key] = key_node.start_mark.line
        except TypeError:  # an unhashable key: PyYAML's own error follows
            pass
    return yaml.SafeLoader.construct_mapping(loader, node, deep)


UniqueKeys.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)


def parse_yaml(text: str, where: str | Path) -> Any:
    """YAML text as plain values, keys unique; a one-line error naming `where` and the line."""
    try:
        return yaml.load(text, Loader=UniqueKeys)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        row = (mark.line + 1 if mark is not None else
               text[:e.position].count("\n") + 1 if isinstance(e, yaml.reader.ReaderError) else None)
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        if isinstance(e, KeyTwice):
            raise SteerlabError(f"{where}: not valid YAML: {problem}; keep one") from None
        raise SteerlabError(f"{where}: not valid YAML: {'' if row is None else f'line {row}: '}{problem}; fix it "
                            "(a value holding ': ' or ' #' needs quotes)") from None


def read_yaml(path: str | Path, what: str = "YAML file") -> Any:
    """A YAML file as people save it, keys unique."""
    path = Path(path)
    return parse_yaml(read_text(path, what, "YAML text"), path)


def unique_pairs(path, line: int | None = None):
    """json's `object_pairs_hook` that refuses an object naming a key twice (which json.loads would let the last
    win), naming `path` and its `line`."""
    def hook(pairs):
        keys = [k for k, _ in pairs]
        twice = sorted({k for k in keys if keys.count(k) > 1})
        if twice:
            raise DataError(path, f"the JSON object names key(s) {twice} twice; keep one", line)
        return dict(pairs)
    return hook


def parse_json(text: str, where: str | Path) -> Any:
    """JSON text as plain values: keys unique, no NaN or Infinity (not JSON); a one-line error naming `where`."""
    def constant(name):
        raise DataError(where, f"{name} is not JSON (a number that is not finite); write null")

    try:
        return json.loads(text, object_pairs_hook=unique_pairs(where), parse_constant=constant)
    except json.JSONDecodeError as e:
        raise DataError(where, f"not valid JSON: {e.msg}; fix its JSON", e.lineno) from None


def read_json(path: str | Path, what: str = "JSON file") -> Any:
    """A JSON file as people save it, keys unique."""
    path = Path(path)
    return parse_json(read_text(path, what), path)


def plain(value: Any) -> Any:
    """`value` with every number that is not finite as None (JSON's null), numpy scalars and arrays as plain
    numbers and lists, tuples as lists, paths as text: what `json_text` writes."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # numpy arrays and scalars
        return plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(value: Any, **kw) -> str:
    """Valid JSON of `value` (see `plain`)."""
    return json.dumps(plain(value), allow_nan=False, **kw)


def write_text(path: str | Path, text: str) -> Path:
    """`text` written to `path` through a temporary file renamed when complete: never a half-written file."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}-{secrets.token_hex(4)}")
    try:
        tmp.write_text(text)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def write_json(path: str | Path, value: Any, indent: int | None = 1) -> Path:
    """`value` as valid JSON in `path` (see `json_text`)."""
    return write_text(path, json_text(value, indent=indent) + "\n")
