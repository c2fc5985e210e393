"""The look of a track's room and of its camera beyond what the room draws itself, and the varied looks of
training recordings (`steerlab sim record --world track --vary`): rooms that cannot be memorised.

`Look()` is the look of every room as drawn (`room.Room`: the floor kind's palette, the named tapes, light
0.75-1.2, the renderer's sensor noise, no blur, the writer's JPEG quality, the mount as given); the suites and
every recording without `vary` render with it. `Look.draw(seed)` draws a look from a stream of its own (the
room's seed with 31; the room's own draws stay as they are) from much wider distributions: a floor of any colour,
plain or in a pattern of two (a checkerboard, or tiles with joints of the second colour), stray tape pieces and
painted marks outside the lane, a tape of any colour that stands out from the floor (`stands_out`) 0.02-0.10 m
wide, light 0.4-1.6 falling off across the floor from a random side, stronger glare of the lamps on a glossy
floor, more clutter and people standing beside the lane, the sensor's noise, a blur, the JPEG quality of the
recording's images and the camera's mount jittered around the given one.
"""

from __future__ import annotations

import colorsys
import itertools
from dataclasses import asdict, dataclass, replace

import numpy as np

from steerlab.data.fisheye import FisheyeCamera

CONTRAST = 120.0  # the least distance (B, G, R, 0-255 each) between a tape's colour and each colour of its floor
CORNERS = [tuple(255.0 * v for v in c) for c in itertools.product((0, 1), repeat=3)]  # black, ..., white
PATTERNS = ["plain", "checker", "tiles"]
Colour = tuple[float, float, float]  # B, G, R in 0-255


def stands_out(tape, floor) -> bool:
    """Whether a tape of colour `tape` stands out from a floor of colour `floor` (B, G, R): their distance is over
    CONTRAST, as people choose a tape their floor does not swallow."""
    return float(np.linalg.norm(np.asarray(tape, float) - np.asarray(floor, float))) > CONTRAST


def tape_colour(floors: list[Colour], candidates: list[Colour]) -> Colour:
    """The first candidate that stands out from every floor colour; without one, the corner of the colour cube
    farthest from them (a colour lies within CONTRAST of at most one corner, the corners being 255 apart: two
    floor colours leave at least six corners that stand out from both)."""
    return next((c for c in candidates if all(stands_out(c, f) for f in floors)),
                max(CORNERS, key=lambda c: min(np.linalg.norm(np.subtract(c, f)) for f in floors)))


def _hsv(rng: np.random.Generator, saturation: tuple[float, float], value: tuple[float, float]) -> Colour:
    """A colour of any hue with saturation and value (0-1) in the ranges given, as B, G, R (0-255)."""
    r, g, b = colorsys.hsv_to_rgb(rng.uniform(0, 1), rng.uniform(*saturation), rng.uniform(*value))
    return round(255 * b, 1), round(255 * g, 1), round(255 * r, 1)


