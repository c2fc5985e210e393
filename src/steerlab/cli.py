"""The `steerlab` command."""

from __future__ import annotations

import argparse
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
    from steerlab.data.readers import open_recording

    rec = open_recording(a.data, a.range, a.labels)
    cfg = {"color": a.color, "modalities": a.modalities.split(","), "flow": a.flow}
    cfg["preset"] = a.preset or rec.preset
    ds = compile_recording(rec, PreprocessConfig.from_dict(cfg), a.cache, a.camera)
    print(f"{len(ds)} frames, {len(rec.segments())} segment(s) -> {ds.path}")
    for m, arr in ds.arrays.items():
        print(f"  {m}: {arr.shape} {arr.dtype}")


def cmd_train(a) -> None:
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    cfg = load_config(a.config, a.overrides)
    if cfg.get("dagger"):
        raise SteerlabError(f"{a.config} has a dagger section: run it with `steerlab sim dagger {a.config}`")
    best = train(cfg)
    print(f"best checkpoint: {cfg['out']}/best.pt (epoch {best.get('epoch')})")
    _print_table(best, ["mse", "rmse", "mae_deg", "gamma_deg", "target_gamma_deg", *SPEED_METRICS])


def cmd_experiment(a) -> None:
    from steerlab.experiment import run_experiment

    table = run_experiment(a.config, a.overrides, a.seeds)
    print(table.read_text())
    print(f"wrote {table}, {table.parent / 'table.csv'}, {table.parent / 'predictions.png'}")


def cmd_evaluate(a) -> None:
    from steerlab.evaluate.offline import evaluate

    m = evaluate(a.checkpoint, a.data, a.range, a.out, a.labels, a.camera, a.video)
    _print_table(m, ["frames", "mse", "rmse", "mae_deg", "gamma_deg", "target_gamma_deg", *SPEED_METRICS])
    print(f"with exponential smoothing a=0.2: rmse {m['smoothed_a0.2']['rmse']:.6f}, "
          f"gamma {m['smoothed_a0.2']['gamma_deg']:.4f} deg")
    print(f"wrote {a.out}/predictions.csv, {a.out}/steering.png, {a.out}/metrics.json"
          + (f", {a.video}" if a.video else ""))


def cmd_score(a) -> None:
    from steerlab.evaluate.scoring import score

    _print_table(score(a.truth, a.pred))


def cmd_models(a) -> None:
    from steerlab.models import list_models, model_class

    for name in list_models():
        cls = model_class(name)
        notes = [f"{k}={v}" for k, v in getattr(cls, "inputs", {}).items()]
        notes += ["recurrent"] * getattr(cls, "recurrent", False) + ["not trained"] * (not cls.trainable)
        notes += [f"predicts {t}, needs speed" for t in getattr(cls, "targets", ())]
        print(f"{name:<18} {', '.join(notes)}")


def cmd_sim_record(a) -> None:
    from steerlab.sim.world import record

    out = record(a.out, a.seed, a.minutes, a.road, a.camera, a.fps, not a.no_drift, not a.no_side_cameras, a.layout,
                 a.chunk_minutes)
    print(f"wrote {out}")


def cmd_sim_drive(a) -> None:
    from steerlab.pilot import Pilot
    from steerlab.sim.world import drive

    pilot = Pilot(a.checkpoint, smoothing=a.smoothing)
    r = drive(pilot, a.out, a.seed, a.minutes, a.road, a.camera, a.fps, video=a.video)
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
    from steerlab.sim.dagger import run_dagger
    from steerlab.train.config import load_config

    cfg = load_config(a.config, a.overrides)
    final = run_dagger(cfg)
    print((Path(cfg["out"]) / "dagger.csv").read_text())
    print(f"final checkpoint: {final}; autonomy per round: {Path(cfg['out']) / 'dagger.png'}")


def cmd_demo(a) -> None:
    from steerlab.demo import run_demo

    report = run_demo(a.out, minutes=a.minutes, epochs=a.epochs, suite_minutes=a.suite_minutes, workers=a.workers)
    print("\n" + (Path(a.out) / "closed-loop" / "suite.md").read_text())
    print(f"report: {report}")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="steerlab", description="End-to-end driving models: camera in, steering out.")
    sub = p.add_subparsers(dest="command", required=True)

    def data_args(q, range_help="frames to use, START:STOP (e.g. 0:2400)"):
        q.add_argument("--data", required=True, help="recording: CH2 folder, driving_log.csv or steerlab recording")
        q.add_argument("--range", help=range_help)
        q.add_argument("--labels", help="CH2: label CSV when the folder holds several")
        q.add_argument("--camera", default="center", help="camera to use (default center)")

    q = sub.add_parser("compile", help="decode + preprocess + modalities once into the memory-mapped cache")
    data_args(q)
    q.add_argument("--preset", help="crop preset (ch2, sim); default: the recording's")
    q.add_argument("--color", default="gray", choices=["gray", "yuv", "hsv", "rgb"])
    q.add_argument("--modalities", default="image", help="comma list of image,diff,flow (default image)")
    q.add_argument("--flow", default="farneback", choices=["farneback", "dis"])
    q.add_argument("--cache", default=".steerlab-cache", help="cache folder (default .steerlab-cache)")
    q.set_defaults(func=cmd_compile)

    q = sub.add_parser("train", help="train a model from a YAML config", epilog="example: steerlab train "
                       "configs/ch2_pilotnet.yaml train.epochs=5 out=runs/quick")
    q.add_argument("config", help="YAML config (see configs/)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. train.lr=3e-4")
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
    q.set_defaults(func=cmd_evaluate)

    q = sub.add_parser("score", help="score predictions like the Udacity Challenge 2 leaderboard")
    q.add_argument("--truth", required=True, help="answer file frame_id,steering_angle,public")
    q.add_argument("--pred", required=True, help="predictions frame_id,steering_angle")
    q.set_defaults(func=cmd_score)

    q = sub.add_parser("models", help="list the registered models")
    q.set_defaults(func=cmd_models)

    sim = sub.add_parser("sim", help="the synthetic driving world").add_subparsers(dest="sim_command", required=True)
    q = sim.add_parser("record", help="record the expert driver on a procedural road")
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("--minutes", type=float, default=1.0)
    q.add_argument("--out", required=True)
    q.add_argument("--road", default="country",
                   help="road preset: highway, country, twisty, mixed (all three), or a comma list")
    q.add_argument("--chunk-minutes", type=float, default=1.0,
                   help="with several road types: minutes before the recording turns to the next one (default 1)")
    q.add_argument("--camera", default="sim", help="camera preset: sim (320x160) or ch2 (640x480)")
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
    q.add_argument("--camera", help="camera preset; default: the one matching the checkpoint")
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

    q = sub.add_parser("demo", help="the whole pipeline on synthetic data: record, train, evaluate, drive, report")
    q.add_argument("--out", default="runs/demo")
    q.add_argument("--minutes", type=float, default=8.0, help="minutes of expert driving on mixed roads to train on")
    q.add_argument("--epochs", type=int, default=5)
    q.add_argument("--suite-minutes", type=float, default=1.0, help="minutes on each road of the closed-loop suite")
    q.add_argument("--workers", type=int, default=2, help="roads driven in parallel")
    q.set_defaults(func=cmd_demo)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
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
