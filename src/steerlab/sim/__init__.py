"""Driving in closed loop: the worlds a model drives in, and replay on recordings.

- `core/`: what every world shares: the one driving loop and its `Trajectory` (`driving.py`), what it asks of a
  world and a pilot (`contracts.py`: `World`, `Pilot`), the kinematic bicycle (`vehicle.py`), the parallel runner
  (`parallel.py`), the donkeycar part as a pilot (`part.py`), what every suite shares (`suite.py`: the pilots it
  races and the drives it keeps), what a world provides to the commands (`entry.py`: `WorldEntry`) and the frame
  strip of a drive (`plots.py`);
- `replay/`: the generic replay, a recording of a real drive seen as a world (`world.py`), the human's path
  (`path.py`) and `steerlab replay` (`run.py`);
- `road/`: the road world of a full-size car on procedural roads; `track/`: the track world of a donkeycar on a
  procedural track in a hall (and its replay flavour, `replay.py`). Each has `entry.py` (its registry entry),
  `world.py` (the world and its options), `run.py` (record, drive, DAgger's rollouts), `suite.py` (its fixed
  suite), `render.py`, `expert.py` and `plots.py`;
- `worlds.py`: the registry, one entry per world: what the commands, DAgger, experiments and tuning use of it. A
  fourth world is a fourth folder like `road/` and one line there (docs/architecture/worlds.md, "Adding a world").
"""
