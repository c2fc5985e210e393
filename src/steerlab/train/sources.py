"""What training learns from, assembled from a config: the compiled dataset, the usable frames of a split, and
the training sources (centre camera, side cameras and virtual views with recovery labels, extra recordings),
which `batches.FrameBatches` gathers into standardised batches. Experiments, DAgger and the benchmarks build
their data with the same functions as `train`."""

from __future__ import annotations

import math
from dataclasses import replace
from functools import partial

import numpy as np

from steerlab.data.car import CARS, throttle_speeds
from steerlab.data.dataset import CompiledDataset, compile_recording
from steerlab.data.geometry import CAMERAS
from steerlab.data.path import human_path, view_steering
from steerlab.data.preprocess import CROP_PRESETS
from steerlab.data.readers import open_recording
from steerlab.data.recording import Recording, SteeringConvention
from steerlab.data.sense import check_sense
from steerlab.data.views import FISHEYE_GEOMETRY, View, lens_of
from steerlab.errors import DataError, SteerlabError
from steerlab.train.config import TrainConfig, TrainOptions, say_without_views


def main_recording(cfg: TrainConfig) -> Recording:
    """The config's recording: its frame range, labels and reader options."""
    return open_recording(cfg.data, cfg.range, cfg.labels, cfg.reader, cfg.cache)


def check_camera(cfg: TrainConfig, rec: Recording) -> None:
    """A recording of another camera than the config's crop preset is for is refused."""
    preset = cfg.preprocess.preset
    if preset is not None and rec.geometry in CROP_PRESETS and rec.geometry != preset:
        raise SteerlabError(f"{rec.source} holds frames of the {rec.geometry!r} camera; the config's preprocess.preset "
                            f"{preset} is for the {preset!r} camera: train it on recordings of that camera")


def check_extra_data(cfg: TrainConfig, main: Recording) -> None:
    """Recordings that do not belong together are not mixed: `extra_data` whose steering means other angles than
    the config's data, or whose frames come from another camera, is refused before any work (each is opened, not
    compiled)."""
    for path in cfg.extra_data:
        rec = open_recording(path, cache=cfg.cache)
        if not rec.convention.matches(main.convention):
            raise SteerlabError(f"extra_data {path} records {rec.convention.describe()} steering and the config's "
                                f"data {main.convention.describe()}: the targets would mean different angles; give "
                                "recordings of one car (extra_data is read with the readers' default options)")
        if rec.geometry != main.geometry:
            raise SteerlabError(f"extra_data {path} holds frames of the {rec.geometry!r} camera and the config's "
                                f"data of the {main.geometry!r} camera: a model sees one camera; give recordings of "
                                "one camera geometry")
        check_views(cfg, rec, main.convention)


def prepare_dataset(cfg: TrainConfig, progress: bool = True, camera: str | None = None, view: View | None = None,
                    data: str | None = None) -> CompiledDataset:
    """The compiled main recording of a config (or the whole recording `data`), one camera stream of it, or a
    virtual view synthesised from its centre camera (through its fisheye, `views.lens_of`, for the donkey
    camera)."""
    rec = main_recording(cfg) if data is None else open_recording(data, cache=cfg.cache)
    check_camera(cfg, rec)
    camera = camera or cfg.camera
    if camera not in rec.frames:
        raise SteerlabError(f"{rec.source} has no {camera!r} camera (it has {', '.join(rec.cameras)}): "
                            "choose one of them")
    if view is not None and rec.geometry not in CAMERAS:
        raise SteerlabError(f"viewpoint shifts need the camera geometry of the recording; {rec.source} has the "
                            f"{rec.geometry!r} preset, and geometry is known for {', '.join(CAMERAS)}")
    lens = None if view is None else lens_of(rec, cfg.train.calibration)
    return compile_recording(rec, cfg.preprocessing(rec.geometry), cfg.cache, camera, progress=progress, view=view,
                             lens=lens)


def usable_frames(ds: CompiledDataset, idx: np.ndarray, name: str, min_speed: float = 0.0,
                  exclude_episodes=()) -> np.ndarray:
    """The frames of a split that training may use: optionally only those at `min_speed` m/s or faster
    (paper 002 V-A drops frames slower than 4 m/s) and outside the excluded episodes."""
    if min_speed:
        if "speed" not in ds.labels:
            raise SteerlabError(f"train.min_speed needs a recording with speed; {ds.meta['source']} has none")
        idx = idx[ds.labels["speed"][idx] >= min_speed]
    if exclude_episodes:
        if "episode" not in ds.labels:
            raise SteerlabError("train.exclude_episodes needs a recording with episode labels (the road and track "
                                "worlds')")
        idx = idx[~np.isin(ds.labels["episode"][idx], list(exclude_episodes))]
    if len(idx) == 0:
        if min_speed:
            top = float(np.max(ds.labels["speed"])) if len(ds.labels["speed"]) else 0.0
            raise SteerlabError(f"the {name} split is empty once frames slower than train.min_speed={min_speed:g} m/s "
                                f"are dropped ({ds.meta['source']} drives at most {top:.3g} m/s): lower "
                                "train.min_speed, or give the split more frames")
        excluded = f" once the episodes {list(exclude_episodes)} are excluded" if exclude_episodes else ""
        raise SteerlabError(f"the {name} split is empty{excluded}: give it more frames")
    return idx


