"""The `steerlab` command."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from steerlab.errors import SteerlabError


SPEED_METRICS = ["speed_mae", "command_accuracy"]  # printed when the model predicts speed or speed commands


def _print_table(metrics: dict, keys=None) -> None:
    for k in [k for k in keys if k in metrics] if keys else metrics:
        v = metrics[k]
        if isinstance(v, float):
            print(f"  {k:<18} {v:.6f}")
        elif not isinstance(v, dict):
            print(f"  {k:<18} {v}")


def cmd_compile(a) -> None:
    from steerlab.data.dataset import compile_recording
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.readers import open_recording, reader_options

    rec = open_recording(a.data, a.range, a.labels, reader_options(a.reader))
    cfg = {"color": a.color, "modalities": a.modalities.split(","), "flow": a.flow}
    cfg["preset"] = a.preset or rec.geometry
    ds = compile_recording(rec, PreprocessConfig.from_dict(cfg), a.cache, a.camera)
    print(f"{len(ds)} frames, {len(rec.segments())} segment(s) -> {ds.path}")
    for m, arr in ds.arrays.items():
        print(f"  {m}: {arr.shape} {arr.dtype}")


def cmd_train(a) -> None:
    import os
    import subprocess

    from steerlab.train.config import load_config
    from steerlab.train.distributed import finish
    from steerlab.train.loop import train

    cfg = load_config(a.config, a.overrides)
    if cfg.get("dagger"):
        raise SteerlabError(f"{a.config} has a dagger section: run it with `steerlab sim dagger {a.config}`")
    if a.nproc > 1 and "WORLD_SIZE" not in os.environ:  # start the ranks with torchrun
        cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc-per-node={a.nproc}",
               "-m", "steerlab", "train", a.config, *a.overrides]
        if subprocess.run(cmd).returncode:
            raise SteerlabError(f"distributed training with {a.nproc} ranks failed (see the messages above)")
        return
    try:
        best = train(cfg)
    finally:
        finish()
    if os.environ.get("RANK", "0") != "0":
        return
    print(f"best checkpoint: {cfg['out']}/best.pt (epoch {best.get('epoch')})")
    _print_table(best, ["mse", "rmse", "mae", "mae_deg", "gamma_deg", "target_gamma_deg", *SPEED_METRICS])


def cmd_experiment(a) -> None:
    from steerlab.experiment import run_experiment

    table = run_experiment(a.config, a.overrides, a.seeds)
    print(table.read_text())
    print(f"wrote {table}, {table.parent / 'table.csv'}, {table.parent / 'predictions.png'}")


def cmd_evaluate(a) -> None:
    from steerlab.data.readers import reader_options
    from steerlab.evaluate.offline import evaluate

    m = evaluate(a.checkpoint, a.data, a.range, a.out, a.labels, a.camera, a.video, reader_options(a.reader),
                 allow_convention_mismatch=a.allow_convention_mismatch)
    _print_table(m, ["frames", "mse", "rmse", "mae", "mae_deg", "gamma_deg", "target_gamma_deg", "tre", "qce",
                     "speed_weighted_mae", *SPEED_METRICS])
    print(f"with exponential smoothing a=0.2: rmse {m['smoothed_a0.2']['rmse']:.6f}, "
          f"gamma {m['smoothed_a0.2']['gamma_deg']:.4f} deg")
    print(f"wrote {a.out}/predictions.csv, {a.out}/steering.png, {a.out}/metrics.json"
          + (f", {a.video}" if a.video else ""))


def cmd_tune(a) -> None:
    from steerlab.tune import run_tune

    out = run_tune(a.config, a.overrides, a.trials, a.objective, a.storage, a.study, a.seed,
                   None if a.no_pruning else a.reduction_factor, join=a.join)
    for name in ("summary.md", "importance.md", "pareto.md"):
        if (out / name).exists():
            print((out / name).read_text())
    print(f"wrote {out}/trials.csv, {out}/best.yaml (run it: steerlab train {out}/best.yaml)"
          + "".join(f", {out}/{f}" for f in ("importance.png", "history.png", "pareto.png") if (out / f).exists()))


def cmd_export(a) -> None:
    from steerlab.export import export_onnx

    if a.int8 and a.calib is None:
        raise SteerlabError("--int8 needs calibration data: --calib RECORDING (frames like the ones it was trained on)")
    if not a.int8 and (a.calib or a.calib_range):
        raise SteerlabError("--calib and --calib-range calibrate an --int8 export: add --int8")
    out = export_onnx(a.checkpoint, a.out, a.calib, a.calib_range)
    print(f"wrote {out}{' (int8)' if a.int8 else ''}, preprocessing and statistics in its metadata (run it with "
          f"Pilot('{out}'), "
          f"steerlab serve {out} or on a donkeycar: steerlab.donkey.SteerlabPilot('{out}'))")


def cmd_ensemble(a) -> None:
    from steerlab.checkpoint import save_ensemble

    out = Path(a.out)
    if out.suffix != ".pt":
        raise SteerlabError(f"{out}: the ensemble is a checkpoint: its file must end in .pt")
    save_ensemble(a.checkpoints, out)
    print(f"wrote {out}: the mean of {len(a.checkpoints)} models (evaluate, replay, drive or export it like any "
          "checkpoint)")


def cmd_latency(a) -> None:
    from steerlab.data.readers import reader_options
    from steerlab.evaluate.latency import latency_table, run_latency

    models = [m.strip() for m in (a.models or ("" if a.checkpoints else "all")).split(",") if m.strip()]
    if models == ["all"]:
        from steerlab.models import list_models

        models = list_models()
    rows = run_latency(a.checkpoints, models, a.geometry, a.threads, a.runtime, a.frames, a.data, a.range, a.labels,
                       reader_options(a.reader), a.decode, a.out)
    print(latency_table(rows))
    if a.out:
        print(f"wrote {a.out}/latency.csv, {a.out}/latency.md")


def cmd_serve(a) -> None:
    from steerlab.serve import serve

    serve(a.checkpoint, a.port, a.set_speed, a.record, a.smoothing)


def cmd_score(a) -> None:
    from steerlab.evaluate.scoring import score

    _print_table(score(a.truth, a.pred))


def cmd_models(a) -> None:
    from steerlab.models import list_models, model_class

    for name in list_models():
        cls = model_class(name)
        notes = [f"{k}={v}" for k, v in cls.inputs.items()]
        notes += ["recurrent"] * cls.recurrent + ["not trained"] * (not cls.trainable)
        notes += [f"predicts {t}, needs speed" for t in cls.targets]
        print(f"{name:<18} {', '.join(notes)}")


def cmd_sim_record(a) -> None:
    from steerlab.sim.world import record

    out = record(a.out, a.seed, a.minutes, a.road, a.geometry, a.fps, not a.no_drift, not a.no_side_cameras, a.layout,
                 a.chunk_minutes)
    print(f"wrote {out}")


def cmd_sim_drive(a) -> None:
    from steerlab.pilot import Pilot
    from steerlab.sim.world import drive

    pilot = Pilot(a.checkpoint, smoothing=a.smoothing)
    r = drive(pilot, a.out, a.seed, a.minutes, a.road, a.geometry, a.fps, video=a.video)
    _print_table(r)
    print(f"wrote {a.out}/trajectory.csv, path.png, frames.png, drive.json" + (f", {a.video}" if a.video else ""))


def cmd_sim_bench(a) -> None:
    from steerlab.sim.bench import run_suite

    start = time.perf_counter()
    run_suite(a.checkpoints, a.out, a.suite, a.minutes, a.workers, a.smoothing, a.roads)
    print((Path(a.out) / "suite.md").read_text())
    print(f"wrote {a.out}/suite.md, suite.csv (one row per drive), summary.csv, roads/*.png "
          f"in {time.perf_counter() - start:.0f} s")


def cmd_sim_dagger(a) -> None:
    from steerlab.dagger import run_dagger
    from steerlab.train.config import load_config

    cfg = load_config(a.config, a.overrides)
    final = run_dagger(cfg)
    print((Path(cfg["out"]) / "dagger.csv").read_text())
    print(f"final checkpoint: {final}; autonomy per round: {Path(cfg['out']) / 'dagger.png'}")


def cmd_replay(a) -> None:
    from steerlab.data.readers import reader_options
    from steerlab.sim.replay import run_replay

    camera = {k: v for k, v in (("mount_height", a.mount_height), ("pitch_deg", a.pitch), ("hfov_deg", a.fov))
              if v is not None}
    start = time.perf_counter()
    run_replay(a.checkpoints, a.data, a.out, a.range, a.labels, reader_options(a.reader), a.speed, camera, a.limit,
               a.max_heading, a.video, a.workers, smoothing=a.smoothing)
    print((Path(a.out) / "replay.md").read_text())
    print(f"wrote {a.out}/replay.md, replay.csv, segments.csv, replay.png, */trajectory.csv"
          + (f", {a.video}" if a.video else "") + f" in {time.perf_counter() - start:.0f} s")


def cmd_demo(a) -> None:
    from steerlab.demo import run_demo

    report = run_demo(a.out, minutes=a.minutes, epochs=a.epochs, suite_minutes=a.suite_minutes,
                      dagger_minutes=a.dagger_minutes, workers=a.workers)
    print("\n" + (Path(a.out) / "closed-loop" / "suite.md").read_text())
    print(f"report: {report}")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="steerlab", description="End-to-end driving models: camera in, steering out.")
    sub = p.add_subparsers(dest="command", required=True)

    def data_args(q, range_help="frames to use, START:STOP (e.g. 0:2400)", stream=True):
        q.add_argument("--data", required=True, help="recording: CH2 folder, driving_log.csv, steerlab recording, "
                       "donkeycar tub, ROS bag or video with a CSV log")
        q.add_argument("--range", help=range_help)
        q.add_argument("--labels", help="CH2: label CSV when the folder holds several")
        q.add_argument("--reader", action="append", default=[], metavar="KEY=VALUE",
                       help="reader option, repeatable: full_lock_deg=25, skip_missing=true (tubs), "
                            "log=FILE.csv (videos), ... (docs/ARCHITECTURE.md lists them)")
        if stream:
            q.add_argument("--camera", default="center", help="camera to use (default center)")

    q = sub.add_parser("compile", help="decode + preprocess + modalities once into the memory-mapped cache")
    data_args(q)
    q.add_argument("--preset", help="crop preset (ch2, sim, donkey); default: the recording's")
    q.add_argument("--color", default="gray", choices=["gray", "yuv", "hsv", "rgb"])
    q.add_argument("--modalities", default="image", help="comma list of image,diff,flow (default image)")
    q.add_argument("--flow", default="farneback", choices=["farneback", "dis"])
    q.add_argument("--cache", default=".steerlab-cache", help="cache folder (default .steerlab-cache)")
    q.set_defaults(func=cmd_compile)

    q = sub.add_parser("train", help="train a model from a YAML config", epilog="example: steerlab train "
                       "configs/ch2_pilotnet.yaml train.epochs=5 out=runs/quick")
    q.add_argument("config", help="YAML config (see configs/)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. train.lr=3e-4")
    q.add_argument("--nproc", type=int, default=1, help="data-parallel ranks on this machine (torchrun + DDP; "
                   "train.batch_size stays the global batch)")
    q.set_defaults(func=cmd_train)

    q = sub.add_parser("experiment", help="train several models with several seeds and tabulate them",
                       epilog="example: steerlab experiment configs/experiment_ch2.yaml --seeds 3")
    q.add_argument("config", help="YAML config with a 'models' list (see configs/experiment_ch2.yaml)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides for every run")
    q.add_argument("--seeds", type=int, default=3, help="runs per model, seeds 0..N-1 (default 3)")
    q.set_defaults(func=cmd_experiment)

    q = sub.add_parser("evaluate", help="open-loop evaluation of a checkpoint, frame by frame")
    q.add_argument("checkpoint")
    data_args(q)
    q.add_argument("--out", default="runs/eval", help="output folder (default runs/eval)")
    q.add_argument("--video", help="also write an MP4 of the frames with predicted and recorded steering")
    q.add_argument("--allow-convention-mismatch", action="store_true",
                   help="evaluate a checkpoint whose steering convention (e.g. simulator road wheel, positive "
                        "right) is not the recording's (e.g. CH2 steering wheel, positive left): with a warning, "
                        "its predictions converted to the recording's convention (steering ratio 14.8; values of "
                        "normalized steering without a full-lock angle are compared unconverted). Without it "
                        "such a mismatch is an error")
    q.set_defaults(func=cmd_evaluate)

    q = sub.add_parser("score", help="score predictions like the Udacity Challenge 2 leaderboard")
    q.add_argument("--truth", required=True, help="answer file frame_id,steering_angle,public")
    q.add_argument("--pred", required=True, help="predictions frame_id,steering_angle")
    q.set_defaults(func=cmd_score)

    q = sub.add_parser("tune", help="BOHB-style hyperparameter search (Optuna TPE + Hyperband) over a config's "
                       "tune: section", epilog="example: steerlab tune configs/tune_multimodal_lstm.yaml --trials 40; "
                       "more workers: run the same command elsewhere with --storage postgresql://... --study NAME")
    q.add_argument("config", help="training config with a tune: section (config key -> range)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. train.epochs=8")
    q.add_argument("--trials", type=int, default=20, help="finished trials the study should have (default 20)")
    q.add_argument("--objective", default="rmse", choices=["rmse", "rmse+gamma", "autonomy"],
                   help="validation RMSE (default), RMSE and gamma (Pareto front), or closed-loop autonomy")
    q.add_argument("--storage", help="Optuna storage shared by workers: a journal file (*.journal) or an RDB URL "
                   "(sqlite:///study.db, postgresql://...); default OUT/study.journal")
    q.add_argument("--study", help="study name (default: the name of the config's out folder)")
    q.add_argument("--seed", type=int, default=0, help="sampler seed (default 0)")
    q.add_argument("--reduction-factor", type=int, default=3, metavar="N",
                   help="Hyperband: each rung keeps the best 1/N of the trials (default 3)")
    q.add_argument("--no-pruning", action="store_true", help="run every trial to completion (no Hyperband)")
    q.add_argument("--join", action="store_true", help="join a study that another worker started: a study that does "
                   "not exist in the storage is an error (a mistyped --study or --storage), not a new study")
    q.set_defaults(func=cmd_tune)

    q = sub.add_parser("ensemble", help="one checkpoint that runs the mean of several (seeds, or models with the "
                       "same inputs)", epilog="example: steerlab ensemble runs/ch2/seed0/best.pt "
                                              "runs/ch2/seed1/best.pt runs/ch2/seed2/best.pt --out runs/ens.pt")
    q.add_argument("checkpoints", nargs="+", help="checkpoints (.pt) of the same preprocessing, camera geometry and "
                                                  "steering convention")
    q.add_argument("--out", required=True, help="checkpoint to write (.pt)")
    q.set_defaults(func=cmd_ensemble)

    q = sub.add_parser("export", help="export a checkpoint to one self-contained ONNX file for ONNX Runtime",
                       epilog="example: steerlab export runs/demo/pilotnet/best.pt --out model.onnx; int8, calibrated "
                              "on the training frames: steerlab export runs/demo/pilotnet/best.pt --out "
                              "model-int8.onnx --int8 --calib runs/demo/recording --calib-range 0:7680")
    q.add_argument("checkpoint", help="checkpoint (.pt)")
    q.add_argument("--out", required=True, help="ONNX file to write (.onnx); it carries its preprocessing and statistics")
    q.add_argument("--int8", action="store_true", help="quantize to int8 (ONNX Runtime static quantization, "
                                                       "calibrated on --calib)")
    q.add_argument("--calib", metavar="DATA", help="recording whose frames calibrate --int8 (any layout)")
    q.add_argument("--calib-range", metavar="A:B", help="its frames to calibrate on (default: the first 500; "
                                                        "up to 300 of them, evenly spread, are kept)")
    q.set_defaults(func=cmd_export)

    q = sub.add_parser("latency", help="per-frame streaming latency of the Pilot on N threads: which models fit "
                       "a 20 Hz loop", epilog="example: steerlab latency --threads 1 --data "
                       "../shared/data/donkeycar/hall --out runs/latency")
    q.add_argument("checkpoints", nargs="*", help="checkpoints (.pt) or exported models (.onnx) to time")
    q.add_argument("--models", help="'all' or a comma list of registered models to time untrained (the weights do "
                   "not change the cost); default: all when no checkpoint is given")
    q.add_argument("--geometry", choices=["donkey", "ch2", "sim"], help="camera geometry of the untrained models "
                   "and the synthetic frames (default: the recording's with --data, else donkey, 160x120)")
    q.add_argument("--threads", type=int, default=1, help="threads of torch, OpenCV and ONNX Runtime (default 1: "
                   "one core)")
    q.add_argument("--runtime", default="both", choices=["torch", "onnx", "both"],
                   help="PyTorch, ONNX Runtime (a .pt is exported first) or both (default)")
    q.add_argument("--frames", type=int, default=500, help="frames timed, after 10 warm-up frames (default 500)")
    q.add_argument("--data", help="recording to take the frames from (any layout; default: synthetic frames)")
    q.add_argument("--range", help="its frames, START:STOP, cycled through (default 0:100)")
    q.add_argument("--labels", help="CH2: label CSV when the folder holds several")
    q.add_argument("--reader", action="append", default=[], metavar="KEY=VALUE", help="reader option, repeatable")
    q.add_argument("--decode", action="store_true", help="time JPEG decoding too (frames encoded once, quality 95)")
    q.add_argument("--out", help="folder for latency.csv and latency.md")
    q.set_defaults(func=cmd_latency)

    q = sub.add_parser("serve", help="drive the Udacity simulator (socket.io server on port 4567)",
                       epilog="example: steerlab serve runs/sim/best.pt --record runs/sim-drive; then start the "
                              "simulator in autonomous mode (README: connecting the simulator)")
    q.add_argument("checkpoint", help="checkpoint (.pt) or exported model (.onnx)")
    q.add_argument("--port", type=int, default=4567, help="port (default 4567, the simulator's)")
    q.add_argument("--set-speed", type=float, default=4.0, help="speed the PI controller holds, m/s (default 4)")
    q.add_argument("--smoothing", type=float, help="exponential smoothing of the steering, alpha in (0, 1]")
    q.add_argument("--record", help="folder to record the drive to (driving_log.csv + IMG/)")
    q.set_defaults(func=cmd_serve)

    q = sub.add_parser("models", help="list the registered models")
    q.set_defaults(func=cmd_models)

    sim = sub.add_parser("sim", help="the synthetic driving world").add_subparsers(dest="sim_command", required=True)
    q = sim.add_parser("record", help="record the expert driver on a procedural road")
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("--minutes", type=float, default=1.0)
    q.add_argument("--out", required=True)
    q.add_argument("--road", default="country",
                   help="road type: highway, country, twisty, mixed (all three), or a comma list")
    q.add_argument("--chunk-minutes", type=float, default=1.0,
                   help="with several road types: minutes before the recording turns to the next one (default 1)")
    q.add_argument("--geometry", default="sim", help="camera geometry: sim (320x160) or ch2 (640x480)")
    q.add_argument("--fps", type=float, default=20.0)
    q.add_argument("--no-drift", action="store_true", help="no drift-and-recover episodes")
    q.add_argument("--no-side-cameras", action="store_true", help="centre camera only")
    q.add_argument("--layout", default="steerlab", choices=["steerlab", "udacity-sim"])
    q.set_defaults(func=cmd_sim_record)
    q = sim.add_parser("drive", help="let a trained model drive in closed loop")
    q.add_argument("checkpoint")
    q.add_argument("--seed", type=int, default=100, help="road seed (default 100, not used for training data)")
    q.add_argument("--minutes", type=float, default=1.0)
    q.add_argument("--road", default="country")
    q.add_argument("--geometry", help="camera geometry (sim, ch2); default: the checkpoint's")
    q.add_argument("--fps", type=float, default=20.0)
    q.add_argument("--smoothing", type=float, help="exponential smoothing factor a (paper 002: 0.2)")
    q.add_argument("--out", default="runs/drive")
    q.add_argument("--video", help="also write an MP4 of the drive with the model's and the expert's steering")
    q.set_defaults(func=cmd_sim_drive)
    q = sim.add_parser("bench", help="drive checkpoints on the fixed closed-loop benchmark roads",
                       epilog="example: steerlab sim bench runs/a/best.pt runs/b/best.pt --out runs/bench")
    q.add_argument("checkpoints", nargs="+", help="checkpoints to compare")
    q.add_argument("--out", default="runs/bench", help="output folder (default runs/bench)")
    q.add_argument("--suite", default="v1", help="suite version (default v1: 5 country, 3 highway, 3 twisty roads)")
    q.add_argument("--minutes", type=float, help="minutes per road (default: the suite's, 3 for v1)")
    q.add_argument("--roads", help="comma list of the suite's road types to drive (default: all)")
    q.add_argument("--workers", type=int, default=2, help="roads driven in parallel (default 2)")
    q.add_argument("--smoothing", type=float, help="exponential smoothing factor a (paper 002: 0.2)")
    q.set_defaults(func=cmd_sim_bench)
    q = sim.add_parser("dagger", help="DAgger: train, roll the model out, let the expert label, aggregate, retrain",
                       epilog="example: steerlab sim dagger configs/dagger_pilotnet.yaml dagger.iterations=2")
    q.add_argument("config", help="training config with a 'dagger' section (see configs/dagger_pilotnet.yaml)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. dagger.minutes=2")
    q.set_defaults(func=cmd_sim_dagger)

    q = sub.add_parser("replay", help="closed-loop replay on a recording: would the model keep the car on the "
                       "human's path?", epilog="example: steerlab replay runs/ch2/best.pt --data "
                       "../shared/data/udacity-ch2 --range 1800:2400 --speed 15 --out runs/replay --video replay.mp4")
    q.add_argument("checkpoints", nargs="+", help="checkpoints (.pt) or exported models (.onnx) to replay")
    data_args(q, stream=False)
    q.add_argument("--speed", type=float, help="speed in m/s (default: the recorded one, else estimated from the frames)")
    q.add_argument("--out", default="runs/replay", help="output folder (default runs/replay)")
    q.add_argument("--video", help="also write an MP4 of the warped view with the model's and the human's steering "
                   "(one per checkpoint)")
    q.add_argument("--limit", type=float, help="metres off the human's path that count as an intervention "
                   "(default: 1 for cars, 0.3 for donkeycars)")
    q.add_argument("--max-heading", type=float, default=10.0, help="degrees of heading error beyond which the "
                   "warped view is not trusted: an intervention (default 10)")
    q.add_argument("--mount-height", type=float, help="camera height above the road, m (default: the geometry's)")
    q.add_argument("--pitch", type=float, help="camera pitch, degrees down (default: the geometry's)")
    q.add_argument("--fov", type=float, help="horizontal field of view, degrees (default: the geometry's)")
    q.add_argument("--workers", type=int, default=2, help="checkpoints replayed in parallel (default 2)")
    q.add_argument("--smoothing", type=float, help="exponential smoothing factor a of the steering, as when driving "
                                                   "(paper 002: 0.2)")
    q.set_defaults(func=cmd_replay)

    q = sub.add_parser("demo", help="the whole pipeline on synthetic data: record, train (with one DAgger round), "
                       "evaluate, replay, drive, report")
    q.add_argument("--out", default="runs/demo")
    q.add_argument("--minutes", type=float, default=8.0, help="minutes of expert driving on mixed roads to train on")
    q.add_argument("--epochs", type=int, default=5, help="epochs of the first training (default 5)")
    q.add_argument("--suite-minutes", type=float, help="minutes on each road of the closed-loop suite (default: "
                   "the suite's 3)")
    q.add_argument("--dagger-minutes", type=float, default=2.0, help="minutes the trained model drives a fresh "
                   "twisty road in its DAgger round (default 2)")
    q.add_argument("--workers", type=int, default=2, help="roads driven in parallel")
    q.set_defaults(func=cmd_demo)
    return p


def _positive(v) -> bool:
    return math.isfinite(v) and v > 0


# Every numeric option of every command that has a range: option -> (check, what is expected). Checked before
# the command does anything; an option that is not given (None) keeps its default.
OPTIONS = {
    "smoothing": (lambda v: 0 < v <= 1, "a number in (0, 1]"),
    "workers": (lambda v: v >= 1, "an integer of at least 1"),
    "seeds": (lambda v: v >= 1, "an integer of at least 1"),
    "nproc": (lambda v: v >= 1, "an integer of at least 1"),
    "epochs": (lambda v: v >= 1, "an integer of at least 1"),
    "threads": (lambda v: v >= 1, "an integer of at least 1"),
    "frames": (lambda v: v >= 1, "an integer of at least 1"),
    **{name: (_positive, "positive and finite") for name in (
        "minutes", "suite_minutes", "dagger_minutes", "chunk_minutes", "fps", "limit", "max_heading", "mount_height",
        "fov", "speed")},
    "set_speed": (lambda v: math.isfinite(v) and v >= 0, "a finite number of at least 0 (m/s)"),
}


def check_options(args: argparse.Namespace) -> None:
    for name, (check, expected) in OPTIONS.items():
        value = getattr(args, name, None)
        if value is not None and not check(value):
            raise SteerlabError(f"--{name.replace('_', '-')} must be {expected}, got {value:g}")


def parse(argv=None) -> argparse.Namespace:
    """The command line; `section.key=value` overrides may stand anywhere after the config, before or after
    the options (`steerlab tune CONFIG --trials 3 train.epochs=2`)."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    overrides = [x for x in extra if "=" in x and not x.startswith("-")]
    if extra and (len(overrides) < len(extra) or not hasattr(args, "overrides")):
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
    if overrides:
        args.overrides = [*args.overrides, *overrides]
    return args


def main(argv=None) -> int:
    args = parse(argv)
    try:
        check_options(args)
        args.func(args)
    except SteerlabError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
