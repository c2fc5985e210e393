"""Subcommands that drive: sim record / drive / bench / dagger, replay, serve, demo."""

from __future__ import annotations

import time
from pathlib import Path

from steerlab.cli import path_option, Parser, add_options, data_args, flag, from_args, print_table, source
from steerlab.errors import SteerlabError
from steerlab.options import optional, options_of, value_of

WORLDS = ("road", "track")


def world_options(a, mine: tuple[type, ...], other: tuple[type, ...]) -> list:
    """The option dataclasses `mine` of the world `a.world` from the flags given. A flag that only the other
    world's classes (`other`) have is checked against its range, then refused: it means nothing in this world."""
    own = {o.key for cls in mine for o in options_of(cls)}
    for cls in other:
        for o in options_of(cls):
            value = getattr(a, o.key, None)
            if o.key in own or value is None:
                continue
            given = flag(f"no_{o.key}" if optional(o.kind)[0] is bool and o.default is True else o.key)
            value_of(o.kind, value, given, o.check, o.expected)
            world = next(w for w in WORLDS if w != a.world)
            raise SteerlabError(f"{given} is an option of the {world} world (--world {world}); the {a.world} world "
                                "does not take it")
    return [from_args(cls, a) for cls in mine]


def cmd_sim_record(a) -> None:
    from steerlab.sim.track_run import record_track
    from steerlab.sim.track_world import TrackRecordOptions
    from steerlab.sim.world import RecordOptions, record

    if a.world == "track":
        (o,) = world_options(a, (TrackRecordOptions,), (RecordOptions,))
        print(f"wrote {record_track(a.out, o)}")
    else:
        (o,) = world_options(a, (RecordOptions,), (TrackRecordOptions,))
        print(f"wrote {record(a.out, o)}")


def cmd_sim_drive(a) -> None:
    from steerlab.pilot import DriveWith, Pilot
    from steerlab.sim.part import donkey_pilot
    from steerlab.sim.track_run import drive_track
    from steerlab.sim.track_world import TrackDriveOptions
    from steerlab.sim.world import DriveOptions, drive

    video = f", {a.video}" if a.video else ""
    if a.world == "track":
        o, w = world_options(a, (TrackDriveOptions, DriveWith), (DriveOptions,))
        r = drive_track(donkey_pilot(a.checkpoint, o.throttle, w.smoothing, o.max_throttle), a.out, o, video=a.video)
        print_table(r)
        print(f"wrote {a.out}/trajectory.csv, track.png, frames.png, drive.json{video}")
        return
    o, w = world_options(a, (DriveOptions, DriveWith), (TrackDriveOptions,))
    pilot = Pilot(a.checkpoint, smoothing=w.smoothing, other_camera=o.geometry is not None)
    r = drive(pilot, a.out, o, video=a.video)
    print_table(r)
    print(f"wrote {a.out}/trajectory.csv, path.png, frames.png, drive.json{video}")


