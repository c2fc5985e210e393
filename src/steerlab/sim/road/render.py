"""Pinhole camera rendering of the road with NumPy and OpenCV, fast enough for hundreds of frames a second.

The ground is flat, so the forward distance of a ground pixel depends only on its image row and its
lateral position is proportional to its column offset: both are precomputed once per camera. Per frame,
the road's centre line is sampled ahead of the car and, for every row, its lateral position and heading at
that row's distance give each pixel its road coordinates (s, d); colour follows from (s, d): asphalt,
markings, verge, grass, with a texture, shadows and the light of the place. Roadside posts and trees are
drawn on top, far to near, so that motion is visible to optical flow.
"""

from __future__ import annotations

import cv2
import numpy as np

from steerlab.data.geometry import Camera, camera
from steerlab.sim.road.road import DS, EDGE, LANE, LINE_WIDTH, ROAD_TYPES, VERGE, Road

MAX_RANGE = 250.0   # m: ground further away is drawn as haze


# (B, G, R) base colours
ASPHALT, MARKING, VERGE_C, GRASS = (92, 96, 100), (225, 230, 232), (120, 150, 170), (60, 125, 80)
SKY_TOP, SKY_HORIZON, HAZE = (200, 150, 110), (235, 215, 195), (190, 190, 185)


class Scenery:
    """Everything about a road that does not move: texture, shadows, lighting along s, roadside objects."""

    def __init__(self, road: Road):
        rng = np.random.default_rng([road.seed, 3])
        self.texture = (rng.standard_normal((256, 256)) * 0.06).astype(np.float32)
        self.texture = cv2.GaussianBlur(self.texture, (3, 3), 0) + 1.0
        n = len(road.s)
        # shadows: a raster over (s, d) with 1 = sunlit; patches cast by roadside trees and buildings
        self.d_res, self.d_max = 0.25, 20.0
        grid = np.ones((n, int(2 * self.d_max / self.d_res)), np.float32)
        for _ in range(int(road.length / 60)):
            i = rng.integers(0, n)
            length = int(rng.uniform(2, 20) / DS)
            side = rng.choice([-1, 1])
            reach = rng.uniform(1.0, 2 * LANE + 2)  # how far the shadow reaches across the road
            lo, hi = (VERGE + 2 - reach, VERGE + 2) if side > 0 else (-VERGE - 2, -VERGE - 2 + reach)
            j0, j1 = (int((v + self.d_max) / self.d_res) for v in (lo, hi))
            grid[i: i + length, max(j0, 0): j1] = rng.uniform(0.45, 0.7)
        self.shadow = cv2.GaussianBlur(grid, (5, 5), 0)
        # light: brightness and colour tint drift slowly along the road
        knots = int(road.length / 400) + 2
        ks = np.arange(knots) * 400.0
        self.brightness = np.interp(road.s, ks, rng.uniform(0.7, 1.25, knots)).astype(np.float32)
        tints = rng.uniform(0.88, 1.12, (knots, 3))
        self.tint = np.stack([np.interp(road.s, ks, tints[:, c]) for c in range(3)], 1).astype(np.float32)
        # roadside objects: (s, d, kind) with kind 0 = marker post, 1 = tree
        posts = [(s, side * (VERGE - 0.5), 0) for s in np.arange(10, road.length, 50.0) for side in (-1, 1)]
        m = int(road.length / 12)
        trees = zip(rng.uniform(0, road.length, m), rng.choice([-1, 1], m) * rng.uniform(VERGE + 1.5, 25, m),
                    np.ones(m, int))
        objs = np.array(posts + list(trees), np.float64)
        objs = objs[np.argsort(objs[:, 0])]
        self.obj_s, self.obj_kind = objs[:, 0], objs[:, 2].astype(int)
        idx = np.clip(np.round(objs[:, 0] / DS).astype(int), 0, n - 1)
        self.obj_x = road.x[idx] - objs[:, 1] * np.sin(road.psi[idx])
        self.obj_y = road.y[idx] + objs[:, 1] * np.cos(road.psi[idx])
        self.obj_size = rng.uniform(0.8, 1.3, len(objs))
        # the look of the place differs from road to road: shades of grass, verge, asphalt and paint
        look = np.random.default_rng([road.seed, 6, list(ROAD_TYPES).index(road.kind)])
        shade = np.concatenate([look.uniform(0.75, 1.25, (3, 1)) * look.uniform(0.9, 1.1, (3, 3)),
                                look.uniform(0.85, 1.0, (1, 1)) * np.ones((1, 3))])
        self.palette = np.array([GRASS, VERGE_C, ASPHALT, MARKING], np.float32) * shade.astype(np.float32)


