"""The registry of worlds: one entry per world, with everything the commands and DAgger need of it, so that no
command chooses a world by its name or by the type of its options.

A world is a folder of `sim/` (`road/`, `track/`) with the same modules: `world.py` (the world as the driving loop
steps it, `core.contracts.World`, and the options of recording and driving in it), `run.py` (recording its expert,
a model's drive, DAgger's rollouts), `suite.py` (its fixed, versioned suite), `render.py`, `expert.py` and
`plots.py`. Recordings of its cameras replay through the replay options it names (`replay/`). A third world is a
third folder and a third entry here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from steerlab.data.fisheye import DONKEY_FISHEYE
from steerlab.errors import SteerlabError
from steerlab.sim.replay.run import ReplayOptions
from steerlab.sim.replay.track import TrackReplayOptions
from steerlab.sim.road import run as road_run, suite as road_suite
from steerlab.sim.road.world import ROAD_CAMERAS, DriveOptions, RecordOptions, road_types
from steerlab.sim.track import run as track_run, suite as track_suite
from steerlab.sim.track.track import STYLES
from steerlab.sim.track.world import TrackDriveOptions, TrackRecordOptions


def track_styles(text: str | None) -> list[str]:
    """"taped", "centre" or a comma list of them (None: both)."""
    styles = list(STYLES) if text is None else [t.strip() for t in text.split(",") if t.strip()]
    bad = [s for s in styles if s not in STYLES]
    if bad or not styles:
        raise SteerlabError(f"unknown track style {','.join(bad) or text!r}; choose {' or '.join(STYLES)}, or a "
                            "comma list")
    return styles


@dataclass(frozen=True)
class WorldEntry:
    """What a world provides.

    - `name`, `help`: `--world NAME` and what it is; `cameras`: the camera geometries its renderer makes (a
      recording of one of them is replayed in this world unless told otherwise);
    - `kinds`: the name of the option that picks some of its places (`roads`: road types; `styles`: track styles)
      and `parse_kinds` that reads it (None: all);
    - recording its expert: `record_options`, `record(out, options)`;
    - a model's drive: `drive_options`, `drive(checkpoint, out, options, drive_with, video)` (`pilot.DriveWith`:
      how its Pilot is made) and the files it writes;
    - its suite: `suite_options`, `suite(checkpoints, out, options, progress, plots)` -> summary rows, its versions
      and figures, and `round_columns(summary)`: a DAgger round's columns of dagger.csv;
    - replay of its recordings: `replay_options` (their `setup(rec)` makes the replay);
    - DAgger's rollouts: `rollout(checkpoint, out, seed, minutes, kind, beta, camera, suite)` (run in a worker process),
      `rollout_camera(rec)`: what the rollouts render through for a training recording, and `rollout_done`: the
      file a finished rollout has.
    """

    name: str
    help: str
    cameras: tuple[str, ...]
    kinds: str
    parse_kinds: Callable[[str | None], list[str]]
    record_options: type
    record: Callable
    drive_options: type
    drive: Callable
    drive_files: str
    suite_options: type
    suite: Callable
    suites: dict
    suite_figures: str
    round_columns: Callable
    replay_options: type
    rollout: Callable
    rollout_camera: Callable
    rollout_done: str


WORLDS = {
    "road": WorldEntry(
        "road", "a full-size car on procedural roads", ROAD_CAMERAS, "roads",
        lambda text: road_types("mixed" if text is None else text),
        RecordOptions, road_run.record, DriveOptions, road_run.drive_checkpoint,
        "trajectory.csv, path.png, frames.png, drive.json",
        road_suite.SuiteOptions, road_suite.run_suite, road_suite.SUITES, "roads/*.png", road_suite.round_columns,
        ReplayOptions, road_run.rollout_job, lambda rec: rec.geometry, "recording.json"),
    "track": WorldEntry(
        "track", "a donkeycar on a procedural track in a hall, seen through its fisheye", ("donkey",), "styles",
        track_styles,
        TrackRecordOptions, track_run.record, TrackDriveOptions, track_run.drive_checkpoint,
        "trajectory.csv, track.png, frames.png, drive.json",
        track_suite.TrackSuiteOptions, track_suite.run_suite, track_suite.TRACK_SUITES, "tracks/*.png",
        track_suite.round_columns,
        TrackReplayOptions, track_run.rollout_job, lambda rec: rec.fisheye or DONKEY_FISHEYE, "manifest.json"),
}


def world_of(geometry: str) -> WorldEntry:
    """The world a recording of this camera geometry is replayed in unless told: the one that renders it (the
    road world for cameras no world renders)."""
    return next((w for w in WORLDS.values() if geometry in w.cameras), WORLDS["road"])


def suite_world(version: str) -> WorldEntry:
    """The world whose suite has this version."""
    return next(w for w in WORLDS.values() if version in w.suites)
