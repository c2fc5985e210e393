"""A Recording is one drive: ordered camera frames, nanosecond timestamps and signals in SI units."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from steerlab.options import Range
from steerlab.errors import DataError, SteerlabError, warn, warn_once

if TYPE_CHECKING:
    from steerlab.data.fisheye import FisheyeCamera

KINDS = ("steering_wheel", "road_wheel", "normalized")

SEGMENT_GAP_NS = 500_000_000  # a gap longer than 0.5 s between frames, or a new session, starts a new segment


FULL_LOCK_DEG = Range(0, 90, lo_open=True, hi_open=True, unit="degrees")  # a car's largest road-wheel angle
PLAUSIBLE_FULL_LOCK_DEG = 5.0  # cars and RC cars turn their wheels 15-35 degrees at full lock


def said_full_lock(deg: float | None, where: str, once: bool = True) -> None:
    """A full-lock angle below PLAUSIBLE_FULL_LOCK_DEG is said (`once`: the first time in the process only, as a
    reader's option is read again with every opening): radians where degrees are expected, most likely. Call it
    with a valid angle (after the convention that holds it is made)."""
    message = (f"{where}: full_lock_deg={float(deg):g}: a car's wheels turn {PLAUSIBLE_FULL_LOCK_DEG:g} degrees or "
               "more at full lock; radians where degrees are expected? (math.degrees converts)") if deg is not None \
        and float(deg) < PLAUSIBLE_FULL_LOCK_DEG else None
    if message:
        (warn_once if once else warn)(message)


@dataclass(frozen=True)
class SteeringConvention:
    """What the steering column of a recording means.

    kind: "steering_wheel" (angle of the hand wheel, radians, as in Udacity CH2), "road_wheel" (angle of the
    tyres, radians) or "normalized" (the servo command in [-1, 1] of an RC car, as in donkeycar tubs;
    `full_lock` is the road-wheel angle of +-1 in radians when it is known).
    positive: "left" (counter-clockwise) or "right".
    """

    kind: str = "steering_wheel"
    positive: str = "left"
    full_lock: float | None = None

    def __post_init__(self):
        if self.kind not in KINDS or self.positive not in ("left", "right"):
            raise ValueError(f"bad steering convention {self.kind!r}/{self.positive!r}")
        if self.full_lock is not None and (self.kind != "normalized" or not 0 < self.full_lock < math.pi / 2):
            raise ValueError(f"a full-lock angle belongs to normalized steering and lies in (0, 90) degrees, "
                             f"got {math.degrees(self.full_lock):.4g} degrees for {self.kind!r}")

    def _road_wheel_scale(self, steering_ratio: float) -> float:
        """Road-wheel radians per unit of this convention."""
        if self.kind == "normalized":
            if self.full_lock is None:
                raise SteerlabError("normalized steering needs the car's full-lock angle to become an angle "
                                    "(reader option full_lock_deg)")
            return self.full_lock
        return 1.0 / steering_ratio if self.kind == "steering_wheel" else 1.0

    def to_road_wheel_left(self, value, steering_ratio: float):
        """Convert to a road-wheel angle in radians, positive left (the vehicle model's convention)."""
        sign = 1.0 if self.positive == "left" else -1.0
        return sign * self._road_wheel_scale(steering_ratio) * value

    def from_road_wheel_left(self, value, steering_ratio: float):
        sign = 1.0 if self.positive == "left" else -1.0
        return sign * value / self._road_wheel_scale(steering_ratio)

    def convert(self, values, target: SteeringConvention, steering_ratio: float, target_ratio: float | None = None):
        """Values of this convention in the `target` convention, through the road-wheel angle (`steering_ratio`
        of this side's car, `target_ratio` of the target's, the same car by default); raises SteerlabError when
        one of them is normalized steering without a full-lock angle."""
        road_wheel = self.to_road_wheel_left(values, steering_ratio)
        return target.from_road_wheel_left(road_wheel, steering_ratio if target_ratio is None else target_ratio)

    def matches(self, other: SteeringConvention) -> bool:
        """Whether values of both conventions are in the same units and sign (a full-lock angle that only one
        side knows does not count as a difference)."""
        locks = (self.full_lock, other.full_lock)
        return ((self.kind, self.positive) == (other.kind, other.positive)
                and (None in locks or math.isclose(*locks, rel_tol=1e-6)))

    def describe(self) -> str:
        """As messages name it: kind/positive side (and the full-lock angle)."""
        lock = "" if self.full_lock is None else f" (full lock {math.degrees(self.full_lock):g} deg)"
        return f"{self.kind}/{self.positive}{lock}"

    @property
    def degrees_per_unit(self) -> float:
        """Degrees (of the wheel this convention measures) per unit of its values; NaN when unknown."""
        if self.kind != "normalized":
            return math.degrees(1.0)
        return math.nan if self.full_lock is None else math.degrees(self.full_lock)

    @property
    def unit(self) -> str:
        return "normalized" if self.kind == "normalized" else "rad"

    def as_dict(self) -> dict:
        d = {"kind": self.kind, "positive": self.positive}
        if self.full_lock is not None:
            d["full_lock"] = self.full_lock
        return d


PLAUSIBLE_LOCKS = 2.0  # steering beyond twice the car's full lock is no car's: another unit


@dataclass
class Recording:
    """One drive.

    frames: camera name -> list of image paths, one per frame, in time order ("center" always present); for a
        video recording every entry is the video file and `video` decodes the frames.
    timestamps_ns: int64 capture times, strictly increasing.
    steering: float64, in `convention` (radians, or [-1, 1] for normalized steering).
    speed, throttle, brake: optional float64 arrays (m/s, 0..1, 0..1); NaN-free.
    extra: further per-frame columns (e.g. the road world's lateral offset and episode label).
    frame_ids: the ids a predictions file uses (CH2: the nanosecond file name; otherwise the timestamp).
    fisheye: the fisheye camera the frames were taken with, when the recording says (the track world's do).
    """

    name: str
    source: Path
    frames: dict[str, list[Path]]
    timestamps_ns: np.ndarray
    steering: np.ndarray
    convention: SteeringConvention
    frame_ids: np.ndarray
    speed: np.ndarray | None = None
    throttle: np.ndarray | None = None
    brake: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    geometry: str = "ch2"  # camera geometry (data/geometry.CAMERAS); the crop preset of the same name fits it
    video: "VideoFrames | None" = None  # frames decoded from one video file instead of image files
    fisheye: "FisheyeCamera | None" = None

    def __post_init__(self):
        n = len(self.timestamps_ns)
        if n == 0:
            raise DataError(self.source, "the recording is empty (no frames): record it again, or give another "
                                          "recording")
        if "center" not in self.frames:
            raise DataError(self.source, "the recording has no 'center' camera: name its frames' camera center")
        for cam, paths in self.frames.items():
            if len(paths) != n:
                raise DataError(self.source, f"camera {cam!r} has {len(paths)} frames, expected {n}")
        for name, arr in self._signals().items():
            if len(arr) != n:
                raise DataError(self.source, f"signal {name!r} has {len(arr)} values, expected {n}")
        if np.any(np.diff(self.timestamps_ns) <= 0):
            i = int(np.argmax(np.diff(self.timestamps_ns) <= 0)) + 1
            raise DataError(self.source, f"timestamps must increase: frame {i} (id {self.frame_ids[i]}) is at "
                                         f"{self.timestamps_ns[i]} ns, not after frame {i - 1} at "
                                         f"{self.timestamps_ns[i - 1]} ns; sort the frames by time, or remove the "
                                         "repeated ones")
        self._check_steering()

    def _check_steering(self) -> None:
        """Steering no car can give is refused: beyond PLAUSIBLE_LOCKS times the full lock of the recording's car
        (a column in degrees read as radians, say), naming the first such frame."""
        from steerlab.data.car import CARS, car_of

        car = car_of(self.geometry if self.geometry in CARS else None)
        if self.convention.kind == "normalized":
            lock, unit = 1.0, "1, normalized"
        else:
            lock = car.full_lock if self.convention.kind == "road_wheel" else car.full_lock * car.steering_ratio
            unit = f"{lock:.3g} rad of the {self.convention.kind.replace('_', '-')} angle"
        beyond = np.flatnonzero(np.abs(self.steering) > PLAUSIBLE_LOCKS * lock)  # NaN is no number the readers take
        if len(beyond):
            i = int(beyond[0])
            raise DataError(self.source, f"frame {i} (id {self.frame_ids[i]}): steering {self.steering[i]:g} is "
                                         f"{abs(self.steering[i]) / lock:.1f} times the car's full lock ({unit}): no "
                                         "car steers so far; convert the column to that unit (is it in degrees?)")

    def _signals(self) -> dict[str, np.ndarray]:
        out = {"steering": self.steering, "frame_ids": self.frame_ids}
        for name in ("speed", "throttle", "brake"):
            if getattr(self, name) is not None:
                out[name] = getattr(self, name)
        out.update(self.extra)
        return out

    def __len__(self) -> int:
        return len(self.timestamps_ns)

    @property
    def cameras(self) -> list[str]:
        return list(self.frames)

    def segment_ids(self) -> np.ndarray:
        """Segment index per frame: a new segment starts after every gap longer than 0.5 s and with every new
        session (`extra["session"]`, e.g. the drives of a donkeycar tub)."""
        gaps = np.diff(self.timestamps_ns) > SEGMENT_GAP_NS
        if "session" in self.extra:
            gaps |= self.extra["session"][1:] != self.extra["session"][:-1]
        return np.concatenate([[0], np.cumsum(gaps)]).astype(np.int32)

    def segments(self) -> list[tuple[int, int]]:
        """Half-open frame ranges [start, stop) of the segments."""
        seg = self.segment_ids()
        starts = np.flatnonzero(np.diff(seg, prepend=-1))
        stops = np.append(starts[1:], len(seg))
        return [(int(a), int(b)) for a, b in zip(starts, stops)]

    def frame_rate(self) -> float:
        """Median frames per second."""
        if len(self) < 2:
            return 20.0
        return float(1e9 / np.median(np.diff(self.timestamps_ns)))

    def load_frame(self, index: int, camera: str = "center") -> np.ndarray:
        """Decode one frame as a BGR uint8 array (OpenCV order)."""
        if self.video is not None:
            return self.video.read(index)
        return read_image(self.frames[camera][index])


class VideoFrames:
    """Lazy, thread-safe access to the frames of a video file: frame `positions[i]` of the video is the
    recording's frame i. Reading in order decodes each frame once; a jump seeks."""

    def __init__(self, path: Path, positions: np.ndarray):
        self.path, self.positions = Path(path), np.asarray(positions, dtype=np.int64)
        self._local = threading.local()

    def read(self, index: int) -> np.ndarray:
        local = self._local
        if getattr(local, "capture", None) is None:
            local.capture, local.next = cv2.VideoCapture(str(self.path)), 0
        target = int(self.positions[index])
        if target != local.next:
            local.capture.set(cv2.CAP_PROP_POS_FRAMES, target)
        ok, frame = local.capture.read()
        if not ok or frame is None:
            local.capture = None
            raise DataError(self.path, f"cannot decode video frame {target}: copy the video again, or give a "
                                           "frame range that stops before it")
        local.next = target + 1
        return frame


def read_image(path: Path) -> np.ndarray:
    """Read an image file into a BGR uint8 array, with a clear error for missing or corrupt files."""
    data = np.fromfile(path, dtype=np.uint8) if Path(path).is_file() else None
    if data is None:
        raise DataError(path, "image file not found: copy it back, or give a frame range without it")
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if image is None or _truncated_jpeg(data):
        raise DataError(path, "cannot decode image (corrupt or not a JPEG/PNG): copy it again, or give a "
                              "frame range without it")
    return image


def _truncated_jpeg(data: np.ndarray) -> bool:
    """A JPEG must end with its end-of-image marker (FF D9); OpenCV decodes cut-off files without complaint."""
    if data.size < 4 or data[0] != 0xFF or data[1] != 0xD8:
        return False
    tail = data[-64:].tobytes()
    return b"\xff\xd9" not in tail