def recovery_labels(ds: CompiledDataset, steering: np.ndarray, shift_m, yaw_deg, t: TrainOptions) -> np.ndarray:
    """The steering that brings a car `shift_m` left of where the recording was made, turned `yaw_deg` to the
    left, back to the recorded path (paper 002 Eq. 3, with the turn added): theta_f = theta_r +
    arctan(-d_y / L) - yaw as a road-wheel angle (positive left), where L = speed * t_r is the distance in which
    the car returns (t_r = `recovery_s`; `recovery_distance_m` when the recording has no speed); `shift_m` and
    `yaw_deg` a number or one per frame. Converted back
    to the recording's convention (steering-wheel recordings use the steering ratio `t.steering_ratio`, which
`TrainConfig.for_car` takes from the car)."""
    if "speed" in ds.labels:
        distance = np.maximum(ds.labels["speed"], 1.0) * t.recovery_s
    elif t.recovery_distance_m:
        distance = t.recovery_distance_m
    else:
        raise SteerlabError(f"{ds.meta['source']} has no speed: set train.recovery_distance_m, the distance in "
                            "which a displaced car returns to its path, for side cameras or viewpoint shifts")
    conv = SteeringConvention(**ds.meta["convention"])
    correction = np.arctan(-shift_m / distance) - np.radians(yaw_deg)
    return steering + conv.from_road_wheel_left(correction, t.steering_ratio)


def view_labels(ds: CompiledDataset, steering: np.ndarray, view: View, t: TrainOptions,
                convention: SteeringConvention | None = None) -> np.ndarray:
    """The targets of a view: the frame's target `steering` plus the correction that brings its car back to the
    recorded path. For the donkey camera (a small car) the correction of `path.view_steering`: the path rebuilt
    from the recorded steering and the speed (from the throttle through the small car's motor model where none is
    recorded, as replay does), pure pursuit with the car's wheelbase of the point `recovery_s` of travel ahead on
    it (replay's own return pursues 0.9 s ahead), the result within the full lock; for other cameras paper 002's
    Eq. 3 (`recovery_labels`, returning within `recovery_s`). The frames' offsets are the ones their compile drew
    (`view_shift_m`, `view_yaw_deg`). `convention`: the steering's (default the recording's; an extra recording's is
    the config's data's, whose reader options give the full lock, which is the car's)."""
    labels = ds.labels
    shift, yaw = (labels["view_shift_m"], labels["view_yaw_deg"]) if "view_shift_m" in labels else view.offsets(len(ds))
    if ds.meta["geometry"] != FISHEYE_GEOMETRY:
        return recovery_labels(ds, steering, shift, yaw, t)
    conv = convention or SteeringConvention(**ds.meta["convention"])
    try:
        recorded = conv.to_road_wheel_left(labels["steering"], t.steering_ratio)
        target = conv.to_road_wheel_left(steering, t.steering_ratio)
    except SteerlabError as e:
        raise SteerlabError(f"{ds.meta['source']}: train.views of a small car rebuild its path from the steering: "
                            f"{e}") from None
    car = CARS[FISHEYE_GEOMETRY]
    if conv.full_lock is not None:  # the reader's full lock is this car's
        car = replace(car, full_lock_deg=math.degrees(conv.full_lock))
    times = labels["timestamps_ns"] / 1e9
    out = np.empty(len(ds))
    seg = labels["segment"]
    for a, b in zip(np.flatnonzero(np.diff(seg, prepend=-1)), [*np.flatnonzero(np.diff(seg)) + 1, len(seg)]):
        speed = labels["speed"][a:b] if "speed" in labels else throttle_speeds(labels["throttle"][a:b], times[a:b],
                                                                                 car)
        path = human_path(recorded[a:b], speed, times[a:b], car)
        out[a:b] = target[a:b] + view_steering(path, shift[a:b], yaw[a:b], car, t.recovery_s) - path.wheel
    return conv.from_road_wheel_left(np.clip(out, -car.full_lock, car.full_lock), t.steering_ratio).astype(np.float32)


def check_views(cfg: TrainConfig, rec: Recording, convention: SteeringConvention | None = None) -> None:
    """What views of a recording need, refused before any frame is compiled: its lens (`views.lens_of`: a
    calibration that reads and fits), and for a small car's recording frames that turn the way its steering says
    (`sense.check_sense`), the speed or throttle and a steering that becomes an angle (the reader's full lock) to
    rebuild its path from. A tub on the tub defaults without views is
    told what it misses (`say_without_views`)."""
    if not cfg.train.views:
        say_without_views(cfg, (convention or rec.convention).full_lock is not None)
        return
    lens = lens_of(rec, cfg.train.calibration)
    if rec.geometry != FISHEYE_GEOMETRY:
        return
    check_sense(rec, lens.mirrored, "its views")
    if rec.speed is None and rec.throttle is None:
        raise DataError(rec.source, "records neither speed nor throttle: train.views of a small car need the speed "
                                    "it drove at (from the throttle, as replay takes it); train without views "
                                    "(train.views=[])")
    try:
        (convention or rec.convention).to_road_wheel_left(0.0, cfg.train.steering_ratio or 1.0)
    except SteerlabError as e:
        raise DataError(rec.source, f"train.views of a small car rebuild its path from the steering: {e}") from None


