"""Plausible variants of a scenario: the same kind of wear under a differently laid-out room, a wider
or narrower motion, other onlookers (issue 39, "answers robust to the scenario's free parameters").

A preset fixes numbers that the world does not: how far apart the downlights hang, where the window
is, how much the hand turns, how high the onlookers' eyes are. :func:`scenario_variants` draws
:attr:`Variation.count` variants of a scenario, each with every free parameter drawn from the
ranges of a :class:`Variation` (Latin hypercube: each range is cut in ``count`` strata and every
stratum is used once, so a handful of variants spans every range):

* **the lights' layout.** For the ``room`` lighting's (ring, pendant, brooch; told by its directions and
  weights, not by name): the downlight grid's
  spacing (:attr:`Variation.downlight_spacing_m`), its height above the stone
  (:attr:`Variation.downlight_height_m`), where the stone sits under it (anywhere in a cell), and
  the window's azimuth (:attr:`Variation.light_turn_deg` either side of the front) and height
  (``± light_tilt_deg``). For any other lights (a lamp, the sun, spots, a JSON file): the lamps
  turned about the vertical by up to ``± light_turn_deg`` (the wearer faces another way) and
  tilted about a random horizontal axis by up to ``light_tilt_deg`` (a lamp not quite overhead,
  the sun higher or lower). An environment map (the room's reflected light, a sky, a photographed
  room) stays as it is: turning its few sampled directions would move the answer by their
  discretisation error, not by anything in the world;
* **the motion**: rocking and swaying amplitudes scaled by a factor in :attr:`Variation.motion_scale`
  (a scenario that does not move stays still);
* **the viewers**: the whole set of viewing directions tilted about a random horizontal axis by up
  to :attr:`Variation.view_tilt_deg` (taller or shorter onlookers, standing nearer or to one side).

Angles in degrees, lengths in metres, world frame (+Z up, the front at -Y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..validation import check_number
from .directions import rotation
from .presets import (DOWNLIGHT_HEIGHT_M, DOWNLIGHT_SPACING_M, ROOM_WINDOW_AZIMUTH_DEG, ROOM_WINDOW_POLAR_DEG,
                      room_lights)
from .scenario import Scenario
from .sets import Lights



@dataclass(frozen=True)
class Variation:
    """How far each free parameter of a scenario may plausibly lie from the preset's value, and how
    many variants to draw (docs/scenarios.md, "Variants": where the ranges come from)."""

    count: int = 6
    #: the window's azimuth (room), or the whole light set's turn about the vertical (others): ±
    light_turn_deg: float = 45.0
    #: the window's height (room), or the light set's tilt about a horizontal axis (others): up to
    light_tilt_deg: float = 10.0
    #: the downlight grid's spacing, metres (office layouts: 1.2-2.4 m; spacing-to-height about 1)
    downlight_spacing_m: tuple[float, float] = (1.4, 2.4)
    #: the downlights' height above the stone, metres (2.5-3.4 m ceilings over a hand at 0.8-1.2 m)
    downlight_height_m: tuple[float, float] = (1.6, 2.6)
    #: the rocking and swaying amplitudes' factor
    motion_scale: tuple[float, float] = (0.6, 1.4)
    #: the viewers' tilt about a horizontal axis: up to
    view_tilt_deg: float = 10.0
    #: the draw's seed (the same seed, the same variants)
    seed: int = 0

    def __post_init__(self) -> None:
        count = check_number(self.count, "variants", 2, 64, integer=True)
        object.__setattr__(self, "count", int(count))
        for key, high in (("light_turn_deg", 180.0), ("light_tilt_deg", 45.0), ("view_tilt_deg", 45.0)):
            object.__setattr__(self, key, float(check_number(getattr(self, key), f"variation {key}", 0.0, high)))
        for key, low, high in (("downlight_spacing_m", 0.5, 6.0), ("downlight_height_m", 0.5, 6.0), ("motion_scale", 0.0, 3.0)):
            value = getattr(self, key)
            if not (isinstance(value, tuple | list) and len(value) == 2):
                raise ParameterError(f"variation {key} must be a (low, high) pair, got {value!r}")
            lo, hi = (float(check_number(v, f"variation {key}", low, high)) for v in value)
            if lo > hi:
                raise ParameterError(f"variation {key} must be a (low, high) pair with low <= high, got {value!r}")
            object.__setattr__(self, key, (lo, hi))
        object.__setattr__(self, "seed", int(check_number(self.seed, "variation seed", 0, 2**63 - 1, integer=True)))

    @classmethod
    def coerce(cls, value: Any) -> Variation | None:
        """``None``/``0``: no variants; a count (int >= 2); or a :class:`Variation`."""
        if value is None or (isinstance(value, int) and not isinstance(value, bool) and value == 0):
            return None
        if isinstance(value, Variation):
            return value
        if isinstance(value, int) and not isinstance(value, bool):
            if not 2 <= value <= 64:
                raise ParameterError(f"variants must be 0 (none) or a count in [2, 64], got {value!r}", parameter="variants")
            return cls(count=value)
        raise ParameterError(f"variants must be a count (2-64), 0 or a labcut Variation, got {value!r}")

    def to_dict(self) -> dict[str, Any]:
        return {"count": self.count, "light_turn_deg": self.light_turn_deg, "light_tilt_deg": self.light_tilt_deg,
                "downlight_spacing_m": list(self.downlight_spacing_m), "downlight_height_m": list(self.downlight_height_m),
                "motion_scale": list(self.motion_scale), "view_tilt_deg": self.view_tilt_deg, "seed": self.seed}


@dataclass(frozen=True, eq=False)
class Variant:
    """One drawn variant: its scenario and the values drawn for it (``changes``, JSON-ready)."""

    scenario: Scenario
    changes: dict[str, Any] = field(default_factory=dict)


def _strata(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    """``(n, k)`` Latin hypercube samples in [0, 1): each column uses each of its n strata once."""
    u = (rng.random((n, k)) + np.arange(n)[:, None]) / n
    for j in range(k):
        u[:, j] = u[rng.permutation(n), j]
    return u


def _tilt(axis_u: float, amount: float) -> np.ndarray:
    """A rotation by ``amount`` degrees about the horizontal axis at azimuth ``axis_u`` x 360°."""
    phi = 2.0 * math.pi * axis_u
    return rotation([math.cos(phi), math.sin(phi), 0.0], amount)


def _is_room(lights: Lights, quality: Any) -> bool:
    """Whether ``lights`` are the ``room`` preset's (:func:`labcut.scene.presets.room_lights` at its
    layout, this quality), whose layout the variants draw fixture by fixture: told by what they hold,
    not by their name (a lighting file may be called "room" too)."""
    preset = room_lights(quality)
    return (lights.n_lamps == preset.n_lamps and lights.directions.shape == preset.directions.shape
            and bool(np.array_equal(lights.directions, preset.directions)) and bool(np.array_equal(lights.weights, preset.weights)))


def _lamps_turned(lights: Lights, r: np.ndarray) -> Lights:
    """``lights`` with their lamps (the first ``n_lamps`` directions) turned by ``r`` and their
    environment map's sampled directions left as they are: a map is the surroundings as given (a
    photograph of a room, an even ceiling or sky), and turning its few sampled directions would
    move the answer by their discretisation error, not by anything in the world."""
    k = lights.n_lamps
    d = lights.directions.copy()
    d[:k] = d[:k] @ np.asarray(r, dtype=np.float64).T
    return Lights._make(d, lights.weights, lights.name, lights.environment, k)


def scenario_variants(scenario: Scenario, variation: Variation | int = 6) -> list[Variant]:
    """``variation.count`` plausible variants of ``scenario`` (module docstring), at its quality.
    Each variant keeps the scenario's name with a ``~k`` suffix (k = 1, 2, ...)."""
    if not isinstance(scenario, Scenario):
        raise ParameterError(f"scenario_variants needs a labcut Scenario, got {type(scenario).__name__}")
    var = Variation.coerce(variation)
    if var is None:
        return []
    rng = np.random.default_rng(var.seed)
    u = _strata(rng, var.count, 9)
    room = _is_room(scenario.lights, scenario.quality)
    out = []
    for k, row in enumerate(u, start=1):
        turn = (2.0 * row[0] - 1.0) * var.light_turn_deg
        tilt = (2.0 * row[1] - 1.0) * var.light_tilt_deg
        changes: dict[str, Any] = {}
        if room:
            spacing = var.downlight_spacing_m[0] + row[2] * (var.downlight_spacing_m[1] - var.downlight_spacing_m[0])
            height = var.downlight_height_m[0] + row[3] * (var.downlight_height_m[1] - var.downlight_height_m[0])
            offset = (float(row[4]), float(row[5]))
            polar = float(np.clip(ROOM_WINDOW_POLAR_DEG - tilt, 30.0, 89.0))
            lights = room_lights(scenario.quality, spacing_m=spacing, height_m=height, offset=offset,
                                 window_polar_deg=polar, window_azimuth_deg=ROOM_WINDOW_AZIMUTH_DEG + turn)
            changes.update({"downlight_spacing_m": round(float(spacing), 3), "downlight_height_m": round(float(height), 3),
                            "downlight_offset": [round(offset[0], 3), round(offset[1], 3)],
                            "window_polar_deg": round(polar, 2), "window_azimuth_deg": round(float(ROOM_WINDOW_AZIMUTH_DEG + turn), 2)})
        else:
            r = _tilt(row[4], tilt) @ rotation([0.0, 0.0, 1.0], turn)
            lights = _lamps_turned(scenario.lights, r)
            changes.update({"light_turn_deg": round(float(turn), 2), "light_tilt_deg": round(float(abs(tilt)), 2),
                            "light_tilt_axis_deg": round(360.0 * float(row[4]), 1)})
        scale = var.motion_scale[0] + row[6] * (var.motion_scale[1] - var.motion_scale[0])
        rock = min(60.0, scenario.rock_deg * scale)
        sway = min(60.0, scenario.sway_deg * scale)
        if scenario.rock_deg or scenario.sway_deg:
            changes["motion_scale"] = round(float(scale), 3)
        view_tilt = row[7] * var.view_tilt_deg
        views = scenario.views.rotated(_tilt(row[8], view_tilt))
        changes.update({"view_tilt_deg": round(float(view_tilt), 2), "view_tilt_axis_deg": round(360.0 * float(row[8]), 1)})
        variant = replace(scenario, name=f"{scenario.name}~{k}", lights=lights, views=views, rock_deg=rock, sway_deg=sway)
        out.append(Variant(variant, changes))
    return out
