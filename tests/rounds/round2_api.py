"""Group D of the second round (round2.py): the Python API with values of other types and units. Each row calls a
function or class of steerlab (`api`: "module:name") or a builder below (`api`: "tests.rounds.round2_api:NAME"),
with `args` and `kwargs`; a frame or a speed is the value itself, `JPEG` (or a part of it) the bytes of the driving
log's first frame, read when the case runs."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.data.readers import Source
from tests.rounds import places

F, W = "{fx}", "{work}"
CK, SIM, TUB, CH2, DK = f"{F}/a.pt", f"{F}/sim", f"{F}/tub", f"{F}/ch2", f"{F}/donkey.pt"
JPG = f"{SIM}/IMG/center_2020_01_01_00_00_00_000.jpg"
HERE = __name__


@dataclass(frozen=True)
class Bytes:
    """The bytes of a fixture's file, or their first 1/`part`."""
    path: str
    part: int = 1

    def read(self) -> bytes:
        data = Path(places.fill(self.path)).read_bytes()
        return data[: len(data) // self.part]


JPEG = Bytes(JPG)


def zeros(*shape, dtype=np.uint8):
    return np.zeros(shape or (160, 320, 3), dtype)


def zeros_of(i):
    """A loader of frames: every item is a black frame."""
    return zeros()


PILOTS = [  # Pilot(*args, **kwargs)
    ("Pilot(123)", (123,), {}, ["checkpoint"]), ("Pilot(None)", (None,), {}, ["checkpoint"]),
    ("Pilot(tub folder)", (TUB,), {}, ["tub"]), ("Pilot(config)", (f"{F}/c.yaml",), {}, ["c.yaml"]),
    ("Pilot({})", ({},), {}, ["checkpoint"]), ("Pilot([a.pt])", ([CK],), {}, ["checkpoint"]),
    ("Pilot(b'bytes')", (b"PK\x03\x04",), {}, ["checkpoint"]),
    ("Pilot(smoothing='0.5')", (CK,), {"smoothing": "0.5"}, ["smoothing"]),
    ("Pilot(smoothing=True)", (CK,), {"smoothing": True}, ["smoothing"]),
    ("Pilot(steering_step=-1)", (CK,), {"steering_step": -1.0}, ["steering_step"]),
    ("Pilot(steering_step='0.1')", (CK,), {"steering_step": "0.1"}, ["steering_step"]),
    ("Pilot(other_camera='no')", (CK,), {"other_camera": "no"}, ["other_camera"]),
    ("Pilot(threads=None, smoothing=nan)", (CK,), {"smoothing": float("nan")}, ["smoothing"])]
FRAMES = [  # Pilot(a.pt).step(frame)
    ("a list", [[0, 0, 0]] * 10, ["frame"]), ("None", None, ["frame"]),
    ("float32 0..1", zeros(dtype=np.float32), ["float32", "uint8"]),
    ("gray 2-D", zeros(160, 320), ["160x320", "frame"]), ("RGBA", zeros(160, 320, 4), ["160x320x4", "frame"]),
    ("channels first", zeros(3, 160, 320), ["3x160x320", "frame"]),
    ("empty bytes", b"", ["frame", "image"]), ("random bytes", bytes(range(256)) * 4, ["frame", "image"]),
    ("a path", JPG, ["frame", "path"]), ("a Path", Path(JPG), ["frame", "path"]),
    ("640x480", zeros(480, 640, 3), ["480", "640"]), ("int16", zeros(dtype=np.int16), ["int16", "uint8"]),
    ("bool", zeros(dtype=bool), ["bool", "uint8"]), ("a scalar", np.uint8(3), ["frame"]),
    ("a 0-size frame", zeros(0, 0, 3), ["frame", "0x0"]),
    ("truncated JPEG", Bytes(JPG, 3), ["frame", "image", "JPEG"])]
SPEEDS = [("40 for a road model", 40.0, "ok"), ("'12'", "12", "refuse"), ("[12.0]", [12.0], "refuse"),
          ("np.array(12.0)", np.array(12.0), "ok"), ("nan", float("nan"), "refuse"), ("complex", 3 + 0j, "refuse")]
STREAMS = [  # Pilot(a.pt).stream(frames, speeds, load)
    ("frames=None", None, None, None, ["frames"]), ("frames=one frame", zeros(), None, None, ["frame"]),
    ("speeds='fast'", [zeros(), zeros()], "fast", None, ["speed"]),
    ("speeds=5.0", [zeros(), zeros()], 5.0, None, ["speed"]), ("load=5", [0, 1], None, 5, ["load"]),
    ("frames of two sizes", [zeros(), zeros(120, 160, 3)], None, None, ["120", "160"]),
    ("a frame that is None in the middle", [zeros(), None, zeros()], None, None, ["frame"])]
PARTS = [  # SteerlabPilot(donkey.pt, **kwargs)
    ("full_lock_deg='25'", {"full_lock_deg": "25"}, ["full_lock_deg"]),
    ("throttle=-0.1", {"throttle": -0.1}, ["throttle"]), ("throttle=True", {"throttle": True}, ["throttle"]),
    ("throttle='0.3'", {"throttle": "0.3"}, ["throttle"]), ("max_throttle=2", {"max_throttle": 2.0}, ["max_throttle"]),
    ("kp=-1", {"kp": -1.0}, ["kp"]), ("threads=0", {"threads": 0}, ["threads"]),
    ("reset_after_s=0", {"reset_after_s": 0}, ["reset_after_s"]),
    ("reset_after_s=500 (ms?)", {"reset_after_s": "500"}, ["reset_after_s"]),
    ("smoothing=2", {"smoothing": 2.0}, ["smoothing"]), ("steering_step=0", {"steering_step": 0.0}, ["steering_step"]),
    ("command_step=nan", {"command_step": float("nan")}, ["command_step"]),
    ("throttle_scale=[1]", {"throttle_scale": [1.0]}, ["throttle_scale"]),
    ("throttle_floor=-0.1", {"throttle_floor": -0.1}, ["throttle_floor"]),
    ("throttle_floor='0.2'", {"throttle_floor": "0.2"}, ["throttle_floor"])]
PART_RUNS = [  # SteerlabPilot(donkey.pt).run(frame, speed)
    ("float frame", zeros(120, 160, 3, dtype=np.float64), None, ["float64"]),
    ("a list", zeros(120, 160, 3).tolist(), None, ["int64", "frame"]),
    ("640x480", zeros(480, 640, 3), None, ["480x640x3"]), ("gray", zeros(120, 160), None, ["120x160"]),
    ("JPEG bytes", JPEG, None, ["frame"]), ("speed -1", zeros(120, 160, 3), -1.0, ["speed"]),
    ("speed '3'", zeros(120, 160, 3), "3", ["speed"])]
RECORDINGS = [  # open_recording(*args, **kwargs)
    ("123", (123,), {}, ["recording", "123"]), ("None", (None,), {}, ["recording"]),
    ("frame_range=5", (SIM,), {"frame_range": 5}, ["range", "5"]),
    ("frame_range='5'", (SIM,), {"frame_range": "5"}, ["range", "5"]),
    ("frame_range='a:b'", (SIM,), {"frame_range": "a:b"}, ["range", "a:b"]),
    ("frame_range=(0, 100)", (SIM,), {"frame_range": (0, 100)}, ["range", "100"]),
    ("frame_range=(5, 2)", (SIM,), {"frame_range": (5, 2)}, ["range", "5"]),
    ("labels=123", (CH2,), {"labels": 123}, ["labels", "123"]),
    ("options='strict=true'", (SIM,), {"options": "strict=true"}, ["option"]),
    ("options={'full_lock_deg': 25} on a driving log", (SIM,), {"options": {"full_lock_deg": 25}}, ["full_lock_deg"]),
    ("options=[('strict', True)]", (SIM,), {"options": [("strict", True)]}, ["option"]),
    ("a checkpoint", (CK,), {}, ["a.pt"]), ("an ONNX file", (f"{F}/m.onnx",), {}, ["m.onnx"])]
CALLS = [  # label, "module:name", args, kwargs, hint
    ("load_config(nothere.yaml)", "steerlab.train.config:load_config", (f"{W}/nothere.yaml",), {}, ["nothere.yaml"]),
    ("load_config(c.yaml, overrides='train.lr=1')", "steerlab.train.config:load_config", (f"{F}/c.yaml",),
     {"overrides": "train.lr=1"}, ["overrides"]),
    ("load_config(a.pt)", "steerlab.train.config:load_config", (CK,), {}, ["a.pt"]),
    ("load_config(base=[1])", "steerlab.train.config:load_config", (None,), {"base": [1]}, ["config"]),
    ("train({'data': ...})", "steerlab.train.loop:train", ({"data": SIM},), {}, ["TrainConfig"]),
    ("train(None)", "steerlab.train.loop:train", (None,), {}, ["TrainConfig"]),
    ("train(c.yaml path)", "steerlab.train.loop:train", (f"{F}/c.yaml",), {}, ["TrainConfig"]),
    ("evaluate(a.pt, 'sim' as a str)", "steerlab.evaluate.offline:evaluate", (CK, SIM, f"{W}/ev-api"), {},
     ["Source"]),
    ("evaluate(123, Source)", "steerlab.evaluate.offline:evaluate", (123, Source(SIM), f"{W}/ev-api2"), {},
     ["checkpoint"]),
    ("evaluate(a.pt, Source, out=sim)", "steerlab.evaluate.offline:evaluate", (CK, Source(SIM), SIM), {}, ["sim"]),
    ("evaluate(a.pt, Source, camera='left')", "steerlab.evaluate.offline:evaluate", (CK, Source(SIM), f"{W}/ev-api3"),
     {"camera": "left"}, ["left"]),
    ("evaluate(a.pt, Source(range=5))", "steerlab.evaluate.offline:evaluate",
     (CK, Source(SIM, range=5), f"{W}/ev-api4"), {}, ["range"]),
    ("score(labels, a CH2 folder)", "steerlab.evaluate.scoring:score", (f"{CH2}/labels.csv", CH2), {}, ["ch2"]),
    ("score(predictions, labels) (swapped)", "steerlab.evaluate.scoring:score", (f"{F}/pred.csv", f"{CH2}/labels.csv"),
     {}, ["public", "pred.csv"]),
    ("export_onnx(a.pt, 'm')", "steerlab.export:export_onnx", (CK, f"{W}/m"), {}, [".onnx"]),
    ("export_onnx(a.pt, out over c.yaml)", "steerlab.export:export_onnx", (CK, f"{F}/c.yaml"), {}, ["c.yaml"]),
    ("export_onnx(m.onnx, ...)", "steerlab.export:export_onnx", (f"{F}/m.onnx", f"{W}/m2.onnx"), {}, ["m.onnx"]),
    ("save_ensemble([a.pt])", "steerlab.checkpoint:save_ensemble", ([CK], f"{W}/e1.pt"), {}, ["two"]),
    ("save_ensemble('a.pt', ...)", "steerlab.checkpoint:save_ensemble", (CK, f"{W}/e2.pt"), {}, ["checkpoints"]),
    ("save_ensemble([a.pt, b.pt], out=a.pt)", "steerlab.checkpoint:save_ensemble", ([CK, f"{F}/b.pt"], CK), {},
     ["a.pt"]),
    ("load_checkpoint(m.onnx)", "steerlab.checkpoint:load_checkpoint", (f"{F}/m.onnx",), {}, ["m.onnx"]),
    ("load_checkpoint(tub folder)", "steerlab.checkpoint:load_checkpoint", (TUB,), {}, ["tub"]),
    ("load_checkpoint(None)", "steerlab.checkpoint:load_checkpoint", (None,), {}, ["checkpoint"]),
    ("read_steering_csv(driving_log.csv)", "steerlab.evaluate.scoring:read_steering_csv", (f"{SIM}/driving_log.csv",),
     {}, ["driving_log.csv"])]
UNITS = [  # label, the options class, its values, what is expected (a number in other units is said), hint
    ("ReplayOptions(fov=1.2) (radians?)", "steerlab.sim.replay.run:ReplayOptions", {"fov": 1.2}, "warn", ["fov"]),
    ("ReplayOptions(mount_height=150) (cm?)", "steerlab.sim.replay.run:ReplayOptions", {"mount_height": 150.0},
     "warn", ["mount_height"]),
    ("ReplayOptions(workers='2')", "steerlab.sim.replay.run:ReplayOptions", {"workers": "2"}, "refuse", ["workers"]),
    ("TrackDriveOptions(lane_width=60) (cm?)", "steerlab.sim.track.world:TrackDriveOptions", {"lane_width": 60.0},
     "warn", ["lane_width"]),
    ("TrackDriveOptions(latency=50) (ms?)", "steerlab.sim.track.world:TrackDriveOptions", {"latency": 50.0}, "warn",
     ["latency"]),
    ("DriveOptions(limit_m='100')", "steerlab.sim.road.world:DriveOptions", {"limit_m": "100"}, "refuse",
     ["limit_m"]),
    ("RecordOptions(geometry='donkey')", "steerlab.sim.road.world:RecordOptions", {"geometry": "donkey"}, "refuse",
     ["geometry"]),
    ("RecordOptions(road='Twisty')", "steerlab.sim.road.world:RecordOptions", {"road": "Twisty"}, "refuse", ["road"])]

CASES = [
    *[{"name": label, "api": "steerlab.pilot:Pilot", "args": args, "kwargs": kw, "hint": hint}
      for label, args, kw, hint in PILOTS],
    *[{"name": f"Pilot.step({label})", "api": f"{HERE}:step", "args": (frame,), "hint": hint}
      for label, frame, hint in FRAMES],
    {"name": "Pilot.step(jpeg bytes)", "api": f"{HERE}:step", "args": (JPEG,), "expect": "ok"},
    *[{"name": f"Pilot.step(frame, speed={label})", "api": f"{HERE}:step", "args": (zeros(), speed), "expect": expect,
       "hint": ["speed"]} for label, speed, expect in SPEEDS],
    *[{"name": f"Pilot.stream({label})", "api": f"{HERE}:stream", "args": (frames, speeds, load), "hint": hint}
      for label, frames, speeds, load, hint in STREAMS],
    {"name": "Pilot.stream([0, 1], load=a function)", "api": f"{HERE}:stream", "args": ([0, 1], None, zeros_of),
     "expect": "ok"},
    *[{"name": f"SteerlabPilot(donkey.pt, {label})", "api": "steerlab.donkey:SteerlabPilot", "args": (DK,),
       "kwargs": kw, "hint": hint} for label, kw, hint in PARTS],
    {"name": "SteerlabPilot(a tub folder)", "api": "steerlab.donkey:SteerlabPilot", "args": (TUB,), "hint": ["tub"]},
    {"name": "SteerlabPilot(None)", "api": "steerlab.donkey:SteerlabPilot", "args": (None,), "hint": ["model"]},
    *[{"name": f"SteerlabPilot.run({label})", "api": f"{HERE}:part_run", "args": (frame, speed), "hint": hint}
      for label, frame, speed, hint in PART_RUNS],
    *[{"name": f"open_recording({label})", "api": "steerlab.data.readers:open_recording", "args": args, "kwargs": kw,
       "hint": hint} for label, args, kw, hint in RECORDINGS],
    {"name": "open_recording(sim, frame_range=[0, 4])", "api": "steerlab.data.readers:open_recording", "args": (SIM,),
     "kwargs": {"frame_range": [0, 4]}, "expect": "ok"},
    *[{"name": label, "api": call, "args": args, "kwargs": kw, "hint": hint} for label, call, args, kw, hint in CALLS],
    *[{"name": label, "api": cls, "kwargs": kw, "expect": expect, "hint": hint}
      for label, cls, kw, expect, hint in UNITS],
]
for row in CASES:
    row["group"] = "D"


def _frame(frame):
    return frame.read() if isinstance(frame, Bytes) else frame


def step(frame, speed=None):
    from steerlab.pilot import Pilot

    return Pilot(str(places.FIX / "a.pt")).step(_frame(frame), speed)


def stream(frames, speeds=None, load=None):
    from steerlab.pilot import Pilot

    return list(Pilot(str(places.FIX / "a.pt")).stream(frames, speeds, load))


def part_run(frame, speed=None):
    from steerlab.donkey import SteerlabPilot

    return SteerlabPilot(str(places.FIX / "donkey.pt")).run(_frame(frame), speed)
