"""Recordings that cannot be right: recorded values outside their physical range, torn lines (read past with
one warning, unless the reader is strict), fields of the wrong type, frames of another size or that are no image,
a recording too short or without what a command needs; a damaged cache entry is compiled again and a damaged
catalog read past, the loss said."""

import json

import cv2
import numpy as np
import pytest

from steerlab.cli import main
from steerlab import errors
from steerlab.errors import SteerlabError
from tests.bad_input.builders import (_compile, _damaged, _renamed_column, _tub_replay, _tune_space, _with, config,
                                      refused_in_one_line, tear)
from tests.inputs import ROWS, ch2, made, sim_log, tub, write_jpeg


def _renamed(catalog, key, other):
    """The first record of a tub catalog with `key` named `other` (as long: the manifest's line lengths hold)."""
    lines = catalog.read_text().splitlines(keepends=True)
    lines[0] = lines[0].replace(f'"{key}"', f'"{other}"')
    catalog.write_text("".join(lines))
    return catalog.parent


def _flat_ch2_replay(tmp_path, stack):
    """5 s of CH2-layout frames of one grey (no speed recorded, no texture to estimate it from), no --speed."""
    (tmp_path / "flat" / "center").mkdir(parents=True)
    ids = [1_000_000_000 + i * 50_000_000 for i in range(100)]
    for fid in ids:
        cv2.imwrite(str(tmp_path / "flat" / "center" / f"{fid}.jpg"), np.full((480, 640, 3), 90, np.uint8))
    (tmp_path / "flat" / "labels.csv").write_text("frame_id,steering_angle,public\n"
                                                  + "".join(f"{fid},0.0,1\n" for fid in ids))
    return ["replay", str(made(tmp_path, "steering_wheel", "left", "ch2")), "--data", str(tmp_path / "flat"),
            "--labels", str(tmp_path / "flat" / "labels.csv"), "--out", str(tmp_path / "out")]


def _corrupt_frame_replay(tmp_path, stack):
    """The flat CH2 frames with one JPEG cut off in the middle of the drive, at a given speed."""
    argv = _flat_ch2_replay(tmp_path, stack)
    frame = sorted((tmp_path / "flat" / "center").glob("*.jpg"))[50]
    frame.write_bytes(frame.read_bytes()[:300])
    return [*argv, "--speed", "10"]


def _corrupt_frame(command):
    """`steerlab COMMAND` of a config whose driving log has one frame that is no image."""
    def build(tmp_path, stack):
        cfg = config(tmp_path, sim_log(tmp_path / "sim"))
        sorted((tmp_path / "sim" / "IMG").glob("*.jpg"))[3].write_text("garbage")
        if command == "experiment":
            cfg.write_text(cfg.read_text() + "models:\n  - {model: {name: pilotnet}}\n")
        return [command, str(cfg)]
    return build


def _tub_manifest(deleted):
    """A tub whose manifest's deleted_indexes is `deleted` (strings, null, not a list...)."""
    def data(t):
        folder = tub(t / "tub")
        lines = (folder / "manifest.json").read_text().splitlines()
        catalog = json.loads(lines[4])
        catalog["deleted_indexes"] = deleted
        lines[4] = json.dumps(catalog)
        (folder / "manifest.json").write_text("\n".join(lines) + "\n")
        return folder
    return data


