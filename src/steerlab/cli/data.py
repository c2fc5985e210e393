"""Subcommands on recordings and models: compile, evaluate, score, ensemble, export, latency, models."""

from __future__ import annotations

from pathlib import Path

from steerlab.cli import path_option, add_options, data_args, from_args, print_table, source
from steerlab.errors import SteerlabError

# printed when the model predicts speed, speed commands or the throttle
OUTPUT_METRICS = ["speed_mae", "command_accuracy", "throttle_mae", "throttle_rmse"]


def cmd_compile(a) -> None:
    from steerlab.data.dataset import compile_recording
    from steerlab.data.preprocess import PreprocessOptions
    from steerlab.options import parse

    rec = source(a).open(a.cache)
    pre = parse(PreprocessOptions, {"preset": a.preset, "color": a.color, "modalities": a.modalities.split(","),
                                    "flow": a.flow}, name=lambda f: f"--{f}").resolve(rec.geometry)
    if a.camera not in rec.frames:
        raise SteerlabError(f"{rec.source} has no {a.camera!r} camera (it has {', '.join(rec.cameras)}): "
                            "choose one of them with --camera")
    ds = compile_recording(rec, pre, a.cache, a.camera)
    print(f"{len(ds)} frames, {len(rec.segments())} segment(s) -> {ds.path}")
    for m, arr in ds.arrays.items():
        print(f"  {m}: {arr.shape} {arr.dtype}")


def cmd_evaluate(a) -> None:
    from steerlab.evaluate.offline import evaluate

    m = evaluate(a.checkpoint, source(a), a.out, a.camera, a.video,
                 allow_convention_mismatch=a.allow_convention_mismatch, other_camera=a.allow_other_camera)
    print_table(m, ["frames", "mse", "rmse", "mae", "mae_deg", "gamma_deg", "target_gamma_deg", "tre", "qce",
                    "speed_weighted_mae", *OUTPUT_METRICS])
    print(f"with exponential smoothing a=0.2: rmse {m['smoothed_a0.2']['rmse']:.6f}, "
          f"gamma {m['smoothed_a0.2']['gamma_deg']:.4f} deg")
    print(f"wrote {a.out}/predictions.csv, {a.out}/steering.png, {a.out}/metrics.json"
          + (f", {a.video}" if a.video else ""))


def cmd_score(a) -> None:
    from steerlab.evaluate.scoring import score

    print_table(score(a.truth, a.pred))


def cmd_export(a) -> None:
    from steerlab.export import export_onnx

    if a.int8 and a.calib is None:
        raise SteerlabError("--int8 needs calibration data: --calib RECORDING (frames like the ones it was trained on)")
    if not a.int8 and (a.calib or a.calib_range):
        raise SteerlabError("--calib and --calib-range calibrate an --int8 export: add --int8")
    out = export_onnx(a.checkpoint, a.out, a.calib, a.calib_range)
    print(f"wrote {out}{' (int8)' if a.int8 else ''}, preprocessing and statistics in its metadata (run it with "
          f"Pilot('{out}'), steerlab serve {out} or on a donkeycar: steerlab.donkey.SteerlabPilot('{out}'))")


def cmd_ensemble(a) -> None:
    from steerlab.checkpoint import save_ensemble

    out = Path(a.out)
    if out.suffix != ".pt":
        raise SteerlabError(f"{out}: the ensemble is a checkpoint: its file must end in .pt")
    save_ensemble(a.checkpoints, out)
    print(f"wrote {out}: the mean of {len(a.checkpoints)} models (evaluate, replay, drive or export it like any "
          "checkpoint)")


def cmd_latency(a) -> None:
    from steerlab.evaluate.latency import LatencyOptions, latency_table, run_latency

    rows = run_latency(a.checkpoints, from_args(LatencyOptions, a), source(a) if a.data else None, a.out)
    print(latency_table(rows))
    if a.out:
        print(f"wrote {a.out}/latency.csv, {a.out}/latency.md")


def cmd_models(a) -> None:
    from steerlab.models import list_models, model_class

    for name in list_models():
        cls = model_class(name)
        notes = [f"{k}={v}" for k, v in cls.inputs.items()]
        notes += ["recurrent"] * cls.recurrent + ["not trained"] * (not cls.trainable)
        notes += [f"predicts {t}, needs speed" for t in cls.targets]
        print(f"{name:<18} {', '.join(notes)}")


