"""Open-loop evaluation of a checkpoint on a recording, frame by frame through the Pilot."""

from __future__ import annotations

from itertools import islice
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.data.car import car_of
from steerlab.data.labels import speed_targets
from steerlab.data.readers import Source, a_source
from steerlab.data.recording import read_image
from steerlab.evaluate.metrics import SMOOTHING_ALPHA, all_metrics, exponential_smoothing, steering_metrics
from steerlab.errors import SteerlabError, warn
from steerlab.files import write_json
from steerlab.evaluate.plots import plot_steering
from steerlab.evaluate.scoring import write_predictions
from steerlab.paths import a_path, check_outputs
from steerlab.pilot import Pilot
from steerlab.video import DriveVideo



def evaluate(checkpoint: str | Path, source: Source, out: str | Path, camera: str = "center",
             video: str | Path | None = None, progress: bool = True, allow_convention_mismatch: bool = False,
             other_camera: bool = False) -> dict:
    """Run the Pilot over every frame of the recording of `source` (resetting at segment starts, feeding the
    recorded speed); write metrics (with speed MAE and command accuracy for speed models), predictions and a
    plot, and optionally a video of the frames with the predicted and the recorded steering.

    A checkpoint whose steering convention is not the recording's is refused, since its metrics would mix
    units; with `allow_convention_mismatch` it is evaluated with a warning, its predictions converted to the
    recording's convention (or compared unconverted where normalized steering has no full-lock angle). A
    recording of another camera geometry than the model's is refused too; with `other_camera` its frames are
    cropped and resized as the model's own would be, with a warning."""
    checkpoint, source = a_path(checkpoint, "evaluate: checkpoint"), a_source(source, "evaluate")
    check_outputs({"output folder": out}, {"video": video}, [checkpoint, source.data, source.labels], "evaluation")
    out = Path(out)
    rec = source.open()
    if camera not in rec.frames:
        raise SteerlabError(f"{rec.source} has no {camera!r} camera (it has {', '.join(rec.cameras)}): "
                            "choose one of them")
    pilot = Pilot(checkpoint, other_camera=other_camera)
    if pilot.speed_history and rec.speed is None:
        raise SteerlabError(f"model {pilot.name!r} needs the measured speed with every frame; {rec.source} has none")
    convert = None
    ratios = (car_of(pilot.geometry).steering_ratio, car_of(rec.geometry).steering_ratio)  # the model's, the data's
    if not pilot.convention.matches(rec.convention):
        what = (f"{checkpoint} predicts {pilot.convention.describe()} steering and {rec.source} records "
                f"{rec.convention.describe()} steering")
        if not allow_convention_mismatch:
            also = ("" if pilot.geometry in (None, rec.geometry) else f"; and the recording's camera geometry "
                    f"({rec.geometry}) is not the model's ({pilot.geometry}) either")
            raise SteerlabError(f"{what}: the metrics would mix units; evaluate it on recordings of its own "
                                f"convention, or run steerlab evaluate with --allow-convention-mismatch to convert its "
                                f"predictions{also}")
        try:
            pilot.convention.convert(0.0, rec.convention, *ratios)
            convert = lambda y: pilot.convention.convert(y, rec.convention, *ratios)  # noqa: E731
            warn(f"{what}: its predictions are converted to the recording's convention (steering ratios "
                 f"{ratios[0]:g} and {ratios[1]:g})")
        except SteerlabError:
            warn(f"{what}: normalized steering without a full-lock angle cannot be converted, so the metrics "
                 "compare unconverted values")
    if pilot.geometry is not None and pilot.geometry != rec.geometry:
        what = (f"{checkpoint} was trained on the {pilot.geometry!r} camera geometry and {rec.source} has the "
                f"{rec.geometry!r} geometry")
        if not other_camera:
            raise SteerlabError(f"{what}: evaluate it on recordings of its own camera, or run steerlab evaluate with "
                                "--allow-other-camera to crop and resize these frames anyway")
        warn(f"{what}: expect worse predictions than the model can make")
    if video:  # both sides are shown as a steering-wheel angle, which needs a physical scale
        try:
            for conv, ratio in zip((pilot.convention, rec.convention), ratios):
                conv.to_road_wheel_left(0.0, ratio)
        except SteerlabError as e:
            raise SteerlabError(f"cannot write {video} (it shows steering-wheel angles): {e}") from None
    out.mkdir(parents=True, exist_ok=True)  # only once the inputs are known to be good
    seg = rec.segment_ids()
    offsets = rec.extra.get("lateral_offset")

    def wheel(conv, ratio, y):  # the steering-wheel angle of the recording's car, positive left, for the video
        return conv.to_road_wheel_left(y, ratio) * ratios[1]

    if rec.video is None:  # image files: read and decoded on the Pilot's worker threads
        frames, load = iter(rec.frames[camera]), read_image
    else:  # a video decodes fastest in order, as it is read
        frames, load = (rec.load_frame(i, camera) for i in range(len(rec))), None
    controls = []
    with tqdm(total=len(rec), desc="evaluate", unit="frame", disable=None if progress else True) as bar:
        for a, b in rec.segments():  # the Pilot streams each segment from a fresh start
            pilot.reset()
            for c in pilot.stream(islice(frames, b - a), None if rec.speed is None else rec.speed[a:b], load):
                controls.append(c)
                bar.update()
    if video:  # drawn once the predictions are made, reading the frames again
        with DriveVideo(video, rec.frame_rate(), reference="recorded") as movie:
            for i, c in enumerate(controls):
                movie.add(rec.load_frame(i, camera), wheel(pilot.convention, ratios[0], c.steering),
                          wheel(rec.convention, ratios[1], rec.steering[i]), None if offsets is None else float(offsets[i]),
                          f"{rec.name}  frame {i}")
    pred = {"steering": np.array([c.steering for c in controls])}
    if convert:
        pred["steering"] = convert(pred["steering"])
    for k in ("speed", "command", "throttle"):
        if getattr(controls[0], k) is not None:
            pred[k] = np.array([getattr(c, k) for c in controls])
    truth = {"steering": rec.steering}
    if rec.speed is not None:
        truth.update(speed_targets(rec.speed, rec.timestamps_ns, seg))
    if rec.throttle is not None:
        truth["throttle"] = rec.throttle
    deg = rec.convention.degrees_per_unit
    metrics = all_metrics(pred, truth, deg)
    smooth = exponential_smoothing(pred["steering"], restarts=[a for a, _ in rec.segments()])
    metrics[f"smoothed_a{SMOOTHING_ALPHA}"] = steering_metrics(smooth, rec.steering, deg)
    write_predictions(out / "predictions.csv", rec.frame_ids, pred["steering"],
                      {k: v for k, v in pred.items() if k != "steering"})
    t = (rec.timestamps_ns - rec.timestamps_ns[0]) / 1e9
    plot_steering(out / "steering.png", t, rec.steering, {pilot.name: pred["steering"]},
                  title=f"{rec.name} {source.range or ''}: RMSE {metrics['rmse']:.4f} rad, "
                        f"gamma {metrics['gamma_deg']:.3f} vs target {metrics['target_gamma_deg']:.3f} deg",
                  throttle=(rec.throttle, pred["throttle"]) if "throttle" in metrics else None)
    write_json(out / "metrics.json", metrics)
    return metrics
