"""The room a track lies in, drawn from the track's seed: the floor (concrete, epoxy, wood, carpet, tarp) with the
track's tape or paint, the walls with doors, shutters and windows, the ceiling and its lights, clutter beside
the track, and the light of the place; its surfaces in one texture atlas at several levels of detail, which
`render.TrackRenderer` reads the frames from."""

from __future__ import annotations

import math

import cv2
import numpy as np

from steerlab.sim.track.look import LOOK, Look, stands_out
from steerlab.sim.track.track import Track

RES = 0.01        # m per floor texel
WALL_RES = 0.03   # m per wall texel
CEIL_RES = 0.05   # m per ceiling texel
LEVELS = 4        # levels of detail of the atlas (each half the resolution of the one before)
PAD = 16          # texels between the atlas regions
MIRROR_LEVEL = 2  # the level of detail a glossy floor mirrors the room with (a blurred reflection)
CLEAR_RES = 0.05  # m per cell of the map of the floor's distance from the lane
SHIFT = 3         # bits of sub-texel precision of the lines painted on the floor

# (B, G, R)
FLOORS = {
    "concrete": [(150, 152, 150), (128, 130, 132), (168, 170, 165), (120, 126, 128)],
    "epoxy": [(160, 170, 150), (175, 178, 172), (150, 160, 165), (140, 150, 140)],
    "wood": [(75, 120, 170), (60, 100, 150), (95, 140, 185), (70, 105, 140)],
    "carpet": [(110, 85, 70), (95, 95, 100), (70, 70, 120), (80, 100, 90)],
    "tarp": [(235, 232, 230), (225, 215, 200), (210, 200, 190), (230, 235, 235)],
}
GLOSS = {"concrete": 0.12, "epoxy": 0.55, "wood": 0.3, "carpet": 0.0, "tarp": 0.25}
TAPES = {"white": (240, 240, 240), "yellow": (40, 200, 235), "orange": (30, 120, 240), "blue": (170, 90, 30),
         "black": (30, 30, 30), "red": (40, 40, 200), "green": (70, 150, 40)}
WALLS = [(215, 215, 210), (200, 205, 200), (180, 195, 205), (205, 200, 185), (185, 190, 180), (150, 160, 170)]


CLUTTER = ["box", "cone", "bin", "chair", "legs", "cabinet"]


def _pick(rng: np.random.Generator, colours: list[tuple[int, int, int]]) -> np.ndarray:
    """One of the colours, as float32 BGR."""
    return np.array(colours[int(rng.integers(len(colours)))], np.float32)