def steering_ahead(ds: CompiledDataset, seconds: float, steering: np.ndarray | None = None) -> np.ndarray:
    """Each frame's target is the steering (`steering`, default the recorded one) `seconds` later in its
    segment (the segment's last value at its end)."""
    steering = ds.steering if steering is None else steering
    if not seconds:
        return steering
    k = int(round(seconds * ds.meta["frame_rate"]))
    seg = ds.labels["segment"]
    last = np.r_[np.flatnonzero(np.diff(seg)), len(seg) - 1]  # each segment's last frame
    return steering[np.minimum(np.arange(len(seg)) + k, last[seg])]


def teacher_steering(cfg: TrainConfig, teacher: dict, progress: bool) -> np.ndarray:
    """Distillation (`train.teacher`): the steering a trained checkpoint (an ensemble, say) predicts for every
    frame of the config's recording, streamed segment by segment as the Pilot drives; it replaces the recorded
    steering as the training target of the main recording (validation still scores against the recording)."""
    from tqdm import tqdm

    from steerlab.pilot import Pilot

    rec = main_recording(cfg)
    pilot = Pilot(teacher)
    where = f"{cfg.train.teacher}: train.teacher"
    if not pilot.convention.matches(rec.convention):
        raise SteerlabError(f"{where} predicts {pilot.convention.describe()} steering and {rec.source} records "
                            f"{rec.convention.describe()} steering: a teacher of the recording's convention is needed")
    if pilot.geometry != rec.geometry:
        raise SteerlabError(f"{where} was trained on the {pilot.geometry!r} camera geometry and {rec.source} has "
                            f"the {rec.geometry!r} geometry: give a teacher of this recording's camera")
    out = []
    with tqdm(total=len(rec), desc="teacher", unit="frame", disable=None if progress else True) as bar:
        for a, b in rec.segments():
            pilot.reset()
            speeds = None if rec.speed is None else rec.speed[a:b]
            for c in pilot.stream(range(a, b), speeds, partial(rec.load_frame, camera=cfg.camera)):
                out.append(c.steering)
                bar.update()
    return np.asarray(out, np.float32)


def training_sources(cfg: TrainConfig, ds: CompiledDataset, train_idx: np.ndarray, progress: bool,
                     teacher: dict | None = None):
    """The training streams and the codes of their training frames (see `batches.FrameBatches`): the main
    recording's training split and every usable frame of the extra recordings, each with its side cameras
    (`side_cameras`; an extra recording without them adds its centre frames only) and virtual views (`views`:
    [shift_m, yaw_deg] pairs) labelled with the recovery steering. With a `teacher` checkpoint the main
    recording's targets are its predictions."""
    t = cfg.train
    taught = None if teacher is None else teacher_steering(cfg, teacher, progress)
    recordings = [(None, ds, train_idx, True)]
    for path in cfg.extra_data:
        extra = prepare_dataset(cfg, progress, data=path)
        idx = usable_frames(extra, np.arange(len(extra)), f"extra recording {path}", t.min_speed,
                            t.exclude_episodes)
        recordings.append((path, extra, idx, {"left", "right"} <= set(open_recording(path).cameras)))
    sources, codes, offset = [], [], 0
    convention = SteeringConvention(**ds.meta["convention"])  # the config's data's: the reader's full lock
    for path, main, idx, sides in recordings:
        ahead = steering_ahead(main, t.target_shift_s, taught if path is None else None)
        streams = [(main, ahead)]
        if t.side_cameras and sides:
            for cam, sign in (("left", 1.0), ("right", -1.0)):
                side = prepare_dataset(cfg, progress, camera=cam, data=path)
                streams.append((side, recovery_labels(side, ahead, sign * t.side_offset_m, 0.0, t)))
        for k, view in enumerate(t.views):
            view = replace(view, draw=k)
            warped = prepare_dataset(cfg, progress, view=view, data=path)
            streams.append((warped, view_labels(warped, ahead, view, t, convention)))
        for stream in streams:
            sources.append(stream)
            codes.append(idx + offset)
            offset += len(main)
    return sources, np.concatenate(codes)


def throttle_learned(cfg: TrainConfig, ds: CompiledDataset, say: bool) -> bool:
    """Whether the model learns the throttle: `train.throttle_weight` > 0 and the recording's throttle varies
    (said once when it does not)."""
    if not cfg.train.throttle_weight:
        return False
    throttle = ds.labels.get("throttle")
    if throttle is not None and np.ptp(throttle) > 0:
        return True
    if say:
        why = "has no throttle" if throttle is None else f"has a constant throttle ({throttle[0]:g})"
        print(f"{ds.meta['source']} {why}: the model learns the steering alone (train.throttle_weight ignored)")
    return False
