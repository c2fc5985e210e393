"""The track world's replay flavour under the path it had before it moved into the track world's folder
(`sim/track/replay.py`): the studies that import it here import it there once they move. Nothing in steerlab imports
this alias; the layering counts it as a module of `track/` (tests/test_layers.py)."""

from steerlab.sim.track.replay import TrackReplay, TrackReplayOptions, TrackReplayWorld

__all__ = ["TrackReplay", "TrackReplayOptions", "TrackReplayWorld"]
