import math

import numpy as np
import pytest

from steerlab.data.readers import open_recording
from steerlab.errors import DataError

from conftest import CH2, SIM, needs_ch2, needs_sim, write_jpeg


@needs_ch2
def test_ch2_real_folder_with_range():
    rec = open_recording(CH2, "0:2400")
    assert len(rec) == 2400
    assert rec.segments() == [(0, 2400)]
    assert rec.frame_rate() == pytest.approx(20.0, abs=0.05)
    assert rec.frames["center"][0].name == f"{rec.frame_ids[0]}.jpg"
    assert rec.convention.kind == "steering_wheel" and rec.convention.positive == "left"
    assert rec.steering[0] == pytest.approx(-0.0169280299332)
    assert rec.load_frame(0).shape == (480, 640, 3)


@needs_ch2
def test_ch2_without_range_names_first_missing_image():
    with pytest.raises(DataError) as e:
        open_recording(CH2)
    assert "1479425561203529002.jpg is missing" in str(e.value)
    assert "row 2402" in str(e.value)


@needs_sim
def test_sim_log_real():
    rec = open_recording(SIM)
    assert len(rec) == 1459
    assert rec.cameras == ["center", "left", "right"]
    assert rec.segments()[0] == (0, 900)
    assert len(rec.segments()) == 8
    assert rec.speed[0] == pytest.approx(2.471481 * 0.44704)
    assert rec.frames["left"][0].parent == SIM / "IMG"
    assert rec.convention.kind == "road_wheel" and rec.convention.positive == "right"
    assert np.abs(rec.steering).max() <= math.radians(25) + 1e-12
    assert rec.frame_rate() == pytest.approx(14, abs=1)
    assert rec.load_frame(10, "right").shape == (160, 320, 3)


def _sim_log(tmp_path, rows, header=False):
    img = tmp_path / "IMG"
    img.mkdir(exist_ok=True)
    lines = ["center,left,right,steering,throttle,brake,speed"] if header else []
    for i, extra in enumerate(rows):
        name = f"center_2020_01_01_00_00_00_{100 * i:03d}.jpg"
        write_jpeg(img / name)
        lines.append(f"/elsewhere/IMG/{name},,,{extra}")
    (tmp_path / "driving_log.csv").write_text("\n".join(lines) + "\n")
    return tmp_path / "driving_log.csv"


def test_sim_log_header_and_extra_columns(tmp_path):
    log = _sim_log(tmp_path, ["0.5,0.2,0,10,junk,more", "-1,0,0.1,20"], header=True)
    rec = open_recording(log)
    assert rec.cameras == ["center"]
    np.testing.assert_allclose(rec.steering, np.radians([12.5, -25]))
    np.testing.assert_allclose(rec.speed, [4.4704, 8.9408])
    assert rec.timestamps_ns[1] - rec.timestamps_ns[0] == 100_000_000


@pytest.mark.parametrize("row, message", [
    ("abc,0,0,10", "column 'steering' must be a number"),
    ("nan,0,0,10", "column 'steering' is 'nan'"),
    ("0,0", "expected at least 7 columns"),
    ("3.5,0,0,10", "column 'steering' is 3.5; a number in [-1, 1] is expected"),
    ("0,0,0,-40", "column 'speed' is -40; a number in [0, 101] (mph, as the simulator records it; not km/h)"),
    ("0,0,0,101", "column 'speed' is 101; a number in [0, 101] (mph"),  # 45.2 m/s: beyond the car's 45
])
def test_sim_log_bad_rows(tmp_path, row, message):
    log = _sim_log(tmp_path, ["0,0,0,10", row])
    with pytest.raises(DataError) as e:
        open_recording(log)
    assert message in str(e.value) and "row 2" in str(e.value)


def test_ch2_bad_inputs(ch2_folder):
    labels = ch2_folder / "labels.csv"
    rec = open_recording(ch2_folder, labels=labels)
    assert len(rec) == 6
    # corrupt (truncated) JPEG
    p = rec.frames["center"][2]
    p.write_bytes(p.read_bytes()[:300])
    with pytest.raises(DataError, match="cannot decode image"):
        open_recording(ch2_folder, labels=labels).load_frame(2)
    # missing image
    rec.frames["center"][3].unlink()
    with pytest.raises(DataError, match=r"row 5: image .* is missing"):
        open_recording(ch2_folder, labels=labels)


