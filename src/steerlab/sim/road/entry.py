"""The road world's registry entry (`core.entry.WorldEntry`, registered by `sim/worlds.py`): what the commands,
DAgger, experiments and tuning use of it, and its own options of a `dagger:` section."""

from __future__ import annotations

from dataclasses import dataclass

from steerlab.options import Options, option
from steerlab.sim.core.entry import (Column, DaggerEntry, Driver, Recorder, ReplayEntry, ReportEntry, SuiteEntry,
                                     WorldEntry)
from steerlab.sim.replay.run import ReplayOptions
from steerlab.sim.road import run, suite
from steerlab.sim.road.world import ROAD_CAMERAS, ROADS, DriveOptions, RecordOptions, _roads, road_types

TYPES = tuple(t for k in suite.SUITES.values() for t in k["roads"])  # the suites' road types, in their order


@dataclass(frozen=True)
class RoadDaggerOptions(Options):
    """The options of a `dagger:` section that only the road world takes."""

    roads: str = option("mixed", _roads, ROADS, help="road world: road types of the rollouts")
    suite_roads: str | None = option(None, help="road world: comma list of the suite's road types to drive "
                                     "(default: all)")

    suite_keys = {"roads": "suite_roads"}  # the round's suite options these set, and their names in `dagger:`
    suite_places = "suite_roads"  # the one that picks the suite's places

    def kinds(self) -> list[str]:
        """The road types of a round's rollouts, one rollout of each."""
        return road_types(self.roads)


def _autonomy(types) -> tuple[str, ...]:
    return tuple(f"autonomy_{t}" for t in dict.fromkeys(types))



def plot_drives(out, suites: dict, o) -> None:
    """An experiment's figures of its entries' seed-0 drives (`plots.plot_drives`)."""
    from steerlab.sim.road.plots import plot_drives as plot  # matplotlib: imported where it draws

    plot(out, suites, o)


ENTRY = WorldEntry(
    name="road", help="a full-size car on procedural roads", cameras=ROAD_CAMERAS,
    record=Recorder(options=RecordOptions, run=run.record),
    drive=Driver(options=DriveOptions, run=run.drive_checkpoint,
                 files="trajectory.csv, path.png, frames.png, drive.json"),
    suite=SuiteEntry(options=suite.SuiteOptions, versions=suite.SUITES, run=suite.run_suite, figures="roads/*.png"),
    replay=ReplayEntry(options=ReplayOptions),
    dagger=DaggerEntry(options=RoadDaggerOptions, rollout=run.rollout_job, camera=lambda rec: rec.geometry,
                       done="recording.json", round_columns=suite.round_columns,
                       columns=(*_autonomy(TYPES), "autonomy_all", "interventions_per_km"),
                       series=(*zip(_autonomy(TYPES), ("o-", "s-", "^-"), dict.fromkeys(TYPES)),
                               ("autonomy_all", "k.--", "all"))),
    report=ReportEntry(
        metrics=suite.closed_loop_metrics,
        table=(Column(header="autonomy [%]", keys=("autonomy",), digits=1, std=True),
               Column(header=" / ".join(dict.fromkeys(TYPES)) + " [%]", keys=_autonomy(TYPES), digits=1),
               Column(header="interventions/km", keys=("interventions_per_km",), digits=2),
               Column(header="command gamma [deg]", keys=("command_gamma_deg",), digits=3)),
        worst=Column(header="worst seed: " + " / ".join(dict.fromkeys(TYPES)) + " [%]", keys=_autonomy(TYPES),
                     digits=1),
        plot_drives=plot_drives))
