"""The speed of a recording that has none, from its frames: the optical flow of the road plane between
consecutive frames read through the camera's known height and pitch (closed-loop replay of CH2 frames and
donkeycar tubs needs a speed)."""

from __future__ import annotations

import cv2
import numpy as np

from steerlab.data.geometry import Camera
from steerlab.data.recording import Recording
from steerlab.errors import DataError


def estimate_speed(rec: Recording, cam: Camera, count: int = 100) -> float:
    """The recording's speed (m/s) from its frames: the optical flow (DIS) of the road plane between pairs of
    consecutive frames, read through the camera's known height and pitch. A textured pixel of the road ahead
    (middle half of the columns, below the far distance, above the bonnet, on an edge across the road whose
    motion the flow can see) at row v lies at distance
    h / tan(depression(v)); where it moved to in the next frame gives the distance the car drove. The median
    over `count` frame pairs spread over the recording; raises when the road shows too little texture."""
    horizon, h = cam.horizon, cam.height
    top, bottom = int(horizon + 0.15 * (h - horizon)), int(h - 0.12 * (h - horizon))
    if bottom - top < 8:
        raise DataError(rec.source, "the camera sees too little road to estimate the speed; give it (steerlab replay "
                                    "--speed M/S, or speed: in a config's replay: section)")
    rows = np.arange(top, bottom)[:, None] + 0.5
    distance = lambda v: cam.mount_height / np.tan(np.arctan2(v - cam.cy, cam.focal) + np.radians(cam.pitch_deg))  # noqa: E731
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    seg = rec.segment_ids()
    pairs = [i for i in range(len(rec) - 1) if seg[i] == seg[i + 1]]
    estimates = []
    for i in [pairs[k] for k in np.linspace(0, len(pairs) - 1, min(count, len(pairs))).astype(int)] if pairs else []:
        a, b = (cv2.cvtColor(rec.load_frame(j), cv2.COLOR_BGR2GRAY)[top:bottom] for j in (i, i + 1))
        moved = rows + dis.calc(a, b, None)[..., 1]
        gy, gx = np.abs(cv2.Sobel(a, cv2.CV_32F, 0, 1)), np.abs(cv2.Sobel(a, cv2.CV_32F, 1, 0))
        use = (gy > 20) & (gx < 0.3 * gy) & (moved > horizon + 1)  # edges across the road: no aperture problem
        use[:, : cam.width // 4] = use[:, 3 * cam.width // 4:] = False
        if use.sum() >= 50:
            drove = distance(rows) - distance(np.where(use, moved, rows))
            estimates.append(float(np.median(drove[use])) / ((rec.timestamps_ns[i + 1] - rec.timestamps_ns[i]) / 1e9))
    if len(estimates) < max(5, 0.5 * min(count, len(pairs))):
        raise DataError(rec.source, "cannot estimate the speed from the frames (the road shows too little texture); "
                                    "give it (steerlab replay --speed M/S, or speed: in a config's replay: "
                                    "section)")
    return float(np.median(estimates))
