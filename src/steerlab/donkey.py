"""A steerlab model as a donkeycar part: `SteerlabPilot("model.onnx")` in a donkeycar `manage.py`.

donkeycar runs parts in its vehicle loop: each loop, `run(*inputs)` gets the values named by `inputs` from the
vehicle's memory and its return value is stored under `outputs`; `shutdown()` is called when the loop stops.
This part takes the camera frame (`cam/image_array`: the H x W x 3 uint8 RGB array donkeycar's camera parts
deliver) and, optionally, the measured speed (`enc/speed`, m/s, from donkeycar's odometry), and returns
`(angle, throttle)` in donkeycar's units for `pilot/angle` and `pilot/throttle`:

- **angle**: the servo command in [-1, 1], positive right (donkeycar's, and its tubs' `user/angle`). A model
  trained on tubs (steering convention `normalized`, positive right) is passed through. A model trained on angles
  (CH2's steering-wheel angle, positive left, through the steering ratio 14.8; the simulator's road-wheel angle,
  positive right) needs the car's full-lock road-wheel angle, `full_lock_deg`: angle = road-wheel angle / full
  lock, positive right. Without it such a model is refused when the part is made. A tub model whose checkpoint
  knows its car's full lock (reader option `full_lock_deg`) is rescaled to this car's when both are known.
  Values beyond full lock are clipped to [-1, 1].
- **throttle**: for a model that learned the throttle (a tub model trained with `train.throttle_weight`, the
  tub default) the learned throttle times `throttle_scale`, capped to [-`max_throttle`, `max_throttle`]
  (negative: the brake or reverse, as the tub recorded it), and at least `throttle_floor` while the measured speed
  says the car stands (`control.Throttle`, the shaping the simulated car applies too; the floor needs `enc/speed`);
  forcing a constant `throttle` on such a model is refused unless `learned_throttle=False` says so. For a steering
  model the constant `throttle` (0.3 unless given, at most `max_throttle`; a scale or a floor, which shape a
  learned throttle, is refused); for a model that predicts the next frame's speed (`multitask-speed`, which also
  needs the measured speed with every frame) a PI controller drives the measured speed to the predicted one around
  `throttle` as the cruising throttle (at most `max_throttle`); for a speed-command model (`speed-command`: decelerate
  / maintain / accelerate) the throttle steps down, stays or steps up by `command_step` each frame. donkeycar's
  `DriveMode` part multiplies it by `AI_THROTTLE_MULT`.

With `steer_by="lane"` a model with a lane head (`train.lane_weight`) steers by the lane it sees, not by its
steering head: the lane controller (`control.lane_steering`, Stanley's law on the offset, heading and curvature,
at the measured speed, which it needs with every frame; the car's wheelbase is its camera's car's) gives the
road-wheel angle, which the car's full lock makes a servo command; the throttle is as above. With
`throttle_by="lane"` its throttle is the pace from that lane instead (`control.lane_throttle`): the speed the
curvature it sees allows at the lateral acceleration `lat_acc`, reached from the measured speed on a car whose
throttle 1 approaches `top_speed` (the car model's, 5 m/s for a donkeycar, unless given), capped at
+-`max_throttle` (a negative throttle brakes, as a learned one may); neither the learned throttle nor a scale or a
floor shapes it.

The streaming state lives in the steerlab `Pilot` (previous frame for difference and flow, frame stack, speed
history, recurrent state): the same code `steerlab evaluate` runs, so what was evaluated is what drives. The
part converts RGB to the BGR the Pilot takes (OpenCV's order, as recordings are read). A gap of more than
`reset_after_s` (0.5 s, the gap that starts a new segment in a recording) between two frames, e.g. when the
pilot was switched off in the web UI and on again, starts a new segment: the model forgets the past. A frame of
another size than the model's camera, or not 3-channel uint8, raises an error naming the expected shape (a
donkeycar vehicle loop prints it and stops the car). A missing frame (`None`: the camera is not ready) gives
(0, 0) and starts a new segment.

On the car, `Pilot("model.onnx")` needs numpy, OpenCV and onnxruntime; torch is imported for .pt checkpoints
only. The model runs on `threads` threads (half the cores by default: a Raspberry Pi's camera and vehicle loop
need the others). donkeycar itself is not imported here: a part is any object with `run`.
"""

