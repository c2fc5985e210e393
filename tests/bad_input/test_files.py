"""Rule 3, files as people save them: every text file a user gives (the readers' CSV files, the score's, a
config, a calibration) is read the same with a byte-order mark, CRLF or trailing blank lines, and refused naming
the file otherwise (another encoding, a key or column twice, NUL bytes, another kind of file); what steerlab writes
is valid JSON."""

import json
from pathlib import Path

import pytest

from steerlab.cli import main
from steerlab.errors import SteerlabError
from tests.bad_input.builders import _compile, _renamed_column, _track, _tub_replay, config, refused_in_one_line, tear
from tests.inputs import ch2, made, sim_log, write_jpeg

CALIBRATION = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
               "D": [-0.02, -0.01, 0.0, 0.005]}


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    "a Latin-1 byte in a config": (lambda t, s: (t / "c.yaml").write_bytes(b"# caf\xe9\n")
                                   and ["train", str(t / "c.yaml")],
                                   "c.yaml, row 1: byte 0xe9 is not UTF-8 text"),
    "a key twice in a config": (lambda t, s: (config(t, sim_log(t / "sim")).open("a").write("train: {epochs: 3}\n"),
                                              ["train", str(t / "c.yaml")])[1],
                                "c.yaml: not valid YAML: key 'train' is given twice (lines 5 and 6); keep one"),
    "a label file that names a column twice": (
        _compile(lambda t: (tear(ch2(t / "ch2") / "labels.csv", 1, "frame_id,steering_angle,steering_angle\n"),
                            t / "ch2")[1]),
        "labels.csv, row 1: the header names column(s) ['steering_angle'] twice"),
    "replay calibration that does not parse": (_tub_replay(calibration="{not json"),
                                               "calib.json, row 1: not valid JSON"),
    "replay calibration of another image size": (
        _tub_replay(calibration={**CALIBRATION, "image_size": [640, 480]}),
        "calib.json: calibrated at 640x480, but the camera takes 160x120 frames"),
    "track calibration that does not parse": (_track("drive", calibration="{not json"),
                                              "calib.json, row 1: not valid JSON"),
    "track calibration of another image size": (
        _track("bench", calibration={**CALIBRATION, "image_size": [640, 480]}),
        "calib.json: calibrated at 640x480, but the camera takes 160x120 frames"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


def _resaved(path):
    """A copy of the file's bytes in another form: with a byte-order mark, CRLF, trailing blank lines; or in UTF-16,
    with a Latin-1 byte, with its first column named twice, with NUL bytes; or another file altogether (a
    checkpoint, an image)."""
    data = path.read_bytes()
    return {"bom": b"\xef\xbb\xbf" + data, "crlf": data.replace(b"\n", b"\r\n"),
            "bom+crlf": b"\xef\xbb\xbf" + data.replace(b"\n", b"\r\n"), "blank lines": data + b"\n\n\n",
            "utf-16": data.decode().encode("utf-16"), "latin-1": data.replace(b"\n", b" \xe9\n", 2),
            "column twice": data.replace(b",", b"," + data.split(b",")[0] + b",", 1),
            "NUL bytes": data.replace(b"\n", b"\0\n", 2), "a checkpoint": made(path.parent, name=".x.pt").read_bytes(),
            "a JPEG image": _jpeg_bytes(path.parent / ".x.jpg")}


def _jpeg_bytes(path: Path) -> bytes:
    write_jpeg(path, 100, (32, 32))
    return path.read_bytes()


def rule3_cases():
    """(file, variant, taken): every text file a user gives (the readers' CSV files, the score's, a config, a
    calibration), saved the ways people save them (taken) or otherwise (refused naming the file)."""
    taken = ("bom", "crlf", "bom+crlf", "blank lines")
    out = []
    for file in ("ch2 labels", "driving log", "native log", "answer file", "config", "calibration"):
        for variant in (*taken, "utf-16", "latin-1", "column twice", "NUL bytes", "a checkpoint", "a JPEG image"):
            if variant == "column twice" and file in ("driving log", "config", "calibration"):
                continue
            out.append((file, variant, variant in taken))
    return out + [("config", "key twice", False), ("calibration", "key twice", False),
                  ("calibration", "NaN", False)]


def _rule3_input(tmp_path, file):
    """(the file, what reads it) for a file of rule3_cases."""
    from steerlab.data.fisheye import load_calibration
    from steerlab.data.readers import open_recording
    from steerlab.evaluate.scoring import score
    from steerlab.train.config import load_config

    if file == "ch2 labels":
        d = ch2(tmp_path / "ch2")
        return d / "labels.csv", lambda: len(open_recording(d, labels=d / "labels.csv"))
    if file == "driving log":
        log = sim_log(tmp_path / "sim")
        return log, lambda: len(open_recording(log))
    if file == "native log":
        d = _renamed_column(tmp_path)
        (d / "log.csv").write_text((d / "log.csv").read_text().replace(",steer,", ",steering,", 1))
        return d / "log.csv", lambda: len(open_recording(d))
    if file == "answer file":
        d = ch2(tmp_path / "ch2")
        return d / "labels.csv", lambda: score(d / "labels.csv", d / "labels.csv")["frames"]
    if file == "config":
        cfg = config(tmp_path, sim_log(tmp_path / "sim"))
        return cfg, lambda: load_config(cfg).train.epochs
    path = tmp_path / "calib.yaml"
    path.write_text("image_size: [160, 120]\nK: [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]]\n"
                    "D: [-0.02, -0.01, 0.0, 0.005]\n")
    return path, lambda: load_calibration(path).fx


@pytest.mark.parametrize("file, variant, taken", rule3_cases(), ids=str)
def test_rule3_files_as_people_save_them(file, variant, taken, tmp_path):
    path, read = _rule3_input(tmp_path, file)
    original = read()
    if variant == "key twice":
        path.write_text(path.read_text() + ("train: {epochs: 2}\n" if file == "config" else "D: [0, 0, 0, 0]\n"))
    elif variant == "NaN":  # a calibration in JSON, with a number JSON does not have
        from steerlab.data.fisheye import load_calibration

        path = tmp_path / "calib.json"
        path.write_text('{"image_size": [160, 120], "K": [[81, 0, 80], [0, 80, 61], [0, 0, 1]], "D": [NaN, 0, 0, 0]}')
        read = lambda: load_calibration(path)  # noqa: E731
    else:
        path.write_bytes(_resaved(path)[variant])
    if taken:
        assert read() == original
        return
    with pytest.raises(SteerlabError) as e:
        read()
    assert str(path) in str(e.value) and "\n" not in str(e.value), str(e.value)
    said = {"a checkpoint": "a steerlab checkpoint, where the", "a JPEG image":
            "a JPEG image, where the"}.get(variant, "")
    assert said in str(e.value), str(e.value)


def test_rule3_what_steerlab_writes_is_valid_json(tmp_path):
    """A metric that is not a number (one frame has no gamma) is null in metrics.json, never NaN."""
    assert main(["evaluate", str(made(tmp_path)), "--data", str(sim_log(tmp_path / "sim")), "--range", "0:1",
                 "--out", str(tmp_path / "eval")]) == 0
    text = (tmp_path / "eval" / "metrics.json").read_text()
    metrics = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in metrics.json"))
    assert metrics["gamma_deg"] is None
