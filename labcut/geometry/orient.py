"""Which side of a stone mesh is face-up: up-axis names, their rotations, and detection from the shape.

labcut's frame (DESIGN.md §3) has +Z face-up and the front of the stone at -Y. Files
come in other conventions: glTF is Y-up by specification (its front faces +Z), many CAD
exports are Y-up, and a cabochon is often exported dome-down (lying on its dome, the flat
base on top). :func:`up_rotation` gives the rotation that takes a file whose face-up side
is one of ``+Z -Z +Y -Y +X -X`` into labcut's frame; :func:`detect_up_axis` reads the
face-up side from the shape where the shape says it:

1. **a flat base**: exactly one side of the bounding box is a flat face covering at least
   90 % of the stone's outline seen from that side, and the opposite side is not (a
   cabochon, a buff-top, a half-bead): face-up is away from the base;
2. **a table over a keel or culet**: a convex stone with a flat face on one side and
   (almost) no flat face on the opposite side (a faceted stone): face-up is the table;
3. **a dome**: a convex stone with no flat base that is clearly thinnest along one axis (a
   double cabochon, a lens): face-up is the side of the taller dome (the one farther from
   the volume's centroid).

A box, a cube, a slab or a sphere does not say which side is up: the file's convention
is kept (+Z, or +Y for glTF).

Rotations are proper (determinant +1): a stone is never mirrored. Each is the smallest
rotation that brings the named axis to +Z: about X for ±Y and for -Z (so a Y-up glTF's
front, +Z, becomes labcut's front, -Y), about Y for ±X.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from .solid import column_bounds, cross_rows, extent

#: up-axis names accepted by ``load_mesh(..., up_axis=)`` and ``--up-axis``
UP_AXES = ("auto", "+Z", "-Z", "+Y", "-Y", "+X", "-X")

#: file axis -> rotation taking file coordinates to labcut's frame (column vectors: p' = R p)
UP_ROTATIONS: dict[str, np.ndarray] = {
    "+Z": np.eye(3),
    "-Z": np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),  # 180° about X
    "+Y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),  # +90° about X
    "-Y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),  # -90° about X
    "+X": np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),  # -90° about Y
    "-X": np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),  # +90° about Y
}

#: share of the outline a flat face must cover to be a base
BASE_FRACTION = 0.9
#: a flat face on the opposite side at least this share of the outline makes it a slab, not a dome
TOP_FLAT_LIMIT = 0.5
#: a table must cover at least this share of the outline, its opposite side at most KEEL_LIMIT
TABLE_FRACTION = 0.05
KEEL_LIMIT = 0.01
#: a dome is clearly thinnest along its axis: at most this share of the next-thinnest extent
DOME_THINNESS = 0.75
#: the centroid must sit this share of the height off the middle to name a dome's side
DOME_OFFSET = 0.03
#: a face counts as part of a flat base when its normal is within ~5.7° of the side's normal
#: and its vertices within 0.5 % of the extent of that side's plane (a scanned base is not
#: exactly planar; a dome's cap never covers 90 % of the outline at this tolerance)
FLAT_COS = 0.995
FLAT_TOL = 0.005
#: tables and slab faces are cut planar: within ~0.8° and 0.01 % of the extent (the cap of a
#: dome is not a table)
PLANAR_COS = 0.9999
PLANAR_TOL = 1e-4


def check_up_axis(up_axis: Any) -> str:
    """Normalise an up-axis name (``auto``, ``+Z``, ``z``, ``-y``, ...); anything else is a ParameterError."""
    if not isinstance(up_axis, str):
        raise ParameterError(f"up axis must be one of {', '.join(UP_AXES)}, got {up_axis!r}", parameter="up axis")
    key = up_axis.strip().upper()
    if key == "AUTO":
        return "auto"
    if key in ("X", "Y", "Z"):
        key = "+" + key
    if key not in UP_ROTATIONS:
        raise ParameterError(f"up axis must be one of {', '.join(UP_AXES)}, got {up_axis!r}", parameter="up axis")
    return key


def up_rotation(axis: str) -> np.ndarray:
    """The rotation (3 x 3, file -> labcut frame) for a file whose face-up side is ``axis``."""
    return UP_ROTATIONS[check_up_axis(axis)].copy()


def axis_vector(axis: str) -> np.ndarray:
    """Unit vector of ``+X`` ... ``-Z`` in the file's coordinates."""
    key = check_up_axis(axis)
    v = np.zeros(3)
    v["XYZ".index(key[1])] = 1.0 if key[0] == "+" else -1.0
    return v


@dataclass(frozen=True)
class UpGuess:
    """What the shape says about the face-up side.

    ``axis``: ``+Z`` ... ``-X``, or None when the shape does not say; ``reason``: why, in words
    (e.g. ``"a flat base facing -Y"``)."""

    axis: str | None
    reason: str


