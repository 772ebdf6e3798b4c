"""What a cutter keeps when the saw misses: flash energy against degrees off the optimum.

A recommendation carries its misorientation curve (``Recommendation.misorientation``), and a
comparison draws one per cut. Frames (DESIGN.md §3): lamella normals in the mesh frame (+Z
face-up, -Y the front; axial, folded to z >= 0); angles in degrees; values relative to the
optimum's own flash energy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene.quality import Quality

#: rings of directions around the optimum, every ``Quality.miss_step_deg``, out to max(15°, 3 x tolerance)
MISS_DIRECTIONS = 16
#: the named directions of a miss: the side of the stone the lamella normal leans further towards,
#: as a unit vector in the mesh frame (face-up names; a stone worn upright calls +Y its top)
SIDES = {"right": (1.0, 0.0, 0.0), "back": (0.0, 1.0, 0.0), "left": (-1.0, 0.0, 0.0), "front": (0.0, -1.0, 0.0)}
UPRIGHT_NAMES = {"right": "right", "back": "top", "left": "left", "front": "bottom"}


def _unit(v: Any) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _fold(pts: np.ndarray) -> np.ndarray:
    return np.where(pts[:, 2:3] < 0, -pts, pts)


def ring(centre: np.ndarray, angle_deg: float, count: int = MISS_DIRECTIONS) -> np.ndarray:
    """``count`` unit normals at ``angle_deg`` from ``centre`` (evenly around it), folded to z >= 0."""
    c = _unit(centre)
    helper = np.array([1.0, 0.0, 0.0]) if abs(c[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = _unit(np.cross(c, helper))
    e2 = np.cross(c, e1)
    t = math.radians(angle_deg)
    phi = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    pts = c[None, :] * math.cos(t) + math.sin(t) * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    return _fold(pts)


def towards(centre: np.ndarray, side: Any, angle_deg: float) -> np.ndarray:
    """The unit normal ``angle_deg`` from ``centre`` in the direction of ``side`` (a mesh-frame
    vector, e.g. (0, -1, 0): the lamella normal leans that much further towards the front),
    folded to z >= 0. ``side`` along ``centre`` has no direction: then the lean is about +X."""
    c = _unit(centre)
    d = np.asarray(side, dtype=np.float64)
    t = d - (d @ c) * c
    if np.linalg.norm(t) < 1e-9:
        t = np.cross([0.0, 1.0, 0.0], c)
    t = _unit(t)
    a = math.radians(angle_deg)
    return _fold((c * math.cos(a) + t * math.sin(a))[None, :])[0]


@dataclass
class MisorientationCurve:
    """Flash energy when the lamella normal misses the optimum by ``miss_deg`` (degrees), relative
    to the optimum's: ``mean`` over a ring of :data:`MISS_DIRECTIONS` directions, ``worst`` (the
    ring's minimum), and ``by_side``: leaning further towards each side of the stone (``front``,
    ``back``, ``left``, ``right``; face-up names). ``tolerance_deg``: the recommendation's."""

    miss_deg: np.ndarray
    mean: np.ndarray
    worst: np.ndarray
    tolerance_deg: float
    by_side: dict[str, np.ndarray] = field(default_factory=dict)

    def kept_at(self, miss_deg: float, side: str | None = None) -> float:
        """The share of the optimum's flash energy kept ``miss_deg`` off (linear between the
        curve's points): on the ring's mean, or leaning towards ``side``."""
        values = self.mean if side is None else self.by_side[side]
        return float(np.interp(float(miss_deg), self.miss_deg, values))

    def to_dict(self) -> dict[str, Any]:
        return {"miss_deg": self.miss_deg.tolist(), "mean_relative": self.mean.tolist(),
                "worst_relative": self.worst.tolist(), "tolerance_deg": self.tolerance_deg,
                "directions": MISS_DIRECTIONS, "by_side": {k: v.tolist() for k, v in self.by_side.items()}}

    @classmethod
    def from_dict(cls, data: Any) -> MisorientationCurve | None:
        """The inverse of :meth:`to_dict`; None for a missing block (older JSON)."""
        if not data:
            return None
        try:
            return cls(np.asarray(data["miss_deg"], dtype=np.float64), np.asarray(data["mean_relative"], dtype=np.float64),
                       np.asarray(data["worst_relative"], dtype=np.float64), float(data["tolerance_deg"]),
                       {k: np.asarray(v, dtype=np.float64) for k, v in (data.get("by_side") or {}).items()})
        except (KeyError, TypeError, ValueError) as exc:
            raise ParameterError(f"misorientation: bad or missing field ({exc})") from None


def misorientation_curve(scores: Callable[[np.ndarray], np.ndarray], best: np.ndarray, tolerance: float,
                         quality: Quality | str = "standard") -> MisorientationCurve:
    """Energy around ``best`` (mesh frame) relative to its own, ring by ring and towards each side,
    out to ``max(15°, 3 x tolerance)`` every ``quality.miss_step_deg``; ``scores(normals) ->
    energies`` (e.g. ``Scorer.energy_map``), called once."""
    step = Quality.coerce(quality).miss_step_deg
    top = max(15.0, 3.0 * float(tolerance))
    miss = np.arange(0.0, top + 0.5 * step, step)
    rings = np.concatenate([ring(best, a) for a in miss])
    sides = np.array([towards(best, d, a) for d in SIDES.values() for a in miss])
    values = np.asarray(scores(np.concatenate([rings, sides])), dtype=np.float64)
    ring_values = values[:len(rings)].reshape(len(miss), MISS_DIRECTIONS)
    base = ring_values[0, 0]  # the first ring is the optimum itself
    if not base > 0:
        raise ParameterError("the optimum's energy is not positive: no misorientation curve")
    ring_values = ring_values / base
    side_values = values[len(rings):].reshape(len(SIDES), len(miss)) / base
    return MisorientationCurve(miss, ring_values.mean(axis=1), ring_values.min(axis=1), float(tolerance),
                               {name: side_values[k] for k, name in enumerate(SIDES)})


__all__ = ["MISS_DIRECTIONS", "MisorientationCurve", "SIDES", "UPRIGHT_NAMES", "misorientation_curve", "ring", "towards"]
