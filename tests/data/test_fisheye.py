"""The donkeycar fisheye camera (data/fisheye.py): rays and projections round trip, hand-computed cases, undistort
then distort, and calibrations read from JSON, YAML, OpenCV and ROS files, or refused naming the file."""

import json
import math

import cv2
import numpy as np
import pytest

from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera, distort, load_calibration, undistort
from steerlab.errors import SteerlabError


def test_fisheye_ray_and_projection_round_trip_every_pixel():
    cam = DONKEY_FISHEYE
    rays = cam.rays()
    assert np.allclose(np.linalg.norm(rays, axis=-1), 1.0)
    u, v = cam.project_camera(rays)
    rows, cols = np.mgrid[0: cam.height, 0: cam.width]
    assert np.abs(u - cols).max() < 1e-3 and np.abs(v - rows).max() < 1e-3
    # the same projection as OpenCV's, on points at several distances and off the pixel grid
    pts = rays[::7, ::9].reshape(-1, 3) * np.linspace(0.3, 20, rays[::7, ::9].size // 3)[:, None]
    ref, _ = cv2.fisheye.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), cam.K, cam.D)
    ours = np.stack(cam.project_camera(pts), -1)
    assert np.abs(ours - ref[:, 0]).max() < 1e-6


def test_fisheye_hand_computed_cases():
    """The ideal equidistant lens (D = 0): a ray theta off the axis lands f * theta from the principal point."""
    cam = FisheyeCamera(fx=70.0, fy=70.0, cx=79.5, cy=59.5, d=(0.0, 0.0, 0.0, 0.0), mount_height=0.2, pitch_deg=0.0)
    u, v = cam.project_camera(np.array([math.sin(0.5), 0.0, math.cos(0.5)]))
    assert u == pytest.approx(79.5 + 70 * 0.5) and v == pytest.approx(59.5)
    # level camera: a floor point 1 m ahead, 0.2 m below is theta = atan(0.2) straight down the image
    u, v = cam.project(1.0, 0.0, -0.2)
    assert u == pytest.approx(79.5) and v == pytest.approx(59.5 + 70 * math.atan(0.2))
    # a point to the left lands left of the centre; pitched down, the horizon rises above the centre row
    assert cam.project(1.0, 0.3, 0.0)[0] < 79.5
    pitched = FisheyeCamera(fx=70.0, fy=70.0, cx=79.5, cy=59.5, d=(0.0, 0.0, 0.0, 0.0), pitch_deg=20.0)
    assert pitched.project(100.0, 0.0, 0.0)[1] == pytest.approx(59.5 - 70 * math.radians(20), abs=1e-9)
    # a world point 1 m ahead of a camera at (2, 3) heading +y, on the floor, is straight ahead below the centre
    u, v = cam.project_world(2.0, 4.0, 0.0, (2.0, 3.0, math.pi / 2))
    assert u == pytest.approx(79.5) and v == pytest.approx(59.5 + 70 * math.atan(0.2))
    fwd, left, up = pitched.vehicle_rays()
    assert fwd[60, 80] > 0.9 and up[0, 80] > 0 > up[119, 80]


def test_undistort_then_distort_is_the_identity_where_both_views_see():
    cam = DONKEY_FISHEYE
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 256, (cam.height, cam.width, 3), dtype=np.uint8), (0, 0), 2.5)
    img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX)
    back = distort(undistort(img))
    # the region the pinhole view shows, away from its border
    r = cam.rays()
    f = 67.0
    px, py = f * r[..., 0] / r[..., 2] + 79.5, f * r[..., 1] / r[..., 2] + 59.5
    valid = (px > 3) & (px < cam.width - 4) & (py > 3) & (py < cam.height - 4)
    assert valid.mean() > 0.5
    err = np.abs(back.astype(int) - img.astype(int))[valid]
    assert err.mean() < 4 and np.percentile(err, 99) < 20
    assert back[~valid].mean() < img[~valid].mean()  # outside, the pinhole view shows nothing
    with pytest.raises(SteerlabError, match="does not fit the 160x120"):
        undistort(np.zeros((60, 80, 3), np.uint8))


