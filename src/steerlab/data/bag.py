"""ROS bags as Udacity released its real-car data, read with `rosbags` (pure Python, no ROS install).

A ROS 1 `.bag` file or a ROS 2 bag folder (`metadata.yaml` + storage files). By default the camera frames are
the compressed images on `/center_camera/image_color/compressed` (and `/left_camera/...`, `/right_camera/...`
when present), the steering and the speed come from `/vehicle/steering_report` (dbw_mkz_msgs/SteeringReport:
`steering_wheel_angle` in radians, positive left, and `speed` in m/s). Topics are reader options
(`topics: {center: ..., steering: ...}`).

On first use the compressed frames are written, byte for byte, as `<cache>/bags/<bag>-<key>/<camera>/<ns>.jpg`
with the header stamps in an index; later opens read only the index. The steering and the speed are
interpolated to each camera frame's header stamp as Udacity's `interpolated.csv` was made (udacity-driving-
reader's bagdump): linearly in time between reports, the last report's value after the last report, and 0
before the first one. Side-camera frames are matched to the nearest centre frame in time.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.data.cache import cache_root
from steerlab.data.ch2 import CH2_CONVENTION
from steerlab.data.rows import Reader, apply_range, check_unique, nearest
from steerlab.data.recording import Recording
from steerlab.errors import DataError, SteerlabError
from steerlab.options import Options, option



TOPICS = {
    "center": "/center_camera/image_color/compressed",
    "left": "/left_camera/image_color/compressed",
    "right": "/right_camera/image_color/compressed",
    "steering": "/vehicle/steering_report",
}


def _topic_names(topics) -> bool:
    return all(isinstance(k, str) and k in TOPICS and isinstance(v, str) and v for k, v in topics.items())


@dataclass(frozen=True)
class BagOptions(Options):
    """A bag's reader options."""

    topics: dict | None = option(None, _topic_names, "a mapping of center, left, right or steering to topic names",
                                 help="the bag's topics of the cameras and the steering report, where they differ "
                                      "from Udacity's")


OPTIONS = BagOptions
# dbw_mkz_msgs/SteeringReport as recorded in the Udacity datasets: used for ROS 2 bags that carry no message
# definitions (ROS 1 bags always carry their own).
STEERING_REPORT = """std_msgs/Header header
float32 steering_wheel_angle
float32 steering_wheel_angle_cmd
float32 steering_wheel_torque
float32 speed
bool enabled
bool override
bool driver
bool fault_wdc
bool fault_bus1
bool fault_bus2
bool fault_calibration
bool fault_connector
"""
STEERING_REPORT_TYPE = "dbw_mkz_msgs/msg/SteeringReport"


def is_bag(path: Path) -> bool:
    return (path.is_file() and path.suffix == ".bag") or (path.is_dir() and (path / "metadata.yaml").is_file())


