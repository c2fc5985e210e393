"""Driving in closed loop: the worlds a model drives in, and replay on recordings.

- `core/`: what every world shares: the one driving loop and its `Trajectory` (`driving.py`), what it asks of a
  world and a pilot (`contracts.py`: `World`, `Pilot`), the kinematic bicycle (`vehicle.py`), the parallel runner
  (`parallel.py`), the donkeycar part as a pilot (`part.py`), what both suites share (`suite.py`) and the frame
  strip of a drive (`plots.py`);
- `road/`: the road world of a full-size car on procedural roads; `track/`: the track world of a donkeycar on a
  procedural track in a hall. Each has `world.py` (the world and its options), `run.py` (record, drive, DAgger's
  rollouts), `suite.py` (its fixed suite), `render.py`, `expert.py` and `plots.py`;
- `replay/`: a recording of a real drive seen as a world (`world.py`; `track.py` for small cars), the human's path
  (`path.py`) and `steerlab replay` (`run.py`);
- `worlds.py`: the registry, one entry per world: what the commands and DAgger use of it. A third world is a third
  folder like `road/` and an entry there.
"""