def register(sub) -> None:
    from steerlab.evaluate.latency import LatencyOptions

    q = sub.add_parser("compile", help="decode + preprocess + modalities once into the memory-mapped cache",
                       epilog="example: steerlab compile --data ../shared/data/donkeycar/hall --modalities image,flow")
    data_args(q)
    q.add_argument("--preset", help="crop preset (ch2, sim, donkey); default: the recording's")
    q.add_argument("--color", default="gray", help="gray, yuv, hsv or rgb (default gray)")
    q.add_argument("--modalities", default="image", help="comma list of image,diff,flow (default image)")
    q.add_argument("--flow", default="farneback", help="farneback or dis (default farneback)")
    path_option(q, "--cache", kind="folder", makes="cache",
                help="cache folder (default: $STEERLAB_CACHE, else .steerlab-cache)")
    q.set_defaults(func=cmd_compile)

    q = sub.add_parser("evaluate", help="open-loop evaluation of a checkpoint, frame by frame",
                       epilog="example: steerlab evaluate runs/ch2/best.pt --data ../shared/data/udacity-ch2 "
                              "--range 1800:2400 --out runs/eval")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt) or exported model (.onnx)")
    data_args(q)
    path_option(q, "--out", kind="folder", makes="evaluation", default="runs/eval",
                help="output folder (default runs/eval)")
    path_option(q, "--video", kind="new-file", help="also write an MP4 of the frames with predicted and recorded steering")
    q.add_argument("--allow-convention-mismatch", action="store_true",
                   help="evaluate a checkpoint whose steering convention (e.g. simulator road wheel, positive "
                        "right) is not the recording's (e.g. CH2 steering wheel, positive left): with a warning, "
                        "its predictions converted to the recording's convention (values of normalized steering "
                        "without a full-lock angle are compared unconverted). Without it such a mismatch is an error")
    q.add_argument("--allow-other-camera", action="store_true",
                   help="evaluate a checkpoint on a recording of another camera geometry than its own (e.g. a sim "
                        "checkpoint on CH2 frames): with a warning, the frames cropped and resized as the model's "
                        "own. Without it such a mismatch is an error")
    q.set_defaults(func=cmd_evaluate)

    q = sub.add_parser("score", help="score predictions like the Udacity Challenge 2 leaderboard",
                       epilog="example: steerlab score --truth CH2_final_evaluation.csv --pred predictions.csv")
    path_option(q, "--truth", kind="file", required=True, help="answer file frame_id,steering_angle,public")
    path_option(q, "--pred", kind="file", required=True, help="predictions frame_id,steering_angle")
    q.set_defaults(func=cmd_score)

    q = sub.add_parser("ensemble", help="one checkpoint that runs the mean of several (seeds, or models with the "
                       "same inputs)", epilog="example: steerlab ensemble runs/ch2/seed0/best.pt "
                                              "runs/ch2/seed1/best.pt runs/ch2/seed2/best.pt --out runs/ens.pt")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints (.pt) of the same preprocessing, camera geometry and "
                                                  "steering convention")
    path_option(q, "--out", kind="new-file", required=True, help="checkpoint to write (.pt)")
    q.set_defaults(func=cmd_ensemble)

    q = sub.add_parser("export", help="export a checkpoint to one self-contained ONNX file for ONNX Runtime",
                       epilog="example: steerlab export runs/demo/pilotnet/best.pt --out model.onnx; int8, calibrated "
                              "on the training frames: steerlab export runs/demo/pilotnet/best.pt --out "
                              "model-int8.onnx --int8 --calib runs/demo/recording --calib-range 0:3840")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt)")
    path_option(q, "--out", kind="new-file", required=True, help="ONNX file to write (.onnx); it carries its preprocessing and statistics")
    q.add_argument("--int8", action="store_true", help="quantize to int8 (ONNX Runtime static quantization, "
                                                       "calibrated on --calib; weights in 7 bits, so that the model "
                                                       "steers alike on AVX2, AVX-512 VNNI and ARM CPUs)")
    q.add_argument("--calib", metavar="DATA", help="recording whose frames calibrate --int8 (any layout)")
    q.add_argument("--calib-range", metavar="A:B", help="its frames to calibrate on (default: the first 500; "
                                                        "up to 300 of them, evenly spread, are kept)")
    q.set_defaults(func=cmd_export)

    q = sub.add_parser("latency", help="per-frame streaming latency of the Pilot on N threads: which models fit "
                       "a 20 Hz loop", epilog="example: steerlab latency --threads 1 --data "
                       "../shared/data/donkeycar/hall --out runs/latency")
    path_option(q, "checkpoints", kind="file", nargs="*", help="checkpoints (.pt) or exported models (.onnx) to time")
    add_options(q, "latency", LatencyOptions)
    data_args(q, "its frames, START:STOP, cycled through (default 0:100)", camera=False, required=False)
    path_option(q, "--out", kind="folder", makes="latency", help="folder for latency.csv and latency.md")
    q.set_defaults(func=cmd_latency)

    q = sub.add_parser("models", help="list the registered models", epilog="example: steerlab models")
    q.set_defaults(func=cmd_models)