def typestore():
    """ROS 2 Humble's standard messages plus dbw_mkz_msgs/SteeringReport."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(STEERING_REPORT, STEERING_REPORT_TYPE))
    return store


def read_bag(path: str | Path, frame_range=None, topics: dict | None = None, cache: str | Path | None = None) -> Recording:
    path = Path(path)
    if not isinstance(topics or {}, dict) or set(topics or {}) - set(TOPICS):
        raise DataError(path, f"reader option topics must map some of {', '.join(TOPICS)} to topic names, "
                              f"got {topics!r}")
    topics = {**TOPICS, **(topics or {})}
    folder, index = _extract(path, topics, cache_root(cache))
    cams = {cam: np.array(index["cameras"][cam], dtype=object) for cam in ("center", "left", "right")
            if index["cameras"].get(cam)}
    center = cams["center"]
    stamps = center[:, 0].astype(np.int64)
    order = np.argsort(stamps, kind="stable")
    center, stamps = center[order], stamps[order]
    check_unique(stamps, path, 1)
    report = np.array(index["steering"], dtype=np.float64).reshape(-1, 3)
    report = report[np.argsort(report[:, 0], kind="stable")]
    angle = np.interp(stamps, report[:, 0], report[:, 1], left=0.0)
    speed = np.interp(stamps, report[:, 0], report[:, 2], left=0.0)
    frames = {"center": [folder / f for f in center[:, 1]]}
    for cam in ("left", "right"):
        if cam in cams:  # the side frame nearest in time to each centre frame
            side = cams[cam][np.argsort(cams[cam][:, 0].astype(np.int64), kind="stable")]
            frames[cam] = [folder / f for f in side[nearest(side[:, 0].astype(np.int64), stamps), 1]]
    cut = apply_range(len(stamps), frame_range, path)
    return Recording(
        name=path.stem, source=path, frames={c: p[cut] for c, p in frames.items()}, timestamps_ns=stamps[cut],
        steering=angle[cut], convention=CH2_CONVENTION, frame_ids=stamps[cut], speed=speed[cut], geometry="ch2",
    )


def _extract(path: Path, topics: dict, cache: Path) -> tuple[Path, dict]:
    """Write the frames of the camera topics to the cache once; return the folder and its index (stamps and
    files per camera, steering reports)."""
    st = os.stat(path / "metadata.yaml" if path.is_dir() else path)
    key = hashlib.sha1(json.dumps([str(path.resolve()), st.st_size, st.st_mtime_ns, topics]).encode()).hexdigest()
    folder = cache / "bags" / f"{path.stem}-{key[:16]}"
    if (folder / "index.json").exists():
        return folder, json.loads((folder / "index.json").read_text())
    try:
        from rosbags.highlevel import AnyReader, AnyReaderError
    except ImportError:
        raise SteerlabError("reading ROS bags needs the rosbags package: pip install rosbags") from None
    tmp = folder.with_name(f".{folder.name}.tmp-{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    cameras = {cam: [] for cam in ("center", "left", "right")}
    reports = []
    try:
        with AnyReader([path], default_typestore=typestore()) as reader:
            have = sorted({c.topic for c in reader.connections})
            for role in ("center", "steering"):
                if topics[role] not in have:
                    raise DataError(path, f"no {role} topic {topics[role]!r}; the bag has the topics "
                                          f"{', '.join(have) or '(none)'} (set reader option topics)")
            role_of = {topics[r]: r for r in TOPICS}
            conns = [c for c in reader.connections if c.topic in role_of]
            for cam in cameras:
                (tmp / cam).mkdir(parents=True, exist_ok=True)
            for conn, bag_ns, raw in tqdm(reader.messages(connections=conns), total=sum(c.msgcount for c in conns),
                                          desc=f"extract {path.name}", unit="msg", disable=None):
                msg = reader.deserialize(raw, conn.msgtype)
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec or bag_ns
                role = role_of[conn.topic]
                if role == "steering":
                    reports.append([stamp, float(msg.steering_wheel_angle), float(msg.speed)])
                else:
                    name = f"{role}/{stamp}.{'png' if 'png' in msg.format else 'jpg'}"
                    (tmp / name).write_bytes(np.asarray(msg.data, dtype=np.uint8).tobytes())
                    cameras[role].append([stamp, name])
    except (AnyReaderError, OSError, KeyError, AttributeError) as e:
        shutil.rmtree(tmp, ignore_errors=True)
        raise DataError(path, f"cannot read this bag ({e.__class__.__name__}: {e}): copy it again if it was cut off, "
                              "or give another bag") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if not cameras["center"] or not reports:
        shutil.rmtree(tmp, ignore_errors=True)
        raise DataError(path, f"no messages on {topics['center'] if not cameras['center'] else topics['steering']}: "
                              "name the bag's topics with the reader option topics")
    index = {"cameras": cameras, "steering": reports}
    (tmp / "index.json").write_text(json.dumps(index))
    try:
        tmp.rename(folder)
    except OSError:
        if not (folder / "index.json").exists():
            raise
        shutil.rmtree(tmp)  # another process extracted the same bag first
    return folder, index


READER = Reader("ros-bag", "a ROS bag (.bag, or a ROS 2 folder with metadata.yaml)", is_bag, read_bag, OPTIONS,
                cache=True)
