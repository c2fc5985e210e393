"""torch's data path for training: a `Dataset` over the memory-mapped cache that gathers whole batches, an
`EpochSampler` that draws each epoch's batches, and a `DataLoader` with worker processes (`processes.worker_context`)
and prefetch (pinned memory on CUDA) that fills them while the model trains.

Everything random is drawn where the batches are drawn, in the main process, from the seed and the epoch:
the order (a `RandomSampler` over the samples, thinned by balanced sampling and repeated by recovery weighting), flips, motion dropout, and one augmentation seed per batch. A worker only computes, so the
batches are the same whatever the number of workers. With several ranks (DDP) every rank draws the same global
batches and takes its contiguous share of each, so K ranks with a global batch B take the steps one process
takes with batch B."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset, RandomSampler, Sampler

from steerlab.data.dataset import CompiledDataset
from steerlab.data.inputs import Standardizer, gather, history, segment_starts, stack_modalities
from steerlab.data.labels import lane_targets, speed_targets
from steerlab.errors import SteerlabError
from steerlab.processes import worker_context
from steerlab.train.augment import augment, mirror, no_motion

PREFETCH = 4  # batches each worker prepares ahead


@dataclass(frozen=True)
class Batch:
    """What to gather: sample codes (B,) or windows of codes (B, T), which samples to mirror (steering negated)
    and which to show "no motion seen", per frame, the seed of the batch's augmentation draws, and the weight of
    this rank's loss (ranks x its share of the global batch: DDP averages the ranks' gradients)."""

    codes: np.ndarray
    flip: np.ndarray | None = None
    still: np.ndarray | None = None
    seed: tuple | None = None
    weight: float = 1.0


class FrameBatches(Dataset):
    """Standardised batches from the cache: `dataset[Batch]` -> (inputs, targets), dicts of tensors.

    A source is a compiled camera stream with its own steering labels: the main recording's centre camera
    (source 0, whose frames are the validation frames too), its side cameras and virtual views, and the streams
    of extra training recordings. Sample codes number the frames of all sources one after another (source k's
    frame i is offsets[k] + i). Samples come back in the order asked for; each source is read in sorted order so
    that the memory-mapped reads run forward.
    inputs: "x" (B, C, H, W), and "speeds" (B, K) for models with a speed history; targets: "steering", and
    where the recordings have speed, "speed" (the next frame's) and "command" (paper 002 IV-B2), and with
    `throttle` the recorded "throttle", with `lane` the recorded "lane" (B, 3) over its scales (`labels.LANE`; a
    mirrored sample's offset, heading and curvature change sign with its steering). Windows (B, T) come back with
    a time axis: (B, T, ...)."""

    def __init__(self, sources: list[tuple[CompiledDataset, np.ndarray]], stats: dict, speed_history: int = 0,
                 rotation_deg: float = 0.0, brightness: float = 0.0, throttle: bool = False, hue_deg: float = 0.0,
                 lane: bool = False):
        self.sources, self.cfg, self.standardize = sources, sources[0][0].config, Standardizer(stats)
        self.offsets = np.cumsum([0] + [len(ds) for ds, _ in sources])
        self.local_starts = [segment_starts(ds.labels["segment"]) for ds, _ in sources]
        self.starts = np.concatenate([st + off for st, off in zip(self.local_starts, self.offsets)])  # per code
        self._steering = np.concatenate([y for _, y in sources])
        with_speed = all("speed" in ds.labels for ds, _ in sources)
        self.speed = np.concatenate([ds.labels["speed"] for ds, _ in sources]) if with_speed else None
        self.targets = {}
        if with_speed:
            parts = [speed_targets(ds.labels["speed"], ds.labels["timestamps_ns"], ds.labels["segment"])
                     for ds, _ in sources]
            self.targets = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        if throttle:
            missing = [ds.meta["source"] for ds, _ in sources if "throttle" not in ds.labels]
            if missing:
                raise SteerlabError(f"the throttle is learned from the main recording, but {missing[0]} has none: "
                                    "give recordings that record it, or set train.throttle_weight to 0 to learn the "
                                    "steering alone")
            self.targets["throttle"] = np.concatenate([ds.labels["throttle"] for ds, _ in sources])
        if lane:
            lanes = [lane_targets(ds.labels) for ds, _ in sources]
            missing = [ds.meta["source"] for (ds, _), y in zip(sources, lanes) if y is None]
            if missing:
                raise SteerlabError(f"{missing[0]} has no lane values (lateral offset, heading error, curvature) for "
                                    "train.lane_weight to learn: record it with steerlab sim record --world track, "
                                    "or set train.lane_weight to 0")
            self.targets["lane"] = np.concatenate(lanes)
        self.speed_history, self.rotation_deg, self.brightness, self.hue_deg = (speed_history, rotation_deg,
                                                                               brightness, hue_deg)

    def steering(self, codes: np.ndarray) -> np.ndarray:
        return self._steering[codes]

    def episodes(self) -> np.ndarray:
        """Every code's episode label ("" where the recording has none)."""
        return np.concatenate([ds.labels.get("episode", np.full(len(ds), "")) for ds, _ in self.sources])

    def __getitem__(self, batch: Batch) -> tuple[dict, dict, float]:
        shape = batch.codes.shape
        codes = batch.codes.ravel()
        order = np.argsort(codes, kind="stable")
        source = np.searchsorted(self.offsets, codes, side="right") - 1
        arrays = {}  # per modality, in the cache's own type (uint8 images): the batch is converted once
        for k, (ds, _) in enumerate(self.sources):
            pos = order[source[order] == k]
            if len(pos):
                for m, a in gather(ds.arrays, self.cfg, codes[pos] - self.offsets[k], self.local_starts[k]).items():
                    arrays.setdefault(m, np.empty((len(codes),) + a.shape[1:], a.dtype))[pos] = a
        x = torch.from_numpy(stack_modalities(arrays, self.cfg))  # the rest on the whole batch, in torch
        y = self.steering(codes).astype(np.float32)
        if batch.still is not None and batch.still.any():
            still = torch.from_numpy(batch.still)
            x[still] = no_motion(x[still], self.cfg)
        if batch.flip is not None and batch.flip.any():
            flip = torch.from_numpy(batch.flip)
            x[flip] = mirror(x[flip], self.cfg)
            y[batch.flip] *= -1
        if batch.seed is not None and (self.rotation_deg or self.brightness or self.hue_deg):
            x = augment(x, self.cfg, np.random.default_rng(batch.seed), self.rotation_deg, self.brightness,
                        self.hue_deg)
        inputs = {"x": self.standardize(x)}
        if self.speed_history:
            inputs["speeds"] = torch.from_numpy(
                self.speed[history(codes, self.starts, self.speed_history)].astype(np.float32))
        targets = {"steering": torch.from_numpy(y)}
        targets.update({k: torch.from_numpy(v[codes].astype(np.int64 if k == "command" else np.float32))
                        for k, v in self.targets.items()})
        if "lane" in targets and batch.flip is not None:
            targets["lane"][torch.from_numpy(batch.flip)] *= -1  # mirrored: the lane turns the other way
        if len(shape) == 2:  # windows: (B*T, ...) -> (B, T, ...)
            inputs, targets = ({k: v.view(*shape, *v.shape[1:]) for k, v in d.items()} for d in (inputs, targets))
        return inputs, targets, batch.weight


def balance_weights(steering: np.ndarray, bins: int = 25) -> np.ndarray:
    """Paper 003's balanced subset as sampling weights: the steering range is cut into `bins` equal bins, and a
    sample of a bin with more samples than the mean of the non-empty bins is kept with probability mean / count,
    which thins out driving straight ahead."""
    edges = np.linspace(steering.min(), steering.max(), bins + 1)[1:-1]
    b = np.digitize(steering, edges)
    counts = np.bincount(b, minlength=bins)
    return np.minimum(1.0, counts[counts > 0].mean() / counts[b])


class EpochSampler(Sampler):
    """The batches of one epoch (`set_epoch` before each): `samples` (codes (M,) or windows (M, T)) in an order
    drawn from (seed, epoch) — `weights` thin them out (balanced sampling: each kept with that probability),
    `repeats` draw samples that many times (recovery weighting) —,
    flips and motion dropout drawn per sample (a window as a whole), cut into global batches of `batch_size` of
    which this rank (of `world`) takes its contiguous share; a last batch smaller than `world` is dropped."""

    def __init__(self, samples: np.ndarray, batch_size: int, seed: int, flip: bool = False,
                 motion_dropout: float = 0.0, weights: np.ndarray | None = None, repeats: np.ndarray | None = None,
                 rank: int = 0, world: int = 1):
        self.samples, self.batch_size, self.seed, self.flip = samples, batch_size, seed, flip
        self.motion_dropout, self.weights, self.repeats, self.rank, self.world = motion_dropout, weights, repeats, \
            rank, world
        self.epoch = 1

    def set_epoch(self, epoch: int) -> None:
        self.epoch = epoch

    def order(self) -> np.ndarray:
        """The epoch's samples, in the order they are trained on."""
        g = torch.Generator().manual_seed(int(np.random.SeedSequence([self.seed, self.epoch]).generate_state(1)[0]))
        index = np.arange(len(self.samples)) if self.repeats is None else np.repeat(np.arange(len(self.samples)),
                                                                                     self.repeats)
        if self.weights is not None:  # each sample kept with its weight's probability, drawn anew every epoch
            index = index[torch.bernoulli(torch.from_numpy(self.weights[index]), generator=g).numpy() > 0]
        return self.samples[index[list(RandomSampler(index, generator=g))]]

    def __iter__(self):
        samples = self.order()
        rng = np.random.default_rng([self.seed, self.epoch])
        k = samples[0].size  # frames per sample
        for n, s in enumerate(range(0, len(samples), self.batch_size)):
            b = samples[s: s + self.batch_size]
            flips = np.repeat(rng.random(len(b)) < 0.5, k) if self.flip else None
            still = np.repeat(rng.random(len(b)) < self.motion_dropout, k) if self.motion_dropout else None
            if len(b) < self.world:  # a last batch too small to share
                continue
            lo, hi = self.rank * len(b) // self.world, (self.rank + 1) * len(b) // self.world
            yield Batch(b[lo:hi], *(None if a is None else a[lo * k: hi * k] for a in (flips, still)),
                        (self.seed, self.epoch, n, self.rank), self.world * (hi - lo) / len(b))

    def __len__(self) -> int:
        full, rest = divmod(len(self.order()), self.batch_size)
        return full + (rest >= self.world)


def _init_worker(_: int) -> None:
    cv2.setNumThreads(1)  # a worker is one core's worth of work; torch already gives it one thread


def loader(dataset: FrameBatches, sampler: EpochSampler, workers: int, device: torch.device) -> DataLoader:
    """The batches of `sampler` from `dataset`, prepared by `workers` processes (0: in this one) ahead of the
    model, in pinned memory when the model trains on CUDA."""
    return DataLoader(dataset, sampler=sampler, batch_size=None, num_workers=workers,
                      prefetch_factor=PREFETCH if workers else None, persistent_workers=workers > 0,
                      pin_memory=device.type == "cuda", worker_init_fn=_init_worker if workers else None,
                      multiprocessing_context=worker_context(__name__) if workers else None)


def sequence_windows(codes: np.ndarray, starts: np.ndarray, length: int) -> np.ndarray:
    """Windows (M, length) of consecutive sample codes that lie inside the sample set and inside one segment
    (`starts`: the first code of each code's segment), starting every `length` frames from the segment's start,
    so an epoch sees each frame about once."""
    all_codes = np.sort(codes)
    w = all_codes[(all_codes - starts[all_codes]) % length == 0][:, None] + np.arange(length)
    inside = np.isin(w, all_codes).all(axis=1)
    w = w[inside]
    return w[(starts[w] == starts[w[:, :1]]).all(axis=1)]


def recovery_repeats(samples: np.ndarray, episodes: np.ndarray, weight: int) -> np.ndarray:
    """How often each sample (a code, or a window of codes) is drawn per epoch: `weight` times when it touches a
    recovery episode, else once."""
    touch = np.isin(episodes[samples], "recover")
    touch = touch.any(axis=1) if samples.ndim == 2 else touch
    return np.where(touch, weight, 1)


def epoch_repeats(n: int, repeats: np.ndarray | None, epoch_samples: int) -> np.ndarray | None:
    """How often each of `n` samples is drawn per epoch (`repeats`, None: once each) so that an epoch draws at least
    `epoch_samples` (`train.epoch_samples`): every count as many times over as it takes."""
    drawn = n if repeats is None else int(repeats.sum())
    if not 0 < drawn < epoch_samples:
        return repeats
    over = -(-epoch_samples // drawn)
    return np.full(n, over) if repeats is None else repeats * over