def cmd_sim_bench(a) -> None:
    from steerlab.sim.bench import SuiteOptions, run_suite
    from steerlab.sim.track_bench import TrackSuiteOptions, run_track_suite

    start = time.perf_counter()
    if a.world == "track":
        (o,) = world_options(a, (TrackSuiteOptions,), (SuiteOptions,))
        run_track_suite(a.checkpoints, a.out, o)
        figures = "tracks/*.png"
    else:
        (o,) = world_options(a, (SuiteOptions,), (TrackSuiteOptions,))
        run_suite(a.checkpoints, a.out, o)
        figures = "roads/*.png"
    print((Path(a.out) / "suite.md").read_text())
    print(f"wrote {a.out}/suite.md, suite.csv (one row per drive), summary.csv, {figures} "
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
    from steerlab.sim.replay_track import TrackReplayOptions, world_of

    data = source(a)
    a.world = a.world or world_of(data.open())
    road = (ReplayOptions,), (TrackReplayOptions,)
    (o,) = world_options(a, *(road if a.world == "road" else road[::-1]))
    start = time.perf_counter()
    run_replay(a.checkpoints, data, a.out, o, a.video)
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
    from steerlab.sim.replay_track import TrackReplayOptions
    from steerlab.sim.track_bench import TrackSuiteOptions
    from steerlab.sim.track_world import TrackDriveOptions, TrackRecordOptions
    from steerlab.sim.world import DriveOptions, RecordOptions

    def world(q) -> None:
        q.add_argument("--world", choices=WORLDS, default="road", help="road: a full-size car on procedural roads "
                       "(default); track: a donkeycar on a procedural track in a hall, seen through its fisheye")

    sim = sub.add_parser("sim", help="the synthetic driving worlds").add_subparsers(dest="sim_command", required=True,
                                                                                     parser_class=Parser)
    q = sim.add_parser("record", help="record the expert driver on a procedural road or track",
                       epilog="example: steerlab sim record --seed 3 --minutes 6 --road mixed --out runs/mixed-seed3; "
                              "steerlab sim record --world track --seed 3 --minutes 10 --out runs/tub-seed3")
    path_option(q, "--out", kind="folder", required=True, help="folder to write the recording to (new or empty)")
    world(q)
    add_options(q, "sim record", RecordOptions)
    add_options(q, "sim record", TrackRecordOptions, label="--world track")
    q.set_defaults(func=cmd_sim_record)

    q = sim.add_parser("drive", help="let a trained model drive in closed loop",
                       epilog="example: steerlab sim drive runs/a/best.pt --road twisty --minutes 2 --out runs/drive; "
                              "steerlab sim drive runs/tub/best.pt --world track --minutes 2 --out runs/track-drive")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt) or exported model (.onnx)")
    world(q)
    add_options(q, "sim drive", DriveOptions, DriveWith)
    add_options(q, "sim drive", TrackDriveOptions, label="--world track")
    path_option(q, "--out", kind="folder", default="runs/drive", help="output folder (default runs/drive)")
    path_option(q, "--video", kind="new-file", help="also write an MP4 of the drive with the model's and the expert's steering")
    q.set_defaults(func=cmd_sim_drive)

    q = sim.add_parser("bench", help="drive checkpoints on the fixed closed-loop benchmark roads or tracks",
                       epilog="example: steerlab sim bench runs/a/best.pt runs/b/best.pt --out runs/bench; "
                              "steerlab sim bench runs/tub/best.pt --world track --out runs/track-bench")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints to compare")
    path_option(q, "--out", kind="folder", default="runs/bench", help="output folder (default runs/bench)")
    world(q)
    add_options(q, "sim bench", SuiteOptions)
    add_options(q, "sim bench", TrackSuiteOptions, label="--world track")
    q.set_defaults(func=cmd_sim_bench)

    q = sim.add_parser("dagger", help="DAgger: train, roll the model out, let the expert label, aggregate, retrain",
                       epilog="example: steerlab sim dagger configs/dagger_pilotnet.yaml dagger.iterations=2; in the "
                              "track world: steerlab sim dagger configs/track_dagger.yaml")
    path_option(q, "config", kind="file", help="training config with a 'dagger' section (see "
                "configs/dagger_pilotnet.yaml; dagger.world: synthetic, replay or track)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. dagger.minutes=2")
    q.set_defaults(func=cmd_sim_dagger)

    q = sub.add_parser("replay", help="closed-loop replay on a recording: would the model keep the car on the "
                       "human's path?", epilog="example: steerlab replay runs/ch2/best.pt --data "
                       "../shared/data/udacity-ch2 --range 1800:2400 --speed 15 --out runs/replay --video replay.mp4; "
                       "steerlab replay runs/tub/best.pt --data ../shared/data/donkeycar/hall --reader "
                       "full_lock_deg=25 --lane-width 0.9 --out runs/replay-hall")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints (.pt) or exported models (.onnx) to replay")
    data_args(q, camera=False)
    path_option(q, "--out", kind="folder", default="runs/replay", help="output folder (default runs/replay)")
    path_option(q, "--video", kind="new-file", help="also write an MP4 of the warped view with the model's and the human's steering "
                   "(one per checkpoint)")
    q.add_argument("--world", choices=WORLDS, help="road: a car's replay, the frames warped as a pinhole camera's, "
                   "an intervention off the human's path or heading; track: a small car's, through its fisheye, the "
                   "speed from the throttle, an intervention when the body leaves the lane (default: track for "
                   "donkeycar tubs and the track world's recordings, road for the others)")
    add_options(q, "replay", ReplayOptions)
    add_options(q, "replay", TrackReplayOptions, label="--world track")
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