@pytest.mark.parametrize("content, message", [
    ("frame,angle\n1,0\n", "unknown columns"),
    ("frame_id,steering_angle\n1000000000,0.1\n1000000000,0.2\n", "row 3: duplicate frame id"),
    ("frame_id,steering_angle\n1000000000,NaN\n", "row 2: column 'steering_angle' is 'NaN'"),
    ("frame_id,steering_angle\n", "no labelled frames"),
    ("frame_id,steering_angle\nabc,0.1\n", "frame_id must be an integer"),
])
def test_ch2_bad_label_files(ch2_folder, content, message):
    (ch2_folder / "labels.csv").write_text(content)
    with pytest.raises(DataError, match=message):
        open_recording(ch2_folder, labels=ch2_folder / "labels.csv")


def test_missing_recording_and_bad_range(tmp_path, ch2_folder):
    with pytest.raises(DataError, match="recording not found"):
        open_recording(tmp_path / "nope")
    with pytest.raises(DataError, match="outside"):
        open_recording(ch2_folder, "0:99", labels=ch2_folder / "labels.csv")


def test_ch2_interpolated_layout_with_side_cameras(tmp_path):
    lines = ["index,timestamp,width,height,frame_id,filename,angle,torque,speed,lat,long,alt"]
    for cam in ("center", "left", "right"):
        (tmp_path / cam).mkdir()
    k = 0
    for i in range(4):
        for j, cam in enumerate(("left", "center", "right")):
            ts = 1_000_000_000 + i * 50_000_000 + (j - 1) * 3_000_000  # side cameras a few ms apart
            write_jpeg(tmp_path / cam / f"{ts}.jpg")
            lines.append(f"{k},{ts},640,480,{cam}_camera,{cam}/{ts}.jpg,{0.1 * i},0.0,{5 + i},37.4,-122.1,0")
            k += 1
    (tmp_path / "interpolated.csv").write_text("\n".join(lines) + "\n")
    rec = open_recording(tmp_path)
    assert len(rec) == 4 and rec.cameras == ["center", "left", "right"]
    np.testing.assert_allclose(rec.steering, [0, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(rec.speed, [5, 6, 7, 8])
    assert rec.frames["left"][2].name == f"{1_000_000_000 + 100_000_000 - 3_000_000}.jpg"
    assert rec.frames["center"][2].name == f"{rec.frame_ids[2]}.jpg"


def test_a_reader_of_ones_own_is_one_registration(tmp_path, monkeypatch):
    """A toy layout (a folder with toy.txt: one grey value a line, the steering its tenth) registered as the
    registry says: detected, its options typed, named in "not a recording", read like any other."""
    from dataclasses import dataclass

    import cv2

    from steerlab.data import readers
    from steerlab.data.recording import Recording, SteeringConvention
    from steerlab.data.rows import Reader
    from steerlab.errors import SteerlabError
    from steerlab.options import Options, Range, option

    @dataclass(frozen=True)
    class ToyOptions(Options):
        gain: float = option(1.0, Range(0, 10))

    def read_toy(folder, frame_range=None, gain=1.0):
        values = [int(v) for v in (folder / "toy.txt").read_text().split()]
        frames = []
        for i, v in enumerate(values):
            cv2.imwrite(str(folder / f"{i}.png"), np.full((4, 4, 3), v, np.uint8))
            frames.append(folder / f"{i}.png")
        return Recording(name=folder.name, source=folder, frames={"center": frames},
                         timestamps_ns=np.arange(len(values), dtype=np.int64) * 50_000_000,
                         steering=gain * np.array(values) / 10, convention=SteeringConvention("road_wheel", "left"),
                         frame_ids=np.arange(len(values)))

    monkeypatch.setattr(readers, "READERS", list(readers.READERS))
    toy = readers.register(Reader("toy", "a toy folder (toy.txt)", lambda p: (p / "toy.txt").is_file(), read_toy,
                                  ToyOptions))
    with pytest.raises(SteerlabError, match="a reader named 'toy' is registered already"):
        readers.register(toy)
    folder = tmp_path / "toy"
    folder.mkdir()
    (folder / "toy.txt").write_text("1\n2\n3\n")
    rec = open_recording(folder, options={"gain": 2.0})
    assert len(rec) == 3 and list(rec.steering) == [0.2, 0.4, 0.6]
    with pytest.raises(DataError, match=r"reader.gain must be a number in \[0, 10\]"):
        open_recording(folder, options={"gain": 11})
    with pytest.raises(DataError, match=r"unknown reader option\(s\) \['strict'\]; this recording's reader \(toy\) "
                                        r"takes gain"):
        open_recording(folder, options={"strict": True})
    (tmp_path / "nothing").mkdir()
    with pytest.raises(DataError, match=r"not a recording: expected a steerlab recording \(recording.json\), .* or a "
                                        r"toy folder \(toy.txt\)$"):
        open_recording(tmp_path / "nothing")


def test_a_donkeycar_tub_v1_is_refused_with_the_command_that_converts_it(tmp_path):
    folder = tmp_path / "tub_1_20-01-01"
    folder.mkdir()
    (folder / "meta.json").write_text('{"inputs": ["cam/image_array", "user/angle"], "types": ["image_array", "float"]}')
    (folder / "record_0.json").write_text('{"cam/image_array": "0_cam-image_array_.jpg", "user/angle": 0.1}')
    with pytest.raises(DataError, match=r"tub_1_20-01-01: a donkeycar tub v1 \(meta.json \+ record_\*.json\), which "
                                        r"steerlab does not read: convert it to a tub v2 with donkeycar 4.x's "
                                        r"scripts/convert_to_tub_v2.py"):
        open_recording(folder)


def test_the_docs_name_every_registered_reader_in_the_registrys_order():
    from pathlib import Path

    from steerlab.data.readers import READERS

    page = (Path(__file__).parents[2] / "docs" / "architecture" / "other-recordings.md").read_text()
    listed = " ".join(page.split("tried in this order: ")[1].split(". ")[0].split())
    assert listed == ", ".join(f"`{r.name}`" for r in READERS)


def _tub(folder, n=6):
    from steerlab.data.writer import TubWriter

    w = TubWriter(folder, full_lock_deg=25)
    for i in range(n):
        w.add(np.full((120, 160, 3), 20 * i, np.uint8), i * 50_000_000, 0.01 * i, 0.3)
    return w.close()


def test_a_tub_is_read_as_people_save_it_a_bom_crlf_and_hand_edited_values(tmp_path, capsys):
    tub = _tub(tmp_path / "tub")
    plain = open_recording(tub)
    manifest = tub / "manifest.json"
    manifest.write_bytes(b"\xef\xbb\xbf" + manifest.read_bytes().replace(b"\n", b"\r\n"))
    catalog = tub / "catalog_0.catalog"
    catalog.write_bytes(b"\xef\xbb\xbf" + catalog.read_bytes().replace(b"\n", b"\r\n"))
    again = open_recording(tub)
    np.testing.assert_array_equal(again.steering, plain.steering)
    # values shortened by hand: the catalog ends before its catalog_manifest's line lengths say, all records read
    catalog.write_text(catalog.read_text(encoding="utf-8-sig").replace('"user/mode": "user", ', ""))
    capsys.readouterr()
    edited = open_recording(tub)
    assert len(edited) == 6 and capsys.readouterr().err == ""
    # a record cut off at the end is still counted lost
    lines = catalog.read_text().splitlines(keepends=True)
    catalog.write_text("".join(lines[:-1]))
    assert len(open_recording(tub)) == 5 and "1 line(s) cut off at its end; 1 record(s) lost" in capsys.readouterr().err


def test_a_record_naming_a_key_twice_is_refused_naming_its_line(tmp_path):
    tub = _tub(tmp_path / "tub")
    catalog = tub / "catalog_0.catalog"
    lines = catalog.read_text().splitlines(keepends=True)
    lines[3] = lines[3].replace('"user/angle": ', '"user/angle": 0.5, "user/angle": ')
    catalog.write_text("".join(lines))
    with pytest.raises(DataError, match=r"catalog_0.catalog, row 4: the JSON object names key\(s\) \['user/angle'\] "
                                        r"twice; keep one"):
        open_recording(tub)
