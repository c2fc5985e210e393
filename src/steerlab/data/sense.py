"""Which way a recording's frames turn when its steering turns: the check that its views and its replay are of
the car's world and not of its mirror image.

A car that turns left sees the world above the horizon (walls, buildings, trees: far away, so a turn moves them
and driving on hardly does) move to the right in its frames. `frame_turn` measures that motion from frame to frame
(the horizontal shift of the band above the horizon, `band_shifts`) and its correlation with the recorded steering, turned left
positive, at the lag (up to `MAX_LAG` frames: the servo and the car take a moment) where it is strongest. A
recording whose frames turn against its steering (r <= -`CONTRARY`) has frames that are mirror images (a camera
flipped left-right in its config) or a steering whose sign is the other way round: for the model that is the
same car, but a view warped as from a car moved left would be labelled as a car moved right, and replay would
drive the mirror image of its path. `check_sense` refuses such a recording for views and replay unless the reader
says its frames are mirrored (the tub reader's option `mirrored`, kept with its lens: `FisheyeCamera.mirrored`),
and refuses `mirrored` where the frames turn with the steering. Where the frames cannot tell (a steering that
hardly varies, frames without texture above the horizon: |r| below `CONTRARY`), nothing is said."""

from __future__ import annotations

import numpy as np

from steerlab.errors import DataError

BAND = (0.04, 0.33)  # the rows above the horizon, as fractions of the height (the donkey camera, pitched 20 deg down)
MAX_SHIFT = 12       # px a frame's band may move to the next
MAX_LAG = 8          # frames from a steering to the turn it makes
CONTRARY = 0.5       # |r| from which the frames are taken to say which way they turn
CHUNKS, CHUNK = 40, 24  # up to this many runs of consecutive frames, evenly spaced, this many frame pairs each
MAX_GAP_S = 0.2      # a longer gap between two frames is no pair
MIN_PAIRS = 40       # fewer frame pairs tell nothing


def band_profile(frame: np.ndarray) -> np.ndarray:
    """The horizontal profile of a frame's band above the horizon: the gradient of its mean grey level per column,
    zero mean."""
    h = frame.shape[0]
    band = np.asarray(frame[int(BAND[0] * h):max(int(BAND[1] * h), int(BAND[0] * h) + 1)], np.float32)
    p = np.gradient(band.mean(axis=(0, 2)) if band.ndim == 3 else band.mean(axis=0))
    return p - p.mean()


def band_shifts(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """How far (px, right positive) each profile of `b` lies to the right of the same row's profile of `a` (rows:
    pairs of frames): the normalised correlation's peak over shifts up to MAX_SHIFT, refined to a fraction of a
    pixel by the parabola through the peak and its neighbours."""
    m = MAX_SHIFT
    xs = np.arange(m, a.shape[1] - m)
    bb = b[:, xs]
    score = np.stack([np.sum(a[:, xs - d] * bb, axis=1)
                      / (np.linalg.norm(a[:, xs - d], axis=1) * np.linalg.norm(bb, axis=1) + 1e-9)
                      for d in range(-m, m + 1)], axis=1)
    k = np.argmax(score, axis=1)
    inner = (k > 0) & (k < 2 * m)
    kk = np.clip(k, 1, 2 * m - 1)
    y0, y1, y2 = (np.take_along_axis(score, (kk + o)[:, None], 1)[:, 0] for o in (-1, 0, 1))
    refined = k + np.where(inner, 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2 - 1e-12), 0.0)
    return refined - m


def frame_turn(rec, frames: np.ndarray | None = None) -> tuple[float, int]:
    """(r, pairs): the correlation of the frames' turn to the right (the band's shift, `band_shifts`) with the
    steering turned left positive, at the lag of 0..MAX_LAG frames where |r| is largest, over up to CHUNKS runs of
    CHUNK consecutive frame pairs of `frames` (default all), evenly spaced and apart; r is nan where fewer than
    MIN_PAIRS pairs fit or the steering does not vary."""
    idx = np.arange(len(rec.timestamps_ns)) if frames is None else np.asarray(frames)
    span = CHUNK + MAX_LAG + 1
    runs = [idx[s:s + span] for s in np.linspace(0, len(idx) - span, min(CHUNKS, len(idx) // span)).astype(int)]
    left = (-1.0 if rec.convention.positive == "right" else 1.0) * np.asarray(rec.steering, float)
    a, b, steer = [], [], []  # the pairs' profiles, and the steering 0..MAX_LAG frames before each pair
    for run in runs:
        t = rec.timestamps_ns[run] / 1e9
        prof = [band_profile(rec.load_frame(int(i))) for i in run[MAX_LAG:]]
        for k in range(CHUNK):
            j = MAX_LAG + k  # the pair (run[j], run[j + 1]), its steering from run[j - MAX_LAG] on, no gap between
            if np.all(np.diff(t[j - MAX_LAG:j + 2]) <= MAX_GAP_S):
                a.append(prof[k])
                b.append(prof[k + 1])
                steer.append(left[run[j - np.arange(MAX_LAG + 1)]])
    if len(a) < MIN_PAIRS:
        return float("nan"), len(a)
    shifts, steer = band_shifts(np.array(a), np.array(b)), np.array(steer)
    if np.std(shifts) < 1e-6:
        return float("nan"), len(a)
    rs = [float(np.corrcoef(shifts, s)[0, 1]) for s in steer.T if np.std(s) > 1e-6]
    return (max(rs, key=abs) if rs else float("nan")), len(a)


def check_sense(rec, mirrored: bool, what: str, frames: np.ndarray | None = None) -> None:
    """Refuse `what` (views, replay) of a recording whose frames turn against its steering unless `mirrored`, and
    `mirrored` where they turn with it (see the module's docstring)."""
    r, pairs = frame_turn(rec, frames)
    if not abs(r) >= CONTRARY:  # nan too: the frames cannot tell
        return
    if r < 0 and not mirrored:
        raise DataError(rec.source, f"its frames turn against its steering: the view above the horizon moves left "
                                    f"while the steering turns left (r = {r:+.2f} over {pairs} frame pairs; a car "
                                    f"turning left sees it move right): its frames are mirror images or its "
                                    f"steering's sign is the other way round, so {what} would be of the mirror "
                                    f"image of its world; give reader option mirrored=true to read it so")
    if r > 0 and mirrored:
        raise DataError(rec.source, f"reader option mirrored is true, but its frames turn with its steering (r = "
                                    f"{r:+.2f} over {pairs} frame pairs): leave mirrored out")
