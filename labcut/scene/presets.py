"""Named lighting and viewing presets, in a scenario's world frame (+Z up, the front at -Y).

Every lighting preset has total irradiance 1 (weights sum to 1), so presets can
be mixed by share. Counts of directions grow with the quality level.
"""

from __future__ import annotations

import numpy as np

from .directions import FRONT_AZIMUTH_DEG, GOLDEN_ANGLE, direction, spherical_cap
from .envmap import Environment, ceiling_radiance, sky_radiance, studio_environment
from .registry import Registry
from .quality import Quality
from .sets import Lights, Views

LIGHTING = Registry("lighting", "a JSON file of directions/weights, or an .exr/.hdr environment map")
VIEWING = Registry("viewing", "or a JSON file of directions/weights")

# direction counts come from the Quality (lamp_samples, env_samples, cone_views, ring_views)

FRONT_LEFT = FRONT_AZIMUTH_DEG - 30.0
FRONT_RIGHT = FRONT_AZIMUTH_DEG + 30.0
#: the window (``window`` lighting, and the room's): its centre's angle from the vertical and its azimuth (in front)
ROOM_WINDOW_POLAR_DEG = 70.0
ROOM_WINDOW_AZIMUTH_DEG = FRONT_AZIMUTH_DEG

_ENV_CACHE: dict[str, Environment] = {}


def _env(name: str) -> Environment:
    """Procedural maps are baked once per process."""
    if name not in _ENV_CACHE:
        if name == "studio":
            _ENV_CACHE[name] = studio_environment()
        elif name == "ceiling":
            _ENV_CACHE[name] = Environment.from_function(ceiling_radiance, 64, 32, "ceiling")
        else:
            _ENV_CACHE[name] = Environment.from_function(sky_radiance, 64, 32, "sky")
    return _ENV_CACHE[name]


def _unit(lights: Lights, name: str) -> Lights:
    return Lights.combine([(lights, 1.0)], name)


# ---------------------------------------------------------------------- lighting
@LIGHTING.register("overhead", "the bench lamp: a disc of 8° radius straight above the stone")
def overhead(quality: Quality | str) -> Lights:
    return _unit(Lights.lamp([0.0, 0.0, 1.0], 8.0, 1.0, Quality.coerce(quality).lamp_samples), "overhead")


@LIGHTING.register("spot", "one small spot 35° from the vertical, in front of the stone")
def spot(quality: Quality | str) -> Lights:
    return Lights.lamp(direction(35.0, FRONT_AZIMUTH_DEG), 0.0, 1.0, 1, "spot")


@LIGHTING.register("ceiling", "an even, bright office ceiling: radiance ∝ cos θ over the upper hemisphere")
def ceiling(quality: Quality | str) -> Lights:
    return _unit(Lights.from_envmap(_env("ceiling"), Quality.coerce(quality).env_samples, "ceiling"), "ceiling")


@LIGHTING.register("sky", "an overcast sky: uniform radiance over the upper hemisphere")
def sky(quality: Quality | str) -> Lights:
    return _unit(Lights.from_envmap(_env("sky"), Quality.coerce(quality).env_samples, "sky"), "sky")


@LIGHTING.register("window", "daylight through a window the stone faces: a disc of 20° radius, 20° above the horizon, in front")
def window(quality: Quality | str) -> Lights:
    return _unit(Lights.lamp(direction(ROOM_WINDOW_POLAR_DEG, ROOM_WINDOW_AZIMUTH_DEG), 20.0, 1.0, Quality.coerce(quality).lamp_samples, "window"), "window")


@LIGHTING.register("sun", "direct sun 50° above the horizon, front-right (a point: its 0.27° radius is far below the lamella spread)")
def sun(quality: Quality | str) -> Lights:
    return Lights.lamp(direction(40.0, FRONT_RIGHT), 0.0, 1.0, 1, "sun")


@LIGHTING.register("office", "ceiling (75 %) and a window (25 %)")
def office(quality: Quality | str) -> Lights:
    return Lights.combine([(ceiling(quality), 0.75), (window(quality), 0.25)], "office")


@LIGHTING.register("daylight", "sun (70 %) and overcast sky (30 %)")
def daylight(quality: Quality | str) -> Lights:
    return Lights.combine([(sun(quality), 0.7), (sky(quality), 0.3)], "daylight")


