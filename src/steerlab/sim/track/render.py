"""The track world seen through the donkeycar fisheye camera: a room with the track on its floor, at hundreds of
frames a second on one core.

The camera is rigid on the car and the floor is flat, so everything about a pixel but the car's pose is
precomputed: its ray in vehicle axes, where that ray meets the floor (as an offset from the camera), the
level of detail its floor footprint needs, where its mirror ray meets the ceiling (reflections on a glossy
floor). Per frame the rays are turned by the car's heading and met with the room: the floor (z = 0) or, if
a wall of the rectangular room comes first, that wall, or above the walls the ceiling. The room's surfaces
are textures in one atlas (the floor raster with the track's lines painted in, the walls unrolled side by
side, the ceiling), so the whole background is one `cv2.remap` per level of detail (far floor is read from a
smoothed, halved copy of the atlas, so that lines seen at a grazing angle do not shimmer). Glossy floors add
the ceiling's lights seen in the floor (a second remap of a light raster), the light of the place scales and
tints the frame (it drifts along the lap, and each track has its own), the lens darkens the corners, and the
sensor adds noise. Clutter beside the track (boxes, cones, bins, chairs, people's legs) stands on the floor
as flat-shaded solids whose faces are projected through the fisheye with curved edges and filled far to near.

Everything that does not move is drawn from the track's seed: floor kind (concrete, epoxy, wood, carpet,
tarp), tape or paint colour and width, walls, ceiling lights, clutter, light. Same pose, same bytes. A look
(`look.Look`, for the varied rooms of training recordings) changes the room's draws as `room.Room` says, scales
the lamps' glare on a glossy floor, sets the sensor's noise and blurs the frame.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from steerlab.data.fisheye import DONKEY_FISHEYE, FisheyeCamera
from steerlab.sim.track.look import LOOK, Look
from steerlab.sim.track.room import CEIL_RES, LEVELS, MIRROR_LEVEL, RES, WALL_RES, Room
from steerlab.sim.track.track import Track

def _subdivide(poly: np.ndarray, k: int = 2) -> np.ndarray:
    """A polygon's outline with k points per edge, so that its edges bend as the fisheye bends them."""
    nxt = np.roll(poly, -1, axis=0)
    t = (np.arange(k) / k)[None, :, None]
    return (poly[:, None] + (nxt - poly)[:, None] * t).reshape(-1, 3)