def _side_fractions(v: np.ndarray, f: np.ndarray, normals: np.ndarray, areas: np.ndarray,
                    cos_min: float = FLAT_COS, rel_tol: float = FLAT_TOL) -> dict[str, tuple[float, float]]:
    """Per axis direction d: (flat area on the far side along +d, flat area on the near side) as
    shares of the outline area seen along d. Only the faces whose normal lies within ``cos_min``
    of the axis are looked at vertex by vertex (a few of a big mesh's millions)."""

    out = {}
    lows, highs = column_bounds(v)  # np.ptp's and each column's min and max, the same values
    scale = float((highs - lows).max())
    for k, name in enumerate("XYZ"):
        coord = v[:, k]
        lo, hi = float(lows[k]), float(highs[k])
        tol = rel_tol * max(hi - lo, 1e-12 * scale)
        nk = normals[:, k]
        projected = float(np.dot(areas, np.clip(nk, 0.0, None)))
        if projected <= 0:
            out[f"+{name}"] = out[f"-{name}"] = (0.0, 0.0)
            continue
        up = np.flatnonzero(nk >= cos_min)
        down = np.flatnonzero(nk <= -cos_min)
        top = float(areas[up[coord[f[up]].min(axis=1) >= hi - tol]].sum()) / projected
        bottom = float(areas[down[coord[f[down]].max(axis=1) <= lo + tol]].sum()) / projected
        out[f"+{name}"] = (top, bottom)
        out[f"-{name}"] = (bottom, top)
    return out


def detect_up_axis(vertices: np.ndarray, faces: np.ndarray, convex: bool, *, cross: np.ndarray | None = None) -> UpGuess:
    """Read the face-up side of a closed, outward-wound mesh from its shape (module docstring).

    Coordinates in any unit, in the file's frame. Returns an :class:`UpGuess`; its axis is
    None when the shape does not say (a box, a sphere) or says it ambiguously. ``cross``: the
    faces' (F, 3) cross products (b - a) x (c - a) when the caller has them (load_mesh's validation
    keeps them: :func:`labcut.geometry.meshio._face_measures`); they are overwritten with the unit
    normals.
    """

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if cross is None or cross.shape != (len(f), 3):
        a = v[f[:, 0]]
        cross = cross_rows(v[f[:, 1]] - a, v[f[:, 2]] - a)
        del a
    norm = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    ok = norm > 0
    if not ok.all():
        f, cross, norm = f[ok], cross[ok], norm[ok]
    cross /= norm[:, None]
    normals = cross
    areas = 0.5 * norm
    sides = _side_fractions(v, f, normals, areas)

    # 1. a flat base on exactly one side
    bases = [d for d, (top, bottom) in sides.items() if bottom >= BASE_FRACTION and top < TOP_FLAT_LIMIT]
    if len(bases) == 1:
        d = bases[0]
        return UpGuess(d, f"a flat base facing {_opposite(d)}")
    if len(bases) > 1:
        return UpGuess(None, f"flat bases on several sides ({', '.join(_opposite(d) for d in bases)})")
    if not convex:
        return UpGuess(None, "no flat base, and a carving's face-up side is not read from its shape")
    # 2. a table over a keel or culet
    sides = _side_fractions(v, f, normals, areas, PLANAR_COS, PLANAR_TOL)
    tables = [d for d, (top, bottom) in sides.items() if top >= TABLE_FRACTION and bottom <= KEEL_LIMIT]
    if len(tables) == 1:
        d = tables[0]
        return UpGuess(d, f"a flat table facing {d} over a keel or culet")
    if len(tables) > 1:
        return UpGuess(None, "flat faces on several sides")
    # 3. a dome: the thinnest axis, the side away from the bulk

    ext = extent(v)
    order = np.argsort(ext)
    if ext[order[0]] > DOME_THINNESS * ext[order[1]]:
        return UpGuess(None, "no flat base and no clearly thinnest axis")
    k = int(order[0])
    if max(sides[f"+{'XYZ'[k]}"]) > KEEL_LIMIT:
        return UpGuess(None, f"flat faces on both sides along {'XYZ'[k]} (a slab)")
    centroid = _volume_centroid(v, f)
    mid = 0.5 * (v[:, k].min() + v[:, k].max())
    offset = (centroid[k] - mid) / ext[k]
    if abs(offset) < DOME_OFFSET:
        return UpGuess(None, f"two domes of about the same height along {'XYZ'[k]}")
    d = ("-" if offset > 0 else "+") + "XYZ"[k]
    return UpGuess(d, f"a dome rising towards {d} (its bulk sits towards {_opposite(d)})")


def _opposite(axis: str) -> str:
    return ("-" if axis[0] == "+" else "+") + axis[1]


def _volume_centroid(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    vol = det.sum()
    if abs(vol) < 1e-300:
        return v.mean(axis=0)
    return (det[:, None] * (a + b + c)).sum(axis=0) / (4.0 * vol)


def describe_up(axis: str) -> str:
    """A file's orientation in words: ``"+Y"`` -> ``"Y-up"``, ``"-Z"`` -> ``"upside down (dome-down: face-up is -Z)"``."""
    if axis == "-Z":
        return "upside down (dome-down: face-up is -Z)"
    return f"{axis[1]}-up" if axis[0] == "+" else f"{axis[1]}-down (face-up is {axis})"
