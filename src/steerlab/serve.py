"""`steerlab serve`: the drive server for the Udacity behavioural-cloning simulator.

The simulator (autonomous mode) connects with Socket.IO to port 4567 and sends a `telemetry` event per frame:
`steering_angle`, `throttle`, `speed` (mph) as strings and `image`, a base64 JPEG of the centre camera
(320x160). The server answers each with a `steer` event (`steering_angle` in [-1, 1] = +-25 degrees, positive
right, and `throttle`, both as strings). Telemetry without data means the simulator is in manual mode: the
server emits `manual` and sends no command. A frame whose image is missing or undecodable gets a safe stop
(steering 0, brake while moving) and a warning; so do a frame of another size than the simulator's 320x160, a
speed no car drives at (negative, or beyond 100 mph: never recorded) and an event without a payload;
the server keeps running. A model that can never drive the simulator (normalized steering without a full-lock
angle, as a donkeycar checkpoint's, or a crop that removes the whole 320x160 frame) is refused at start.

The simulator speaks Engine.IO protocol 3, which python-socketio 5 rejects ("unsupported version"): steerlab
pins python-socketio 4.6.1 + python-engineio 3.14.2 and serves with eventlet, the combination the
simulator's own drive.py was written for.
"""

from __future__ import annotations

import base64
import csv
import math
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from steerlab.control import SpeedControl
from steerlab.data.car import CARS
from steerlab.data.geometry import CAMERAS
from steerlab.data.preprocess import crop_resize
from steerlab.data.simlog import MPH_TO_MS, image_name, log_row, to_sim_steering
from steerlab.errors import SteerlabError, warn
from steerlab.options import SPEED, Options, Range, option
from steerlab.pilot import Pilot, smoothing_option

SIM_FRAME = (CAMERAS["sim"].width, CAMERAS["sim"].height)  # the simulator's centre camera: 320x160


def to_simulator(pilot: Pilot, steering: float) -> float:
    """The pilot's steering (its checkpoint's convention) as the simulator's normalised value."""
    road_wheel_left = pilot.convention.to_road_wheel_left(steering, CARS[pilot.geometry or "sim"].steering_ratio)
    return float(np.clip(to_sim_steering(road_wheel_left), -1.0, 1.0))


def check_drivable(pilot: Pilot, source: str | Path) -> None:
    """Refuse at start a model that can never drive the simulator: steering that has no angle (normalized
    steering without a full-lock angle, e.g. a donkeycar checkpoint) or a crop that removes the whole frame."""
    try:
        to_simulator(pilot, 0.0)
    except SteerlabError as e:
        raise SteerlabError(f"{source} cannot drive the simulator: it predicts normalized steering without a "
                            f"full-lock angle, so its steering has no angle ({e})") from None
    try:
        crop_resize(np.zeros((SIM_FRAME[1], SIM_FRAME[0], 3), np.uint8), pilot.config)
    except SteerlabError as e:
        raise SteerlabError(f"{source} cannot drive the simulator: {e} (the simulator's frames are "
                            f"{SIM_FRAME[0]}x{SIM_FRAME[1]})") from None