from __future__ import annotations

import math
import os
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable

import numpy as np

from steerlab.control import (DEFAULT_THROTTLE, LAT_ACC, PACE_MAX, SpeedControl, Throttle, lane_steering, lane_throttle,
                               number)
from steerlab.data.car import car_of
from steerlab.data.geometry import CAMERAS
from steerlab.data.recording import SteeringConvention, said_full_lock
from steerlab.errors import SteerlabError, warn
from steerlab.paths import a_path
from steerlab.pilot import Controls, Pilot


@contextmanager
def _said_by_the_part():
    """A refusal of the checks below, said as the part's ("SteerlabPilot: ...")."""
    try:
        yield
    except SteerlabError as e:
        raise SteerlabError(f"SteerlabPilot: {e}") from None


def _check(name: str, value, low: float, high: float, low_open: bool = False) -> float:
    with _said_by_the_part():
        return number(name, value, low, high, low_open)


def servo_angle(value: float, convention: SteeringConvention, full_lock: float | None, steering_ratio: float) -> float:
    """A model's steering (its checkpoint's convention) as donkeycar's servo command: in [-1, 1], positive right,
    `full_lock` (radians) the car's road-wheel angle at +-1. Normalized steering passes through (rescaled when
    both full-lock angles are known); angles need `full_lock`."""
    if convention.kind == "normalized" and (convention.full_lock is None or full_lock is None):
        servo = value if convention.positive == "right" else -value
    elif full_lock is None:
        raise SteerlabError("an angle needs the car's full-lock angle to become a servo command")
    else:
        servo = -convention.to_road_wheel_left(value, steering_ratio) / full_lock
    return float(np.clip(servo, -1.0, 1.0))


