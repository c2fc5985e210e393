"""Camera geometry of the recordings steerlab knows, and viewpoint shifts of the flat road plane.

A `Camera` is a pinhole camera on a car: image size, focal length, principal row, mount height and pitch
(down positive), looking straight ahead from the car's centre line. Vehicle axes are forward, left, up
(metres); camera axes x right, y down, z along the optical axis. The presets carry the name of the
preprocessing preset whose frames they match (docs/architecture/road-world.md shows real and rendered frames side by
side), and the road world renders with the same cameras.

`shift_view(frame, cam, shift_m, yaw_deg)` turns a frame into the frame a camera moved `shift_m` to the left
and turned `yaw_deg` to the left would have seen (two homographies: the flat road plane and the sky); it makes
the viewpoint-shift augmentation and the views of closed-loop replay on recordings.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from steerlab.errors import SteerlabError
from steerlab.options import PIXELS, Range, value_of

MAX_MOUNT_M = 10.0  # a camera's mount height: higher than a bus's roof is a mistake of units


@dataclass(frozen=True)
class Camera:
    width: int
    height: int
    focal: float         # px
    cy: float            # principal point row
    mount_height: float  # m above the ground
    pitch_deg: float     # down positive

    def __post_init__(self):  # each field of its kind and plausible, named: a camera is given in the Python API too
        value_of(int, self.width, "camera.width", PIXELS)
        value_of(int, self.height, "camera.height", PIXELS)
        value_of(float, self.focal, "camera.focal", Range(0, lo_open=True, unit="px"))
        value_of(float, self.cy, "camera.cy", Range(0, self.height, unit="px (a row of the frame)"))
        value_of(float, self.mount_height, "camera.mount_height",
                 Range(0, MAX_MOUNT_M, lo_open=True, unit="m above the ground (not cm)"))
        value_of(float, self.pitch_deg, "camera.pitch_deg", Range(-90, 90, True, True, "degrees, down positive"))

    @property
    def horizon(self) -> float:
        """Image row of the horizon."""
        return self.cy - self.focal * np.tan(np.radians(self.pitch_deg))

    def ray(self, u, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Direction (forward, left, up) of the ray through continuous image coordinates (u, v)."""
        th = np.radians(self.pitch_deg)
        xc, yc = (np.asarray(u, float) - self.width / 2) / self.focal, (np.asarray(v, float) - self.cy) / self.focal
        return np.cos(th) - yc * np.sin(th), -xc, -yc * np.cos(th) - np.sin(th)

    def project(self, fwd, left, up) -> tuple[np.ndarray, np.ndarray]:
        """Continuous image coordinates (u, v) of directions (fwd, left, up) seen from the camera; pixel i
        spans [i, i + 1)."""
        th = np.radians(self.pitch_deg)
        z = fwd * np.cos(th) - up * np.sin(th)
        y = -fwd * np.sin(th) - up * np.cos(th)
        return self.width / 2 - self.focal * left / z, self.cy + self.focal * y / z


# Geometry chosen so that a preprocessed synthetic frame looks like a preprocessed real one of the dataset
# whose preprocessing preset has the same name (see docs/architecture/road-world.md for the side-by-side). donkey: the
# 160x120 wide-angle camera of a donkeycar, mounted low and pitched down (horizon near row 35, as in the shared
# tubs); its lens is a fisheye, which a pinhole of 100 degrees horizontal field of view only approximates.
CAMERAS = {
    "sim": Camera(320, 160, 277.0, 80.0, 1.3, 4.0),
    "ch2": Camera(640, 480, 554.0, 240.0, 1.45, -1.0),
    "donkey": Camera(160, 120, 67.0, 60.0, 0.15, 20.0),
}