class TrackRenderer:
    """Renders `track` through `cam` (by default the donkeycar fisheye at 160x120). The room's look is drawn
    from the track's seed, or from `seed` to put one track into several rooms; `look` as `Room`'s."""

    def __init__(self, track: Track, cam: FisheyeCamera = DONKEY_FISHEYE, seed: int | None = None,
                 look: Look = LOOK):
        self.track, self.cam = track, cam
        self.room = room = Room(track, seed, look)
        fwd, left, up = (a.astype(np.float32).ravel() for a in cam.vehicle_rays())
        h = cam.mount_height
        below = up < -1e-6
        # level of detail: a pixel's floor footprint in texels, across its ray (along it, a grazing ray's
        # footprint is long: choosing the level by it would wash out a tape line a metre ahead); rays above the
        # horizon as if they met the floor far away. The pixels are kept grouped by level, so that each level is
        # one slice and one remap
        t_floor = np.where(below, h / np.where(below, -up, 1), 1e3).astype(np.float32)
        grid = (cam.height, cam.width)
        fx, fy = (t_floor * fwd).reshape(grid), (t_floor * left).reshape(grid)
        step = np.minimum(np.hypot(np.gradient(fx, axis=0), np.gradient(fy, axis=0)),
                          np.hypot(np.gradient(fx, axis=1), np.gradient(fy, axis=1))).ravel()
        level = np.clip(np.floor(np.log2(np.maximum(step / RES, 1.0))), 0, LEVELS - 1).astype(int)
        level[~below] = 1
        key = np.where(below, level, LEVELS + level)  # rays below the horizon first (only they meet the floor)
        order = np.argsort(key, kind="stable")
        self.unsort = (np.argsort(order)[:, None] * 3 + np.arange(3)).ravel()  # each pixel's B, G, R back in place
        edges = np.searchsorted(key[order], np.arange(2 * LEVELS + 1))
        self.levels = [(k % LEVELS, slice(edges[k], edges[k + 1])) for k in range(2 * LEVELS)
                       if edges[k + 1] > edges[k]]
        self.below = slice(0, int(below.sum()))
        fwd, left, up, below = fwd[order], left[order], up[order], below[order]
        self.fwd, self.left, self.up = fwd, left, up
        self.t_floor = np.where(below, h / np.where(below, -up, 1), np.inf).astype(np.float32)
        self.t_mirror = np.where(below, (h + room.height) / np.where(below, -up, 1), np.inf).astype(np.float32)
        # Schlick's approximation of the share of light a floor mirrors: more the more grazing the ray
        self.fresnel = (0.05 + 0.95 * (1 - np.clip(-up, 0, 1)) ** 5).astype(np.float32)
        above = up > 1e-6
        self.t_ceiling = np.where(above, (room.height - h) / np.where(above, up, 1), np.inf).astype(np.float32)
        # the lens darkens towards the corners; the sensor adds noise
        v, u = np.mgrid[0: cam.height, 0: cam.width]
        r2 = (((u - cam.cx) / cam.width) ** 2 + ((v - cam.cy) / cam.height) ** 2).ravel()[order]
        rng = np.random.default_rng([track.seed, 22])
        # the vignette of every value of the frame (pixel by pixel, B, G, R), so that it meets the light in one
        # flat product: a (N, 1) x (3,) broadcast is twice as slow as the product it makes
        self.vignette = np.repeat((1 - rng.uniform(0.3, 0.6) * r2).astype(np.float32), 3)
        self.noise = rng.normal(0, look.noise, (4, cam.height * cam.width, 3)).astype(np.float32)
        # clutter: every face outline, subdivided, in one array
        faces = [(poly, colour) for obj in room.objects for poly, colour in obj["faces"]]
        outlines = [_subdivide(poly) for poly, _ in faces]
        self.face_points = np.concatenate(outlines) if outlines else np.zeros((0, 3))
        self.face_end = np.cumsum([len(p) for p in outlines]).astype(np.int64)
        self.face_start = self.face_end - [len(p) for p in outlines]
        self.face_centre = np.array([poly.mean(0) for poly, _ in faces]).reshape(-1, 3)
        normal = np.array([np.cross(p[1] - p[0], p[2] - p[0]) for p, _ in faces]).reshape(-1, 3)
        self.face_normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        self.face_colour = np.array([colour for _, colour in faces], np.float32).reshape(-1, 3)
        sun = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
        self.face_shade = (0.65 + 0.35 * np.clip(self.face_normal @ sun, -1, 1)).astype(np.float32)

    def render(self, x: float, y: float, psi: float, s: float) -> np.ndarray:
        """BGR uint8 frame of the camera at world position (x, y) (m; `SmallCar.camera_pose()`), heading psi
        (rad), the car at arc length s of the track (for the light along the lap)."""
        room, cam = self.room, self.cam
        x, y, h = float(x), float(y), cam.mount_height  # Python floats keep the per-pixel arithmetic in float32
        c, sn = np.float32(math.cos(psi)), np.float32(math.sin(psi))
        dx = self.fwd * c - self.left * sn
        dy = self.fwd * sn + self.left * c
        with np.errstate(divide="ignore"):  # a ray along a wall meets it at infinity
            tx = np.where(dx > 0, np.float32(room.x1 - x), np.float32(x - room.x0)) / np.abs(dx)
            ty = np.where(dy > 0, np.float32(room.y1 - y), np.float32(y - room.y0)) / np.abs(dy)
        wall_x = tx < ty
        t_wall = np.minimum(tx, ty)
        floor = self.t_floor < t_wall
        z = h + t_wall * self.up
        ceiling = ~floor & (z > room.height)
        # floor and ceiling hits are points of their planes; a wall hit a point of the perimeter
        t = np.where(floor, self.t_floor, self.t_ceiling)
        with np.errstate(invalid="ignore"):  # inf x 0 where a ray meets neither plane: such pixels are walls
            px, py = x + t * dx - room.x0, y + t * dy - room.y0
            hx, hy = x + t_wall * dx - room.x0, y + t_wall * dy - room.y0
        wx, wy = room.x1 - room.x0, room.y1 - room.y0
        perim = np.where(wall_x, np.where(dx > 0, wx + hy, 2 * (wx + wy) - hy), np.where(dy > 0, 2 * wx + wy - hx, hx))
        mx = np.where(floor, px * np.float32(1 / RES), np.where(ceiling, px * np.float32(1 / CEIL_RES),
                                                                 perim * np.float32(1 / WALL_RES)))
        my = np.where(floor, py * np.float32(1 / RES),
                      np.where(ceiling, room.ceil_row + py * np.float32(1 / CEIL_RES),
                               room.wall_row + (room.height - z) * np.float32(1 / WALL_RES)))
        mx, my = mx.astype(np.float32), my.astype(np.float32)
        base = np.empty((mx.size, 1, 3), np.uint8)
        for k, sl in self.levels:
            scale = np.float32(0.5 ** k)
            cv2.remap(room.atlas[k], ((mx[sl] + 0.5) * scale - 0.5)[:, None], ((my[sl] + 0.5) * scale - 0.5)[:, None],
                      cv2.INTER_LINEAR, dst=base[sl], borderMode=cv2.BORDER_REPLICATE)
        frame = base.reshape(-1, 3).astype(np.float32)
        if room.gloss > 0:
            # a glossy floor mirrors the room: the mirror ray of a floor pixel meets the wall at the height the
            # ray itself would have met it below the floor, or the ceiling at the mirror point; read blurred.
            # Only rays below the horizon can meet the floor.
            b = self.below
            mirror_z = -z[b]
            on_wall = mirror_z < room.height
            lx = (x - room.x0 + self.t_mirror[b] * dx[b]) * np.float32(1 / CEIL_RES)
            ly = (y - room.y0 + self.t_mirror[b] * dy[b]) * np.float32(1 / CEIL_RES)
            rx = np.where(on_wall, perim[b] * np.float32(1 / WALL_RES), lx)
            ry = np.where(on_wall, room.wall_row + (room.height - mirror_z) * np.float32(1 / WALL_RES),
                          room.ceil_row + ly)
            scale = np.float32(0.5 ** MIRROR_LEVEL)
            mirror = cv2.remap(room.atlas[MIRROR_LEVEL], ((rx + 0.5) * scale - 0.5).astype(np.float32)[:, None],
                               ((ry + 0.5) * scale - 0.5).astype(np.float32)[:, None], cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_REPLICATE).reshape(-1, 3)
            k = (self.fresnel[b] * np.float32(room.gloss) * floor[b])[:, None]
            frame[b] += k * (mirror - frame[b])
            # the lamps, far brighter than anything the atlas holds, add their light
            spec = cv2.remap(room.lights, lx[:, None], ly[:, None], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
            frame[b] += spec * (np.float32(255 * room.gloss * room.look.glare) * floor[b])[:, None]
        i = self.track.index(s)
        light = room.brightness[i] * room.tint[i]
        frame *= (self.vignette * np.tile(light, len(frame))).reshape(-1, 3)
        frame += self.noise[int(abs(x * 1000 + y * 7919)) % len(self.noise)]
        np.clip(frame, 0, 255, out=frame)
        out = np.take(frame.astype(np.uint8).ravel(), self.unsort).reshape(cam.height, cam.width, 3)
        if len(self.face_start):
            self._draw_clutter(out, x, y, psi, light)
        if room.look.blur:
            cv2.GaussianBlur(out, (0, 0), room.look.blur, dst=out)
        return out

    def _draw_clutter(self, img: np.ndarray, x: float, y: float, psi: float, light: np.ndarray) -> None:
        cam = self.cam
        pts = self.face_points
        xyz = cam.world_to_camera(pts[:, 0], pts[:, 1], pts[:, 2], (x, y, psi))
        u, v = cam.project_camera(xyz)
        # a face is drawn if it faces the camera, lies wholly in front of the lens (where the projection holds)
        # and reaches into the image
        behind = xyz[:, 2] < np.hypot(xyz[:, 0], xyz[:, 1]) * math.cos(math.radians(100))
        cent = self.face_centre - (x, y, cam.mount_height)
        start = self.face_start
        draw = ((np.einsum("ij,ij->i", self.face_normal, cent) < 0) & (np.add.reduceat(behind, start) == 0)
                & (np.maximum.reduceat(u, start) > 0) & (np.minimum.reduceat(u, start) < cam.width)
                & (np.maximum.reduceat(v, start) > 0) & (np.minimum.reduceat(v, start) < cam.height))
        faces = np.flatnonzero(draw)
        if not len(faces):
            return
        faces = faces[np.argsort(-np.hypot(cent[faces, 0], cent[faces, 1]))]  # far to near
        pix = np.round(np.stack([u, v], 1) * 8).astype(np.int32)  # 3 bits of sub-pixel precision
        colours = np.clip(self.face_colour[faces] * self.face_shade[faces, None] * light, 0, 255).tolist()
        ends = self.face_end
        for f, colour in zip(faces.tolist(), colours):
            cv2.fillPoly(img, [pix[self.face_start[f]: ends[f]]], colour, cv2.LINE_AA, 3)
