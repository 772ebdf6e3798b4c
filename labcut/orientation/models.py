"""Lighting and viewing models: weighted sets of distant directions (DESIGN.md §3).

Directions are unit vectors in the mesh frame pointing *towards* the light or the
viewer; +Z is face-up, the front of the stone faces -Y. Light weights are
irradiances (relative; only their ratios and sum matter), view weights are how
often the stone is seen from that direction (normalised to sum 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ..errors import ParameterError

FRONT_AZIMUTH_DEG = 270.0

QUALITY_COUNTS = {  # directions per extended preset
    "draft": {"lamp": 7, "ceiling": 24, "sky": 32, "cone": 7, "rock": 7},
    "standard": {"lamp": 13, "ceiling": 48, "sky": 64, "cone": 13, "rock": 11},
    "high": {"lamp": 25, "ceiling": 96, "sky": 128, "cone": 25, "rock": 21},
}


def _dir(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    t, a = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


def _spherical_cap(centre: np.ndarray, half_angle_deg: float, n: int) -> np.ndarray:
    """``n`` directions filling a cap around ``centre`` evenly (Fibonacci spiral, deterministic)."""
    if n == 1:
        return centre[None, :]
    i = np.arange(n) + 0.5
    cos_max = math.cos(math.radians(half_angle_deg))
    z = 1.0 - (1.0 - cos_max) * i / n
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    local = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    # rotate +Z onto centre
    zc = centre / np.linalg.norm(centre)
    helper = np.array([1.0, 0.0, 0.0]) if abs(zc[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, zc)
    x /= np.linalg.norm(x)
    y = np.cross(zc, x)
    return local @ np.stack([x, y, zc])


def _hemisphere(n: int, cosine: bool) -> tuple[np.ndarray, np.ndarray]:
    """Fibonacci directions over the upper hemisphere; weights uniform or cosine."""
    i = np.arange(n) + 0.5
    z = 1.0 - i / n  # equal solid angle bands
    r = np.sqrt(1.0 - z * z)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    w = z.copy() if cosine else np.ones(n)
    return d, w


def _validated(directions: Any, weights: Any, what: str, allow_below: bool) -> tuple[np.ndarray, np.ndarray]:
    try:
        d = np.asarray(directions, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} directions must be a list of [x, y, z] numbers") from None
    if d.ndim != 2 or d.shape[1] != 3 or d.shape[0] == 0:
        raise ParameterError(f"{what} need at least one direction given as [x, y, z]")
    if not np.all(np.isfinite(d)):
        raise ParameterError(f"{what} directions must be finite")
    scale = np.max(np.abs(d), axis=1, keepdims=True)
    d = d / np.where(scale > 0, scale, 1.0)  # no overflow in the norm for huge components
    norms = np.linalg.norm(d, axis=1)
    if np.any(norms < 1e-9):
        raise ParameterError(f"{what} directions must not be zero vectors")
    d = d / norms[:, None]
    if weights is None:
        w = np.ones(len(d))
    else:
        try:
            w = np.asarray(weights, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise ParameterError(f"{what} weights must be numbers") from None
        if w.shape[0] != d.shape[0]:
            raise ParameterError(f"{what}: {len(w)} weights for {len(d)} directions")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ParameterError(f"{what} weights must be finite and >= 0")
    if not allow_below:
        below = d[:, 2] <= 0.0
        if np.all(below | (w == 0)):
            raise ParameterError(f"{what}: no direction above the horizon")
    if float(w.sum()) <= 0.0:
        raise ParameterError(f"{what} weights must not all be zero")
    return d, w


@dataclass(frozen=True, eq=False)  # arrays: compare by identity
class _DirectionSet:
    """Validated unit directions with non-negative weights (shared by :class:`Lights` and :class:`Views`)."""

    directions: np.ndarray
    weights: np.ndarray
    name: str = "custom"

    _what: ClassVar[str] = "directions"
    _allow_below: ClassVar[bool] = True
    _normalise_weights: ClassVar[bool] = False

    def __init__(self, directions: Any, weights: Any = None, name: str = "custom") -> None:
        d, w = _validated(directions, weights, self._what, allow_below=self._allow_below)
        object.__setattr__(self, "directions", d)
        object.__setattr__(self, "weights", w / w.sum() if self._normalise_weights else w)
        object.__setattr__(self, "name", name)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "directions": self.directions.tolist(), "weights": self.weights.tolist()}


@dataclass(frozen=True, init=False, eq=False)
class Lights(_DirectionSet):
    """Distant lights: unit ``directions`` towards each light and their ``weights`` (irradiance).

    Lights below the horizon are allowed (they light only faces that see them).
    """

    _what: ClassVar[str] = "lights"

    @property
    def total_irradiance(self) -> float:
        return float(self.weights.sum())

    @classmethod
    def preset(cls, name: str, quality: str = "standard") -> Lights:
        """``overhead`` (the bench lamp straight above the stone, a disc of 8° radius), ``ceiling`` (office
        lighting: many directions, cosine-weighted), ``spot`` (one light, 35° from the
        front), ``sky`` (uniform diffuse sky over the upper hemisphere)."""
        n = QUALITY_COUNTS[_quality(quality)]
        key = str(name).strip().lower()
        if key == "overhead":
            d = _spherical_cap(np.array([0.0, 0.0, 1.0]), 8.0, n["lamp"])
            return cls(d, None, "overhead")
        if key == "ceiling":
            d, w = _hemisphere(n["ceiling"], cosine=True)
            return cls(d, w, "ceiling")
        if key == "spot":
            return cls([_dir(35.0, FRONT_AZIMUTH_DEG)], None, "spot")
        if key == "sky":
            d, w = _hemisphere(n["sky"], cosine=False)
            return cls(d, w, "sky")
        raise ParameterError(f"unknown lighting {name!r}; choose one of overhead, ceiling, spot, sky, or a JSON file")


@dataclass(frozen=True, init=False, eq=False)
class Views(_DirectionSet):
    """Viewing directions (towards the viewer) and how often each is used (normalised weights)."""

    _what: ClassVar[str] = "views"
    _allow_below: ClassVar[bool] = False
    _normalise_weights: ClassVar[bool] = True

    @classmethod
    def preset(cls, name: str, quality: str = "standard") -> Views:
        """``face-up`` (a 15° cone of tilts around +Z, weighted toward the centre),
        ``rocking`` (the stone rocked ±35° front-to-back and a little sideways in the hand),
        ``pendant`` (near-horizontal, 60-80° from face-up, from the front half)."""
        n = QUALITY_COUNTS[_quality(quality)]
        key = str(name).strip().lower()
        if key == "face-up":
            d = _spherical_cap(np.array([0.0, 0.0, 1.0]), 15.0, n["cone"])
            w = np.exp(-0.5 * (np.degrees(np.arccos(np.clip(d[:, 2], -1, 1))) / 8.0) ** 2)
            return cls(d, w, "face-up")
        if key == "rocking":
            tilts = np.linspace(-35.0, 35.0, n["rock"])
            d = [_dir(abs(t), FRONT_AZIMUTH_DEG if t < 0 else 90.0) for t in tilts]
            d += [_dir(15.0, 0.0), _dir(15.0, 180.0)]
            return cls(d, None, "rocking")
        if key == "pendant":
            d = [_dir(t, FRONT_AZIMUTH_DEG + a) for t in (60.0, 70.0, 80.0) for a in np.linspace(-40, 40, max(n["rock"] // 3, 3))]
            return cls(d, None, "pendant")
        raise ParameterError(f"unknown viewing {name!r}; choose one of face-up, rocking, pendant, or a JSON file")


def _quality(q: str) -> str:
    if q not in QUALITY_COUNTS:
        raise ParameterError(f"quality must be one of {', '.join(QUALITY_COUNTS)}, got {q!r}")
    return q


def _from_json(path: Path, cls: type) -> Any:
    from ..fileio import read_json

    data = read_json(path, f"{cls.__name__.lower()[:-1]} file")
    if isinstance(data, list):
        data = {"directions": data}
    if not isinstance(data, dict) or "directions" not in data:
        raise ParameterError(f"{path} must hold {{'directions': [[x, y, z], ...], 'weights': [...]}}")
    return cls(data["directions"], data.get("weights"), str(data.get("name", path.stem)))


def _model_from(spec: Any, cls: type, what: str, quality: str) -> Any:
    if isinstance(spec, cls):
        return spec
    if isinstance(spec, str | Path) and str(spec).lower().endswith(".json"):
        return _from_json(Path(spec), cls)
    if isinstance(spec, str):
        return cls.preset(spec, quality)
    raise ParameterError(f"{what} must be a preset name, a JSON file or labcut.{cls.__name__}, got {type(spec).__name__}")


def lights_from(spec: Any, quality: str = "standard") -> Lights:
    """A :class:`Lights` from an instance, a preset name, or a JSON file path."""
    return _model_from(spec, Lights, "lighting", quality)


def views_from(spec: Any, quality: str = "standard") -> Views:
    """A :class:`Views` from an instance, a preset name, or a JSON file path."""
    return _model_from(spec, Views, "viewing", quality)
