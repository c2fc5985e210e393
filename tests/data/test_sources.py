"""Readers for donkeycar tubs, ROS bags and videos with a log."""

import json
import math

import cv2
import numpy as np
import pytest

from conftest import SHARED
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import Split, make_split
from steerlab.errors import DataError, SteerlabError
from tests.inputs import write_tub

TUBS = SHARED / "donkeycar"
needs_tubs = pytest.mark.skipif(not (TUBS / "hall" / "manifest.json").exists(), reason="../shared/data absent")


# ---------------------------------------------------------------- donkeycar tubs

@needs_tubs
def test_real_tub_hall():
    rec = open_recording(TUBS / "hall")
    assert len(rec) == 5015 and rec.geometry == "donkey"
    assert rec.convention == SteeringConvention("normalized", "right")
    assert np.abs(rec.steering).max() <= 1.0 and 0.5 < np.mean(rec.steering == 0) < 0.6
    assert len(rec.segments()) == 3  # one session with two gaps longer than 0.5 s
    assert rec.load_frame(0).shape == (120, 160, 3)
    assert math.isnan(rec.convention.degrees_per_unit)


@needs_tubs
def test_real_tub_wood_tape():
    """A third car's tub (../shared/data's README): 8,000 records of one session with one gap longer than 0.5 s, the
    steering in steps of 0.1 from -0.3 to 0.4 with float noise (3.7 % exactly 0), the throttle at 12 levels from
    0.25 to 0.8, 0.35 and 0.45 the most common: read as written, nothing rounded."""
    rec = open_recording(TUBS / "wood-tape")
    assert len(rec) == 8000 and rec.geometry == "donkey" and len(rec.segments()) == 2
    assert rec.convention == SteeringConvention("normalized", "right")
    steps = np.round(rec.steering * 10)
    np.testing.assert_array_equal(np.unique(steps), np.arange(-3, 5))
    assert 0 < np.abs(rec.steering - steps / 10).max() < 1e-12  # the noise is kept (0.10000000000000003)
    assert np.mean(rec.steering == 0) == pytest.approx(0.03675)
    levels, counts = np.unique(rec.throttle, return_counts=True)
    np.testing.assert_allclose(levels, np.arange(25, 81, 5) / 100)
    assert list(levels[np.argsort(-counts)[:2]]) == pytest.approx([0.35, 0.45])
    assert rec.load_frame(7999).shape == (120, 160, 3) and rec.fisheye is None


@needs_tubs
def test_real_tub_with_missing_images(capsys):
    with pytest.raises(DataError, match=r"catalog_0.catalog, row 1: record 10000: image .*10000_cam_image_array_"
                                        r".jpg is missing .*skip_missing"):
        open_recording(TUBS / "taped-track")
    rec = open_recording(TUBS / "taped-track", options={"skip_missing": True, "full_lock_deg": 25})
    assert len(rec) == 3078 - 2
    assert "skipped 2 record(s)" in capsys.readouterr().err
    assert rec.convention.degrees_per_unit == pytest.approx(25.0)


def test_tub_deletions_sessions_and_split(tmp_path):
    records = [(i, "a" if i < 4 else "b", 1000 + 50 * i, 0.1 * (i % 3)) for i in range(8)]
    rec = open_recording(write_tub(tmp_path / "tub", records, deleted=[2, 6]))
    assert list(rec.frame_ids) == [0, 1, 3, 4, 5, 7]
    assert list(rec.timestamps_ns) == [(1000 + 50 * i) * 1_000_000 for i in (0, 1, 3, 4, 5, 7)]
    assert rec.segments() == [(0, 3), (3, 6)]  # the session change starts a segment although no gap
    train, val = make_split(Split.parse_option({"train": {"sessions": ["a"]}, "val": {"sessions": ["b"]}}, "split"), len(rec),
                            rec.extra["session"])
    assert list(train) == [0, 1, 2] and list(val) == [3, 4, 5]
    with pytest.raises(SteerlabError, match=r"val sessions \['c'\] are not in the recording; it has a, b"):
        make_split(Split.parse_option({"train": {"sessions": ["a"]}, "val": {"sessions": ["c"]}}, "split"), len(rec),
                   rec.extra["session"])
    with pytest.raises(SteerlabError, match="has no sessions"):
        make_split(Split.parse_option({"train": {"sessions": ["a"]}, "val": "0:2"}, "split"), len(rec), None)


