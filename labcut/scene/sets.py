"""Lights and viewers as weighted sets of distant directions (DESIGN.md §3).

Directions are unit vectors pointing *towards* the light or the viewer, in
whatever frame the set is used in: presets are defined in a scenario's world
frame (+Z up, the front at -Y) and a :class:`~labcut.scene.Scenario` rotates
them into the mesh frame (+Z face-up). Light weights are irradiances (relative:
only their ratios matter; presets sum to 1); view weights are how often the stone
is seen from that direction (normalised to sum 1).

A :class:`Lights` may also carry an :class:`~labcut.scene.envmap.Environment`:
its samples are among the directions (so the optimiser sees them), and the
renderer lights the stone with the map itself. The first ``n_lamps`` directions
are lamps, rendered as distant (directional) lights.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ..errors import ParameterError
from .directions import spherical_cap, unit_vector
from .envmap import ENVMAP_SUFFIXES, Environment
from .quality import QUALITIES, Quality

def check_quality(quality: Quality | str) -> Quality:
    """The :class:`~labcut.scene.quality.Quality` of a preset name or a Quality (one check)."""
    return Quality.coerce(quality)


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
class DirectionSet:
    """Validated unit directions with non-negative weights (base of :class:`Lights` and :class:`Views`)."""

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
        object.__setattr__(self, "name", str(name))

    def __len__(self) -> int:
        return int(len(self.weights))

    def __repr__(self) -> str:
        """One line: the kind, the name, how many directions and where they point on average
        (``to_dict()`` holds every direction)."""
        mean = self.weights @ self.directions
        norm = float(np.linalg.norm(mean))
        towards = "" if norm < 1e-9 else f", towards ({', '.join(f'{x:.2f}' for x in mean / norm)})"
        return f"{type(self).__name__}({self.name!r}, {len(self)} direction{'s' if len(self) != 1 else ''}{towards})"

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "directions": self.directions.tolist(), "weights": self.weights.tolist()}


@dataclass(frozen=True, init=False, eq=False, repr=False)  # __repr__: DirectionSet's one line
class Lights(DirectionSet):
    """Distant lights: unit ``directions`` towards each light and their ``weights`` (irradiance).

    Lights below the horizon are allowed (they light only faces that see them).
    ``environment`` (optional) is the map some of the directions were sampled from;
    the first ``n_lamps`` directions are lamps (all of them when there is no map).
    """

    environment: Environment | None = None
    n_lamps: int = 0

    _what: ClassVar[str] = "lights"

    @property
    def invariants(self) -> dict[str, Any]:
        """Values derived from these lights that no change of frame alters (the scene's flash peak,
        :func:`labcut.orientation.radiance.scene_peak`), kept by whoever derives them: one dict shared
        by these lights and every copy :meth:`rotated` makes of them, so a scenario's poses and its
        main setting derive each value once."""
        return self.__dict__.setdefault("_invariants", {})

    def __init__(self, directions: Any, weights: Any = None, name: str = "custom") -> None:
        super().__init__(directions, weights, name)
        object.__setattr__(self, "environment", None)
        object.__setattr__(self, "n_lamps", len(self.weights))

    @classmethod
    def _make(cls, directions: Any, weights: Any, name: str, environment: Environment | None, n_lamps: int) -> Lights:
        out = cls(directions, weights, name)
        object.__setattr__(out, "environment", environment)
        object.__setattr__(out, "n_lamps", int(n_lamps))
        return out

    # ------------------------------------------------------------------ builders
    @classmethod
    def lamp(cls, direction: Any, radius_deg: float = 0.0, irradiance: float = 1.0, n: int = 1, name: str = "lamp") -> Lights:
        """A round lamp of angular radius ``radius_deg`` (a disc seen from the stone), sampled by
        ``n`` equal-solid-angle directions; ``radius_deg = 0`` is a point (directional) light.

        Examples
        --------
        >>> import labcut
        >>> lamp = labcut.Lights.lamp([0, 0, 1], radius_deg=8.0, irradiance=1.0, n=13)
        >>> len(lamp), round(lamp.total_irradiance, 6)
        (13, 1.0)
        """
        d = unit_vector(direction, "lamp direction")
        if not (0.0 <= float(radius_deg) <= 60.0):
            raise ParameterError(f"lamp radius must lie in [0, 60] degrees, got {radius_deg!r}")
        if not (np.isfinite(irradiance) and irradiance > 0):
            raise ParameterError(f"lamp irradiance must be a finite number > 0, got {irradiance!r}")
        count = 1 if radius_deg == 0.0 else int(n)
        dirs = spherical_cap(d, float(radius_deg), count)
        return cls(dirs, np.full(count, float(irradiance) / count), name)

    @classmethod
    def from_envmap(cls, env: str | os.PathLike[str] | Environment, n: int = 256, name: str | None = None) -> Lights:
        """Importance-sample an environment map (.exr/.hdr lat-long in Mitsuba's convention, world
        +Z up, see :mod:`labcut.scene.envmap`) into at most ``n`` weighted distant lights.
        The renderer lights the stone with the same map."""
        e = env if isinstance(env, Environment) else Environment.from_file(env)
        d, w = e.sample(n)
        return cls._make(d, w, name or e.name, e, 0)

    @classmethod
    def preset(cls, name: str, quality: Quality | str = "standard") -> Lights:
        """A named lighting preset (world frame); :data:`labcut.scene.LIGHTING` lists them."""
        from .presets import LIGHTING

        return LIGHTING.get(name).factory(check_quality(quality))

    @classmethod
    def combine(cls, parts: list[tuple[Lights, float]], name: str) -> Lights:
        """Several light sets in one frame, each scaled to total irradiance ``share``."""
        if not parts:
            raise ParameterError("lighting needs at least one part")
        lamps_d, lamps_w, env_d, env_w = [], [], [], []
        env: Environment | None = None
        for lights, share in parts:
            if not (np.isfinite(share) and share > 0):
                raise ParameterError(f"a lighting part's share must be a finite number > 0, got {share!r}")
            s = float(share) / lights.total_irradiance
            k = lights.n_lamps
            lamps_d.append(lights.directions[:k])
            lamps_w.append(lights.weights[:k] * s)
            env_d.append(lights.directions[k:])
            env_w.append(lights.weights[k:] * s)
            if lights.environment is not None:
                scaled = lights.environment.scaled(s)
                env = scaled if env is None else env.plus(scaled)
        d = np.concatenate(lamps_d + env_d)
        w = np.concatenate(lamps_w + env_w)
        return cls._make(d, w, name, env, sum(len(x) for x in lamps_w))

    def with_env_samples(self, n: int) -> Lights:
        """The same lights with the environment map sampled by ``n`` directions (importance-sampled
        as :meth:`from_envmap` does) instead of the ones it holds: the lamps are kept, and the map's
        directions carry the irradiance the map carried here (so a scene's parts keep their shares).
        Lights without a map are returned as they are. The effect planner asks for more directions
        where a carving sees the map past its parts (docs/planner.md)."""
        env = self.environment
        if env is None:
            return self
        k = self.n_lamps
        d, w = env.sample(int(n))
        carried = float(self.weights[k:].sum())
        w = w * (carried / float(w.sum())) if w.sum() > 0 else w
        return Lights._make(np.concatenate([self.directions[:k], d]), np.concatenate([self.weights[:k], w]),
                            self.name, env, k)

    # ------------------------------------------------------------------ use
    @property
    def total_irradiance(self) -> float:
        return float(self.weights.sum())

    def rotated(self, r: np.ndarray) -> Lights:
        """The same lights in a frame rotated by ``r`` (new direction = r @ old)."""
        env = None if self.environment is None else self.environment.rotated(r)
        # a rotation of validated unit directions: no second validation (a scenario's settings
        # rotate every pose's lights, several times per recommendation)
        out = object.__new__(Lights)
        for key, value in (("directions", self.directions @ np.asarray(r, dtype=np.float64).T), ("weights", self.weights),
                           ("name", self.name), ("environment", env), ("n_lamps", self.n_lamps),
                           ("_invariants", self.invariants)):
            object.__setattr__(out, key, value)
        return out

    @property
    def lamp_directions(self) -> np.ndarray:
        return self.directions[: self.n_lamps]

    @property
    def lamp_weights(self) -> np.ndarray:
        return self.weights[: self.n_lamps]

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out["lamps"] = self.n_lamps
        out["environment"] = None if self.environment is None else self.environment.name
        return out


@dataclass(frozen=True, init=False, eq=False, repr=False)  # __repr__: DirectionSet's one line
class Views(DirectionSet):
    """Viewing directions (towards the viewer) and how often each is used (normalised weights).

    ``main`` is the direction a render shows (default: the heaviest direction).
    """

    main: np.ndarray = None  # type: ignore[assignment]

    _what: ClassVar[str] = "views"
    _allow_below: ClassVar[bool] = False
    _normalise_weights: ClassVar[bool] = True

    def __init__(self, directions: Any, weights: Any = None, name: str = "custom", main: Any = None) -> None:
        super().__init__(directions, weights, name)
        m = self.directions[int(np.argmax(self.weights))] if main is None else unit_vector(main, "main view")
        object.__setattr__(self, "main", m)

    @classmethod
    def preset(cls, name: str, quality: Quality | str = "standard") -> Views:
        """A named viewing preset (world frame); :data:`labcut.scene.VIEWING` lists them."""
        from .presets import VIEWING

        return VIEWING.get(name).factory(check_quality(quality))

    def rotated(self, r: np.ndarray) -> Views:
        """The same views in a frame rotated by ``r``; directions below the new horizon are
        kept (they see nothing of a face-up stone, but a posed stone's faces may see them)."""
        r = np.asarray(r)
        out = object.__new__(Views)
        object.__setattr__(out, "directions", self.directions @ r.T)
        object.__setattr__(out, "weights", self.weights)
        object.__setattr__(out, "name", self.name)
        object.__setattr__(out, "main", r @ self.main)
        return out

    def subset(self, rows: np.ndarray) -> Views:
        """The viewers at ``rows`` (indices), their weights renormalised, the same main view: one
        pose's share of a moving scenario's viewers (:meth:`labcut.Scenario.views_of_pose`)."""
        rows = np.asarray(rows, dtype=np.int64)
        if rows.size == 0:
            raise ParameterError("a subset of the views needs at least one of them")
        w = self.weights[rows]
        out = object.__new__(Views)
        object.__setattr__(out, "directions", self.directions[rows])
        object.__setattr__(out, "weights", w / w.sum())
        object.__setattr__(out, "name", self.name)
        object.__setattr__(out, "main", self.main)
        return out

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out["main"] = self.main.tolist()
        return out


# ---------------------------------------------------------------------- from files / names
def _json_lights(data: Any, path: str, quality: Quality | str) -> Lights:
    if isinstance(data, list):
        data = {"directions": data}
    if not isinstance(data, dict) or "directions" not in data:
        raise ParameterError(f"{path} must hold {{'directions': [[x, y, z], ...], 'weights': [...]}}")
    return Lights(data["directions"], data.get("weights"), str(data.get("name", Path(path).stem)))


def _json_views(data: Any, path: str) -> Views:
    if isinstance(data, list):
        data = {"directions": data}
    if not isinstance(data, dict) or "directions" not in data:
        raise ParameterError(f"{path} must hold {{'directions': [[x, y, z], ...], 'weights': [...]}}")
    return Views(data["directions"], data.get("weights"), str(data.get("name", Path(path).stem)), data.get("main"))


def lights_from(spec: Any, quality: Quality | str = "standard", envmap_samples: int | None = None) -> Lights:
    """A :class:`Lights` from an instance, a preset name, a JSON file of directions/weights,
    or an .exr/.hdr environment map (importance-sampled)."""
    from ..fileio import read_json
    from .presets import LIGHTING

    if isinstance(spec, Lights):
        return spec
    if isinstance(spec, Environment):
        return Lights.from_envmap(spec, envmap_samples or check_quality(quality).env_samples)
    if isinstance(spec, str | Path):
        text = str(spec)
        if text.lower().endswith(".json"):
            return _json_lights(read_json(text, "lighting file"), text, quality)
        if text.lower().endswith(ENVMAP_SUFFIXES):
            return Lights.from_envmap(text, envmap_samples or check_quality(quality).env_samples)
        return Lights.preset(text, quality)
    raise ParameterError(f"lighting must be one of {LIGHTING.choices()} or labcut.Lights, got {type(spec).__name__}")


def views_from(spec: Any, quality: Quality | str = "standard") -> Views:
    """A :class:`Views` from an instance, a preset name, or a JSON file of directions/weights."""
    from ..fileio import read_json
    from .presets import VIEWING

    if isinstance(spec, Views):
        return spec
    if isinstance(spec, str | Path):
        text = str(spec)
        if text.lower().endswith(".json"):
            return _json_views(read_json(text, "viewing file"), text)
        return Views.preset(text, quality)
    raise ParameterError(f"viewing must be one of {VIEWING.choices()} or labcut.Views, got {type(spec).__name__}")