def _calib(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text if isinstance(text, str) else json.dumps(text))
    return p


GOOD = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
        "D": [[-0.02], [-0.01], [0.0], [0.005]]}


def test_load_calibration_json_yaml_opencv_and_ros(tmp_path):
    cam = load_calibration(_calib(tmp_path, "c.json", GOOD))
    assert (cam.fx, cam.fy, cam.cx, cam.cy, cam.d) == (81.0, 80.0, 80.0, 61.0, (-0.02, -0.01, 0.0, 0.005))
    assert cam.mount_height == DONKEY_FISHEYE.mount_height
    opencv = ("%YAML:1.0\n---\nDIM: [160, 120]\nK: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
              "   data: [81., 0., 80., 0., 80., 61., 0., 0., 1.]\nD: !!opencv-matrix\n   rows: 4\n   cols: 1\n"
              "   dt: d\n   data: [-0.02, -0.01, 0., 0.005]\n")
    assert load_calibration(_calib(tmp_path, "c.yaml", opencv)) == cam
    ros = ("image_width: 160\nimage_height: 120\ndistortion_model: equidistant\ncamera_matrix:\n  rows: 3\n"
           "  cols: 3\n  data: [81, 0, 80, 0, 80, 61, 0, 0, 1]\ndistortion_coefficients:\n  rows: 1\n  cols: 4\n"
           "  data: [-0.02, -0.01, 0, 0.005]\n")
    assert load_calibration(_calib(tmp_path, "ros.yml", ros)) == cam


@pytest.mark.parametrize("name,content,message", [
    ("a.json", "{not json", "not valid JSON"),
    ("a.yaml", "K: [1, 2\n", "not a YAML calibration file"),
    ("a.yaml", "- 1\n- 2\n", "must hold a mapping"),
    ("a.json", {**GOOD, "K": None}, "K must be the 3x3 camera matrix"),
    ("a.json", {k: v for k, v in GOOD.items() if k != "D"}, "missing the four fisheye coefficients"),
    ("a.json", {k: v for k, v in GOOD.items() if k != "image_size"}, "missing the image size"),
    ("a.json", {**GOOD, "K": [[81.0, 0.0], [0.0, 80.0]]}, "got shape 2x2"),
    ("a.json", {**GOOD, "D": [0.1, 0.2, 0.3]}, "got shape 3"),
    ("a.json", {**GOOD, "D": [0.1, float("nan"), 0.0, 0.0]}, "NaN is not JSON"),
    ("a.json", {**GOOD, "image_size": [640, 480]}, "calibrated at 640x480, but the camera takes 160x120"),
    ("a.json", {**GOOD, "image_size": "160x120"}, "two whole numbers"),
    ("a.json", {**GOOD, "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 2.0]]}, r"\[0, 0, 1\]"),
    ("a.json", {**GOOD, "K": [[-81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]]}, "positive focal"),
    ("a.json", {**GOOD, "D": [0.0, 0.0, 0.0, -1.0]}, "do not map the image corners"),
    ("a.json", {**GOOD, "D": ["-0.02", "-0.01", "0.0", "0.005"]}, r"D must be .* of numbers \(not text in quotes\)"),
    ("a.yaml", "image_size: [160, 120]\nK: [[81, 0, 80], [0, 80, '61'], [0, 0, 1]]\nD: [0, 0, 0, 0]\n",
     "K must be the 3x3 camera matrix of numbers"),
])
def test_load_calibration_bad_input(tmp_path, name, content, message):
    path = _calib(tmp_path, name, content)
    with pytest.raises(SteerlabError, match=message) as e:
        load_calibration(path)
    assert str(path) in str(e.value) and "\n" not in str(e.value)
    for path, base in ((123, DONKEY_FISHEYE), (path, None)):  # the API's own types, named
        with pytest.raises(SteerlabError, match="must be a path|base must be a fisheye.FisheyeCamera"):
            load_calibration(path, base)
    with pytest.raises(SteerlabError, match="calibration file not found"):
        load_calibration(tmp_path / "absent.json")