def test_tub_bad_input(tmp_path):
    records = [(i, "a", 1000 + 50 * i, 0.0) for i in range(3)]
    with pytest.raises(DataError, match=r"manifest.json: truncated manifest: 3 JSON lines, expected 5"):
        open_recording(write_tub(tmp_path / "t1", records, manifest_lines=3))
    tub = write_tub(tmp_path / "t2", records)
    lines = (tub / "catalog_0.catalog").read_text().splitlines()
    (tub / "catalog_0.catalog").write_text("\n".join([lines[0], lines[1][:40], lines[2]]) + "\n")
    with pytest.raises(DataError, match=r"catalog_0.catalog, row 2: a torn line"):
        open_recording(tub, options={"strict": True})
    assert list(open_recording(tub).frame_ids) == [0, 2]  # read past by default, with a warning
    tub = write_tub(tmp_path / "t3", [(0, "a", 1000, 0.0), (1, "a", 1050, float("nan"))])
    with pytest.raises(DataError, match=r"row 2: record 1: user/angle is nan; a number in \[-1, 1\]"):
        open_recording(tub)
    with pytest.raises(SteerlabError, match="full_lock_deg"):
        open_recording(write_tub(tmp_path / "t4", records), options={"full_lock_deg": 120})


def test_normalized_convention():
    conv = SteeringConvention("normalized", "right", math.radians(30))
    assert conv.to_road_wheel_left(0.5, 14.8) == pytest.approx(-math.radians(15))
    assert conv.from_road_wheel_left(math.radians(15), 14.8) == pytest.approx(-0.5)
    with pytest.raises(SteerlabError, match="full-lock angle"):
        SteeringConvention("normalized", "right").to_road_wheel_left(0.5, 14.8)
    with pytest.raises(ValueError):
        SteeringConvention("road_wheel", "left", 0.3)  # a full lock belongs to normalized steering


# ---------------------------------------------------------------- video + log

def write_video(path, n, size=(64, 48)):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, size)
    for i in range(n):
        img = np.zeros((size[1], size[0], 3), np.uint8)
        img[:, : 4 * (i + 1)] = 200  # a bar that grows by 4 px per frame
        writer.write(img)
    writer.release()


