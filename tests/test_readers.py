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
    ("0,0,0,-40", "column 'speed' is -40; a number of at least 0 (mph) is expected"),
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
