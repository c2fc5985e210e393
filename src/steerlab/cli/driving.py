"""Subcommands that drive: sim record / drive / bench / dagger, replay, serve, demo."""

from __future__ import annotations

import time
from dataclasses import asdict
from pathlib import Path

from steerlab.cli import path_option, Parser, add_options, data_args, flag, from_args, print_table, source
from steerlab.errors import SteerlabError
from steerlab.options import optional, options_of


def world_options(a, command: str, extra: tuple[type, ...] = ()) -> list:
    """The options of `command` ("record", "drive", "suite" or "replay") in the world `a.world` from the flags
    given, then those of `extra`. A flag that only another world's options have is refused, whatever its value
    (its range is that world's): it means nothing in this world."""
    from steerlab.sim.worlds import WORLDS

    mine = (getattr(WORLDS[a.world], command).options, *extra)
    own = {o.key for cls in mine for o in options_of(cls)}
    for world in WORLDS.values():
        if world.name == a.world:
            continue
        for o in options_of(getattr(world, command).options):
            value = getattr(a, o.key, None)
            if o.key in own or value is None:
                continue
            given = flag(f"no_{o.key}" if optional(o.kind)[0] is bool and o.default is True else o.key)
            raise SteerlabError(f"{given} is an option of the {world.name} world (--world {world.name}); the "
                                f"{a.world} world does not take it")
    return [from_args(cls, a) for cls in mine]


def cmd_sim_record(a) -> None:
    from steerlab.sim.worlds import WORLDS

    (o,) = world_options(a, "record")
    print(f"wrote {WORLDS[a.world].record.run(a.out, o)}")


def cmd_sim_drive(a) -> None:
    from steerlab.pilot import DriveWith
    from steerlab.sim.worlds import WORLDS

    world = WORLDS[a.world]
    o, w = world_options(a, "drive", (DriveWith,))
    print_table(asdict(world.drive.run(a.checkpoint, a.out, o, w, a.video)))
    print(f"wrote {a.out}/{world.drive.files}" + (f", {a.video}" if a.video else ""))


def cmd_sim_bench(a) -> None:
    from steerlab.sim.worlds import WORLDS

    world = WORLDS[a.world]
    start = time.perf_counter()
    (o,) = world_options(a, "suite")
    world.suite.run(a.checkpoints, a.out, o)
    print((Path(a.out) / "suite.md").read_text())
    print(f"wrote {a.out}/suite.md, suite.csv (one row per drive), summary.csv, {world.suite.figures} "
          f"in {time.perf_counter() - start:.0f} s")


def cmd_sim_dagger(a) -> None:
    from steerlab.dagger import run_dagger
    from steerlab.train.config import load_config

    cfg = load_config(a.config, a.overrides)
    final = run_dagger(cfg)
    print((Path(cfg.out) / "dagger.csv").read_text())
    print(f"final checkpoint: {final}; autonomy per round: {Path(cfg.out) / 'dagger.png'}")