def bar_width(img):
    return int((img[img.shape[0] // 2, :, 1] > 100).sum())


def test_video_with_log(tmp_path):
    write_video(tmp_path / "drive.avi", 10)
    rows = ["timestamp,steering,speed"] + [f"{0.05 * i:.2f},{0.01 * i},{5 + i}" for i in range(10)]
    (tmp_path / "drive.csv").write_text("\n".join(rows) + "\n")
    rec = open_recording(tmp_path / "drive.avi", "2:9")
    assert len(rec) == 7 and rec.steering[0] == pytest.approx(0.02) and rec.speed[-1] == 13
    assert list(np.diff(rec.timestamps_ns)) == [50_000_000] * 6
    order = [3, 0, 1, 6, 2]  # jumps seek, runs decode in order
    assert [bar_width(rec.load_frame(i)) for i in order] == [4 * (i + 3) for i in order]


def test_video_frame_column_and_bad_logs(tmp_path):
    write_video(tmp_path / "drive.avi", 6)
    log = tmp_path / "labels.csv"
    log.write_text("frame,steering\n1,0.1\n3,0.2\n5,0.3\n")
    rec = open_recording(tmp_path / "drive.avi", options={"log": str(log)})
    assert [bar_width(rec.load_frame(i)) for i in range(3)] == [8, 16, 24]
    assert list(rec.timestamps_ns) == [50_000_000, 150_000_000, 250_000_000]
    log.write_text("frame,steering\n1,0.1\n7,0.2\n")
    with pytest.raises(DataError, match=r"labels video frame 7 but drive.avi has only 6 frames \(2 too few\)"):
        open_recording(tmp_path / "drive.avi", options={"log": str(log)})
    log.write_text("timestamp,steering\n" + "".join(f"{i},0.0\n" for i in range(8)))
    with pytest.raises(DataError, match=r"the log has 8 rows but drive.avi has 6 frames \(2 more rows than frames\)"):
        open_recording(tmp_path / "drive.avi", options={"log": str(log)})
    log.write_text("time,angle\n0,0\n")
    with pytest.raises(DataError, match="expected 'steering' and one of 'timestamp_ns'"):
        open_recording(tmp_path / "drive.avi", options={"log": str(log)})
    with pytest.raises(DataError, match=r"drive.csv: the log of video drive.avi is missing"):
        open_recording(tmp_path / "drive.avi")


# ---------------------------------------------------------------- ROS bags

def write_bag(path, ros2=False, steering_topic="/vehicle/steering_report"):
    """Three centre frames at 1.00/1.05/1.10 s (bar widths 4/8/12 px) and a left frame; steering reports at
    1.01/1.06/1.11 s with angles 0, 0.1, 0.2 and speeds 5, 6, 7 m/s (header stamps)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import Writer as Writer2
    from steerlab.data.bag import STEERING_REPORT_TYPE, typestore

    ts = typestore()
    header, stamp = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    image, report = ts.types["sensor_msgs/msg/CompressedImage"], ts.types[STEERING_REPORT_TYPE]
    serialize = ts.serialize_cdr if ros2 else ts.serialize_ros1

    def hdr(ns):
        return header(stamp(ns // 10**9, ns % 10**9), "base")

    def jpeg(width):
        img = np.zeros((48, 64, 3), np.uint8)
        img[:, :width] = 200
        return np.frombuffer(cv2.imencode(".jpg", img)[1].tobytes(), np.uint8)

    with (Writer2(path, version=9) if ros2 else Writer1(path)) as w:
        center = w.add_connection("/center_camera/image_color/compressed", "sensor_msgs/msg/CompressedImage",
                                  typestore=ts)
        left = w.add_connection("/left_camera/image_color/compressed", "sensor_msgs/msg/CompressedImage",
                                typestore=ts)
        steer = w.add_connection(steering_topic, STEERING_REPORT_TYPE, typestore=ts)
        for i in range(3):
            t = 1_000_000_000 + 50_000_000 * i
            w.write(center, t, serialize(image(hdr(t), "jpeg", jpeg(4 * (i + 1))), "sensor_msgs/msg/CompressedImage"))
            if i == 1:
                w.write(left, t + 2_000_000, serialize(image(hdr(t + 2_000_000), "jpeg", jpeg(40)),
                                                       "sensor_msgs/msg/CompressedImage"))
            w.write(steer, t + 10_000_000, serialize(
                report(hdr(t + 10_000_000), 0.1 * i, 0.0, 0.0, 5.0 + i, *[False] * 8), STEERING_REPORT_TYPE))
    return path


@pytest.mark.parametrize("ros2", [False, True])
def test_bag_interpolates_like_udacity(tmp_path, monkeypatch, ros2):
    monkeypatch.setenv("STEERLAB_CACHE", str(tmp_path / "cache"))
    bag = write_bag(tmp_path / ("drive" if ros2 else "drive.bag"), ros2)
    rec = open_recording(bag)
    # frame 1.00 s: before the first report -> 0; 1.05 s: 4/5 of the way from 0 (1.01 s) to 0.1 (1.06 s);
    # 1.10 s: 4/5 of the way from 0.1 to 0.2
    assert rec.steering == pytest.approx([0.0, 0.08, 0.18])
    assert rec.speed == pytest.approx([0.0, 5.8, 6.8])
    assert rec.convention == SteeringConvention("steering_wheel", "left")
    assert [bar_width(rec.load_frame(i)) for i in range(3)] == [4, 8, 12]
    assert [bar_width(rec.load_frame(i, "left")) for i in range(3)] == [40, 40, 40]
    again = open_recording(bag, "1:3")  # from the extracted frames
    assert again.steering == pytest.approx([0.08, 0.18])
    assert len(list((tmp_path / "cache" / "bags").iterdir())) == 1
    configured = open_recording(bag, cache=tmp_path / "mine")  # a config's cache: the one cache root
    assert configured.frames["center"][0].is_relative_to(tmp_path / "mine" / "bags")


def test_bag_without_the_topics(tmp_path, monkeypatch):
    monkeypatch.setenv("STEERLAB_CACHE", str(tmp_path / "cache"))
    bag = write_bag(tmp_path / "drive.bag", steering_topic="/can/steering")
    with pytest.raises(DataError, match=r"no steering topic '/vehicle/steering_report'; the bag has the topics "
                                        r"/can/steering, /center_camera/image_color/compressed, /left_camera"):
        open_recording(bag)
    rec = open_recording(bag, options={"topics": {"steering": "/can/steering"}})
    assert len(rec) == 3
    assert not list((tmp_path / "cache" / "bags").glob(".*"))  # the failed extraction left nothing behind


def test_train_and_evaluate_on_a_tub_split_by_session(tmp_path, capsys):
    from steerlab.checkpoint import load_checkpoint
    from steerlab.cli import main
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    records = [(i, "s1" if i < 30 else "s2", 1000 + 50 * i, 0.5 * np.sin(i / 5)) for i in range(45)]
    tub = write_tub(tmp_path / "tub", records)
    best = train(load_config(None, base={
        "data": str(tub), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "run"),
        "split": {"train": {"sessions": ["s1"]}, "val": {"sessions": ["s2"]}},
        "model": {"name": "pilotnet"}, "train": {"epochs": 1, "batch_size": 8}}), progress=False)
    assert best["frames"] == 15 and math.isnan(best["mae_deg"]) and best["mae"] > 0
    ckpt = load_checkpoint(tmp_path / "run" / "best.pt")
    assert ckpt["convention"] == {"kind": "normalized", "positive": "right"} and ckpt["geometry"] == "donkey"
    assert main(["evaluate", str(tmp_path / "run" / "best.pt"), "--data", str(tub), "--range", "30:45",
                 "--reader", "full_lock_deg=25", "--out", str(tmp_path / "eval")]) == 0
    metrics = json.loads((tmp_path / "eval" / "metrics.json").read_text())
    assert metrics["mae_deg"] == pytest.approx(25 * metrics["mae"])
    assert main(["evaluate", str(tmp_path / "run" / "best.pt"), "--data", str(tub), "--reader", "log=x.csv",
                 "--out", str(tmp_path / "eval")]) == 2
    assert "unknown reader option(s) ['log']; this recording's reader (donkeycar-tub) takes full_lock_deg, skip_missing" in \
        capsys.readouterr().err
