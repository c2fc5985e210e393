"""The Pilot: the one object that drives. Raw frames in, one set of controls per frame out.

It applies exactly the preprocessing the model was trained with, keeps the previous frame for the frame
difference and optical flow, the last frames for stacked input, the last speeds for models with a speed
history and the recurrent state, standardises with the checkpoint's statistics, runs the model and optionally
smooths the steering (paper 002 Eq. 2). Offline evaluation and closed-loop driving both use it, so what is
measured is what runs. `step` takes one frame; `stream` takes a sequence and decodes and preprocesses the next
frames on worker threads while the model runs (OpenCV, ONNX Runtime and torch release the GIL), with exactly
the outputs of `step`. The model runs on PyTorch (a .pt checkpoint) or on ONNX Runtime (an exported .onnx
file); everything around the model is the same code. torch is imported only for a .pt checkpoint: the Pilot
on an exported .onnx file needs numpy, OpenCV and ONNX Runtime alone (what a car's computer has).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from itertools import repeat, zip_longest
from pathlib import Path

import cv2
import numpy as np

from steerlab.data.car import CARS, car_of
from steerlab.data.geometry import CAMERAS
from steerlab.data.labels import lane_values
from steerlab.data.modalities import frame_difference, optical_flow
from steerlab.data.preprocess import preprocess
from steerlab.errors import DataError, SteerlabError, warn
from steerlab.options import FRACTION, POSITIVE, THREADS, Options, option
from steerlab.runtime import load_model


# `stream`: worker threads (three: a worker computing a frame's motion may wait for the previous frame's
# decode, and a third keeps decoding; measured best on two cores) and frames prepared ahead of the model
WORKERS, AHEAD = 3, 8


def smoothing_option():
    """The option of every command that makes a Pilot: its exponential smoothing of the steering."""
    return option(None, FRACTION, help="exponential smoothing factor a of the steering, s = a y + (1 - a) s' "
                  "(paper 002 Eq. 2; 0.2 there)")


def steering_step_option():
    """The option of every command that makes a Pilot: the largest change of its steering from one frame to the
    next."""
    return option(None, POSITIVE, help="the largest change of the steering from one frame to the next, in the "
                  "model's unit (a tub model's servo units; radians otherwise): a limit on how fast it turns")


@dataclass(frozen=True)
class DriveWith(Options):
    """How a drive makes its Pilot (`sim drive`, the suites, DAgger's rollouts)."""

    smoothing: float | None = smoothing_option()
    steering_step: float | None = steering_step_option()


@dataclass(frozen=True)
class Controls:
    """One frame's output: steering in the checkpoint's convention (radians, or servo units in [-1, 1] for models
    of donkeycar tubs); for speed models also the next frame's speed (m/s) or the speed command (0 decelerate, 1
    maintain, 2 accelerate); for models that learned the throttle (donkeycar tubs' `user/throttle`) the throttle in
    [-1, 1]; for models with a lane head (`train.lane_weight`) the lane they see, (offset m positive left, heading
    rad positive turned left, curvature 1/m positive turning left), as `data.labels.LANE` describes it."""

    steering: float
    speed: float | None = None
    command: int | None = None
    throttle: float | None = None
    lane: tuple[float, float, float] | None = None


def _check_speed(speed):
    """A measured speed must be a real, finite number of m/s, at least 0 (or None: not measured)."""
    if speed is not None and (isinstance(speed, bool) or not isinstance(speed, (int, float, np.number))
                              or not np.isfinite(speed) or speed < 0):
        raise SteerlabError(f"the measured speed must be a finite number of m/s, at least 0, got {speed!r}")
    return speed


def _paired(frames: Iterable, speeds: Iterable) -> Iterator[tuple]:
    """(frame, speed) pairs; frames and speeds of different lengths are refused (a speed would go to the wrong
    frame, or frames be left undriven)."""
    for n, (frame, speed) in enumerate(zip_longest(frames, speeds, fillvalue=_paired)):
        if frame is _paired or speed is _paired:
            longer, shorter = ("frames", "speed") if speed is _paired else ("speeds", "frame")
            raise SteerlabError(f"Pilot.stream: more {longer} than {shorter}s ({n} {shorter}{'s' * (n != 1)}): give "
                                "one speed a frame")
        yield frame, speed


class Pilot:
    def __init__(self, checkpoint: str | Path | dict, smoothing: float | None = None, threads: int | None = None,
                 other_camera: bool = False, steering_step: float | None = None):
        """`checkpoint`: a .pt checkpoint (path or loaded dict) or an exported .onnx file (self-contained: its
        preprocessing, statistics and convention are in its metadata). `threads`: the runtime's threads (ONNX
        Runtime's intra-op threads, or torch's for a .pt checkpoint; default: see `runtime`). A frame of another
        size than the camera the model was trained on is refused, unless `other_camera` (then it is cropped and
        resized like any). `smoothing`: exponential smoothing of the steering; `steering_step`: then the largest
        change of the steering from one frame to the next (in the model's unit)."""
        if smoothing is not None and not FRACTION(smoothing):
            raise SteerlabError(f"smoothing must be a number in (0, 1], got {smoothing!r}")
        if steering_step is not None and not POSITIVE(steering_step):
            raise SteerlabError(f"steering_step must be a positive finite number, got {steering_step!r}")
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or not THREADS(threads)):
            raise SteerlabError(f"threads must be {THREADS.words(int)} (this machine's cores), got {threads!r}")
        if not isinstance(other_camera, bool):
            raise SteerlabError(f"other_camera must be True or False, got {other_camera!r}")
        self.net = load_model(checkpoint, threads)
        self.source = f"checkpoint of {checkpoint['model']}" if isinstance(checkpoint, dict) else str(checkpoint)
        self.name, self.config, self.convention = self.net.name, self.net.config, self.net.convention
        self.geometry, self.speed_history, self.targets = self.net.geometry, self.net.speed_history, self.net.targets
        cam = None if other_camera else CAMERAS.get(self.geometry)
        self.frame_size = None if cam is None else (cam.height, cam.width)
        self.smoothing, self.steering_step = smoothing, steering_step
        self._top_speed = car_of(self.geometry if self.geometry in CARS else None).speeds[1]  # of the model's car
        self._said_speed = False
        self._channels, c = {}, 0  # each modality's channels of the network input, in input order
        for m, n in self.config.channels().items():
            self._channels[m], c = slice(c, c + n), c + n
        self._x = np.empty((1, self.config.height, self.config.width, c), np.float32)  # refilled every frame
        self.reset()

    def _plausible(self, speed: float | None) -> float | None:
        """A measured speed beyond twice the fastest the model's car drives is said once: m/s is expected, and km/h
        or mph are the likely cause."""
        top = self._top_speed
        if speed is not None and speed > 2 * top and not self._said_speed:
            self._said_speed = True
            warn(f"{self.source}: a measured speed of {speed:g} m/s is beyond what its car drives (up to {top:g} m/s):"
                 " km/h or mph where m/s is expected?")
        return speed

    def reset(self) -> None:
        """Forget the past: the next frame is treated as the first of a segment."""
        self._prev = None  # the previous frame's (image, gray)
        self._frames: deque = deque(maxlen=self.config.stack)
        self._speeds: deque = deque(maxlen=self.speed_history)
        self._smoothed = self._steered = None
        self.net.reset()

    @staticmethod
    def _push(history: deque, item) -> None:
        """Append to a history; a segment's first item stands in for the past before it."""
        while len(history) < history.maxlen - 1:
            history.append(item)
        history.append(item)

    def step(self, frame: np.ndarray | bytes, speed: float | None = None) -> Controls:
        """One raw frame (and the measured speed in m/s, for models that use it) -> controls. The frame is a
        BGR array or an encoded image (JPEG or PNG bytes, or a 1-D uint8 array of them)."""
        self._plausible(_check_speed(speed))
        cur = self._prepare(frame)
        return self._drive(cur, self._motion(cur if self._prev is None else self._prev, cur), speed)

    def stream(self, frames: Iterable, speeds: Iterable[float] | None = None,
               load: Callable[[object], np.ndarray] | None = None) -> Iterator[Controls]:
        """`step` over a sequence of frames, pipelined: WORKERS threads decode, preprocess and compute the
        motion modalities up to AHEAD frames ahead while the model runs. The controls are exactly those of
        `step` frame by frame, continuing from the Pilot's state as `step` does (call `reset()` before a new
        segment). `load`, when given, turns each item into a BGR frame on the worker threads (a frame index or
        a file, say)."""
        for name, value in (("frames", frames), ("speeds", speeds)):
            if (value is not None or name == "frames") and (isinstance(value, (str, bytes))
                                                          or not isinstance(value, Iterable)):
                raise SteerlabError(f"Pilot.stream: {name} must be a sequence (a list, a generator), one item a frame"
                                    f"{'' if name == 'frames' else ' (None: not measured)'}, got {type(value).__name__}"
                                    f"{'' if name == 'frames' else f' {value!r}'}; Pilot.step takes one frame")
        if load is not None and not callable(load):
            raise SteerlabError(f"Pilot.stream: load must be a function of an item that returns its BGR frame, got "
                                f"{load!r}")

        def prepare(item) -> tuple:
            frame = item if load is None else load(item)
            try:
                return self._prepare(frame)
            except SteerlabError as e:  # a frame loaded from a file is named by it
                if load is not None and isinstance(item, (str, Path)):
                    raise DataError(item, str(e)) from None
                raise

        checked = None if speeds is None else map(self._plausible, map(_check_speed, speeds))
        pairs = zip(frames, repeat(None)) if speeds is None else _paired(frames, checked)
        before = self._prev  # the frame before the first one (None: the first starts a segment)

        def motion(prev: Future | None, cur: Future) -> tuple:
            """Runs on a worker after both frames' preparation was submitted, so it never waits on later work."""
            cur = cur.result()
            prev = prev.result() if prev is not None else cur if before is None else before
            return cur, self._motion(prev, cur)

        pending: deque = deque()
        with ThreadPoolExecutor(WORKERS) as pool:
            prev = None
            for frame, speed in pairs:
                cur = pool.submit(prepare, frame)
                pending.append((pool.submit(motion, prev, cur), speed))
                prev = cur
                if len(pending) > AHEAD:
                    yield self._drive_next(pending)
            while pending:
                yield self._drive_next(pending)

    def _drive_next(self, pending: deque) -> Controls:
        done, speed = pending.popleft()
        return self._drive(*done.result(), speed)

    def expected(self) -> str:
        size = "HxW" if self.frame_size is None else "x".join(map(str, self.frame_size))
        camera = "" if self.frame_size is None else f" of the {self.geometry!r} camera the model was trained on"
        return f"a {size}x3 uint8 BGR array{camera}, or the bytes of a JPEG or PNG image"

    def _prepare(self, frame: np.ndarray | bytes) -> tuple[np.ndarray, np.ndarray]:
        """Check, decode if encoded, then preprocess: (image, gray). Depends on the config alone (thread safe)."""
        if isinstance(frame, (bytes, bytearray, memoryview)):
            frame = np.frombuffer(frame, np.uint8)
        if not isinstance(frame, np.ndarray):
            raise SteerlabError(f"the Pilot got {type(frame).__name__} as a frame; it takes {self.expected()}")
        if frame.ndim == 1 and frame.dtype == np.uint8:
            encoded, frame = frame, cv2.imdecode(frame, cv2.IMREAD_COLOR) if frame.size else None
            if frame is None:
                raise SteerlabError(f"cannot decode a frame of {encoded.size} bytes (not a JPEG or PNG image); the "
                                    f"Pilot takes {self.expected()}")
        if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
            raise SteerlabError(f"the Pilot got a {'x'.join(map(str, frame.shape))} {frame.dtype} frame; it takes "
                                f"{self.expected()}")
        if self.frame_size is not None and frame.shape[:2] != self.frame_size:
            h, w = self.frame_size
            raise SteerlabError(f"a {frame.shape[0]}x{frame.shape[1]} frame (height x width); model {self.name!r} was "
                                f"trained on the {self.geometry!r} camera ({h}x{w}): give it that camera's frames "
                                "(other_camera: crop and resize any frame)")
        return preprocess(frame, self.config)

    def _motion(self, prev: tuple[np.ndarray, np.ndarray], cur: tuple[np.ndarray, np.ndarray]) -> dict:
        """The motion modalities from the previous prepared frame to this one (thread safe)."""
        (prev_img, prev_gray), (img, gray) = prev, cur
        out = {}
        if "diff" in self._channels:
            out["diff"] = frame_difference(prev_img, img)
        if "flow" in self._channels:
            out["flow"] = optical_flow(prev_gray, gray, self.config.flow).astype(np.float16)
        return out

    def _drive(self, cur: tuple[np.ndarray, np.ndarray], motion: dict, speed: float | None) -> Controls:
        """The stateful part of a step: histories, the input buffer, model, smoothing."""
        self._prev = cur
        self._push(self._frames, cur[0])
        x, c = self._x[0], self.config.image_channels
        for k, frame in enumerate(self._frames):  # the image channels come first, oldest frame first
            x[:, :, k * c: (k + 1) * c] = frame
        for m, array in motion.items():
            x[:, :, self._channels[m]] = array
        speeds = None
        if self.speed_history:
            if speed is None:
                raise SteerlabError(f"model {self.name!r} needs the measured speed with every frame")
            self._push(self._speeds, float(speed))
            speeds = list(self._speeds)
        out = self.net(self._x, speeds)
        y = float(out["steering"])
        if self.smoothing is not None:
            self._smoothed = y if self._smoothed is None else self.smoothing * y + (1 - self.smoothing) * self._smoothed
            y = self._smoothed
        if self.steering_step is not None:
            if self._steered is not None:
                y = float(np.clip(y, self._steered - self.steering_step, self._steered + self.steering_step))
            self._steered = y
        return Controls(y, float(out["speed"]) if "speed" in out else None,
                        int(out["command"].argmax()) if "command" in out else None,
                        float(out["throttle"]) if "throttle" in out else None,
                        lane_values(out["lane"]) if "lane" in out else None)