class Renderer:
    def __init__(self, road: Road, cam: Camera | str = "sim"):
        self.road, self.cam = road, camera(cam) if isinstance(cam, str) else cam
        self.scenery = Scenery(road)
        c = self.cam
        th = np.radians(c.pitch_deg)
        cos_t, sin_t = np.cos(th), np.sin(th)
        v = np.arange(c.height) + 0.5
        yc = (v - c.cy) / c.focal
        denom = sin_t + yc * cos_t
        ground = denom > 1e-4
        t = np.where(ground, c.mount_height / np.where(ground, denom, 1), np.inf)
        fwd = t * (cos_t - yc * sin_t)
        self.first_row = int(np.argmax(ground & (fwd < MAX_RANGE)))  # rows above show sky or haze
        self.horizon = c.horizon
        rows = slice(self.first_row, c.height)
        self.fwd = fwd[rows].astype(np.float32)
        self.ray = t[rows].astype(np.float32)  # ground point = camera + ray * (x_c, y_c, 1) in camera axes
        xc = (np.arange(c.width) + 0.5 - c.width / 2) / c.focal
        self.lateral = (-self.ray[:, None] * xc[None, :]).astype(np.float32)  # left positive, metres
        sky_v = np.clip((np.arange(self.first_row) - (self.horizon - 80)) / 80.0, 0, 1)[:, None]
        sky = np.array(SKY_TOP, np.float32) * (1 - sky_v) + np.array(SKY_HORIZON, np.float32) * sky_v
        self.sky = np.ascontiguousarray(np.repeat(sky[:, None, :], c.width, axis=1).transpose(2, 0, 1))
        # far ground fades to haze: colour * clear + haze_light, per channel (planes: (3, rows, width))
        haze = np.broadcast_to(np.clip(self.fwd / MAX_RANGE, 0, 1)[:, None] ** 1.5, self.lateral.shape)
        self.clear = np.ascontiguousarray(1 - haze)
        self.haze_light = np.stack([np.float32(h) * haze for h in HAZE])

    def render(self, x: float, y: float, psi: float, s_hint: float, shift: float = 0.0) -> np.ndarray:
        """BGR uint8 frame of the camera on a car at world pose (x, y, psi), moved `shift` m to the left."""
        road, sc, c = self.road, self.scenery, self.cam
        cx, cy = x - shift * np.sin(psi), y + shift * np.cos(psi)
        # centre line ahead of the camera, in camera coordinates (forward, left)
        a, b = road.index(s_hint - 10), road.index(s_hint + MAX_RANGE + 20)
        px, py = road.x[a:b] - cx, road.y[a:b] - cy
        cs, sn = np.cos(psi), np.sin(psi)
        f_pts, l_pts = px * cs + py * sn, -px * sn + py * cs
        stop = np.argmax(np.diff(f_pts) <= 0) + 1 if np.any(np.diff(f_pts) <= 0) else len(f_pts)
        f_pts, l_pts, idx = f_pts[:stop], l_pts[:stop], np.arange(a, a + stop)
        lat_c = np.interp(self.fwd, f_pts, l_pts).astype(np.float32)
        rel = np.interp(self.fwd, f_pts, road.psi[idx] - psi).astype(np.float32)
        s_row = np.interp(self.fwd, f_pts, road.s[idx]).astype(np.float32)
        beyond = self.fwd > f_pts[-1]
        d = (self.lateral - lat_c[:, None]) * np.cos(rel)[:, None]
        s = s_row[:, None] + (self.lateral - lat_c[:, None]) * np.sin(rel)[:, None]
        ad = np.abs(d)
        # classes: 0 grass, 1 verge, 2 asphalt, 3 marking
        cls = np.where(ad < EDGE, 2, np.where(ad < VERGE, 1, 0)).astype(np.uint8)
        edge = (ad > EDGE - LINE_WIDTH) & (ad < EDGE)
        dash = ad < LINE_WIDTH / 2
        dash[dash] = np.mod(s[dash], 12.0) < 4.0
        cls[edge | dash] = 3
        cls[beyond] = 0
        # texture and shadow looked up by flat index (faster than indexing with two index arrays)
        ti = (((s * 6.0).astype(np.int32) & 255) << 8) | ((d * 6.0).astype(np.int32) & 255)
        light = sc.texture.ravel().take(ti)
        si = np.clip((s / DS).astype(np.int32), 0, len(road.s) - 1)
        dj = np.clip(((d + sc.d_max) / sc.d_res).astype(np.int32), 0, sc.shadow.shape[1] - 1)
        light *= sc.shadow.ravel().take(si * sc.shadow.shape[1] + dj)
        # colour channel by channel, each a plane (per-pixel products over a last axis of 3 are slow in NumPy)
        i0 = road.index(s_hint)
        factor = sc.brightness[i0] * sc.tint[i0]
        planes = np.empty((3, c.height, c.width), np.float32)
        for ch in range(3):
            plane = sc.palette[:, ch].take(cls)
            plane *= light
            plane = plane * self.clear + self.haze_light[ch]
            planes[ch, : self.first_row] = self.sky[ch]
            planes[ch, self.first_row:] = plane
            planes[ch] *= factor[ch]
        out = cv2.merge(list(np.clip(planes, 0, 255).astype(np.uint8)))
        self._draw_objects(out, cx, cy, psi, s_hint)
        return out

    def _draw_objects(self, img: np.ndarray, cx: float, cy: float, psi: float, s_hint: float) -> None:
        sc, c = self.scenery, self.cam
        a, b = np.searchsorted(sc.obj_s, [s_hint - 5, s_hint + 120])
        if a == b:
            return
        px, py = sc.obj_x[a:b] - cx, sc.obj_y[a:b] - cy
        cs, sn = np.cos(psi), np.sin(psi)
        fwd, left = px * cs + py * sn, -px * sn + py * cs
        light = self.scenery.brightness[self.road.index(s_hint)]
        for k in np.argsort(-fwd):
            f = fwd[k]
            if f < 1.5:
                continue
            kind, size = sc.obj_kind[a + k], sc.obj_size[a + k]
            top_h = 1.0 if kind == 0 else 2.5 * size
            u0, v0 = c.project(f, left[k], -c.mount_height)
            u1, v1 = c.project(f, left[k], top_h - c.mount_height)
            w = max(1, int(round((0.12 if kind == 0 else 0.3) * c.focal / f)))
            if u0 < -60 or u0 > c.width + 60:
                continue
            trunk = (235, 235, 235) if kind == 0 else (40, 60, 80)
            trunk = tuple(int(min(255, ch * light)) for ch in trunk)
            cv2.rectangle(img, (int(u0 - w / 2), int(v1)), (int(u0 + w / 2), int(v0)), trunk, -1)
            if kind == 1:
                r = max(1, int(1.6 * size * c.focal / f))
                crown = tuple(int(min(255, ch * light)) for ch in (35, 95, 45))
                cv2.circle(img, (int(u1), int(v1 - r * 0.6)), r, crown, -1)
