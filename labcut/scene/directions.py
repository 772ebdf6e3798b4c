"""Directions, rotations and deterministic direction sets on the sphere.

Frames (DESIGN.md §3): the *world* frame of a scenario has +Z up; the *mesh* frame
has +Z face-up and the front of the stone at -Y. Directions are unit vectors
pointing *towards* a light or a viewer. Tilts are measured from +Z, azimuths from
+X toward +Y, in degrees.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..validation import check_number
from ..validation import unit_vector as _unit_vector

FRONT_AZIMUTH_DEG = 270.0
"""Azimuth of the front of the stone (-Y), where a viewer usually stands."""

GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def direction(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    """Unit vector at ``tilt_deg`` from +Z and ``azimuth_deg`` from +X toward +Y."""
    t, a = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


def tilt_azimuth(d: Any) -> tuple[float, float]:
    """(tilt from +Z, azimuth from +X toward +Y in [0, 360)) of a direction, degrees. A unit vector
    (a lamella normal, a view) is taken as it is; any other length is normalised first."""
    v = np.asarray(d, dtype=np.float64)
    length2 = float(v @ v)
    if abs(length2 - 1.0) > 1e-12:
        v = v / math.sqrt(length2)
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(v[2])))))
    az = math.degrees(math.atan2(float(v[1]), float(v[0]))) % 360.0 if 1e-9 < tilt < 180.0 - 1e-9 else 0.0
    return tilt, az


def frame_to(axis: Any) -> np.ndarray:
    """A rotation (3 x 3, columns x, y, z) whose third column is the unit vector ``axis``."""
    return frames_to(np.asarray(axis, dtype=np.float64).reshape(1, 3))[0]


def _lengths(rows: np.ndarray) -> np.ndarray:
    """(U, 1) lengths of ``rows``, each a dot product as ``np.linalg.norm`` of one row takes it."""
    return np.sqrt(np.matmul(rows[:, None, :], rows[:, :, None])[:, 0])


def frames_to(axes: Any) -> np.ndarray:
    """(U, 3, 3): :func:`frame_to` of each row of ``axes`` (U x 3) at once. The x column is the
    helper axis (+X, or +Y for an axis within 26° of X) crossed with the axis."""
    z = np.asarray(axes, dtype=np.float64).reshape(-1, 3)
    z = z / _lengths(z)
    helper = np.where((np.abs(z[:, 0]) < 0.9)[:, None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    x = np.cross(helper, z)
    x /= _lengths(x)
    return np.stack([x, np.cross(z, x), z], axis=2)


def spherical_cap(centre: Any, half_angle_deg: float, n: int) -> np.ndarray:
    """``n`` directions filling the cap of ``half_angle_deg`` around ``centre`` with equal solid
    angle each (Fibonacci spiral; deterministic). ``n == 1`` gives the centre itself."""
    c = np.asarray(centre, dtype=np.float64)
    c = c / np.linalg.norm(c)
    if n == 1:
        return c[None, :]
    i = np.arange(n) + 0.5
    cos_max = math.cos(math.radians(half_angle_deg))
    z = 1.0 - (1.0 - cos_max) * i / n
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = i * GOLDEN_ANGLE
    local = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    return local @ frame_to(c).T


def rotation(axis: Any, angle_deg: float) -> np.ndarray:
    """The rotation matrix about unit ``axis`` by ``angle_deg`` (right hand), 3 x 3."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    t = math.radians(angle_deg)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(t) * kx + (1.0 - math.cos(t)) * (kx @ kx)


def check_rotation(value: Any, what: str = "pose") -> np.ndarray:
    """A validated 3 x 3 rotation matrix (finite, orthonormal to 1e-6, determinant +1)."""
    try:
        r = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be a 3 x 3 rotation matrix of numbers") from None
    if r.shape != (3, 3):
        raise ParameterError(f"{what} must be a 3 x 3 rotation matrix, got shape {list(r.shape)}")
    if not np.all(np.isfinite(r)):
        raise ParameterError(f"{what} must be finite (it holds NaN or infinity)")
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or abs(float(np.linalg.det(r)) - 1.0) > 1e-6:
        raise ParameterError(f"{what} is not a rotation (its rows must be orthonormal with determinant +1)")
    return r


def axial_upper(n: Any) -> np.ndarray:
    """The unit vector of the axis ``n`` on the upper hemisphere (z >= 0): lamella normals are
    axial (``m`` and ``-m`` are one orientation) and reported with z >= 0."""
    v = np.asarray(n, dtype=np.float64)
    v = v / np.linalg.norm(v)
    return -v if v[2] < 0 else v


def normalize_normal(normal: Any) -> np.ndarray:
    """Validate a lamella normal (3 finite numbers, not zero) and return it as a unit vector, z >= 0."""
    m = _unit_vector(normal, "lamella normal")
    return -m if m[2] < 0 else m  # axial: report the upper-hemisphere representative


def unit_vector(value: Any, what: str) -> np.ndarray:
    """A validated unit vector from three finite numbers (not all zero)."""
    return _unit_vector(value, what)


def lamella_normal(normal: Any = None, tilt: float | None = None, azimuth: float | None = None) -> np.ndarray:
    """A lamella normal (unit, mesh frame, the upper of its two signs: z >= 0) from a ``normal``
    vector or from ``tilt`` (degrees from +Z, [0, 90]) and ``azimuth`` (degrees from +X toward +Y,
    [-360, 360]); exactly one of the two ways (:class:`~labcut.errors.ParameterError` otherwise)."""
    if normal is not None:
        if tilt is not None or azimuth is not None:
            raise ParameterError("give a lamella normal or tilt and azimuth, not both")
        return normalize_normal(normal)
    if tilt is None or azimuth is None:
        raise ParameterError("give a lamella normal, or both tilt and azimuth (degrees)")
    t = check_number(tilt, "tilt", 0.0, 90.0, unit="degrees")
    a = check_number(azimuth, "azimuth", -360.0, 360.0, unit="degrees")
    return normalize_normal(direction(t, a))