def _noise(rng: np.random.Generator, shape: tuple[int, int], cells: float, amplitude: float) -> np.ndarray:
    """A smooth random field of `shape` around 1 with features about `cells` texels wide."""
    small = rng.standard_normal((max(2, int(shape[0] / cells)) + 1, max(2, int(shape[1] / cells)) + 1))
    field = cv2.resize(small.astype(np.float32), (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)
    return 1.0 + amplitude * field


def _tile(rng: np.random.Generator, shape: tuple[int, int], amplitude: float, blur: float = 0.8) -> np.ndarray:
    """Fine grain: a 256-texel tile of blurred noise repeated over `shape`, around 1."""
    t = cv2.GaussianBlur(rng.standard_normal((256, 256)).astype(np.float32), (0, 0), blur)
    t = 1.0 + amplitude * t / t.std()
    return np.tile(t, (shape[0] // 256 + 1, shape[1] // 256 + 1))[: shape[0], : shape[1]]


class Room:
    """Everything about a track's room that does not move: its size, the atlas of its surfaces, the ceiling's
    lights, the clutter, and the light along the lap. `look`: its look beyond its own draws (`look.Look`: a light
    level of its own is the same room at another time of day), whose floor marks, clutter and people are placed from
    a stream of their own (the seed with 32)."""

    def __init__(self, track: Track, seed: int | None = None, look: Look = LOOK):
        self.track, self.look = track, look
        seed = track.seed if seed is None else seed
        rng, placed = np.random.default_rng([seed, 21]), np.random.default_rng([seed, 32])
        self.floor_kind = str(rng.choice(list(FLOORS), p=[0.25, 0.25, 0.15, 0.15, 0.2]))
        self.gloss = GLOSS[self.floor_kind] * rng.uniform(0.6, 1.2)
        palette = FLOORS[self.floor_kind]
        self.floor_bgr = np.array(palette[int(rng.integers(len(palette)))], np.float32) * rng.uniform(0.85, 1.1)
        # people tape a track in a colour that stands out from their floor
        self.tape_name = next(str(t) for t in rng.permutation(list(TAPES)) if stands_out(TAPES[str(t)], self.floor_bgr))
        self.tape_bgr = np.array(TAPES[self.tape_name], np.float32) * rng.uniform(0.9, 1.0)
        self.tape_width = float(rng.uniform(0.04, 0.06))
        self.floor_bgr = self.floor_bgr if look.floor is None else np.array(look.floor, np.float32)
        if look.tape is not None:
            self.tape_name, self.tape_bgr = "varied", np.array(look.tape, np.float32)
        self.tape_width = self.tape_width if look.tape_width is None else look.tape_width
        outline = np.concatenate([np.stack(track.offset(d), 1) for d in (-track.lane_width / 2, track.lane_width / 2)])
        margin = rng.uniform(1.2, 3.0, 4)
        self.x0, self.y0 = (float(v) for v in outline.min(0) - margin[:2])  # Python floats keep the per-pixel
        self.x1, self.y1 = (float(v) for v in outline.max(0) + margin[2:])  # arithmetic in float32
        self.height = float(rng.uniform(2.6, 5.0))
        self.light = float(rng.uniform(0.75, 1.2))  # drawn also where the look's replaces it: the rest stays as drawn
        self.light = self.light if look.light is None else float(look.light)
        self.warmth = rng.uniform(0.92, 1.08, 3).astype(np.float32)
        self.lamps, self.tubes_along_x = self._lamps(rng)
        self.clear = self._clearance()
        floor = self._floor(rng, placed)
        walls = self._walls(rng)
        ceiling, self.lights = self._ceiling(rng)
        width = max(floor.shape[1], walls.shape[1], ceiling.shape[1])
        self.wall_row = floor.shape[0] + PAD
        self.ceil_row = self.wall_row + walls.shape[0] + PAD
        atlas = np.zeros((self.ceil_row + ceiling.shape[0] + PAD, width, 3), np.uint8)
        for img, row in ((floor, 0), (walls, self.wall_row), (ceiling, self.ceil_row)):
            atlas[row: row + img.shape[0], : img.shape[1]] = img
            atlas[row: row + img.shape[0], img.shape[1]: img.shape[1] + PAD] = img[:, -1:]  # no black seams
            atlas[row + img.shape[0]: row + img.shape[0] + PAD, : img.shape[1]] = img[-1:]
        self.atlas = [atlas]
        for _ in range(1, LEVELS):
            self.atlas.append(cv2.pyrDown(self.atlas[-1]))
        self.objects = self._clutter(rng, placed)
        # the light of the place drifts along the lap: brightness and tint every ~4 m
        knots = max(3, int(track.length / 4))
        ks = np.linspace(0, track.length, knots + 1)
        bright = rng.uniform(0.8, 1.15, knots + 1)
        bright[-1] = bright[0]
        tint = rng.uniform(0.94, 1.06, (knots + 1, 3))
        tint[-1] = tint[0]
        self.brightness = np.interp(track.s, ks, bright).astype(np.float32) * self.light
        self.tint = np.stack([np.interp(track.s, ks, tint[:, c]) for c in range(3)], 1).astype(np.float32)
        self.tint *= self.warmth

    # --- surfaces ----------------------------------------------------------------------------------------------

    def _floor(self, rng: np.random.Generator, placed: np.random.Generator) -> np.ndarray:
        tr, kind = self.track, self.floor_kind
        w, h = int(math.ceil((self.x1 - self.x0) / RES)), int(math.ceil((self.y1 - self.y0) / RES))
        base = self.floor_bgr if self.look.pattern == "plain" else self.look.floor_colours(h, w, RES)
        shade = _noise(rng, (h, w), 60, 0.05) * _noise(rng, (h, w), 12, 0.02)
        if kind == "concrete":
            shade *= _tile(rng, (h, w), 0.03)
        elif kind == "epoxy":
            shade *= _tile(rng, (h, w), 0.015)
        elif kind == "carpet":
            shade *= _tile(rng, (h, w), 0.06, 0.6)
            tiles = rng.uniform(0.93, 1.07, (h // 50 + 1, w // 50 + 1)).astype(np.float32)
            shade *= cv2.resize(tiles, (tiles.shape[1] * 50, tiles.shape[0] * 50),
                                interpolation=cv2.INTER_NEAREST)[:h, :w]
        elif kind == "wood":
            plank = int(rng.integers(8, 16))  # texels: planks 8-15 cm wide
            rows = rng.uniform(0.92, 1.08, h // plank + 1).astype(np.float32)
            grain = cv2.resize(rng.standard_normal((h // 2 + 1, w // 40 + 2)).astype(np.float32), (w, h))
            shade *= np.repeat(rows, plank)[:h, None] * (1 + 0.05 * grain) * _tile(rng, (h, w), 0.03)
        elif kind == "tarp":
            shade *= _tile(rng, (h, w), 0.02)
        img = shade[..., None] * base
        if kind == "tarp":  # the tarp lies on a darker floor; its creases catch the light
            ground = np.array((95, 100, 105), np.float32) * _tile(rng, (h, w), 0.08)[..., None]
            inside = np.zeros((h, w), np.uint8)
            pts = np.stack(tr.offset(0.0), 1)
            lo = (pts.min(0) - tr.lane_width - [self.x0, self.y0]) / RES
            hi = (pts.max(0) + tr.lane_width - [self.x0, self.y0]) / RES
            cv2.rectangle(inside, tuple(int(v) for v in lo), tuple(int(v) for v in hi), 1, -1)
            img = np.where(inside[..., None] > 0, img, ground)
            creases = np.zeros((h, w), np.float32)
            for _ in range(int((self.x1 - self.x0) * (self.y1 - self.y0) / 1.5)):
                p = rng.uniform([0, 0], [w, h])
                q = p + rng.normal(0, 120, 2)
                cv2.line(creases, tuple(int(v) for v in p), tuple(int(v) for v in q), float(rng.uniform(-0.12, 0.12)),
                         int(rng.integers(2, 7)), cv2.LINE_AA)
            img *= (1 + cv2.GaussianBlur(creases, (0, 0), 3) * inside)[..., None]
        elif kind == "concrete":  # expansion joints
            step = int(rng.uniform(3, 6) / RES)
            off = int(rng.integers(0, step))
            img[:, off::step] *= 0.6
            img[off::step, :] *= 0.6
        # pools of light under the ceiling lamps
        img *= cv2.resize(np.float32(0.85) + 0.3 * self._lamp_field((h // 20 + 1, w // 20 + 1), 20 * RES),
                          (w, h), interpolation=cv2.INTER_LINEAR)[..., None]
        self._paint_lines(img, rng)
        self._paint_marks(img, placed)
        if self.look.gradient:
            img *= self.look.light_across(h, w)[..., None]
        return np.clip(img, 0, 255).astype(np.uint8)

    def _lamps(self, rng: np.random.Generator) -> tuple[np.ndarray, bool]:
        """The ceiling lamps' (x, y), in a grid, and whether long tubes run along x."""
        nx = max(1, int((self.x1 - self.x0) / rng.uniform(3, 6)))
        ny = max(1, int((self.y1 - self.y0) / rng.uniform(3, 6)))
        gx = (np.arange(nx) + 0.5) / nx * (self.x1 - self.x0) + self.x0
        gy = (np.arange(ny) + 0.5) / ny * (self.y1 - self.y0) + self.y0
        return np.array([(x, y) for x in gx for y in gy]), bool(rng.random() < 0.5)

    def _lamp_field(self, shape: tuple[int, int], res: float) -> np.ndarray:
        """Brightness in [0, 1] of the floor under the lamps (a soft pool under each), sampled every `res` m."""
        yy, xx = np.mgrid[0: shape[0], 0: shape[1]].astype(np.float32)
        xx, yy = xx * res + self.x0, yy * res + self.y0
        field = np.zeros(shape, np.float32)
        for lx, ly in self.lamps:
            field += np.exp(-((xx - lx) ** 2 + (yy - ly) ** 2) / (2 * (0.35 * self.height) ** 2))
        return field / max(float(field.max()), 1e-6)

    def _texels(self, x, y) -> np.ndarray:
        """Floor points (m) as texels with SHIFT bits of sub-texel precision, (n, 2) int32."""
        return np.stack([(x - self.x0) / RES * 2 ** SHIFT, (y - self.y0) / RES * 2 ** SHIFT], 1).astype(np.int32)

    def _paint_lines(self, img: np.ndarray, rng: np.random.Generator) -> None:
        tr = self.track
        thick = max(1, int(round(self.tape_width / RES)))
        colour = tuple(float(c) for c in self.tape_bgr)
        for d in tr.lines:
            cv2.polylines(img, [self._texels(*tr.offset(d))], True, colour, thick, cv2.LINE_AA, SHIFT)
        self.start_line = bool(rng.random() < 0.6)
        if self.start_line:  # a start line across the lane
            a, b = (np.array(tr.pose(0.0, d)[:2], float)[None] for d in (-tr.lane_width / 2, tr.lane_width / 2))
            pts = self._texels(*np.concatenate([a, b]).T)
            cv2.line(img, tuple(pts[0]), tuple(pts[1]), colour, thick, cv2.LINE_AA, SHIFT)

    def _paint_marks(self, img: np.ndarray, rng: np.random.Generator) -> None:
        """A varied look's stray tape pieces and painted marks: strips 0.1-1.5 m long and 0.02-0.10 m wide, half in
        the tape's colour, each where it lies wholly at least 0.1 m beside the lane's margin (`_clearance`)."""
        lo, hi = (self.x0, self.y0), (self.x1 - CLEAR_RES, self.y1 - CLEAR_RES)
        for _ in range(self.look.marks):
            p, a = rng.uniform(lo, hi), rng.uniform(0, math.pi)
            strip = np.clip(p + np.linspace(0, rng.uniform(0.1, 1.5), 16)[:, None] * (math.cos(a), math.sin(a)), lo, hi)
            width, colour = rng.uniform(0.02, 0.10), self.tape_bgr if rng.random() < 0.5 else rng.uniform(20, 240, 3)
            if self._clear_at(*strip.T).min() >= 0.1:
                a, b = (tuple(pt) for pt in self._texels(*strip[[0, -1]].T))
                cv2.line(img, a, b, tuple(map(float, colour)), max(1, round(width / RES)), cv2.LINE_AA, SHIFT)

    def _walls(self, rng: np.random.Generator) -> np.ndarray:
        """The four walls unrolled side by side along the perimeter (south, east, north, west), the top row
        at the ceiling."""
        wx, wy = self.x1 - self.x0, self.y1 - self.y0
        w, h = int(math.ceil(2 * (wx + wy) / WALL_RES)), int(math.ceil(self.height / WALL_RES))
        base = np.array(WALLS[int(rng.integers(len(WALLS)))], np.float32) * rng.uniform(0.8, 1.05)
        img = np.empty((h, w, 3), np.float32)
        img[:] = base
        img *= (_noise(rng, (h, w), 30, 0.04) * _tile(rng, (h, w), 0.03))[..., None]
        img *= np.linspace(0.9, 1.0, h, dtype=np.float32)[:, None, None]

        def rect(x0, z0, x1, z1, colour):  # x along the perimeter, z up (m)
            c0, c1 = int(x0 / WALL_RES), int(x1 / WALL_RES)
            r0, r1 = int((self.height - z1) / WALL_RES), int((self.height - z0) / WALL_RES)
            img[max(r0, 0): max(r1, 0), max(c0, 0): max(c1, 0)] = colour

        for _ in range(int(2 * (wx + wy) / 3.5)):  # doors, roller shutters, windows, boards, cabinets
            p = rng.uniform(0, 2 * (wx + wy))
            kind = rng.choice(["door", "shutter", "window", "board", "cabinet"], p=[0.3, 0.1, 0.25, 0.15, 0.2])
            if kind == "door":
                rect(p, 0, p + rng.uniform(0.8, 1.8), 2.1, base * rng.uniform(0.55, 0.85))
            elif kind == "shutter":
                width, top = rng.uniform(2.5, 4), min(self.height - 0.3, rng.uniform(2.5, 3.5))
                rect(p, 0, p + width, top, base * 0.8)
                for z in np.arange(0, top, 0.1):
                    rect(p, z, p + width, z + 0.02, base * 0.65)
            elif kind == "window":
                rect(p, 1.0, p + rng.uniform(1, 2.5), min(self.height - 0.2, 2.3),
                     np.array((250, 245, 235), np.float32))
            elif kind == "board":
                rect(p, 0.9, p + rng.uniform(0.8, 2), 1.9, np.array((235, 238, 240), np.float32) * rng.uniform(0.85, 1))
            else:
                colour = _pick(rng, [(90, 90, 95), (60, 70, 140), (150, 140, 120), (40, 40, 45)])
                rect(p, 0, p + rng.uniform(0.5, 1.5), rng.uniform(0.8, 2.0), colour)
        rect(0, 0, 2 * (wx + wy), rng.uniform(0.06, 0.15), base * rng.uniform(0.3, 0.6))  # skirting
        for corner in (wx, wx + wy, 2 * wx + wy):  # shade of the corners
            rect(corner - 0.03, 0, corner + 0.03, self.height, base * 0.8)
        return np.clip(img, 0, 255).astype(np.uint8)

    def _ceiling(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """The ceiling (grey, with its lamps) and the lamps alone as one float32 channel (the light a glossy
        floor mirrors; blurred the more the less glossy the floor)."""
        w, h = int(math.ceil((self.x1 - self.x0) / CEIL_RES)), int(math.ceil((self.y1 - self.y0) / CEIL_RES))
        lights = np.zeros((h, w), np.float32)
        tube = rng.random() < 0.75  # long fluorescent tubes or square panels
        for lx, ly in self.lamps:
            if tube:
                half = (0.6, 0.05) if self.tubes_along_x else (0.05, 0.6)
            else:
                half = (0.3, 0.3)
            a = (int((lx - half[0] - self.x0) / CEIL_RES), int((ly - half[1] - self.y0) / CEIL_RES))
            b = (int((lx + half[0] - self.x0) / CEIL_RES), int((ly + half[1] - self.y0) / CEIL_RES))
            cv2.rectangle(lights, a, b, 1.0, -1)
        grey = np.array((170, 172, 170), np.float32) * rng.uniform(0.5, 0.9)
        ceiling = grey * _noise(rng, (h, w), 10, 0.05)[..., None] * (1 - lights[..., None]) + 255 * lights[..., None]
        blur = 0.6 + 4 * (1 - min(self.gloss / 0.6, 1))
        return np.clip(ceiling, 0, 255).astype(np.uint8), cv2.GaussianBlur(lights, (0, 0), blur / CEIL_RES * 0.05)

    # --- clutter -----------------------------------------------------------------------------------------------

    def _clearance(self) -> np.ndarray:
        """The floor's distance (m) from the lane and a margin of 0.1 m around it, every CLEAR_RES m."""
        tr, res = self.track, CLEAR_RES
        w, h = int((self.x1 - self.x0) / res) + 1, int((self.y1 - self.y0) / res) + 1
        lane = np.full((h, w), 255, np.uint8)
        pts = np.stack([(tr.x - self.x0) / res, (tr.y - self.y0) / res], 1).astype(np.int32)
        cv2.polylines(lane, [pts], True, 0, max(1, int((tr.lane_width + 0.2) / res)))
        return cv2.distanceTransform(lane, cv2.DIST_L2, 5) * res

    def _clear_at(self, x, y) -> np.ndarray:
        """`_clearance` at floor points (m)."""
        row, col = ((np.asarray(v) - v0) / CLEAR_RES for v, v0 in ((y, self.y0), (x, self.x0)))
        return self.clear[row.astype(int), col.astype(int)]

    def _clutter(self, rng: np.random.Generator, placed: np.random.Generator) -> list[dict]:
        """Solids on the floor away from the lane: boxes, cones, bins, chairs and people's legs, each a list of
        faces (polygons of world points) with a colour; a varied look's more of them (from `placed`) and people
        standing 0.45-0.9 m beside the lane's edge (where that is as far from any other part of the lane)."""
        area = (self.x1 - self.x0) * (self.y1 - self.y0)
        objects = self._scatter(rng, int(area / rng.uniform(5, 12)))
        objects += self._scatter(placed, int(area * self.look.clutter))
        tr = self.track
        for _ in range(self.look.people):
            side, s, gap = placed.choice([-1, 1]), placed.uniform(0, tr.length), placed.uniform(0.45, 0.9)
            x, y, yaw = (float(v) for v in tr.pose(s, side * (tr.lane_width / 2 + gap)))
            if self._clear_at(x, y) >= gap - 0.15:
                objects.append(self._solid("person", x, y, yaw, 1.0, placed))
        return [o for o in objects if o["faces"]]

    def _scatter(self, rng: np.random.Generator, n: int) -> list[dict]:
        """n solids of the clutter's kinds tried at random places of the room: those at least 0.5 m from the lane
        (`_clearance`) are placed."""
        objects = []
        for _ in range(n):
            kind = str(rng.choice(CLUTTER, p=[0.3, 0.2, 0.15, 0.12, 0.08, 0.15]))
            x, y = rng.uniform([self.x0 + 0.3, self.y0 + 0.3], [self.x1 - 0.3, self.y1 - 0.3])
            yaw = rng.uniform(0, math.pi)
            if kind == "cabinet":  # against a wall
                side = int(rng.integers(4))
                x = [x, self.x1 - 0.3, x, self.x0 + 0.3][side]
                y = [self.y0 + 0.3, y, self.y1 - 0.3, y][side]
                yaw = 0.0
            c = self._clear_at(x, y)
            if c < 0.5:
                continue
            objects.append(self._solid(kind, x, y, yaw, min(c - 0.2, 1.5), rng))
        return objects

    def _solid(self, kind: str, x: float, y: float, yaw: float, room: float, rng: np.random.Generator) -> dict:
        faces: list[tuple[np.ndarray, np.ndarray]] = []

        def box(cx, cy, hx, hy, z0, z1, colour, yaw_=yaw):
            c, s = math.cos(yaw_), math.sin(yaw_)
            corner = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
            xy = np.stack([cx + corner[:, 0] * c - corner[:, 1] * s, cy + corner[:, 0] * s + corner[:, 1] * c], 1)
            for i in range(4):
                a, b = xy[i], xy[(i + 1) % 4]
                faces.append((np.array([[*a, z0], [*b, z0], [*b, z1], [*a, z1]]), colour))
            faces.append((np.array([[*p, z1] for p in xy]), colour))

        def prism(cx, cy, r_bottom, r_top, z0, z1, colour, sides=6):
            ang = np.arange(sides) * 2 * math.pi / sides + yaw
            lo = np.stack([cx + r_bottom * np.cos(ang), cy + r_bottom * np.sin(ang)], 1)
            hi = np.stack([cx + r_top * np.cos(ang), cy + r_top * np.sin(ang)], 1)
            for i in range(sides):
                j = (i + 1) % sides
                faces.append((np.array([[*lo[i], z0], [*lo[j], z0], [*hi[j], z1], [*hi[i], z1]]), colour))
            if r_top > 0:
                faces.append((np.array([[*p, z1] for p in hi]), colour))

        size = min(room, 1.0)
        if kind == "box":
            colour = _pick(rng, [(80, 130, 170), (95, 145, 185), (60, 110, 150), (200, 200, 200), (150, 90, 40)])
            hx, hy = rng.uniform(0.12, 0.45, 2) * size
            z1 = rng.uniform(0.15, 0.7)
            box(x, y, hx, hy, 0.0, z1, colour * rng.uniform(0.85, 1.1))
            if rng.random() < 0.35:  # another box on top
                box(x, y, hx * 0.8, hy * 0.8, z1, z1 + rng.uniform(0.15, 0.5), colour * rng.uniform(0.8, 1.1),
                    yaw + rng.uniform(-0.4, 0.4))
        elif kind == "cone":
            r, hgt = rng.uniform(0.1, 0.17), rng.uniform(0.3, 0.7)
            orange = np.array((20, 90, 235), np.float32)
            box(x, y, r * 1.25, r * 1.25, 0.0, 0.03, orange * 0.7)
            prism(x, y, r, r * 0.55, 0.03, hgt * 0.45, orange)
            prism(x, y, r * 0.55, r * 0.4, hgt * 0.45, hgt * 0.6, np.array((235, 235, 235), np.float32))
            prism(x, y, r * 0.4, 0.0, hgt * 0.6, hgt, orange)
        elif kind == "bin":
            colour = _pick(rng, [(40, 40, 40), (150, 80, 30), (40, 120, 40), (50, 50, 170), (200, 200, 200)])
            r = rng.uniform(0.12, 0.3) * max(size, 0.5)
            prism(x, y, r, r * 1.05, 0.0, rng.uniform(0.3, 0.9), colour, 8)
        elif kind == "chair":
            colour = _pick(rng, [(30, 30, 30), (120, 120, 120), (140, 70, 30), (40, 40, 160)])
            leg = np.array((80, 80, 80), np.float32)
            c, s = math.cos(yaw), math.sin(yaw)
            for fx, fy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                lx, ly = 0.2 * fx, 0.2 * fy
                box(x + lx * c - ly * s, y + lx * s + ly * c, 0.015, 0.015, 0.0, 0.45, leg)
            box(x, y, 0.23, 0.23, 0.42, 0.47, colour)
            bx, by = -0.21, 0.0
            box(x + bx * c - by * s, y + bx * s + by * c, 0.02, 0.22, 0.47, 0.88, colour)
        elif kind == "legs":
            jeans = _pick(rng, [(120, 70, 40), (60, 50, 40), (40, 40, 40), (110, 110, 100)])
            shoe = _pick(rng, [(220, 220, 220), (30, 30, 30), (60, 60, 140)])
            c, s = math.cos(yaw), math.sin(yaw)
            for side in (-1, 1):
                lx, ly = 0.0, 0.12 * side
                px, py = x + lx * c - ly * s, y + lx * s + ly * c
                box(px + 0.05 * c, py + 0.05 * s, 0.14, 0.05, 0.0, 0.08, shoe)
                prism(px, py, 0.065, 0.08, 0.08, 0.9, jeans)
            box(x, y, 0.13, 0.22, 0.85, 1.5, _pick(rng, [(40, 40, 160), (200, 200, 200), (60, 60, 60), (140, 90, 40)]))
        elif kind == "person":  # standing, 1.5-1.9 m tall, in clothes of any colour
            tall, trousers, top = rng.uniform(1.5, 1.9), rng.uniform(20, 230, 3), rng.uniform(20, 230, 3)
            c, s = math.cos(yaw), math.sin(yaw)
            for side in (-1, 1):
                prism(x - 0.1 * side * s, y + 0.1 * side * c, 0.07, 0.08, 0.0, 0.47 * tall, trousers)
            box(x, y, 0.12, 0.22, 0.47 * tall, 0.83 * tall, top)
            prism(x, y, 0.09, 0.09, 0.85 * tall, tall, _pick(rng, [(80, 110, 160), (60, 90, 140), (45, 60, 90)]), 8)
        else:  # cabinet or table against the wall
            colour = _pick(rng, [(110, 110, 115), (70, 90, 130), (160, 160, 160), (50, 60, 80)])
            box(x, y, rng.uniform(0.3, 1.0), 0.25, 0.0, rng.uniform(0.7, 2.0), colour)
        return {"kind": kind, "x": x, "y": y, "faces": faces}