@dataclass(frozen=True)
class Look:
    """How a room and its camera look; None and the defaults: as the room draws it (see the module's docstring)."""

    floor: Colour | None = None    # the floor's colour (None: its kind's palette)
    floor2: Colour | None = None   # the second colour of a pattern
    pattern: str = "plain"         # plain, checker (squares of both colours) or tiles (joints of the second)
    tile_m: float = 0.5            # the squares' or tiles' side, m
    marks: int = 0                 # stray tape pieces and painted marks tried on the floor outside the lane
    tape: Colour | None = None     # the tape's colour (None: one of the named tapes)
    tape_width: float | None = None  # m (None: 0.04-0.06)
    light: float | None = None     # the light level (None: 0.75-1.2)
    gradient: float = 0.0          # the floor's light runs from 1 - gradient to 1 + gradient across the room
    light_from_deg: float = 0.0    # towards the side it comes from: the direction (degrees from the world's x axis)
    glare: float = 1.0             # the lamps' reflections in a glossy floor, times this
    clutter: float = 0.0           # more clutter: objects per m2 of the room tried beside the room's own
    people: int = 0                # people (1.5-1.9 m tall) tried standing beside the lane
    noise: float = 3.0             # the sensor's noise, standard deviation (0-255)
    blur: float = 0.0              # the frame's Gaussian blur, sigma in pixels (0: none)
    jpeg_quality: int | None = None  # of the recording's images (None: the writer's own)
    mount_dz: float = 0.0          # m added to the camera's mount height
    pitch_ddeg: float = 0.0        # degrees added to its pitch

    @staticmethod
    def draw(seed: int) -> Look:
        """A varied look drawn from `seed` (a room's): the same seed, the same look."""
        rng = np.random.default_rng([seed, 31])
        floor = _hsv(rng, (0.0, 0.6), (0.2, 0.95))
        pattern = str(rng.choice(PATTERNS, p=[0.5, 0.25, 0.25]))
        floor2 = _hsv(rng, (0.0, 0.6), (0.2, 0.95))
        floors = [floor] if pattern == "plain" else [floor, floor2]
        tape = tape_colour(floors, [_hsv(rng, (0.0, 1.0), (0.1, 1.0)) for _ in range(32)])
        return Look(floor=floor, floor2=None if pattern == "plain" else floor2, pattern=pattern,
                    tile_m=float(rng.uniform(0.3, 1.0)), marks=int(rng.integers(0, 13)), tape=tape,
                    tape_width=float(rng.uniform(0.02, 0.10)), light=float(rng.uniform(0.4, 1.6)),
                    gradient=float(rng.uniform(0.0, 0.5)), light_from_deg=float(rng.uniform(0, 360)),
                    glare=float(rng.uniform(1.0, 3.0)), clutter=float(rng.uniform(0.05, 0.3)),
                    people=int(rng.integers(0, 7)), noise=float(rng.uniform(1.0, 10.0)),
                    blur=float(rng.uniform(0.0, 1.0)), jpeg_quality=int(rng.integers(40, 96)),
                    mount_dz=float(rng.uniform(-0.03, 0.03)), pitch_ddeg=float(rng.uniform(-4.0, 4.0)))

    @property
    def varied(self) -> bool:
        return self != Look()

    def mount(self, cam: FisheyeCamera) -> FisheyeCamera:
        """`cam` at this look's mount: its height and pitch jittered."""
        if not (self.mount_dz or self.pitch_ddeg):
            return cam
        return replace(cam, mount_height=cam.mount_height + self.mount_dz, pitch_deg=cam.pitch_deg + self.pitch_ddeg)

    def metadata(self) -> dict:
        """What a recording keeps of its look beside its camera: a varied look's draws (`look`), else nothing."""
        return {"look": asdict(self)} if self.varied else {}

    def floor_colours(self, h: int, w: int, res: float) -> np.ndarray:
        """The floor's colour texel by texel ((h, w, 3) float32, texels of `res` m) in its pattern."""
        n = self.tile_m / res
        rows, cols = np.arange(h) / n, np.arange(w) / n
        if self.pattern == "checker":
            second = (rows.astype(int)[:, None] + cols.astype(int)[None]) % 2 == 1
        else:  # tiles with joints 2 cm wide
            joint = 0.02 / self.tile_m
            second = (rows % 1 < joint)[:, None] | (cols % 1 < joint)[None]
        return np.where(second[..., None], np.float32(self.floor2), np.float32(self.floor))

    def light_across(self, h: int, w: int) -> np.ndarray:
        """The floor's light across the room ((h, w) float32 of its texels): 1 - gradient on the side away from
        the light, 1 + gradient on the side it comes from."""
        a = np.radians(self.light_from_deg)
        along = np.arange(h, dtype=np.float32)[:, None] * np.float32(np.sin(a)) + \
            np.arange(w, dtype=np.float32)[None] * np.float32(np.cos(a))
        lo, hi = float(along.min()), float(along.max())
        return (1 + self.gradient * (2 * (along - lo) / max(hi - lo, 1e-6) - 1)).astype(np.float32)


LOOK = Look()  # every room's own look