@LIGHTING.register("shop", "shop-window spots 30-45° from the vertical: front-left, front-right and back")
def shop(quality: Quality | str) -> Lights:
    n = max(1, Quality.coerce(quality).lamp_samples // 3)
    parts = [
        (Lights.lamp(direction(35.0, FRONT_LEFT - 20.0), 3.0, 1.0, n), 0.4),
        (Lights.lamp(direction(40.0, FRONT_RIGHT + 20.0), 3.0, 1.0, n), 0.4),
        (Lights.lamp(direction(45.0, 90.0), 3.0, 1.0, n), 0.2),
    ]
    return Lights.combine(parts, "shop")


# ---------------------------------------------------------------------- rooms as they are lit
#: recessed office downlights (docs/scenarios.md, "Lit as rooms are"): a square grid DOWNLIGHT_SPACING_M
#: apart, DOWNLIGHT_HEIGHT_M above the stone (a 2.75 m ceiling over a hand at desk height), the stone
#: off the nearest fixture by DOWNLIGHT_OFFSET spacings; each fixture a point (a 15 cm opening 2 m away
#: subtends 2°, below the lamella lobe's 9°) of Lambertian intensity I0 cos θ, so the irradiance it
#: gives across its ray at the stone is ∝ cos³ θ (θ from the vertical); fixtures giving less than
#: DOWNLIGHT_CUTOFF of the brightest's are left out
DOWNLIGHT_SPACING_M = 1.8
DOWNLIGHT_HEIGHT_M = 2.0
DOWNLIGHT_OFFSET = (0.5, 0.3)
DOWNLIGHT_CUTOFF = 0.1
#: an office as lit: the downlights' direct light, a window, and the room's reflected light
#: (ceiling, walls: an even ceiling stands for it), shares of the irradiance at the stone
ROOM_SHARES = {"downlights": 0.55, "window": 0.15, "reflected": 0.30}


def downlight_grid(spacing_m: float = DOWNLIGHT_SPACING_M, height_m: float = DOWNLIGHT_HEIGHT_M,
                   offset: tuple[float, float] = DOWNLIGHT_OFFSET) -> tuple[np.ndarray, np.ndarray]:
    """(directions towards each downlight, world frame; their irradiance weights, summing to 1) of a
    square grid ``spacing_m`` apart, ``height_m`` above the stone, the stone off the nearest fixture
    by ``offset`` spacings (x, y)."""
    k = np.arange(-8, 9)
    gx, gy = np.meshgrid((k - offset[0]) * spacing_m, (k - offset[1]) * spacing_m)
    pos = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, height_m)], axis=1)
    d = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    w = d[:, 2] ** 3
    keep = w >= DOWNLIGHT_CUTOFF * w.max()
    return d[keep], w[keep] / w[keep].sum()


@LIGHTING.register("downlights", "recessed office downlights on a 1.8 m grid, 2 m above the stone: point lights, each "
                                 "weighted by its cos³ from the vertical")
def downlights(quality: Quality | str) -> Lights:
    d, w = downlight_grid()
    return Lights(d, w, "downlights")


def room_lights(quality: Quality | str, *, spacing_m: float = DOWNLIGHT_SPACING_M, height_m: float = DOWNLIGHT_HEIGHT_M,
                offset: tuple[float, float] = DOWNLIGHT_OFFSET, window_polar_deg: float = ROOM_WINDOW_POLAR_DEG,
                window_azimuth_deg: float = ROOM_WINDOW_AZIMUTH_DEG) -> Lights:
    """The ``room`` lighting with its layout given: the downlight grid (:func:`downlight_grid`) and
    the window's direction (a disc of 20° radius); the shares of :data:`ROOM_SHARES`. The preset is
    this at its defaults; :mod:`labcut.scene.variants` draws other plausible layouts."""
    q = Quality.coerce(quality)
    d, w = downlight_grid(spacing_m, height_m, offset)
    win = _unit(Lights.lamp(direction(window_polar_deg, window_azimuth_deg), 20.0, 1.0, q.lamp_samples, "window"), "window")
    return Lights.combine([(Lights(d, w, "downlights"), ROOM_SHARES["downlights"]), (win, ROOM_SHARES["window"]),
                           (ceiling(q), ROOM_SHARES["reflected"])], "room")


@LIGHTING.register("room", "an office as lit: downlights (55 %), a window in front (15 %), the room's reflected light "
                           "as an even ceiling (30 %)")
def room(quality: Quality | str) -> Lights:
    return room_lights(quality)


@LIGHTING.register("studio", "a photographer's light tent built in code: key softbox, strip light, top light")
def studio(quality: Quality | str) -> Lights:
    return _unit(Lights.from_envmap(_env("studio"), 2 * Quality.coerce(quality).env_samples, "studio"), "studio")


# ---------------------------------------------------------------------- viewing
@VIEWING.register("face-up", "looking straight down at the face: a 15° cone, weighted toward the centre")
def face_up(quality: Quality | str) -> Views:
    d = spherical_cap(np.array([0.0, 0.0, 1.0]), 15.0, Quality.coerce(quality).cone_views)
    w = np.exp(-0.5 * (np.degrees(np.arccos(np.clip(d[:, 2], -1, 1))) / 8.0) ** 2)
    return Views(d, w, "face-up", main=[0.0, 0.0, 1.0])


@VIEWING.register("cutter", "the cutter's eye just in front of the bench lamp, 10° from the vertical")
def cutter(quality: Quality | str) -> Views:
    return Views([direction(10.0, FRONT_AZIMUTH_DEG)], None, "cutter")


@VIEWING.register("above", "people around the stone looking down at it, 20-60° from the vertical, from every side")
def above(quality: Quality | str) -> Views:
    n = Quality.coerce(quality).ring_views
    i = np.arange(n) + 0.5
    c_hi, c_lo = np.cos(np.radians(20.0)), np.cos(np.radians(60.0))
    z = c_hi - (c_hi - c_lo) * i / n  # equal solid angle bands
    r = np.sqrt(1.0 - z * z)
    phi = i * GOLDEN_ANGLE
    d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    return Views(d, None, "above", main=direction(40.0, FRONT_AZIMUTH_DEG))


@VIEWING.register("eye-level", "people in front at eye level, within ±20° of the horizontal line of sight")
def eye_level(quality: Quality | str) -> Views:
    front = direction(90.0, FRONT_AZIMUTH_DEG)
    d = spherical_cap(front, 20.0, Quality.coerce(quality).cone_views)
    return Views(d, None, "eye-level", main=front)


@VIEWING.register("front", "looking down at a stone on display, 0-30° from the vertical, from the front half")
def front(quality: Quality | str) -> Views:
    d = spherical_cap(np.array([0.0, 0.0, 1.0]), 30.0, 2 * Quality.coerce(quality).cone_views)
    d = d[d[:, 1] <= 0.05]  # front half (-Y), and the centre
    return Views(d, None, "front", main=direction(15.0, FRONT_AZIMUTH_DEG))
