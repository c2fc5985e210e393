"""A training config's recording in closed-loop replay: rollouts over its training frames (DAgger in replay)
and replays of its validation frames (after every DAgger round, and in experiments)."""

from __future__ import annotations

from pathlib import Path

from steerlab.data.car import CARS
from steerlab.data.geometry import CAMERAS
from steerlab.data.readers import Source
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError
from steerlab.sim.core.parallel import run_parallel, tick_reporter
from steerlab.sim.replay.run import rollout_recording, run_replay
from steerlab.sim.replay.world import Replay
from steerlab.sim.worlds import world_of
from steerlab.train.config import TrainConfig
from steerlab.train.sources import main_recording


def _rollout_job(checkpoint: str, out: str, source: Source, replay: Replay, beta: float, seed: int) -> dict:
    from steerlab.pilot import Pilot

    return rollout_recording(Pilot(checkpoint), replay, source.open(), source.frames, out, beta, seed,
                             on_tick=tick_reporter())


class SplitReplay:
    """The recording of `cfg`, its split, and its replay as `steerlab replay` makes it in the world of its camera
    (`speed`, else the recorded or estimated one)."""

    def __init__(self, cfg: TrainConfig, speed: float | None = None):
        rec = main_recording(cfg)
        if rec.geometry not in CAMERAS:
            raise SteerlabError(f"{rec.source}: replay knows no camera geometry for {rec.geometry!r} frames")
        self.train_idx, self.val_idx = make_split(cfg.split, len(rec), rec.extra.get("session"))
        try:  # before any training: the models of this recording must steer the replayed car
            rec.convention.to_road_wheel_left(0.0, CARS[rec.geometry].steering_ratio)
        except SteerlabError as e:
            raise SteerlabError(f"{rec.source}: replay cannot turn its steering into a wheel angle: {e}") from None
        self.options = world_of(rec.geometry).replay.options(speed=speed, workers=1)
        setup = self.options.setup(rec)
        self.replay = setup.replay
        self.source = Source(cfg.data, cfg.range, cfg.labels, cfg.reader)

    def _frames(self, idx) -> Source:
        return Source(**{**self.source.__dict__, "frames": tuple(int(i) for i in idx)})

    def rollouts(self, checkpoint: Path, folder: Path, beta: float, seed: int, progress: bool) -> list[dict]:
        job = (str(checkpoint), str(folder), self._frames(self.train_idx), self.replay, beta, seed)
        return run_parallel(_rollout_job, [job], 1, len(self.train_idx), progress, "replay rollouts")

    def evaluate(self, checkpoint: Path, out: Path, progress: bool) -> dict:
        row = run_replay([checkpoint], self._frames(self.val_idx), out, self.options, progress=progress)[0]
        return {"replay_autonomy": row["autonomy"], "replay_interventions_per_km": row["interventions_per_km"],
                "replay_mean_offset_m": row["mean_offset_m"]}
