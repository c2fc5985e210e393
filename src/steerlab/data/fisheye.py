"""The donkeycar camera as OpenCV's fisheye model: per-pixel rays, projection, pinhole views of its frames, and
its frames seen from a camera moved on a flat floor (`shift_view`, the view of replay).

donkeycar's usual camera is a Raspberry Pi camera module with a 160-degree wide-angle lens, read at 160x120. A
pinhole (`geometry.CAMERAS["donkey"]`) only approximates it: straight lines bend, the horizon bulges, and the
image edges see far more than a pinhole of the same centre focal length. OpenCV's fisheye model
(`cv2.fisheye`) describes such a lens with the intrinsic matrix K and four coefficients D = (k1, k2, k3, k4):
a ray at angle theta from the optical axis lands at distance

    theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)

(normalised units; theta_d = theta is the ideal equidistant lens) from the principal point, in the ray's
azimuth. Pixel coordinates follow OpenCV: the centre of pixel (column i, row j) is at (u, v) = (i, j), so K and
D from a user's OpenCV calibration mean what they meant there. Camera axes are OpenCV's (x right, y down, z
along the optical axis); vehicle axes are steerlab's (forward, left, up; see `geometry.py`), the camera
`mount_height` above the floor and pitched `pitch_deg` down.

The default coefficients are rounded from a published OpenCV fisheye calibration of a 160-degree Raspberry Pi
camera module at 640x480 (fx 320.7, fy 314.1, principal point (315.8, 251.7), D = (-0.0227, -0.0246, 0.0000,
0.0115)), scaled to 160x120: about 120 degrees across the image width and 140 across its diagonal. The mount
is that of `geometry.CAMERAS["donkey"]` (0.15 m, 20 degrees down), which puts the horizon near row 35 as in
the shared tubs. A user's own calibration replaces them: `load_calibration(path)`.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields, replace
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
import yaml

from steerlab.data.geometry import CAMERAS
from steerlab.errors import DataError, SteerlabError
from steerlab.files import UniqueKeys, parse_json, read_text
from steerlab.paths import a_path

PINHOLE = CAMERAS["donkey"]  # the pinhole view `undistort` makes by default: the donkey geometry's focal length


MIN_VIEW_DEG = 10.0  # a camera that sees less across renders one colour: nothing to steer by


@dataclass(frozen=True)
class FisheyeCamera:
    width: int = 160
    height: int = 120
    fx: float = 80.2          # px
    fy: float = 78.5          # px
    cx: float = 78.6          # px, OpenCV convention (pixel centres at integers)
    cy: float = 62.6          # px
    d: tuple[float, float, float, float] = (-0.0227, -0.0246, 0.0, 0.0115)
    skew: float = 0.0         # K[0, 1] (px): fx times OpenCV's alpha
    mount_height: float = 0.15  # m above the floor
    pitch_deg: float = 20.0     # down positive
    mirrored: bool = False      # the frames are mirror images of what the lens saw (`shift_view`; data/sense.py)

    def __post_init__(self):
        if not isinstance(self.mirrored, bool):
            raise SteerlabError(f"a fisheye camera's mirrored must be true or false, got {self.mirrored!r}")
        object.__setattr__(self, "d", tuple(float(v) for v in self.d))  # hashable: the pinhole maps are cached
        values = (self.fx, self.fy, self.cx, self.cy, self.skew, self.mount_height, self.pitch_deg, *self.d)
        if len(self.d) != 4 or not all(math.isfinite(float(v)) for v in values):
            raise SteerlabError(f"a fisheye camera needs finite K, four finite coefficients D and a finite mount, "
                                f"got K=({self.fx}, {self.fy}, {self.cx}, {self.cy}), D={self.d}")
        if self.width < 2 or self.height < 2 or self.fx <= 0 or self.fy <= 0:
            raise SteerlabError(f"a fisheye camera needs an image of at least 2x2 px and positive focal lengths, "
                                f"got {self.width}x{self.height}, fx={self.fx}, fy={self.fy}")
        if not (0 <= self.cx <= self.width - 1 and 0 <= self.cy <= self.height - 1):
            raise SteerlabError(f"the principal point ({self.cx}, {self.cy}) lies outside the "
                                f"{self.width}x{self.height} image: fix cx and cy (the calibration's K)")
        # every pixel must see a ray: theta_d(theta) has to rise monotonically past the image corners
        corners = np.array([[0, 0], [self.width - 1, 0], [0, self.height - 1], [self.width - 1, self.height - 1]])
        reach = float(np.max(np.hypot(*self._normalised(corners[:, 0], corners[:, 1]))))
        if reach > np.pi:  # theta_d beyond pi: no lens, whatever its D, sees the corners
            raise SteerlabError(f"the focal lengths fx={self.fx:g}, fy={self.fy:g} px put the image's corners "
                                f"{reach:.3g} rad from the optical axis (beyond pi: no lens sees so wide); K in pixels "
                                f"of the {self.width}x{self.height} image is expected (a K of a smaller image, or in "
                                "other units?)")
        theta = np.linspace(0, np.pi, 2001)
        rising = np.diff(self.distort_theta(theta)) > 0
        top = self.distort_theta(theta[int(np.argmin(rising))] if not rising.all() else np.pi)
        if top <= reach:
            raise SteerlabError(f"fisheye coefficients D={tuple(self.d)} do not map the image corners to rays: "
                                "theta_d must rise with theta past the corners")
        left, right = self.ray(np.array([0.0, self.width - 1.0]), np.array([self.cy, self.cy]))
        across = math.degrees(math.acos(float(np.clip(left @ right, -1, 1))))
        if across < MIN_VIEW_DEG:  # every pixel would see nearly the same point: a blank frame
            raise SteerlabError(f"the camera sees {across:.2g} degrees across its {self.width} px (fx={self.fx:g} px): "
                                f"a blank frame; K in pixels of the {self.width}x{self.height} image is expected (a K "
                                "of a larger image, or in other units?)")

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, self.skew, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def D(self) -> np.ndarray:
        return np.array(self.d, float).reshape(4, 1)

    def distort_theta(self, theta):
        """theta_d of rays at angle theta (rad) from the optical axis."""
        t2 = np.square(theta)
        k1, k2, k3, k4 = self.d
        return theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))

    def undistort_theta(self, theta_d):
        """The ray angle theta whose theta_d is given (Newton's method from theta = theta_d)."""
        theta_d = np.asarray(theta_d, float)
        theta = theta_d.copy()
        k1, k2, k3, k4 = self.d
        for _ in range(20):
            t2 = theta * theta
            f = self.distort_theta(theta) - theta_d
            slope = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
            step = f / slope
            theta = theta - step
            if np.all(np.abs(step) < 1e-13):
                break
        return theta

    def _normalised(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """Distorted normalised coordinates of pixel coordinates (u, v)."""
        yd = (np.asarray(v, float) - self.cy) / self.fy
        return (np.asarray(u, float) - self.cx - self.skew * yd) / self.fx, yd

    def ray(self, u, v) -> np.ndarray:
        """Unit directions (..., 3) in camera axes (x right, y down, z forward) of pixel coordinates (u, v)."""
        xd, yd = self._normalised(u, v)
        theta_d = np.hypot(xd, yd)
        theta = self.undistort_theta(theta_d)
        scale = np.where(theta_d > 0, np.sin(theta) / np.where(theta_d > 0, theta_d, 1), 1.0)
        return np.stack([xd * scale, yd * scale, np.cos(theta)], -1)

    def rays(self) -> np.ndarray:
        """(height, width, 3) unit directions in camera axes of every pixel's centre."""
        v, u = np.mgrid[0: self.height, 0: self.width].astype(float)
        return self.ray(u, v)

    def project_camera(self, xyz) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (u, v) of points (..., 3) in camera axes (any point but the camera centre; points
        behind the camera project too, as far as the coefficients stay monotonic)."""
        xyz = np.asarray(xyz, float)
        x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
        r = np.hypot(x, y)
        theta = np.arctan2(r, z)
        scale = np.where(r > 0, self.distort_theta(theta) / np.where(r > 0, r, 1), 0.0)
        xd, yd = x * scale, y * scale
        return self.fx * xd + self.skew * yd + self.cx, self.fy * yd + self.cy

    def vehicle_to_camera(self, fwd, left, up) -> np.ndarray:
        """Points (or directions) in vehicle axes relative to the camera -> camera axes (..., 3)."""
        th = math.radians(self.pitch_deg)
        fwd, left, up = (np.asarray(a, float) for a in (fwd, left, up))
        return np.stack([-left, -fwd * math.sin(th) - up * math.cos(th), fwd * math.cos(th) - up * math.sin(th)], -1)

    def camera_to_vehicle(self, xyz) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Camera axes (..., 3) -> (forward, left, up) in vehicle axes."""
        th = math.radians(self.pitch_deg)
        x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
        return z * math.cos(th) - y * math.sin(th), -x, -z * math.sin(th) - y * math.cos(th)

    def project(self, fwd, left, up) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (u, v) of points at (forward, left, up) metres from the camera in vehicle axes
        (a point on the floor has up = -mount_height)."""
        return self.project_camera(self.vehicle_to_camera(fwd, left, up))

    def world_to_camera(self, x, y, z, pose: tuple[float, float, float]) -> np.ndarray:
        """World points (x, y on the floor plane, z up from the floor; m) -> camera axes (..., 3), the camera at
        world `pose` = (x, y, heading psi) on its mount."""
        cx, cy, psi = pose
        dx, dy = np.asarray(x, float) - cx, np.asarray(y, float) - cy
        c, s = math.cos(psi), math.sin(psi)
        return self.vehicle_to_camera(dx * c + dy * s, -dx * s + dy * c, np.asarray(z, float) - self.mount_height)

    def project_world(self, x, y, z, pose: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (u, v) of world points seen from the camera at world `pose` (see `world_to_camera`)."""
        return self.project_camera(self.world_to_camera(x, y, z, pose))

    def vehicle_rays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(forward, left, up) unit directions of every pixel's ray in vehicle axes, each (height, width)."""
        return self.camera_to_vehicle(self.rays())


DONKEY_FISHEYE = FisheyeCamera()


def camera_fields(cam: FisheyeCamera) -> dict:
    """A lens's fields as a recording's metadata and cache names keep them: `mirrored` only where true."""
    return {k: v for k, v in asdict(cam).items() if k != "mirrored" or v}


def fisheye_from(path: Path, value) -> FisheyeCamera:
    """The fisheye camera a recording's metadata carries (its fields, as `dataclasses.asdict` writes them)."""
    names = [f.name for f in fields(FisheyeCamera)]
    if not isinstance(value, dict) or not set(value) <= set(names):
        raise DataError(path, f"the fisheye camera must be a mapping of {', '.join(names)}, got {value!r}")
    try:
        return FisheyeCamera(**value)
    except (SteerlabError, TypeError, ValueError) as e:
        raise DataError(path, f"the fisheye camera: {e}; fix it in this file") from None


def pinhole_matrix(cam: FisheyeCamera, focal: float | None = None) -> np.ndarray:
    """K of the pinhole view `undistort` makes: same image size, centred, `focal` px (by default the donkey
    pinhole geometry's, so that the view matches `geometry.CAMERAS["donkey"]`)."""
    f = PINHOLE.focal if focal is None else float(focal)
    if not f > 0:
        raise SteerlabError(f"the pinhole focal length must be positive, got {f}")
    return np.array([[f, 0.0, (cam.width - 1) / 2], [0.0, f, (cam.height - 1) / 2], [0.0, 0.0, 1.0]])


@lru_cache(maxsize=8)
def _maps(cam: FisheyeCamera, focal: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(pinhole <- fisheye maps, fisheye <- pinhole maps) as float32 for cv2.remap; outside is -1."""
    p = pinhole_matrix(cam, focal)
    size = (cam.width, cam.height)
    ux, uy = cv2.fisheye.initUndistortRectifyMap(cam.K, cam.D, np.eye(3), p, size, cv2.CV_32FC1)
    r = cam.rays()
    ahead = r[..., 2] > 1e-6
    z = np.where(ahead, r[..., 2], 1.0)
    dx = np.where(ahead, p[0, 0] * r[..., 0] / z + p[0, 2], -1.0).astype(np.float32)
    dy = np.where(ahead, p[1, 1] * r[..., 1] / z + p[1, 2], -1.0).astype(np.float32)
    return ux, uy, dx, dy


def undistort(img: np.ndarray, cam: FisheyeCamera = DONKEY_FISHEYE, focal: float | None = None) -> np.ndarray:
    """The frame as a pinhole camera at the same place would see it (`pinhole_matrix`), bilinear; what the
    fisheye does not see is black."""
    _check_frame(img, cam)
    ux, uy, _, _ = _maps(cam, focal)
    return cv2.remap(img, ux, uy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)


def distort(img: np.ndarray, cam: FisheyeCamera = DONKEY_FISHEYE, focal: float | None = None) -> np.ndarray:
    """A pinhole frame (`pinhole_matrix`) as the fisheye sees it: the inverse of `undistort`; what the pinhole
    frame does not show is black."""
    _check_frame(img, cam)
    _, _, dx, dy = _maps(cam, focal)
    return cv2.remap(img, dx, dy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)


@lru_cache(maxsize=8)
def _floor_points(cam: FisheyeCamera) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(forward, left, up) in vehicle axes from the camera of where every pixel's ray meets the floor, or of its
    direction for a ray at or above the horizon, and which rays meet the floor."""
    fwd, left, up = cam.vehicle_rays()
    below = up < 0
    t = np.where(below, cam.mount_height / np.where(below, -up, 1.0), 1.0)
    return t * fwd, t * left, np.where(below, -cam.mount_height, up), below


def view_maps(cam: FisheyeCamera, shift_m: float, yaw_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Where (u, v) in a frame of `cam` every pixel of the view lies that the camera moved `shift_m` to the left
    and turned `yaw_deg` to the left sees, under the flat-floor assumption of `geometry.shift_view`: everything
    below the horizon lies on the floor, everything above it infinitely far away. Per pixel this is undistort
    (the pixel's ray, `FisheyeCamera.ray`), the flat-floor homography (where the ray meets the floor, that point
    seen from the frame's camera; a ray above the horizon only turns) and distort again (`project`), composed
    into one map for `cv2.remap` (float32, (height, width) each)."""
    f, left, up, below = _floor_points(cam)  # the rays of the view, met with the floor once per camera
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    u, v = cam.project(f * c - left * s, f * s + left * c + np.where(below, shift_m, 0.0), up)
    return u.astype(np.float32), v.astype(np.float32)


def shift_view(img: np.ndarray, cam: FisheyeCamera, shift_m: float, yaw_deg: float = 0.0) -> np.ndarray:
    """The fisheye frame as seen from the camera moved `shift_m` to the left and turned `yaw_deg` to the left
    (`view_maps`: one remap, bilinear). What the frame does not show repeats its nearest border pixels, as in
    `geometry.shift_view`. A mirrored camera's frame is turned back into what the lens saw, warped, and mirrored
    again: the view of the car's world, as the frames show it."""
    _check_frame(img, cam)
    if cam.mirrored:
        return shift_view(img[:, ::-1], replace(cam, mirrored=False), shift_m, yaw_deg)[:, ::-1]
    mx, my = view_maps(cam, float(shift_m), float(yaw_deg))
    return cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def _check_frame(img: np.ndarray, cam: FisheyeCamera) -> None:
    if img.shape[:2] != (cam.height, cam.width):
        raise SteerlabError(f"a {img.shape[1]}x{img.shape[0]} frame does not fit the {cam.width}x{cam.height} "
                            "fisheye camera: give the calibration of the camera that took it")


# --- calibration files -------------------------------------------------------------------------------------------

class _Loader(UniqueKeys):
    """YAML as OpenCV's FileStorage writes it: `%YAML:1.0` and `!!opencv-matrix` {rows, cols, dt, data}."""


def _opencv_matrix(loader, node):
    return loader.construct_mapping(node, deep=True)


_Loader.add_constructor("tag:yaml.org,2002:opencv-matrix", _opencv_matrix)

SIZE_KEYS = ("image_size", "DIM", "image_width/image_height")


def _parse(path: Path) -> dict:
    text = read_text(path, "calibration file")
    try:
        if path.suffix.lower() == ".json":
            data = parse_json(text, path)
        else:
            if text.startswith("%YAML:"):  # OpenCV's FileStorage header, which PyYAML does not take
                text = text.split("\n", 1)[1] if "\n" in text else ""
            data = yaml.load(text, Loader=_Loader)
    except (json.JSONDecodeError, yaml.YAMLError) as e:
        kind = "JSON" if path.suffix.lower() == ".json" else "YAML"
        raise DataError(path, f"not a {kind} calibration file ({str(e).splitlines()[0]}): give the YAML file the "
                              "calibration wrote") from None
    if not isinstance(data, dict):
        raise DataError(path, "a calibration file must hold a mapping with the image size, K and D")
    return data


def _matrix(path: Path, data: dict, names: tuple[str, ...], shapes: tuple[tuple[int, ...], ...],
            what: str) -> np.ndarray:
    """The matrix under the first of `names`, in one of the accepted `shapes`, flattened."""
    key = next((k for k in names if k in data), None)
    if key is None:
        raise DataError(path, f"missing {what} (key {' or '.join(names)}): add it")
    value = data[key]
    if isinstance(value, dict):  # OpenCV FileStorage and ROS camera_info: {rows, cols, data}
        value = value.get("data")
    try:
        m = np.array(value, dtype=float)
        text = np.array(value, dtype=object).ravel()  # a number written as text ('80.0') is refused, as options do
    except (TypeError, ValueError):
        raise DataError(path, f"{key} must be {what}, got {value!r}") from None
    if any(isinstance(v, (str, bool)) for v in text):
        raise DataError(path, f"{key} must be {what} of numbers (not text in quotes), got {value!r}")
    if m.shape not in shapes:
        raise DataError(path, f"{key} must be {what} ({' or '.join('x'.join(map(str, s)) for s in shapes)}), got "
                              f"shape {'x'.join(map(str, m.shape)) or 'scalar'}")
    if not np.all(np.isfinite(m)):
        raise DataError(path, f"{key} holds a value that is not finite: {m.ravel().tolist()}; finite numbers expected")
    return m.ravel()


def _size(path: Path, data: dict) -> tuple[int, int]:
    if "image_width" in data or "image_height" in data:
        value = [data.get("image_width"), data.get("image_height")]
    else:
        key = next((k for k in ("image_size", "DIM") if k in data), None)
        if key is None:
            raise DataError(path, f"missing the image size (key {' or '.join(SIZE_KEYS)}: width, height): add it")
        value = data[key]
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) for v in value)):
        raise DataError(path, f"the image size must be two whole numbers (width, height), got {value!r}")
    return value[0], value[1]


def load_calibration(path: str | Path, base: FisheyeCamera = DONKEY_FISHEYE) -> FisheyeCamera:
    """`base` with K and D from a calibration file: JSON or YAML with the image size (`image_size` or `DIM`:
    [width, height], or `image_width` and `image_height`), `K` or `camera_matrix` (3x3, nested or flat, or
    {rows, cols, data} as OpenCV's FileStorage and ROS camera_info write it) and `D` or
    `distortion_coefficients` (k1..k4). The image size must be the camera's."""
    if not isinstance(base, FisheyeCamera):
        raise SteerlabError(f"load_calibration: base must be a fisheye.FisheyeCamera (the lens whose K and D the "
                            f"file gives), got {base!r}")
    path = a_path(path, "the calibration file")
    data = _parse(path)
    size = _size(path, data)
    if size != (base.width, base.height):
        raise DataError(path, f"calibrated at {size[0]}x{size[1]}, but the camera takes {base.width}x{base.height} "
                              f"frames: calibrate at that size (or scale K by the size ratio)")
    k = _matrix(path, data, ("K", "camera_matrix"), ((3, 3), (9,)), "the 3x3 camera matrix").reshape(3, 3)
    d = _matrix(path, data, ("D", "distortion_coefficients"), ((4,), (4, 1), (1, 4)),
                "the four fisheye coefficients k1..k4")
    if k[1, 0] != 0 or k[2, 0] != 0 or k[2, 1] != 0 or k[2, 2] != 1:
        raise DataError(path, f"K must look like [[fx, skew, cx], [0, fy, cy], [0, 0, 1]], got {k.tolist()}")
    try:
        return replace(base, fx=float(k[0, 0]), fy=float(k[1, 1]), cx=float(k[0, 2]), cy=float(k[1, 2]),
                       skew=float(k[0, 1]), d=tuple(float(v) for v in d))
    except SteerlabError as e:
        raise DataError(path, str(e)) from None
