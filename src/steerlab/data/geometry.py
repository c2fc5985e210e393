"""Camera geometry of the recordings steerlab knows, and viewpoint shifts of the flat road plane.

A `Camera` is a pinhole camera on a car: image size, focal length, principal row, mount height and pitch
(down positive), looking straight ahead from the car's centre line. Vehicle axes are forward, left, up
(metres); camera axes x right, y down, z along the optical axis. The presets carry the name of the
preprocessing preset whose frames they match (docs/ARCHITECTURE.md shows real and rendered frames side by
side), and the synthetic world renders with the same cameras.

`viewpoint_maps(cam, shift_m, yaw_deg)` gives the remap that turns a frame into the frame a camera moved
`shift_m` to the left and turned `yaw_deg` to the left would have seen, assuming (as NVIDIA's PilotNet
augmentation does) that everything below the horizon lies on the flat ground and everything above it is
infinitely far away.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from steerlab.errors import SteerlabError


@dataclass(frozen=True)
class Camera:
    width: int
    height: int
    focal: float         # px
    cy: float            # principal point row
    mount_height: float  # m above the ground
    pitch_deg: float     # down positive

    @property
    def horizon(self) -> float:
        """Image row of the horizon."""
        return self.cy - self.focal * np.tan(np.radians(self.pitch_deg))

    def rays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Direction (forward, left, up) of the ray through every pixel centre, each (H, W)."""
        th = np.radians(self.pitch_deg)
        xc = (np.arange(self.width) + 0.5 - self.width / 2) / self.focal
        yc = (np.arange(self.height) + 0.5 - self.cy) / self.focal
        xc, yc = np.meshgrid(xc, yc)
        return np.cos(th) - yc * np.sin(th), -xc, -yc * np.cos(th) - np.sin(th)

    def project(self, fwd, left, up) -> tuple[np.ndarray, np.ndarray]:
        """Continuous image coordinates (u, v) of directions (fwd, left, up) seen from the camera; pixel i
        spans [i, i + 1)."""
        th = np.radians(self.pitch_deg)
        z = fwd * np.cos(th) - up * np.sin(th)
        y = -fwd * np.sin(th) - up * np.cos(th)
        return self.width / 2 - self.focal * left / z, self.cy + self.focal * y / z


# Geometry chosen so that a preprocessed synthetic frame looks like a preprocessed real one of the dataset
# whose preprocessing preset has the same name (see docs/ARCHITECTURE.md for the side-by-side).
CAMERAS = {
    "sim": Camera(320, 160, 277.0, 80.0, 1.3, 4.0),
    "ch2": Camera(640, 480, 554.0, 240.0, 1.45, -1.0),
}


def camera(name: str) -> Camera:
    if name not in CAMERAS:
        raise SteerlabError(f"unknown camera preset {name!r}; choose one of {', '.join(CAMERAS)}")
    return CAMERAS[name]


@lru_cache(maxsize=32)
def viewpoint_maps(cam: Camera, shift_m: float, yaw_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """cv2.remap maps (fixed point) from a frame to the view of the same camera moved `shift_m` to the left
    and turned `yaw_deg` to the left. Ground pixels follow the road plane; sky pixels only turn."""
    f, left, up = cam.rays()
    ground = up < -1e-6
    t = np.where(ground, cam.mount_height / np.where(ground, -up, 1.0), 1.0)
    # a ground point where the ray hits, or for the sky the ray itself as a direction at infinity
    f, left, up = (np.where(ground, t * a, a) for a in (f, left, up))
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    f0, l0 = f * c - left * s, f * s + left * c + np.where(ground, shift_m, 0.0)
    up0 = np.where(ground, -cam.mount_height, up)
    u, v = cam.project(f0, l0, up0)
    th = np.radians(cam.pitch_deg)
    behind = f0 * np.cos(th) - up0 * np.sin(th) <= 1e-6
    u, v = np.where(behind, -1e4, u - 0.5), np.where(behind, -1e4, v - 0.5)  # remap indexes pixel centres
    return cv2.convertMaps(u.astype(np.float32), v.astype(np.float32), cv2.CV_16SC2)


def shift_view(bgr: np.ndarray, cam: Camera, shift_m: float, yaw_deg: float = 0.0) -> np.ndarray:
    """The frame as seen from the camera moved `shift_m` to the left and turned `yaw_deg` to the left.
    Parts of the new view that the original frame does not show repeat its nearest border pixels."""
    if bgr.shape[:2] != (cam.height, cam.width):
        raise SteerlabError(f"a {bgr.shape[1]}x{bgr.shape[0]} frame does not fit the {cam.width}x{cam.height} "
                            "camera geometry of its preset")
    m1, m2 = viewpoint_maps(cam, float(shift_m), float(yaw_deg))
    return cv2.remap(bgr, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