class SteerlabPilot:
    """A donkeycar part: `run(img_arr, speed=None) -> (angle, throttle)`; see the module's docstring.

    model: an exported `.onnx` file (self-contained; needs onnxruntime, not torch) or a `.pt` checkpoint.
    throttle: the constant throttle of a steering model (default 0.3), and the cruising throttle of the speed
        controllers; for a model that learned the throttle only with `learned_throttle=False`.
    learned_throttle: a model that learned the throttle drives with it (False: with the constant `throttle`).
    throttle_scale: the learned throttle is multiplied by it (donkeycar's AI_THROTTLE_MULT does the same later);
        refused for a model that drives at a constant or cruising throttle.
    throttle_floor: the learned throttle is at least this while the car stands (slower than 0.1 m/s; needs the
        measured speed with every frame); refused as throttle_scale is.
    full_lock_deg: the car's road-wheel angle at full lock, in degrees; needed for models trained on angles.
    max_throttle: no throttle exceeds it (a learned one is capped to +-max_throttle; a constant or cruising one
        above it is refused).
    threads: the model's threads (default: half the cores, at least one).
    kp, ki: the PI gains of the speed controller (throttle per m/s, per m/s and frame).
    command_step: the throttle change per frame of a speed-command model's accelerate / decelerate.
    smoothing: exponential smoothing of the steering (paper 002 Eq. 2), as `steerlab sim drive --smoothing`.
    steering_step: then the largest change of the steering from one frame to the next (servo units for a tub model),
    as `steerlab sim drive --steering-step`.
    steer_by: "steering" (the model's steering head) or "lane" (the lane controller on the lane its lane head
        sees; needs the measured speed, and the full lock from `full_lock_deg` or the checkpoint's).
    throttle_by: "model" (the throttle above: learned, constant or cruising) or "lane" (the pace from the lane its
        lane head sees; needs the measured speed).
    lat_acc: with throttle_by lane, the lateral acceleration (m/s^2) the pace allows (default 3.5, the track
        expert's).
    top_speed: with throttle_by lane, the speed (m/s) the car approaches at throttle 1 (default: its car model's).
    reset_after_s: a longer gap between frames starts a new segment (None: never).
    clock: seconds, for the gap (`time.monotonic`).
    """

    def __init__(self, model: str | Path, throttle: float | None = None, *, learned_throttle: bool = True,
                 throttle_scale: float = 1.0, throttle_floor: float = 0.0, full_lock_deg: float | None = None,
                 max_throttle: float = 0.5, kp: float = 0.1, ki: float = 0.01, command_step: float = 0.01,
                 smoothing: float | None = None, steering_step: float | None = None, threads: int | None = None,
                 steer_by: str = "steering", throttle_by: str = "model", lat_acc: float | None = None,
                 top_speed: float | None = None, reset_after_s: float | None = 0.5,
                 clock: Callable[[], float] = time.monotonic):
        forced = throttle is not None
        with _said_by_the_part():
            given = Throttle(DEFAULT_THROTTLE if throttle is None else throttle, throttle_scale, max_throttle,
                             throttle_floor)
        self.full_lock = None if full_lock_deg is None else math.radians(
            _check("full_lock_deg", full_lock_deg, 0.0, 89.0, low_open=True))
        said_full_lock(full_lock_deg, "SteerlabPilot", once=False)  # each part is made once
        if smoothing is not None:
            _check("smoothing", smoothing, 0.0, 1.0, low_open=True)
        if not isinstance(learned_throttle, bool):
            raise SteerlabError(f"SteerlabPilot: learned_throttle must be True or False, got {learned_throttle!r}")
        self.source = a_path(model, "SteerlabPilot: model")
        self.pilot = Pilot(model, smoothing=smoothing, steering_step=steering_step,
                           threads=max(1, (os.cpu_count() or 2) // 2) if threads is None else threads)
        self.throttle_by = self._lane_pace(throttle_by, lat_acc, top_speed, forced)
        self.learned = learned_throttle and "throttle" in self.pilot.targets and self.throttle_by == "model"
        if self.learned and forced:
            raise SteerlabError(f"SteerlabPilot: {self.source.name} learned the throttle; throttle={throttle!r} "
                                "would override it: pass learned_throttle=False to drive at a constant throttle, or "
                                "leave throttle out (throttle_scale, max_throttle and throttle_floor shape the learned "
                                "one)")
        kind = ("lane-paced" if self.throttle_by == "lane" else
                "cruising" if {"speed", "command"} & set(self.pilot.targets) else "constant")
        with _said_by_the_part():
            self.shaping = given.for_model(self.learned, self.source.name, kind)
        conv = self.pilot.convention
        self.steer_by = self._lane_steering(steer_by, smoothing, steering_step)
        if conv.kind != "normalized" and self.full_lock is None:
            wheel = "steering-wheel" if conv.kind == "steering_wheel" else "road-wheel"
            raise SteerlabError(f"{self.source} predicts the {wheel} angle (positive {conv.positive}); donkeycar "
                                "steers with a servo command in [-1, 1]: give the car's full-lock road-wheel angle, "
                                f"SteerlabPilot({str(self.source)!r}, full_lock_deg=...)")
        self.speed_control = SpeedControl(_check("kp", kp, 0.0, 10.0), _check("ki", ki, 0.0, 10.0),
                                          self.shaping.constant, 0.0, self.shaping.cap)
        self.command_step = _check("command_step", command_step, 0.0, 1.0)
        self.reset_after_s = None if reset_after_s is None else _check("reset_after_s", reset_after_s, 0.0, 1e9,
                                                                       low_open=True)
        if not callable(clock):
            raise SteerlabError(f"SteerlabPilot: clock must be a function that returns seconds (time.monotonic), "
                                f"got {clock!r}")
        self.clock = clock
        car = car_of(self.pilot.geometry)  # the car its angles were recorded on
        self.steering_ratio, self.wheelbase = car.steering_ratio, car.wheelbase
        if self.throttle_by == "lane":
            self.lat_acc = LAT_ACC if lat_acc is None else lat_acc
            self.top_speed = top_speed or (car.motor.top_speed if car.motor else None)
            if self.top_speed is None:
                raise SteerlabError(f"SteerlabPilot: throttle_by lane needs the speed the car approaches at "
                                    f"throttle 1, which the {self.pilot.geometry!r} car does not say: give top_speed")
        cam = CAMERAS.get(self.pilot.geometry)
        self.shape = None if cam is None else (cam.height, cam.width, 3)  # the frames the model was trained on
        self.frames = 0
        self.controls = None  # the model's last answer (`pilot.Controls`: the lane of a model with a lane head too)
        self._last = None
        self._commanded = self.shaping.constant
        self._closed = self._warned = False

    def _lane_steering(self, steer_by, smoothing, steering_step) -> str:
        """`steer_by` checked against the model: "lane" needs a lane head and a full lock, and leaves the steering
        head's smoothing and step nothing to shape."""
        if steer_by not in ("steering", "lane"):
            raise SteerlabError(f"SteerlabPilot: steer_by must be 'steering' or 'lane', got {steer_by!r}")
        if steer_by == "steering":
            return steer_by
        if "lane" not in self.pilot.targets:
            raise SteerlabError(f"{self.source}: steer_by lane steers by the lane a model's lane head sees; model "
                                f"{self.pilot.name!r} has none: train it with train.lane_weight > 0 on tubs with "
                                "lane values (steerlab sim record --world track), or set steer_by to steering")
        for name, value in (("smoothing", smoothing), ("steering_step", steering_step)):
            if value is not None:
                raise SteerlabError(f"SteerlabPilot: {name} shapes the steering head's output; steer_by lane steers "
                                    f"by the lane controller instead: leave {name} out, or set steer_by to steering")
        if (self.full_lock or self.pilot.convention.full_lock) is None:
            raise SteerlabError(f"SteerlabPilot: steer_by lane turns the lane controller's road-wheel angle into a "
                                f"servo command with the car's full lock, which {self.source.name} does not know: "
                                "give full_lock_deg")
        return steer_by

    def _lane_pace(self, throttle_by, lat_acc, top_speed, forced: bool) -> str:
        """`throttle_by` checked against the model and the other options: "lane" needs a lane head, and the
        constant throttle does not drive; `lat_acc` and `top_speed` shape the lane's pace only."""
        if throttle_by not in ("model", "lane"):
            raise SteerlabError(f"SteerlabPilot: throttle_by must be 'model' or 'lane', got {throttle_by!r}")
        for name, value in (("lat_acc", lat_acc), ("top_speed", top_speed)):
            if value is None:
                continue
            if throttle_by != "lane":
                raise SteerlabError(f"SteerlabPilot: {name} shapes the pace from the lane: leave it out, or set "
                                    "throttle_by to lane")
            _check(name, value, 0.0, PACE_MAX, low_open=True)
        if throttle_by == "model":
            return throttle_by
        if "lane" not in self.pilot.targets:
            raise SteerlabError(f"{self.source}: throttle_by lane drives at the pace of the lane a model's lane head "
                                f"sees; model {self.pilot.name!r} has none: train it with train.lane_weight > 0 on "
                                "tubs with lane values (steerlab sim record --world track), or set throttle_by to "
                                "model")
        if forced:
            raise SteerlabError("SteerlabPilot: throttle is the constant throttle of a model that predicts none; "
                                "throttle_by lane drives at the lane's pace instead: leave throttle out")
        return throttle_by

    def reset(self) -> None:
        """Forget the past: the next frame starts a segment (previous frame, histories, recurrent state)."""
        self.pilot.reset()
        self.speed_control.reset()
        self._commanded = self.shaping.constant

    def expected(self) -> str:
        if self.shape is None:
            return "H x W x 3 uint8 RGB frames"
        h, w, _ = self.shape
        return (f"{h}x{w}x3 uint8 RGB frames of the {self.pilot.geometry!r} camera it was trained on "
                f"(donkeycar config: IMAGE_H = {h}, IMAGE_W = {w}, IMAGE_DEPTH = 3)")

    def run(self, img_arr: np.ndarray | None, speed: float | None = None) -> tuple[float, float]:
        """One camera frame (RGB, as donkeycar's cameras give it) and optionally the measured speed (m/s) ->
        (angle in [-1, 1] positive right, throttle)."""
        if self._closed:
            raise SteerlabError("SteerlabPilot: run() after shutdown(): make a new one")
        now = self.clock()
        if isinstance(now, bool) or not isinstance(now, (int, float, np.integer, np.floating)) or not math.isfinite(now):
            raise SteerlabError(f"SteerlabPilot: clock() must return seconds, a finite number (as time.monotonic), "
                                f"got {now!r}")
        gap = self._last is not None and self.reset_after_s is not None and now - self._last > self.reset_after_s
        self._last = now
        if img_arr is None:
            if not self._warned:
                warn("SteerlabPilot: no camera frame (cam/image_array is None): steering 0, throttle 0 (said once)")
                self._warned = True
            self.reset()
            self._last = None
            return 0.0, 0.0
        img = np.asarray(img_arr)
        if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] != 3 or (self.shape and img.shape != self.shape):
            got = "x".join(map(str, img.shape)) or "a scalar"
            raise SteerlabError(f"SteerlabPilot: the camera frame is {got} {img.dtype}; {self.source.name} "
                                f"(model {self.pilot.name!r}) expects {self.expected()}")
        lane, pace = self.steer_by == "lane", self.throttle_by == "lane"
        if (self.pilot.speed_history or "speed" in self.pilot.targets or self.shaping.floor or lane or pace) \
                and speed is None:
            needs = ("the throttle floor needs" if self.shaping.floor else "steer_by lane needs" if lane
                     else "throttle_by lane needs" if pace else f"model {self.pilot.name!r} needs")
            raise SteerlabError(f"SteerlabPilot: {needs} the measured speed (m/s) with every frame: add the car's "
                                "odometry (HAVE_ODOM = True) and inputs=['cam/image_array', 'enc/speed']")
        if gap:
            self.reset()
        self.frames += 1
        out = self.controls = self.pilot.step(np.ascontiguousarray(img[..., ::-1]), speed)
        if lane:
            full_lock = self.full_lock or self.pilot.convention.full_lock
            wheel = lane_steering(*out.lane, speed, self.wheelbase)
            angle = float(np.clip(-wheel / full_lock, -1.0, 1.0))
        else:
            angle = servo_angle(out.steering, self.pilot.convention, self.full_lock, self.steering_ratio)
        return angle, self._throttle(out, speed)

    def _throttle(self, out: Controls, speed: float | None) -> float:
        """The throttle of the model's answer `out` (see the module's docstring): the learned one shaped
        (`control.Throttle.shaped`), the speed controller's, the speed command's step, or the constant one."""
        if self.throttle_by == "lane":
            return lane_throttle(out.lane[2], speed, self.lat_acc, self.top_speed, self.shaping.cap)
        if self.learned:
            return self.shaping.shaped(out.throttle, speed)
        if out.speed is not None:
            return self.speed_control.update(out.speed, speed)
        if out.command is not None:
            self._commanded = float(np.clip(self._commanded + self.command_step * (out.command - 1), 0.0,
                                            self.shaping.cap))
            return self._commanded
        return self.shaping.constant

    def shutdown(self) -> None:
        """donkeycar calls it when the vehicle stops: the model is released."""
        self._closed = True
        self.pilot = None