class DriveSession:
    """Telemetry in, commands out; optionally records the drive as a driving_log.csv with IMG/. A model that
    can never drive the simulator is refused here (`source` names it in the message)."""

    def __init__(self, pilot: Pilot, set_speed: float, record: str | Path | None = None,
                 source: str | Path | None = None):
        check_drivable(pilot, source or f"model {pilot.name!r}")
        self.pilot, self.set_speed, self.controller = pilot, set_speed, SpeedControl()
        self.record = Path(record) if record else None
        self.frames = self.bad = self._last_ms = 0
        if self.record:
            (self.record / "IMG").mkdir(parents=True, exist_ok=True)

    def _safe_stop(self, speed: float, problem: str) -> dict[str, str]:
        """A bad frame: steering 0, brake while moving, one warning; the session goes on."""
        self.bad += 1
        warn(f"telemetry frame {self.frames + self.bad}: {problem}; sent a safe stop")
        brake = -1.0 if math.isfinite(speed) and speed > 0.5 else 0.0
        return {"steering_angle": "0.0", "throttle": str(brake)}

    def malformed(self, problem: str) -> dict[str, str]:
        """A safe stop for an event that carries no usable telemetry."""
        return self._safe_stop(math.nan, problem)

    def command(self, data: dict) -> dict[str, str]:
        try:
            speed = float(data["speed"]) * MPH_TO_MS
        except (KeyError, TypeError, ValueError):
            speed = math.nan
        jpeg = _decode_base64(data.get("image"))
        frame = None if jpeg is None else cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        if frame is None or not math.isfinite(speed):
            return self._safe_stop(speed, f"missing or undecodable {'speed' if frame is not None else 'image'}")
        low, high = 0.0, CARS["sim"].speeds[1]
        if not low <= speed <= high:  # never driven, never recorded, and not trusted to brake by
            return self._safe_stop(math.nan, f"a speed of {data['speed']} mph is none a car drives at (0 to "
                                             f"{high / MPH_TO_MS:.0f} mph)")
        if frame.shape[1::-1] != SIM_FRAME:
            return self._safe_stop(speed, f"the image is {frame.shape[1]}x{frame.shape[0]}, not the simulator's "
                                          f"{SIM_FRAME[0]}x{SIM_FRAME[1]}")
        try:
            controls = self.pilot.step(frame, speed)
        except SteerlabError as e:
            return self._safe_stop(speed, str(e))
        self.frames += 1
        steering, throttle = to_simulator(self.pilot, controls.steering), self.controller.update(self.set_speed, speed)
        if self.record:
            self._log(jpeg, steering, throttle, speed)
        return {"steering_angle": f"{steering:.6f}", "throttle": f"{throttle:.6f}"}

    def _log(self, jpeg: bytes, steering: float, throttle: float, speed: float) -> None:
        ms = max(time.time_ns() // 1_000_000, self._last_ms + 1)  # file names carry the time, so unique ms
        self._last_ms = ms
        name = self.record / "IMG" / image_name("center", ms * 1_000_000)
        name.write_bytes(jpeg)
        with open(self.record / "driving_log.csv", "a", newline="") as f:
            csv.writer(f).writerow(log_row(name, "", "", steering, max(throttle, 0.0), max(-throttle, 0.0), speed))


def _decode_base64(text) -> bytes | None:
    if not isinstance(text, str) or not text:
        return None
    try:
        return base64.b64decode(text, validate=True)
    except ValueError:
        return None


def _socketio():
    """python-socketio 4.x with eventlet: the combination that speaks the simulator's Engine.IO 3."""
    try:
        with warnings.catch_warnings():  # eventlet announces its maintenance mode on import
            warnings.simplefilter("ignore")
            import eventlet
            import eventlet.wsgi
            import socketio
    except ImportError:
        raise SteerlabError("steerlab serve needs python-socketio 4.6.1, python-engineio 3.14.2 and eventlet "
                            "(pip install -r requirements.txt)") from None
    if not socketio.__version__.startswith("4."):
        raise SteerlabError(f"python-socketio {socketio.__version__} cannot talk to the Udacity simulator (it "
                            "speaks Engine.IO 3): pip install python-socketio==4.6.1 python-engineio==3.14.2")
    return socketio, eventlet


def make_app(session: DriveSession):
    """The WSGI application with the Socket.IO server on it."""
    socketio, _ = _socketio()
    sio = socketio.Server(async_mode="eventlet", logger=False, engineio_logger=False)

    @sio.on("connect")
    def connect(sid, environ):
        print(f"simulator connected ({sid})")
        sio.emit("steer", {"steering_angle": "0.0", "throttle": "0.0"}, room=sid)

    @sio.on("telemetry")
    def telemetry(sid, *payload):
        if len(payload) != 1:  # malformed: no payload, or several
            sio.emit("steer", session.malformed(f"a telemetry event with {len(payload)} payloads"), room=sid)
            return
        if not payload[0]:  # manual mode
            sio.emit("manual", {}, skip_sid=True)
            return
        try:
            reply = session.command(payload[0] if isinstance(payload[0], dict) else {})
        except Exception as e:  # noqa: BLE001 - whatever went wrong, the car gets an answer: stop
            reply = session.malformed(f"the telemetry could not be handled ({e.__class__.__name__}: {e})")
        sio.emit("steer", reply, room=sid)

    @sio.on("manual")
    def manual(sid, *_):
        session.pilot.reset()  # a human drove in between: the next autonomous frame starts a new segment

    @sio.on("disconnect")
    def disconnect(sid):
        print(f"simulator disconnected after {session.frames} frames ({session.bad} bad)")

    return socketio.WSGIApp(sio)


@dataclass(frozen=True)
class ServeOptions(Options):
    """`steerlab serve`'s options."""

    port: int = option(4567, Range(1, 65535), help="port (4567: the simulator's)")
    set_speed: float = option(4.0, Range(0, SPEED.hi, unit="m/s"),
                              help="speed the PI controller holds, m/s")
    smoothing: float | None = smoothing_option()
    record: str | None = option(None, help="folder to record the drive to (driving_log.csv + IMG/)", path="folder",
                               makes="recording")


def serve(checkpoint: str | Path, o: ServeOptions = ServeOptions(), host: str = "0.0.0.0") -> None:
    _, eventlet = _socketio()
    pilot = Pilot(checkpoint, smoothing=o.smoothing)
    app = make_app(DriveSession(pilot, o.set_speed, o.record, checkpoint))
    try:
        listener = eventlet.listen((host, o.port), reuse_port=False)
    except OSError as e:
        raise SteerlabError(f"cannot listen on port {o.port}: {e.strerror}; choose another one "
                            "(steerlab serve --port)") from None
    print(f"steerlab serve: {pilot.name} on port {o.port}, set speed {o.set_speed:.1f} m/s"
          + (f", recording to {o.record}" if o.record else "") + " - start the simulator in autonomous mode",
          flush=True)
    t0 = time.time()
    eventlet.wsgi.server(listener, app, log_output=False)
    print(f"stopped after {time.time() - t0:.0f} s")
