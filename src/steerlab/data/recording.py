"""A Recording is one drive: ordered camera frames, nanosecond timestamps and signals in SI units."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from steerlab.errors import DataError

SEGMENT_GAP_NS = 500_000_000  # a gap longer than 0.5 s between frames starts a new segment


@dataclass(frozen=True)
class SteeringConvention:
    """What the steering column of a recording means.

    kind: "steering_wheel" (angle of the hand wheel, as in Udacity CH2) or "road_wheel" (angle of the tyres).
    positive: "left" (counter-clockwise) or "right".
    Values are always radians.
    """

    kind: str = "steering_wheel"
    positive: str = "left"

    def __post_init__(self):
        if self.kind not in ("steering_wheel", "road_wheel") or self.positive not in ("left", "right"):
            raise ValueError(f"bad steering convention {self.kind!r}/{self.positive!r}")

    def to_road_wheel_left(self, value, steering_ratio: float):
        """Convert to a road-wheel angle in radians, positive left (the vehicle model's convention)."""
        sign = 1.0 if self.positive == "left" else -1.0
        scale = 1.0 / steering_ratio if self.kind == "steering_wheel" else 1.0
        return sign * scale * value

    def from_road_wheel_left(self, value, steering_ratio: float):
        sign = 1.0 if self.positive == "left" else -1.0
        scale = steering_ratio if self.kind == "steering_wheel" else 1.0
        return sign * scale * value

    def as_dict(self) -> dict:
        return {"kind": self.kind, "positive": self.positive}


@dataclass
class Recording:
    """One drive.

    frames: camera name -> list of image paths, one per frame, in time order ("center" always present).
    timestamps_ns: int64 capture times, strictly increasing.
    steering: float64 radians, in `convention`.
    speed, throttle, brake: optional float64 arrays (m/s, 0..1, 0..1); NaN-free.
    extra: further per-frame columns (e.g. the synthetic world's lateral offset and episode label).
    frame_ids: the ids a predictions file uses (CH2: the nanosecond file name; otherwise the timestamp).
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
    preset: str = "ch2"  # preprocessing preset that fits this camera geometry

    def __post_init__(self):
        n = len(self.timestamps_ns)
        if n == 0:
            raise DataError(self.source, "the recording is empty (no frames)")
        if "center" not in self.frames:
            raise DataError(self.source, "the recording has no 'center' camera")
        for cam, paths in self.frames.items():
            if len(paths) != n:
                raise DataError(self.source, f"camera {cam!r} has {len(paths)} frames, expected {n}")
        for name, arr in self._signals().items():
            if len(arr) != n:
                raise DataError(self.source, f"signal {name!r} has {len(arr)} values, expected {n}")
        if np.any(np.diff(self.timestamps_ns) <= 0):
            i = int(np.argmax(np.diff(self.timestamps_ns) <= 0)) + 1
            raise DataError(self.source, f"timestamps must increase; frame {i} ({self.frame_ids[i]}) does not")

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
        """Segment index per frame: a new segment starts after every gap longer than 0.5 s."""
        gaps = np.diff(self.timestamps_ns) > SEGMENT_GAP_NS
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
        return read_image(self.frames[camera][index])


def read_image(path: Path) -> np.ndarray:
    """Read an image file into a BGR uint8 array, with a clear error for missing or corrupt files."""
    data = np.fromfile(path, dtype=np.uint8) if Path(path).is_file() else None
    if data is None:
        raise DataError(path, "image file not found")
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if image is None or _truncated_jpeg(data):
        raise DataError(path, "cannot decode image (corrupt or not a JPEG/PNG)")
    return image


def _truncated_jpeg(data: np.ndarray) -> bool:
    """A JPEG must end with its end-of-image marker (FF D9); OpenCV decodes cut-off files without complaint."""
    if data.size < 4 or data[0] != 0xFF or data[1] != 0xD8:
        return False
    tail = data[-64:].tobytes()
    return b"\xff\xd9" not in tail
