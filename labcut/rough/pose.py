"""Poses of a cut inside a rough: rotations, the largest scale that fits, the flash a pose keeps.

A pose maps the cut's own frame (mm, +Z face-up, base on z = 0) into the rough's:
``x = R (s (v - p0)) + t`` for a cut vertex ``v``, with ``p0`` the cut's reference point (the
centre of its bounding box), ``s`` the scale, ``R`` the rotation and ``t`` where ``p0`` lands.
``R`` is written as the cut's face-up axis in the rough, ``u = R e_z``, and a spin ``psi`` about
it: ``R = frame_to(u) Rz(psi)``.

Containment in a convex region ``{x : a_i . x <= b_i}`` is exact through the cut's support
function: the cut (or its hull) fits iff ``s h_i + a_i . t <= b_i`` with ``h_i = max_v (R^T
a_i) . (v - p0)`` for every plane, so the largest scale is a linear programme in ``(s, t)`` with
one row per plane (:func:`largest_fit`). The lamella normal ``n`` (rough frame) lies at ``R^T n``
in the cut's frame, where the cut's own score map says how much of its best flash is left.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene.directions import GOLDEN_ANGLE, frame_to, frames_to


@dataclass(frozen=True)
class Fit:
    """The largest copy of a cut in one rotation: ``scale`` (times the reference cut),
    ``centre`` (mm, where the cut's reference point lands, rough frame)."""

    scale: float
    centre: np.ndarray


def sphere_directions(n: int) -> np.ndarray:
    """``n`` unit vectors spread evenly over the whole sphere (Fibonacci; deterministic)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = i * GOLDEN_ANGLE
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def spin(psi: float) -> np.ndarray:
    """Rotation about +Z by ``psi`` radians."""
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_of(up: np.ndarray, psi: float) -> np.ndarray:
    """The rotation taking the cut's frame into the rough's: its +Z to the unit vector ``up``,
    spun by ``psi`` radians about it."""
    return frame_to(up) @ spin(psi)


def rotations(ups: np.ndarray, spins: np.ndarray) -> np.ndarray:
    """(len(ups) * len(spins), 3, 3) rotations, every face-up axis with every spin."""
    frames = frames_to(ups)  # (U, 3, 3)
    c, s = np.cos(spins), np.sin(spins)
    z = np.zeros_like(c)
    spin_m = np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                       np.stack([z, z, np.ones_like(c)], -1)], 1)  # (S, 3, 3)
    return np.einsum("uij,sjk->usik", frames, spin_m).reshape(-1, 3, 3)


#: hull points a screening of many rotations reads at most (:func:`thinned`)
SCREEN_POINTS = 256


def thinned(points: np.ndarray, count: int = SCREEN_POINTS) -> np.ndarray:
    """At most ``count`` of ``points``: for each of as many directions the point farthest along it."""
    if len(points) <= count:
        return points
    return points[np.unique(np.argmax(sphere_directions(count) @ points.T, axis=1))]


#: how many plane-point products :func:`supports` forms at once (512 KiB of doubles)
SUPPORT_CHUNK = 65_536


def supports(rots: np.ndarray, normals: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(R, m): ``h[r, i] = max_v (rots[r]^T normals[i]) . points[v]``, the cut's extent (points:
    its hull's vertices relative to its reference point) towards each plane, in each rotation."""
    rots = np.asarray(rots, dtype=np.float64)
    pts_t = np.ascontiguousarray(np.asarray(points, dtype=np.float64).T)
    local = np.matmul(normals[None, :, :], rots).reshape(-1, 3)  # rows a^T R = (R^T a)^T, (r * m, 3)
    out = np.empty(len(local))
    # a step's products stay in the CPU's cache (SUPPORT_CHUNK doubles): written once and read
    # back by the max while still there, not streamed through memory
    step = max(1, SUPPORT_CHUNK // max(1, len(points)))
    for k in range(0, len(local), step):
        out[k : k + step] = (local[k : k + step] @ pts_t).max(axis=1)
    return out.reshape(len(rots), len(normals))


def centred_scales(h: np.ndarray, planes: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """The largest scale of each rotation (rows of ``h``) with the cut's reference point held at
    ``centre``: a lower bound of :func:`largest_fit` that is cheap for many rotations."""
    room = planes[:, 3] - planes[:, :3] @ centre  # (m,) > 0 inside
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(h > 1e-12, room[None, :] / h, np.inf)
    return np.clip(ratio.min(axis=1), 0.0, None)


def _largest_first(column: np.ndarray, planes: np.ndarray) -> tuple[float, np.ndarray] | None:
    """The linear programme both fits below are: the largest ``s >= 0`` with a ``t`` such that
    ``s column_i + a_i . t <= b_i`` for every plane (HiGHS); ``(s, t)``, or None when no positive
    ``s`` fits."""
    from scipy.optimize import linprog

    a = np.concatenate([np.asarray(column, dtype=np.float64).reshape(-1, 1), planes[:, :3]], axis=1)
    res = linprog(c=[-1.0, 0.0, 0.0, 0.0], A_ub=a, b_ub=planes[:, 3], bounds=[(0.0, None)] + [(None, None)] * 3,
                  method="highs")
    if res.status != 0 or res.x is None or res.x[0] <= 0:
        return None
    return float(res.x[0]), np.asarray(res.x[1:], dtype=np.float64)


def largest_fit(h: np.ndarray, planes: np.ndarray) -> Fit | None:
    """The largest scale ``s`` and position ``t`` with ``s h_i + a_i . t <= b_i`` for every plane
    (one rotation's supports ``h``, shape (m,)): exact for the convex region ``planes``. None when
    nothing fits (the region is empty)."""
    found = _largest_first(h, planes)
    return None if found is None else Fit(*found)


def chebyshev_centre(planes: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The centre and radius (mm) of the largest ball inside ``planes`` (unit normals: a ball's
    support is its radius towards every plane); None when empty."""
    found = _largest_first(np.ones(len(planes)), planes)
    return None if found is None else (found[1], found[0])


def axial_upper(m: np.ndarray) -> np.ndarray:
    """Rows of ``m`` with the sign that points up (z >= 0): a lamella normal is axial."""
    return np.where(m[..., 2:3] < 0.0, -m, m)


def transform(rotation: np.ndarray, scale: float, ref: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """The 4 x 4 matrix taking the scaled cut's frame (the cut ``scale`` times its reference
    size, as it is returned) into the rough's: ``x = R (v - scale p0) + t``."""
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = centre - rotation @ (scale * ref)
    return out
