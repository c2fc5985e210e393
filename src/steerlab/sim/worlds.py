"""The registry of worlds: one entry per world (`core.entry.WorldEntry`), with everything the commands, DAgger,
experiments and tuning need of it, so that none of them chooses a world by its name or by the type of its options.

A world is a folder of `sim/` (`road/`, `track/`) with the same modules: `entry.py` (its entry, built by keyword,
and its options of a `dagger:` section), `world.py` (the world as the driving loop steps it, `core.contracts.World`,
and the options of recording and driving in it), `run.py` (recording its expert, a model's drive, DAgger's
rollouts), `suite.py` (its fixed, versioned suite), `render.py`, `expert.py` and `plots.py`. A fourth world is a
fourth folder and one more line in `WORLDS` (docs/architecture/worlds.md, "Adding a world"); `register` adds one at run
time (the tests' toy world).
"""

from __future__ import annotations

from steerlab.errors import SteerlabError
from steerlab.options import parse
from steerlab.sim.core.entry import WorldEntry
from steerlab.sim.road.entry import ENTRY as ROAD
from steerlab.sim.track.entry import ENTRY as TRACK

WORLDS: dict[str, WorldEntry] = {w.name: w for w in (ROAD, TRACK)}  # the first: the default


def register(entry: WorldEntry) -> WorldEntry:
    """Add a world to the registry (a world named as one already there is refused). Returns it."""
    if entry.name in WORLDS:
        raise SteerlabError(f"a world named {entry.name!r} is registered already: choose another name")
    WORLDS[entry.name] = entry
    return entry


def default_world() -> WorldEntry:
    """The world a command drives in unless `--world` says otherwise: the first registered."""
    return next(iter(WORLDS.values()))


def world_of(geometry: str) -> WorldEntry:
    """The world a recording of this camera geometry is replayed in unless told: the one that renders it (the
    default world for cameras no world renders)."""
    return next((w for w in WORLDS.values() if geometry in w.cameras), default_world())


def suite_world(version: str) -> WorldEntry:
    """The world whose suite has this version."""
    return next(w for w in WORLDS.values() if version in w.suite.versions)


def all_suites() -> list[str]:
    """Every world's suite versions."""
    return [v for w in WORLDS.values() for v in w.suite.versions]


def closed_loop(section: dict | None, where: str = "closed_loop") -> tuple[WorldEntry, object]:
    """A config's `closed_loop:` section (None: the default world's default suite) as (the world, its suite
    options): the world named by `world:` or, without it, the one whose suite `suite:` names (the default world
    without either)."""
    raw = dict(section or {})
    name = raw.pop("world", None)
    if name is not None and name not in WORLDS:
        raise SteerlabError(f"{where}.world must be one of {', '.join(WORLDS)}, got {name!r}")
    if name is not None:
        world = WORLDS[name]
    elif raw.get("suite") in all_suites():
        world = suite_world(raw["suite"])
    else:
        world = default_world()
    return world, parse(world.suite.options, raw, where)
