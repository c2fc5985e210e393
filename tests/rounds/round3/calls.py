"""Group D of the third round, its Python API calls with wrong types and units: (label, "module:name", args,
kwargs, hint, expect), and the calls that need code."""

from pathlib import Path

import numpy as np

from tests.rounds import places
from tests.rounds.round3.common import CK, SIM, TUB, DK, LANE, TRK, WOOD, CAL

HERE = __name__


API = [  # (label, "module:name", args, kwargs, hint, expect)
    ("View(0.5, 10)", "steerlab.data.views:View", (0.5, 10), {}, ["shift_m"], "refuse"),
    ("View([0.5, 0.5], [10, 10])", "steerlab.data.views:View", ([0.5, 0.5], [10, 10]), {}, ["shift_m"], "refuse"),
    ("View((0.5, 0.5), (10, 10))", "steerlab.data.views:View", ((0.5, 0.5), (10, 10)), {}, [], "ok"),
    ("View((np.float32 0.1, ...))", "steerlab.data.views:View", ((np.float32(0.1), np.float32(0.1)), (0.0, 0.0)), {},
     ["shift_m"], "ok"),
    ("View((0.1, 0.1), (0.26, 0.26)) (radians)", "steerlab.data.views:View", ((0.1, 0.1), (0.26, 0.26)), {}, [],
     "ok"),
    ("View((0.1, 0.1), (0, 0), draw='1')", "steerlab.data.views:View", ((0.1, 0.1), (0.0, 0.0)), {"draw": "1"},
     ["draw"], "refuse"),
    ("View((0.1, 0.1), (0, 0), draw=-1)", "steerlab.data.views:View", ((0.1, 0.1), (0.0, 0.0)), {"draw": -1},
     ["draw"], "refuse"),
    ("View((nan, nan), (0, 0))", "steerlab.data.views:View", ((float("nan"),) * 2, (0.0, 0.0)), {}, ["shift_m"],
     "refuse"),
    ("View.parse_option([0.5, '10deg'])", f"{HERE}:parse_view", ([0.5, "10deg"],), {}, ["10deg", "yaw_deg"],
     "refuse"),
    ("View.parse_option('0.5,10')", f"{HERE}:parse_view", ("0.5,10",), {}, ["0.5,10"], "refuse"),
    ("View.parse_option({'shift_m': 0.5, 'yaw_deg': 10})", f"{HERE}:parse_view", ({"shift_m": 0.5, "yaw_deg": 10},),
     {}, ["shift_m", "pair"], "refuse"),
    ("View.parse_option(np.array([0.5, 10]))", f"{HERE}:parse_view", (np.array([0.5, 10.0]),), {},
     ["pair", "array"], "ok"),
    ("View(...).offsets(-1)", f"{HERE}:view_offsets", (-1,), {}, ["n", "-1"], "refuse"),
    ("View(...).offsets(2.5)", f"{HERE}:view_offsets", (2.5,), {}, ["n", "2.5"], "refuse"),
    ("load_config(views as a text)", "steerlab.train.config:load_config", (None,),
     {"base": {"data": SIM, "train": {"views": "[[0.5, 10]]"}}}, ["views"], "refuse"),
    ("load_config(views of a View)", f"{HERE}:config_with_view", (), {}, [], "ok"),
    ("load_config(recovery_s='0.3')", "steerlab.train.config:load_config", (None,),
     {"base": {"data": SIM, "train": {"recovery_s": "0.3"}}}, ["recovery_s"], "refuse"),
    ("load_config(calibration=Path)", "steerlab.train.config:load_config", (None,),
     {"base": {"data": TUB, "train": {"views": [[0.1, 5]], "calibration": Path(CAL)}}}, ["calibration"], "ok"),
    ("load_config(lane_weight=True)", "steerlab.train.config:load_config", (None,),
     {"base": {"data": TRK, "train": {"lane_weight": True}}}, ["lane_weight"], "refuse"),
    ("TrainOptions(views=[[0.5, 10]]) directly", f"{HERE}:train_options", (), {"views": [[0.5, 10]]}, ["views"],
     "ok"),
    ("TrainOptions(views=((0.5, 10),)) directly, then a config", f"{HERE}:train_config_direct", (),
     {"views": ((0.5, 10),)}, ["views"], "ok"),
    ("TrainOptions(views=((9, 0),)) directly, then a config", f"{HERE}:train_config_direct", (),
     {"views": ((9, 0),)}, ["views", "2"], "refuse"),
    ("TrainOptions(views='[[0.5, 10]]') directly, then a config", f"{HERE}:train_config_direct", (),
     {"views": "[[0.5, 10]]"}, ["views"], "refuse"),
    ("TrainOptions(lane_weight='0.5')", f"{HERE}:train_options", (), {"lane_weight": "0.5"}, ["lane_weight"],
     "refuse"),
    ("TrainOptions(calibration=123)", f"{HERE}:train_options", (), {"calibration": 123}, ["calibration"], "refuse"),
    ("TrackDriveOptions(throttle_floor=20)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_floor": 20.0}, ["throttle_floor"], "refuse"),
    ("TrackDriveOptions(throttle_floor='0.2')", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_floor": "0.2"}, ["throttle_floor"], "refuse"),
    ("TrackDriveOptions(throttle_scale=0)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_scale": 0.0}, ["throttle_scale"], "refuse"),
    ("TrackDriveOptions(throttle_scale=np.float64(1.2))", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_scale": np.float64(1.2)}, ["throttle_scale"], "ok"),
    ("TrackDriveOptions(steer_by='Lane')", "steerlab.sim.track.world:TrackDriveOptions", (), {"steer_by": "Lane"},
     ["steer_by"], "refuse"),
    ("TrackDriveOptions(steer_by=True)", "steerlab.sim.track.world:TrackDriveOptions", (), {"steer_by": True},
     ["steer_by"], "refuse"),
    ("TrackDriveOptions(latency=0.05) (seconds)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"latency": 0.05}, ["latency"], "refuse"),
    ("TrackDriveOptions(light=55)", "steerlab.sim.track.world:TrackDriveOptions", (), {"light": 55.0}, ["light"],
     "refuse"),
    ("TrackDriveOptions(throttle_floor=0.6, max_throttle=0.5)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_floor": 0.6, "max_throttle": 0.5}, ["throttle_floor", "max_throttle"], "refuse"),
    ("TrackSuiteOptions(steer_by='lanes')", "steerlab.sim.track.suite:TrackSuiteOptions", (), {"steer_by": "lanes"},
     ["steer_by"], "refuse"),
    ("TrackSuiteOptions(throttle_floor=-0.1)", "steerlab.sim.track.suite:TrackSuiteOptions", (),
     {"throttle_floor": -0.1}, ["throttle_floor"], "refuse"),
    ("TrackReplayOptions(mount_height=15) (cm)", "steerlab.sim.track.replay:TrackReplayOptions", (),
     {"mount_height": 15.0}, ["mount_height"], "refuse"),
    ("TrackReplayOptions(pitch=0.35) (radians)", "steerlab.sim.track.replay:TrackReplayOptions", (), {"pitch": 0.35},
     ["pitch"], "ok"),
    ("TrackReplayOptions(calibration=Path)", "steerlab.sim.track.replay:TrackReplayOptions", (),
     {"calibration": Path(CAL)}, ["calibration"], "refuse"),
    ("TrackReplayOptions(lane_width=90) (cm)", "steerlab.sim.track.replay:TrackReplayOptions", (),
     {"lane_width": 90.0}, ["lane_width"], "warn"),
    ("SteerlabPilot(lane.pt, steer_by='Lane')", "steerlab.donkey:SteerlabPilot", (LANE,), {"steer_by": "Lane"},
     ["steer_by", "Lane"], "refuse"),
    ("SteerlabPilot(donkey.pt, steer_by='lane')", "steerlab.donkey:SteerlabPilot", (DK,), {"steer_by": "lane"},
     ["lane", "donkey.pt"], "refuse"),
    ("SteerlabPilot(lane.pt, steer_by='lane')", "steerlab.donkey:SteerlabPilot", (LANE,), {"steer_by": "lane"}, [],
     "ok"),
    ("SteerlabPilot(lane.pt, steer_by=None)", "steerlab.donkey:SteerlabPilot", (LANE,), {"steer_by": None},
     ["steer_by"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_floor=20)", "steerlab.donkey:SteerlabPilot", (DK,), {"throttle_floor": 20.0},
     ["throttle_floor"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_scale=0)", "steerlab.donkey:SteerlabPilot", (DK,), {"throttle_scale": 0.0},
     ["throttle_scale"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_scale='1.2')", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_scale": "1.2"}, ["throttle_scale"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_scale=120) (percent)", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_scale": 120.0}, ["throttle_scale"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_floor=0.6, max_throttle=0.5)", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_floor": 0.6, "max_throttle": 0.5}, ["throttle_floor", "max_throttle"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_floor=nan)", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_floor": float("nan")}, ["throttle_floor"], "refuse"),
    ("SteerlabPilot(lane.pt, steer_by='lane').run(BGR 120x160 frame)", f"{HERE}:lane_run", (), {}, [], "ok"),
    ("SteerlabPilot(lane.pt, steer_by='lane').run(a 160x320 frame)", f"{HERE}:lane_run", ((160, 320, 3),), {},
     ["160x320", "120x160"], "refuse"),
    ("Pilot(lane.pt).step(frame, speed=40 km/h)", f"{HERE}:lane_step", (40.0,), {}, ["speed"], "warn"),
    ("open_recording(wood-tape, full_lock_deg=0.44)", "steerlab.data.readers:open_recording", (WOOD,),
     {"options": {"full_lock_deg": 0.44}}, ["full_lock_deg"], "warn"),
    ("open_recording(wood-tape, frame_range=(0.0, 4.0))", "steerlab.data.readers:open_recording", (WOOD,),
     {"frame_range": (0.0, 4.0)}, ["range"], "refuse"),
    ("open_recording(wood-tape, frame_range=(0, 9000))", "steerlab.data.readers:open_recording", (WOOD,),
     {"frame_range": (0, 9000)}, ["9000", "8000"], "refuse"),
    ("open_recording(wood-tape, options={'skip_missing': 'true'})", "steerlab.data.readers:open_recording", (WOOD,),
     {"options": {"skip_missing": "true"}}, ["skip_missing"], "refuse"),
    ("open_recording(wood-tape/manifest.json)", "steerlab.data.readers:open_recording",
     (f"{WOOD}/manifest.json",), {}, ["manifest.json"], "refuse"),
    ("open_recording(bytes path)", "steerlab.data.readers:open_recording", (b"/tmp/x",), {}, ["recording", "path"],
     "refuse"),
    ("Source(wood-tape, range=(0, 20)) evaluate", f"{HERE}:evaluate_source", ((0, 20),), {}, ["range"], "ok"),
    ("Source(wood-tape, range='0:20', reader='skip_missing=true') evaluate", f"{HERE}:evaluate_source", ("0:20",),
     {"reader": "skip_missing=true"}, ["reader"], "refuse"),
    ("evaluate(donkey.pt, Source(wood-tape), out=a.pt)", f"{HERE}:evaluate_source", ("0:20",), {"out": CK},
     ["a.pt"], "refuse"),
    ("load_calibration(cal.json, base=None)", "steerlab.data.fisheye:load_calibration", (CAL,), {"base": None},
     ["base", "FisheyeCamera"], "refuse"),
    ("load_calibration(123)", "steerlab.data.fisheye:load_calibration", (123,), {}, ["123", "calibration"],
     "refuse"),
    ("load_calibration(a.pt)", "steerlab.data.fisheye:load_calibration", (CK,), {}, ["a.pt"], "refuse"),
    ("load_calibration(the tub folder)", "steerlab.data.fisheye:load_calibration", (TUB,), {}, ["tub"], "refuse"),
    ("lens_of(sim recording, calibration)", f"{HERE}:lens_of_sim", (), {}, ["cal.json", "donkey"], "refuse"),
    ("warp(frame, 'sim', None, shift 3 m)", f"{HERE}:warp_frame", ("sim", 3.0, 0.0), {}, ["shift", "2"], "ok"),
    ("warp(frame, 'nothere', None, 0.1, 0)", f"{HERE}:warp_frame", ("nothere", 0.1, 0.0), {}, ["nothere"],
     "refuse"),
    ("warp(frame, 'sim', None, 0.1, 0.26 (radians))", f"{HERE}:warp_frame", ("sim", 0.1, 0.26), {}, [], "ok"),
    ("warp(float frame, 'sim', None, 0.1, 5)", f"{HERE}:warp_frame", ("sim", 0.1, 5.0), {"dtype": "float32"},
     ["uint8", "float32", "frame"], "ok"),  # warp: an inner function, its frames checked where they enter
]


