"""Subcommands that drive: sim record / drive / bench / dagger, replay, serve, demo."""

from __future__ import annotations

import time
from pathlib import Path

from steerlab.cli import path_option, Parser, add_options, data_args, from_args, print_table, source


def cmd_sim_record(a) -> None:
    from steerlab.sim.world import RecordOptions, record

    print(f"wrote {record(a.out, from_args(RecordOptions, a))}")


def cmd_sim_drive(a) -> None:
    from steerlab.pilot import DriveWith, Pilot
    from steerlab.sim.world import DriveOptions, drive

    o = from_args(DriveOptions, a)
    pilot = Pilot(a.checkpoint, smoothing=from_args(DriveWith, a).smoothing, other_camera=o.geometry is not None)
    r = drive(pilot, a.out, o, video=a.video)
    print_table(r)
    print(f"wrote {a.out}/trajectory.csv, path.png, frames.png, drive.json" + (f", {a.video}" if a.video else ""))


def cmd_sim_bench(a) -> None:
    from steerlab.sim.bench import SuiteOptions, run_suite

    o = from_args(SuiteOptions, a)
    start = time.perf_counter()
    run_suite(a.checkpoints, a.out, o)
    print((Path(a.out) / "suite.md").read_text())
    print(f"wrote {a.out}/suite.md, suite.csv (one row per drive), summary.csv, roads/*.png "
          f"in {time.perf_counter() - start:.0f} s")


def cmd_sim_dagger(a) -> None:
    from steerlab.dagger import run_dagger
    from steerlab.train.config import load_config

    cfg = load_config(a.config, a.overrides)
    final = run_dagger(cfg)
    print((Path(cfg.out) / "dagger.csv").read_text())
    print(f"final checkpoint: {final}; autonomy per round: {Path(cfg.out) / 'dagger.png'}")


def cmd_replay(a) -> None:
    from steerlab.sim.replay_run import ReplayOptions, run_replay

    o = from_args(ReplayOptions, a)
    start = time.perf_counter()
    run_replay(a.checkpoints, source(a), a.out, o, a.video)
    print((Path(a.out) / "replay.md").read_text())
    print(f"wrote {a.out}/replay.md, replay.csv, segments.csv, replay.png, */trajectory.csv"
          + (f", {a.video}" if a.video else "") + f" in {time.perf_counter() - start:.0f} s")


def cmd_serve(a) -> None:
    from steerlab.serve import ServeOptions, serve

    serve(a.checkpoint, from_args(ServeOptions, a))


def cmd_demo(a) -> None:
    from steerlab.demo import DemoOptions, run_demo

    o = from_args(DemoOptions, a)
    report = run_demo(o)
    print("\n" + (Path(o.out) / "closed-loop" / "suite.md").read_text())
    print(f"report: {report}")


def register(sub) -> None:
    from steerlab.demo import DemoOptions
    from steerlab.pilot import DriveWith
    from steerlab.serve import ServeOptions
    from steerlab.sim.bench import SuiteOptions
    from steerlab.sim.replay_run import ReplayOptions
    from steerlab.sim.world import DriveOptions, RecordOptions

    sim = sub.add_parser("sim", help="the synthetic driving world").add_subparsers(dest="sim_command", required=True,
                                                                                    parser_class=Parser)
    q = sim.add_parser("record", help="record the expert driver on a procedural road",
                       epilog="example: steerlab sim record --seed 3 --minutes 6 --road mixed --out runs/mixed-seed3")
    path_option(q, "--out", kind="folder", required=True, help="folder to write the recording to (new or empty)")
    add_options(q, "sim record", RecordOptions)
    q.set_defaults(func=cmd_sim_record)

    q = sim.add_parser("drive", help="let a trained model drive in closed loop",
                       epilog="example: steerlab sim drive runs/a/best.pt --road twisty --minutes 2 --out runs/drive")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt) or exported model (.onnx)")
    add_options(q, "sim drive", DriveOptions, DriveWith)
    path_option(q, "--out", kind="folder", default="runs/drive", help="output folder (default runs/drive)")
    path_option(q, "--video", kind="new-file", help="also write an MP4 of the drive with the model's and the expert's steering")
    q.set_defaults(func=cmd_sim_drive)

    q = sim.add_parser("bench", help="drive checkpoints on the fixed closed-loop benchmark roads",
                       epilog="example: steerlab sim bench runs/a/best.pt runs/b/best.pt --out runs/bench")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints to compare")
    path_option(q, "--out", kind="folder", default="runs/bench", help="output folder (default runs/bench)")
    add_options(q, "sim bench", SuiteOptions)
    q.set_defaults(func=cmd_sim_bench)

    q = sim.add_parser("dagger", help="DAgger: train, roll the model out, let the expert label, aggregate, retrain",
                       epilog="example: steerlab sim dagger configs/dagger_pilotnet.yaml dagger.iterations=2")
    path_option(q, "config", kind="file", help="training config with a 'dagger' section (see configs/dagger_pilotnet.yaml)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. dagger.minutes=2")
    q.set_defaults(func=cmd_sim_dagger)

    q = sub.add_parser("replay", help="closed-loop replay on a recording: would the model keep the car on the "
                       "human's path?", epilog="example: steerlab replay runs/ch2/best.pt --data "
                       "../shared/data/udacity-ch2 --range 1800:2400 --speed 15 --out runs/replay --video replay.mp4")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints (.pt) or exported models (.onnx) to replay")
    data_args(q, camera=False)
    path_option(q, "--out", kind="folder", default="runs/replay", help="output folder (default runs/replay)")
    path_option(q, "--video", kind="new-file", help="also write an MP4 of the warped view with the model's and the human's steering "
                   "(one per checkpoint)")
    add_options(q, "replay", ReplayOptions)
    q.set_defaults(func=cmd_replay)

    q = sub.add_parser("serve", help="drive the Udacity simulator (socket.io server on port 4567)",
                       epilog="example: steerlab serve runs/sim/best.pt --record runs/sim-drive; then start the "
                              "simulator in autonomous mode (README: connecting the simulator)")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt) or exported model (.onnx)")
    add_options(q, "serve", ServeOptions)
    q.set_defaults(func=cmd_serve)

    q = sub.add_parser("demo", help="the whole pipeline on synthetic data: record, train (with one DAgger round), "
                       "evaluate, replay, drive, report", epilog="example: steerlab demo --out runs/demo")
    add_options(q, "demo", DemoOptions)
    q.set_defaults(func=cmd_demo)