def _ch2_with_odd_frame(size):
    """A CH2 folder whose fourth frame is of another size than the recording's."""
    def build(tmp_path, stack):
        folder = ch2(tmp_path / "ch2")
        write_jpeg(sorted((folder / "center").glob("*.jpg"))[3], 10, size)
        return ["compile", "--data", str(folder), "--cache", str(tmp_path / "cache")]
    return build


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    # a) recorded values outside their physical range, with file and row
    "sim steering 3.5": (_compile(lambda t: sim_log(t / "sim", {2: "3.5,0.5,0,10"})),
                         "driving_log.csv, row 3: column 'steering' is 3.5; a number in [-1, 1] is expected"),
    "sim steering -7": (_compile(lambda t: sim_log(t / "sim", {0: "-7,0.5,0,10"})),
                        "driving_log.csv, row 1: column 'steering' is -7; a number in [-1, 1]"),
    "sim speed -40": (_compile(lambda t: sim_log(t / "sim", {4: "0,0.5,0,-40"})),
                      "row 5: column 'speed' is -40; a number in [0, 101] (mph, as the simulator records it; not "
                      "km/h) is expected"),
    "sim speed 110 (km/h)": (_compile(lambda t: sim_log(t / "sim", {4: "0,0.5,0,110"})),
                             "row 5: column 'speed' is 110; a number in [0, 101] (mph"),
    "sim throttle 7": (_compile(lambda t: sim_log(t / "sim", {1: "0,7,0,10"})),
                       "row 2: column 'throttle' is 7; a number in [0, 1] is expected"),
    "tub angle 1.5": (_compile(lambda t: tub(t / "tub", {3: {"user/angle": 1.5}})),
                      "catalog_0.catalog, row 4: record 3: user/angle is 1.5; a number in [-1, 1] is expected"),
    "tub _index twice": (_compile(lambda t: tub(t / "tub", {4: {"_index": 2}})),
                         "catalog_0.catalog, row 5: _index 2 is given twice (first in catalog_0.catalog row 3); a "
                         "tub numbers each record once"),
    "tub without its catalogs": (_compile(lambda t: _without_catalogs(tub(t / "tub"))),
                                 "tub: not a recording: a donkeycar tub's manifest.json without its catalogs "
                                 "(catalog_0.catalog, the records, beside it)"),
    "tub throttle 7": (_compile(lambda t: tub(t / "tub", {5: {"user/throttle": 7}})),
                       "catalog_0.catalog, row 6: record 5: user/throttle is 7; a number in [-1, 1]"),
    # b) torn lines: read past with a warning, unless the reader is strict; a bad middle line stays an error
    "tub torn line, strict": (_compile(lambda t: (tear(tub(t / "tub") / "catalog_0.catalog", 4, "\0" * 60 + "\n"),
                                                  t / "tub")[1], "strict=true"),
                              "catalog_0.catalog, row 4: a torn line"),
    "sim torn last line, strict": (_compile(lambda t: (tear(sim_log(t / "sim"), ROWS, "/elsewhere/IMG/cen"),
                                                       t / "sim")[1], "strict=true"),
                                   f"driving_log.csv, row {ROWS}: expected at least 7 columns"),
    "sim torn middle line": (_compile(lambda t: (tear(sim_log(t / "sim"), 3, "/elsewhere/IMG/cen\n"),
                                                 t / "sim")[1]),
                             "driving_log.csv, row 3: expected at least 7 columns"),
    # m) every option and every file field checked where it enters (no traceback)
    "tub deleted_indexes of text": (_compile(_tub_manifest(["3", "x"])),
                                    "manifest.json, row 5: deleted_indexes must be a list of record indexes"),
    "tub deleted_indexes null": (_compile(_tub_manifest([None])), "deleted_indexes must be a list of record indexes"),
    "tub deleted_indexes not a list": (_compile(_tub_manifest(5)),
                                       "deleted_indexes must be a list of record indexes (integers), got 5"),
    "tub _index of text": (_compile(lambda t: tub(t / "tub", {2: {"_index": "two"}})),
                           "catalog_0.catalog, row 3: _index is 'two'; an integer is expected"),
    "tub record with a misnamed column": (
        _compile(lambda t: _renamed(tub(t / "tub") / "catalog_0.catalog", "user/angle", "user/angel")),
        "catalog_0.catalog, row 1: a record needs the keys _index, _timestamp_ms, cam/image_array, user/angle"),
    # n) what cannot be right is refused, never used
    "compile a CH2 frame of 1280x960 among 640x480": (_ch2_with_odd_frame((960, 1280)),
                                                      ".jpg: the frame is 960x1280 (height x width); the "
                                                      "recording's frames are 480x640 (frame 3)", ("cache/",)),
    "compile a CH2 frame of 400x480": (_ch2_with_odd_frame((480, 400)), "the frame is 480x400 (height x width); the recording's",
                                       ("cache/",)),
    "compile a recording whose log names a column otherwise": (
        _compile(_renamed_column), "log.csv, row 1: header lacks columns ['steering']; expected frame,timestamp_ns,"),
    "compile a CH2 frame of 1x1": (_ch2_with_odd_frame((1, 1)), ".jpg: the frame is 1x1 (height x width); the recording's frames",
                                   ("cache/",)),
    # j) closed-loop replay of a recording
    "replay too short": (_with(command="replay"), "driving_log.csv: too short to replay: no segment lasts 3 s"),
    "replay no speed to estimate": (_flat_ch2_replay, "cannot estimate the speed from the frames"),
    "replay corrupt frame": (_corrupt_frame_replay, ".jpg: cannot decode image (corrupt or not a JPEG/PNG)"),
    "train corrupt frame": (_corrupt_frame("train"), "_300.jpg: cannot decode image (corrupt or not a JPEG/PNG)",
                            ("run/", "cache/")),  # the run's config, written before the data is compiled
    "experiment corrupt frame": (_corrupt_frame("experiment"),
                                 "_300.jpg: cannot decode image (corrupt or not a JPEG/PNG)", ("run/", "cache/")),
    "replay a tub without throttle": (_tub_replay(records={i: {"user/throttle": None} for i in range(ROWS)}),
                                      "tub: records no throttle to take the speed from: give one with steerlab "
                                      "replay --speed M/S"),
    "replay a tub whose fisheye is no camera": (_tub_replay(metadata={"fisheye": {"fx": -1.0}}),
                                                "manifest.json: the fisheye camera: a fisheye camera needs an image "
                                                "of at least 2x2 px and positive focal lengths"),
    # i) a study's journal this worker cannot write
    # bad data stops the study at its first trial, naming the file and row (not "no complete trial" after many)
    "tune on a driving log with a bad row": (
        lambda t, s: _tune_space({"train.lr": {"low": 1.0e-5, "high": 0.1, "log": True}})(t, s, rows={3: "x,0.5,0,10"}),
        "driving_log.csv, row 4: ", ("run/", "cache/", "s.journal")),
    "a label file whose time goes back": (
        _compile(lambda t: (tear(ch2(t / "ch2") / "labels.csv", 4, "1020000000,0.0,0\n"), t / "ch2")[1]),
        "labels.csv, row 4: the time goes back (1020000000 ns after 1050000000 ns in the row before)"),
    # j) views of a tub refused before any frame is compiled or the run folder made
    "views of a tub whose steering has no full lock": (
        lambda t, s: ["train", str(config(t, tub(t / "tub"), views=[[0.1, 0]])), "model.name=donkey-linear"],
        "train.views of a small car rebuild its path from the steering: normalized steering needs the car's "
        "full-lock angle"),
    "views of a tub through a calibration of another size": (
        lambda t, s: ["train", str(config(t, tub(t / "tub"), views=[[0.1, 0]], calibration=str(_calibration(t)))),
                      "model.name=donkey-linear", "reader.full_lock_deg=25"],
        "calib.yaml: calibrated at 640x480, but the camera takes 160x120 frames"),
}