def parse_view(value):
    from steerlab.data.views import View

    return View.parse_option(value, "train.views[0]")


def view_offsets(n):
    from steerlab.data.views import View

    return View((0.0, 0.1), (0.0, 5.0)).offsets(n)


def config_with_view():
    from steerlab.data.views import View
    from steerlab.train.config import load_config

    return load_config(None, base={"data": str(places.FIX / "sim"), "train": {"views": [View((0.5, 0.5),
                                                                                             (10.0, 10.0))]}})


def train_options(**kw):
    from steerlab.train.config import TrainOptions

    return TrainOptions(**kw)


def train_config_direct(**kw):
    from steerlab.train.config import TrainConfig, TrainOptions

    return TrainConfig(data=str(places.FIX / "sim"), train=TrainOptions(**kw))


def lane_run(size=(120, 160, 3)):
    from steerlab.donkey import SteerlabPilot

    return SteerlabPilot(str(places.FIX / "lane.pt"), steer_by="lane").run(np.zeros(size, np.uint8))


def lane_step(speed):
    from steerlab.pilot import Pilot

    return Pilot(str(places.FIX / "lane.pt")).step(np.zeros((120, 160, 3), np.uint8), speed)


def evaluate_source(rng, reader=None, out=None):
    from steerlab.data.readers import Source
    from steerlab.evaluate.offline import evaluate

    src = Source(places.fill(WOOD), rng, reader=reader) if reader is not None else Source(places.fill(WOOD), rng)
    return evaluate(str(places.FIX / "donkey.pt"), src, out or str(places.WORK / "ev-src"), progress=False)


def lens_of_sim():
    from steerlab.data.readers import open_recording
    from steerlab.data.views import lens_of

    return lens_of(open_recording(str(places.FIX / "sim")), str(places.FIX / "cal.json"))


def warp_frame(geometry, shift, yaw, dtype="uint8"):
    from steerlab.data.views import warp

    return warp(np.zeros((160, 320, 3), dtype), geometry, None, shift, yaw)