def with_overrides(cam: Camera, mount_height: float | None = None, pitch_deg: float | None = None,
                   hfov_deg: float | None = None) -> Camera:
    """A camera geometry with its mount height (m), pitch (deg, down positive) or horizontal field of view
    (deg) replaced, for a car whose camera sits elsewhere."""
    if mount_height is not None and not 0 < mount_height < 10:
        raise SteerlabError(f"camera mount height must lie in (0, 10) m, got {mount_height}")
    if pitch_deg is not None and not -45 < pitch_deg < 45:
        raise SteerlabError(f"camera pitch must lie in (-45, 45) degrees, got {pitch_deg}")
    if hfov_deg is not None and not 10 < hfov_deg < 170:
        raise SteerlabError(f"horizontal field of view must lie in (10, 170) degrees, got {hfov_deg}")
    focal = cam.focal if hfov_deg is None else cam.width / 2 / np.tan(np.radians(hfov_deg) / 2)
    return replace(cam, focal=float(focal), mount_height=cam.mount_height if mount_height is None else float(mount_height),
                   pitch_deg=cam.pitch_deg if pitch_deg is None else float(pitch_deg))


def camera(name: str) -> Camera:
    if name not in CAMERAS:
        raise SteerlabError(f"unknown camera geometry {name!r}; choose one of {', '.join(CAMERAS)}")
    return CAMERAS[name]


def _ground_row(cam: Camera) -> int:
    """First image row whose pixel centres look below the horizon (0 .. height)."""
    return int(np.clip(np.floor(cam.horizon - 0.5) + 1, 0, cam.height))


def viewpoint_homographies(cam: Camera, shift_m: float, yaw_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Homographies (pixel index of the new view -> pixel index of the frame) for the camera moved `shift_m`
    to the left and turned `yaw_deg` to the left: one for the ground below the horizon (the flat road plane
    seen from two places), one for the sky (directions at infinity, which only turn)."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    first = _ground_row(cam)
    out = []
    for rows, ground in (((max(first, (first + cam.height) / 2 - 1), cam.height - 1), True), ((0, max(first - 1, 1)), False)):
        u = np.array([0.0, cam.width - 1, 0.0, cam.width - 1])
        v = np.array([rows[0], rows[0], rows[1], rows[1]], float)
        f, left, up = cam.ray(u + 0.5, v + 0.5)
        if ground:  # where the ray meets the road, then that point seen from the frame's camera
            t = cam.mount_height / -up
            f, left, up = t * f, t * left, np.full(4, -cam.mount_height)
        f0, l0 = f * c - left * s, f * s + left * c + (shift_m if ground else 0.0)
        u0, v0 = cam.project(f0, l0, up)
        out.append(cv2.getPerspectiveTransform(np.stack([u, v], 1).astype(np.float32),
                                               np.stack([u0 - 0.5, v0 - 0.5], 1).astype(np.float32)))
    return out[0], out[1]


def shift_view(bgr: np.ndarray, cam: Camera, shift_m: float, yaw_deg: float = 0.0) -> np.ndarray:
    """The frame as seen from the camera moved `shift_m` to the left and turned `yaw_deg` to the left,
    assuming (as NVIDIA's PilotNet augmentation does) that everything below the horizon lies on the flat
    ground and everything above it is infinitely far away. Parts of the new view that the original frame
    does not show repeat its nearest border pixels."""
    if bgr.shape[:2] != (cam.height, cam.width):
        raise SteerlabError(f"a {bgr.shape[1]}x{bgr.shape[0]} frame does not fit the {cam.width}x{cam.height} "
                            "camera geometry of its preset: give frames of that camera")
    if shift_m == 0 and yaw_deg == 0:
        return bgr.copy()
    ground, sky = viewpoint_homographies(cam, float(shift_m), float(yaw_deg))
    first = _ground_row(cam)
    out = np.empty_like(bgr)
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    for m, rows in ((ground, slice(first, cam.height)), (sky, slice(0, first))):
        if rows.stop > rows.start:  # warp into the rows only: the homography takes the rows' own origin
            m = m @ np.array([[1, 0, 0], [0, 1, rows.start], [0, 0, 1]], float)
            out[rows] = cv2.warpPerspective(bgr, m, (cam.width, rows.stop - rows.start), flags=flags,
                                            borderMode=cv2.BORDER_REPLICATE).reshape(out[rows].shape)
    return out