def cmd_replay(a) -> None:
    from steerlab.sim.replay.run import run_replay
    from steerlab.sim.worlds import world_of

    data = source(a)
    a.world = a.world or world_of(data.open().geometry).name
    (o,) = world_options(a, "replay")
    start = time.perf_counter()
    run_replay(a.checkpoints, data, a.out, o, a.video)
    print((Path(a.out) / "replay.md").read_text())
    print(f"wrote {a.out}/replay.md, replay.csv, segments.csv, replay.png, path.png, */trajectory.csv"
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
    from steerlab.sim.worlds import WORLDS, default_world

    first = default_world().name

    def world(q, command: str, name: str, *extra: type) -> None:
        """--world and the options of `command` in every world (the default world's first, without a label)."""
        q.add_argument("--world", choices=list(WORLDS), default=first, help="; ".join(
            f"{w.name}: {w.help}" + (" (default)" if w.name == first else "") for w in WORLDS.values()))
        for w in WORLDS.values():
            add_options(q, name, getattr(w, command).options, *(extra if w.name == first else ()),
                        label=None if w.name == first else f"--world {w.name}")

    sim = sub.add_parser("sim", help="the synthetic driving worlds").add_subparsers(dest="sim_command", required=True,
                                                                                     parser_class=Parser)
    q = sim.add_parser("record", help="record the expert driver on a procedural road or track",
                       epilog="example: steerlab sim record --seed 3 --minutes 6 --road mixed --out runs/mixed-seed3; "
                              "steerlab sim record --world track --seed 3 --minutes 10 --out runs/tub-seed3")
    path_option(q, "--out", kind="folder", makes="recording", required=True,
                help="folder to write the recording to (new or empty)")
    world(q, "record", "sim record")
    q.set_defaults(func=cmd_sim_record)

    q = sim.add_parser("drive", help="let a trained model drive in closed loop",
                       epilog="example: steerlab sim drive runs/a/best.pt --road twisty --minutes 2 --out runs/drive; "
                              "steerlab sim drive runs/tub/best.pt --world track --minutes 2 --out runs/track-drive")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt) or exported model (.onnx)")
    world(q, "drive", "sim drive", DriveWith)
    path_option(q, "--out", kind="folder", makes="drive", default="runs/drive",
                help="output folder (default runs/drive)")
    path_option(q, "--video", kind="new-file",
                help="also write an MP4 of the drive with the model's and the expert's steering")
    q.set_defaults(func=cmd_sim_drive)

    q = sim.add_parser("bench", help="drive checkpoints on the fixed closed-loop benchmark roads or tracks",
                       epilog="example: steerlab sim bench runs/a/best.pt runs/b/best.pt --out runs/bench; "
                              "steerlab sim bench runs/tub/best.pt --world track --out runs/track-bench")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints to compare")
    path_option(q, "--out", kind="folder", makes="suite", default="runs/bench",
                help="output folder (default runs/bench)")
    world(q, "suite", "sim bench")
    q.set_defaults(func=cmd_sim_bench)

    q = sim.add_parser("dagger", help="DAgger: train, roll the model out, let the expert label, aggregate, retrain",
                       epilog="example: steerlab sim dagger configs/dagger_pilotnet.yaml dagger.iterations=2; in the "
                              "track world: steerlab sim dagger configs/track_dagger.yaml")
    path_option(q, "config", kind="file", help="training config with a 'dagger' section (see "
                "configs/dagger_pilotnet.yaml; dagger.world: road, replay or track)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. dagger.minutes=2")
    q.set_defaults(func=cmd_sim_dagger)

    q = sub.add_parser("replay", help="closed-loop replay on a recording: would the model keep the car on the "
                       "human's path?", epilog="example: steerlab replay runs/ch2/best.pt --data "
                       "../shared/data/udacity-ch2 --range 1800:2400 --speed 15 --out runs/replay --video replay.mp4; "
                       "steerlab replay runs/tub/best.pt --data ../shared/data/donkeycar/hall --reader "
                       "full_lock_deg=25 --lane-width 0.9 --out runs/replay-hall")
    path_option(q, "checkpoints", kind="file", nargs="+", help="checkpoints (.pt) or exported models (.onnx) to replay")
    data_args(q, camera=False)
    path_option(q, "--out", kind="folder", makes="replay", default="runs/replay",
                help="output folder (default runs/replay)")
    path_option(q, "--video", kind="new-file",
                help="also write an MP4 of the warped view with the model's and the human's steering "
                     "(one per checkpoint)")
    q.add_argument("--world", choices=list(WORLDS), help="road: a car's replay, the frames warped as a pinhole "
                   "camera's, an intervention off the human's path or heading; track: a small car's, through its "
                   "fisheye, the speed from the throttle, an intervention when the body leaves the lane (default: the "
                   "world of the recording's camera: track for donkeycar tubs and the track world's recordings, road "
                   "for the others)")
    for w in WORLDS.values():
        add_options(q, "replay", w.replay.options, label=None if w.name == first else f"--world {w.name}")
    q.set_defaults(func=cmd_replay)

    q = sub.add_parser("serve", help="drive the Udacity simulator (socket.io server on port 4567)",
                       epilog="example: steerlab serve runs/sim/best.pt --record runs/sim-drive; then start the "
                              "simulator in autonomous mode (docs/guide/simulator.md)")
    path_option(q, "checkpoint", kind="file", help="checkpoint (.pt) or exported model (.onnx)")
    add_options(q, "serve", ServeOptions)
    q.set_defaults(func=cmd_serve)

    q = sub.add_parser("demo", help="the whole pipeline on synthetic data: record, train (with one DAgger round), "
                       "evaluate, replay, drive, report", epilog="example: steerlab demo --out runs/demo")
    add_options(q, "demo", DemoOptions)
    q.set_defaults(func=cmd_demo)
