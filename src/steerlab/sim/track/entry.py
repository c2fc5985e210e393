"""The track world's registry entry (`core.entry.WorldEntry`, registered by `sim/worlds.py`): what the commands,
DAgger, experiments and tuning use of it, and its own options of a `dagger:` section."""

from __future__ import annotations

from dataclasses import dataclass

from steerlab.data.fisheye import DONKEY_FISHEYE
from steerlab.errors import SteerlabError
from steerlab.options import Options, Range, option
from steerlab.sim.core.entry import (Column, DaggerEntry, Driver, Recorder, ReplayEntry, ReportEntry, SuiteEntry,
                                     WorldEntry)
from steerlab.sim.track.replay import TrackReplayOptions
from steerlab.sim.track import run, suite
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


def _styles(styles: str) -> bool:
    track_styles(styles)
    return True


@dataclass(frozen=True)
class TrackDaggerOptions(Options):
    """The options of a `dagger:` section that only the track world takes."""

    styles: str | None = option(None, _styles, "taped, centre or a comma list of them",
                                help="track world: track styles of the rollouts (default: both)")
    suite_styles: str | None = option(None, help="track world: comma list of the suite's track styles to drive "
                                      "(default: all)")
    max_throttle: float = option(0.5, Range(0, 1, lo_open=True), help="track world: the cap of the learned throttle "
                                 "in the rollouts and the suite, and of the expert's throttle labels (1: uncapped)")

    # the round's suite options these set, and their names in `dagger:`; the one that picks the suite's places
    suite_keys = {"styles": "suite_styles", "max_throttle": "max_throttle"}
    suite_places = "suite_styles"

    def kinds(self) -> list[str]:
        """The track styles of a round's rollouts, one rollout of each."""
        return track_styles(self.styles)


AUTONOMY = tuple(f"autonomy_{s}" for s in STYLES)


def plot_drives(out, suites: dict, o) -> None:
    """An experiment's figures of its entries' seed-0 drives (`plots.plot_drives`)."""
    from steerlab.sim.track.plots import plot_drives as plot  # matplotlib: imported where it draws

    plot(out, suites, o)


ENTRY = WorldEntry(
    name="track", help="a donkeycar on a procedural track in a hall, seen through its fisheye", cameras=("donkey",),
    record=Recorder(options=TrackRecordOptions, run=run.record),
    drive=Driver(options=TrackDriveOptions, run=run.drive_checkpoint,
                 files="trajectory.csv, track.png, frames.png, drive.json"),
    suite=SuiteEntry(options=suite.TrackSuiteOptions, versions=suite.TRACK_SUITES, run=suite.run_suite,
                     figures="tracks/*.png"),
    replay=ReplayEntry(options=TrackReplayOptions),
    dagger=DaggerEntry(options=TrackDaggerOptions, rollout=run.rollout_job,
                       camera=lambda rec: rec.fisheye or DONKEY_FISHEYE, done="manifest.json",
                       round_columns=suite.round_columns, columns=("clean_laps_pct", "lap_ratio", "off_track_per_lap"),
                       series=(("clean_laps_pct", "g*-", "clean laps of the track suite"),)),
    report=ReportEntry(
        metrics=suite.closed_loop_metrics,
        table=(Column(header="autonomy [%]", keys=("autonomy",), digits=1, std=True),
               Column(header=" / ".join(STYLES) + " [%]", keys=AUTONOMY, digits=1),
               Column(header="clean laps [%]", keys=("clean_laps_pct",), digits=1),
               Column(header="pace", keys=("lap_ratio",), digits=2),
               Column(header="off track / lap", keys=("off_track_per_lap",), digits=2),
               Column(header="command gamma [deg]", keys=("command_gamma_deg",), digits=3)),
        worst=Column(header="worst seed: " + " / ".join(STYLES) + " [%]", keys=AUTONOMY, digits=1),
        plot_drives=plot_drives))