def _without_catalogs(folder):
    for f in folder.glob("catalog_*"):
        f.unlink()
    return folder


def _calibration(tmp_path):
    path = tmp_path / "calib.yaml"
    path.write_text("image_size: [640, 480]\nK: [[320, 0, 319], [0, 320, 239], [0, 0, 1]]\nD: [0, 0, 0, 0]\n")
    return path


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


# ---------------------------------------------------------------- what is read past, with a warning

def test_torn_tub_lines_are_read_past_with_one_warning(tmp_path, capsys):
    folder = tub(tmp_path / "tub")
    catalog = folder / "catalog_0.catalog"
    lines = catalog.read_text().splitlines(keepends=True)
    # power lost after record 2: NULs where records 3 and 4 were, then record 5 after them on the same line;
    # record 6 written half; 7 intact
    lines[3:7] = ["\0" * 300 + lines[5], lines[6][:50] + "\n"]
    catalog.write_text("".join(lines))
    assert main(["compile", "--data", str(folder), "--cache", str(tmp_path / "cache")]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"{ROWS - 3} frames")
    warning = [line for line in captured.err.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1, captured.err
    assert "read past torn catalog lines" in warning[0] and "catalog_0.catalog row(s) 4-5" in warning[0]
    assert "3 record(s) lost" in warning[0] and "strict: true" in warning[0]


def test_what_a_reader_reads_past_is_said_once_however_often_the_recording_is_read(tmp_path, capsys):
    from steerlab.data.readers import open_recording

    folder = tub(tmp_path / "tub")
    (folder / "images" / "3_cam_image_array_.jpg").unlink()
    for _ in range(2):  # a command reads its recording more than once (its checks, then its frames)
        assert len(open_recording(folder, options={"skip_missing": True})) == ROWS - 1
    assert main(["compile", "--data", str(folder), "--reader", "skip_missing=true",
                 "--cache", str(tmp_path / "cache")]) == 0
    warning = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert warning == [f"warning: {folder}: skipped 1 record(s) whose image is missing (indexes 3)"]


def test_torn_last_line_of_a_driving_log_is_read_past(tmp_path, capsys):
    from steerlab.data.readers import open_recording

    log = sim_log(tmp_path / "sim")
    tear(log, ROWS, f"/elsewhere/IMG/center_2020_01_01_00_00_00_{100 * (ROWS - 1):03d}.jpg,,,0.1,0.")  # no line end
    rec = open_recording(log)
    assert len(rec) == ROWS - 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"driving_log.csv: row {ROWS} is torn" in err and "1 record lost" in err
    tear(log, ROWS, "\0" * 40 + "\n")  # NUL bytes, even with a line end
    assert len(open_recording(log)) == ROWS - 1
    tear(log, ROWS, f"/elsewhere/IMG/center_2020_01_01_00_00_00_{100 * (ROWS - 1):03d}.jpg,,,0.1,0.5,0,10")
    assert len(open_recording(log)) == ROWS  # a whole last line without a line end is a line


def test_a_damaged_cache_entry_is_said_and_compiled_again(tmp_path, capsys):
    from steerlab.data.dataset import compile_recording
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.readers import open_recording

    rec, cfg = open_recording(sim_log(tmp_path / "sim")), PreprocessConfig.from_dict({"preset": "sim"})
    ds = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    image = np.array(ds.arrays["image"])
    for name in ("image.npy", "labels.npz", "meta.json"):
        data = (ds.path / name).read_bytes()
        for what, bad in list(_damaged(data))[::3]:
            (ds.path / name).write_bytes(bad)
            capsys.readouterr()
            again = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
            err = capsys.readouterr().err
            assert "is damaged" in err and "compiling it again" in err, (name, what, err)
            np.testing.assert_array_equal(again.arrays["image"], image)
    compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    assert "damaged" not in capsys.readouterr().err


def test_a_damaged_tub_catalog_is_read_past_with_the_loss_said(tmp_path, capsys):
    from steerlab.data.readers import open_recording

    folder = tub(tmp_path / "tub")
    catalog = folder / "catalog_0.catalog"
    data = catalog.read_bytes()
    for what, bad in _damaged(data):
        catalog.write_bytes(bad)
        capsys.readouterr()
        errors._SAID.clear()  # each damage read as a fresh process reads it (a loss is said once a process)
        try:
            rec = open_recording(folder)
        except SteerlabError as e:  # nothing left to read, or a record a flip made wrong: said in one line
            assert str(e).startswith(str(folder)) and "\n" not in str(e), (what, str(e))
            continue
        err = capsys.readouterr().err
        assert len(rec) == ROWS or ("record(s) lost" in err or "read past torn" in err), (what, err)
