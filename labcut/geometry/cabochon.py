"""Watertight cabochon solids (DESIGN.md §3 frame: mm, +Z face-up, base on z = 0).

:func:`cabochon` builds the stone as a stack of rings: every ring is the outline
scaled towards its centre (by ``s`` from a :class:`~labcut.geometry.profiles.Profile`)
and lifted to a height ``z``. Consecutive rings are joined by planar trapezoids
(each split into two triangles) and the top and bottom close in a single apex
vertex, so the surface is a closed, consistently wound 2-manifold by construction;
it then goes through :class:`manifold3d.Manifold`, which certifies it (and would
refuse anything that is not an oriented 2-manifold) before it becomes a
:class:`trimesh.Trimesh`.

From the bottom up a stone is: the base (a flat face on z = 0, or for a double
cabochon a lower dome whose apex touches z = 0), an optional vertical girdle band,
and the crown dome (optionally a buff-top with a flat table).

Dome heights ``"low"``, ``"medium"`` and ``"high"`` are fractions of the stone's
width (the smaller of length and width), see :data:`DOME_RATIOS`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..validation import check_number
from . import outlines as _ol
from .profiles import MAX_TABLE, PROFILES, Profile, dome_limit
from .solid import is_convex_mesh

#: Dome height as a fraction of the stone's width (its smaller horizontal size).
#:
#: Trade practice describes domes loosely as low, medium (standard) and high:
#: calibrated commercial cabochons are usually cut with a dome of about a third of
#: the width ("standard" or medium), low domes at about a fifth (the usual choice
#: for labradorite, jasper and other stones shown for a flat, even flash or
#: pattern, and for thin rough) and high or "bullet" domes at about half the width
#: (a hemisphere over a round stone, used for chatoyant stones whose eye needs
#: a strong curvature). 0.20 / 0.33 / 0.50 follow that practice; "high" is the
#: largest dome a spherical profile allows (a hemisphere).
DOME_RATIOS: dict[str, float] = {"low": 0.20, "medium": 0.33, "high": 0.50}

#: points around the outline at resolution="default": a 16 x 12 mm oval with a
#: low dome gives about 22k triangles, smooth under per-vertex shading.
DEFAULT_RESOLUTION = 256
MIN_RESOLUTION, MAX_RESOLUTION = 16, 4096


def _finite_positive(name: str, value: Any, allow_zero: bool = False) -> float:
    """A length in mm: finite, > 0 (>= 0 with ``allow_zero``)."""
    return check_number(value, name, 0.0, low_open=not allow_zero, unit="mm")


def _resolution(resolution: int | str) -> int:
    if isinstance(resolution, str):
        if resolution == "default":
            return DEFAULT_RESOLUTION
        try:
            resolution = int(resolution)
        except ValueError:
            raise ParameterError(f"resolution must be an integer or 'default', got {resolution!r}", parameter="resolution") from None
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)):
        raise ParameterError(f"resolution must be an integer or 'default', got {resolution!r}", parameter="resolution")
    if not MIN_RESOLUTION <= int(resolution) <= MAX_RESOLUTION:
        raise ParameterError(f"resolution must be between {MIN_RESOLUTION} and {MAX_RESOLUTION}, got {resolution}", parameter="resolution")
    return int(resolution)


def _dome_height(name: str, dome: Any, width: float, kind: str, table: float = 0.0) -> float:
    a = width / 2.0
    if isinstance(dome, str):
        key = dome.lower()
        if key not in DOME_RATIOS:
            try:
                dome = float(dome)
            except ValueError:
                raise ParameterError(f"{name} must be low, medium, high or a height in mm, got {dome!r}") from None
        else:
            h = DOME_RATIOS[key] * width
            if kind == "spherical":
                h = min(h, dome_limit(kind, a, table))
            return h
    h = _finite_positive(name, dome)
    limit = dome_limit(kind, a, table)
    if h > limit * (1 + 1e-9):
        why = (
            "a hemisphere" if kind == "spherical" else "the stone's width"
        )
        raise ParameterError(
            f"{name} {h:g} mm is higher than allowed for {_article(kind)} {kind} profile on this stone "
            f"({limit:.4g} mm: {why}{' with this buff-top table' if table else ''})"
        )
    return min(h, limit)


def _article(word: str) -> str:
    """``"an"`` before a vowel sound (an oval), else ``"a"`` (a pear)."""
    return "an" if word[:1].lower() in "aeiou" else "a"


def _outline_points(outline: Any, length: Any, width: Any, corner_radius: Any, n: int) -> tuple[np.ndarray, str]:
    """The outline polygon (CCW, centred on its bounding box) and its label."""
    if isinstance(outline, str):
        name = outline.lower()
        if name == "navette":
            name = "marquise"
        if name not in _ol.OUTLINES:
            raise ParameterError(
                f"unknown outline {outline!r}; use one of {', '.join(_ol.OUTLINES)} or an (N, 2) array of points in mm"
            )
        if length is None and name == "round" and width is not None:
            length = width
        if length is None:
            raise ParameterError(f"{_article(name)} {name} cabochon needs its length in mm")
        if width is None:
            if name != "round":
                raise ParameterError(f"{_article(name)} {name} cabochon needs its width in mm")
            width = length
        if corner_radius is not None and name != "rectangle":
            raise ParameterError("corner_radius applies only to the rectangle outline")
        pts = _ol.make_outline(name, length, width, n=n, corner_radius=corner_radius)
        if len(pts) < n // 2:  # sharp rectangle: 8 corner/mid points
            pts = _ol.densify(pts, n)
        L, W = float(length), float(width)
        # make the bounding box exact (resampling keeps the extremes; this removes rounding)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pts = (pts - (lo + hi) / 2) * np.array([L / (hi[0] - lo[0]), W / (hi[1] - lo[1])])
        return pts, name
    pts = _ol.validate_outline(outline)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if corner_radius is not None:
        raise ParameterError("corner_radius applies only to the rectangle outline")
    sx = sy = 1.0
    if length is not None:
        sx = _finite_positive("length", length) / (hi[0] - lo[0])
    if width is not None:
        sy = _finite_positive("width", width) / (hi[1] - lo[1])
    if length is not None and width is None:
        sy = sx
    if width is not None and length is None:
        sx = sy
    pts = (pts - (lo + hi) / 2) * np.array([sx, sy])
    if len(pts) < n:
        pts = _ol.densify(pts, n)
    elif len(pts) > n:
        # a traced outline with many points: resample to the resolution, keeping
        # corners (turns over 15 degrees) and the extreme points as vertices
        d_in = pts - np.roll(pts, 1, axis=0)
        d_out = np.roll(pts, -1, axis=0) - pts
        turn = np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0], np.einsum("ij,ij->i", d_in, d_out)))
        keys = set(np.flatnonzero(turn > np.radians(15.0)).tolist())
        keys |= {int(np.argmin(pts[:, 0])), int(np.argmax(pts[:, 0])), int(np.argmin(pts[:, 1])), int(np.argmax(pts[:, 1]))}
        if len(keys) < n:
            fewer = _ol.resample(pts, sorted(keys), n)
            if _ol.segments_intersect(fewer) is None and _ol.star_centre(fewer) is not None:
                pts = fewer
    return pts, "custom"


def _grid_mesh(outline: np.ndarray, centre: np.ndarray, rings: list[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a closed stack of scaled-outline rings.

    ``rings`` goes from bottom to top as ``(s, z)``; the first and last must have
    ``s = 0`` (single apex vertices). Faces are wound outward for a CCW outline.
    """
    n = len(outline)
    verts: list[np.ndarray] = []
    starts: list[int] = []
    count = 0
    for s, z in rings:
        starts.append(count)
        if s == 0.0:
            verts.append(np.array([[centre[0], centre[1], z]]))
            count += 1
        else:
            xy = centre + s * (outline - centre)
            verts.append(np.column_stack([xy, np.full(n, z)]))
            count += n
    faces: list[np.ndarray] = []
    j = np.arange(n)
    jn = (j + 1) % n
    for k in range(len(rings) - 1):
        (s0, _), (s1, _) = rings[k], rings[k + 1]
        a0, a1 = starts[k], starts[k + 1]
        if s0 == 0.0 and s1 == 0.0:
            raise AssertionError("two consecutive apex rings")
        if s0 == 0.0:  # bottom apex fan, normals down
            faces.append(np.column_stack([np.full(n, a0), a1 + jn, a1 + j]))
        elif s1 == 0.0:  # top apex fan, normals up
            faces.append(np.column_stack([a0 + j, a0 + jn, np.full(n, a1)]))
        else:
            faces.append(np.column_stack([a0 + j, a0 + jn, a1 + jn]))
            faces.append(np.column_stack([a0 + j, a1 + jn, a1 + j]))
    return np.vstack(verts), np.vstack(faces)


def cabochon(
    outline: str | np.ndarray = "oval",
    length: float | None = None,
    width: float | None = None,
    dome: str | float = "medium",
    profile: str = "elliptic",
    girdle: float = 0.0,
    base: str | float = "flat",
    buff_top: bool | float = False,
    corner_radius: float | None = None,
    resolution: int | str = "default",
):
    """Build a watertight cabochon as a :class:`trimesh.Trimesh` (mm, +Z face-up, base on z = 0).

    Args:
        outline: ``"round"``, ``"oval"``, ``"cushion"``, ``"pear"``,
            ``"marquise"`` (or ``"navette"``), ``"rectangle"``, or an ``(K, 2)``
            array of x, y points in mm (a closed, simple polygon that is
            star-shaped about some point; either winding). Polygons with fewer
            than ``resolution`` points get extra points along their edges,
            longer ones are resampled to ``resolution`` points keeping corners.
        length: size along X in mm (for ``"round"``, the diameter). With a user
            outline, optional: the outline is scaled to this length.
        width: size along Y in mm (``"round"``: may be omitted or equal to length).
        dome: crown height above the girdle, ``"low"``, ``"medium"``, ``"high"``
            (:data:`DOME_RATIOS` times the smaller of length and width) or mm.
        profile: ``"elliptic"``, ``"spherical"`` or ``"tallow"`` (see
            :mod:`labcut.geometry.profiles`).
        girdle: height in mm of a vertical band between base and crown (0: none).
        base: ``"flat"`` or, for a double cabochon, the height in mm of a lower
            dome (same profile as the crown, usually lower; may also be
            ``"low"``/``"medium"``/``"high"``).
        buff_top: ``False`` or the linear fraction (0, 0.95] of the outline
            covered by a flat table on top of the crown (``True``: 0.5). The
            total dome height stays ``dome``.
        corner_radius: corner radius in mm of the ``"rectangle"`` outline
            (default 15 % of its smaller side).
        resolution: points around the outline (16..4096) or ``"default"``
            (:data:`DEFAULT_RESOLUTION`); the crown gets ``resolution / 6`` rings.

    Returns:
        A watertight, outward-wound ``trimesh.Trimesh``. ``mesh.metadata["labcut"]``
        holds the parameters, the nominal (analytic) volume in mm^3 and
        ``convex``.

    Raises:
        ParameterError: a size is not positive and finite, a dome is higher
            than the profile allows, a user outline is self-intersecting or not
            star-shaped, or an option is unknown.

    Examples:
        >>> import labcut
        >>> cab = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
        >>> cab.is_watertight, [round(float(x), 1) for x in cab.extents], cab.metadata["labcut"]["convex"]
        (True, [16.0, 12.0, 2.4], True)
        >>> labcut.cabochon(outline="oval", length=-1, width=12)
        Traceback (most recent call last):
        ...
        labcut.errors.ParameterError: length must lie in [0.1, 1000] mm (a stone's size), got -1
    """
    import manifold3d as m3
    import trimesh


    n = _resolution(resolution)
    if not isinstance(profile, str) or profile.lower() not in PROFILES:
        raise ParameterError(f"unknown profile {profile!r}; use one of {', '.join(PROFILES)}")
    profile = profile.lower()
    pts, label = _outline_points(outline, length, width, corner_radius, n)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    L, W = float(hi[0] - lo[0]), float(hi[1] - lo[1])
    ref_half = min(L, W) / 2.0

    centre = _ol.star_centre(pts)
    if centre is None:
        raise ParameterError(
            "the outline is not star-shaped (no point inside sees its whole boundary), so it cannot be domed"
        )

    if buff_top is None or buff_top is False or (not isinstance(buff_top, bool) and buff_top == 0):
        table = 0.0
    elif buff_top is True:
        table = 0.5
    else:
        try:
            table = float(buff_top)
        except (TypeError, ValueError):
            raise ParameterError(f"buff_top must be False or a table fraction in (0, {MAX_TABLE}], got {buff_top!r}") from None
        if not (math.isfinite(table) and 0.0 < table <= MAX_TABLE):
            raise ParameterError(f"buff_top must be False or a table fraction in (0, {MAX_TABLE}], got {buff_top!r}")

    H = _dome_height("dome", dome, min(L, W), profile, table)
    crown = Profile(profile, H, ref_half, table)
    g = _finite_positive("girdle", girdle, allow_zero=True)
    if g > max(L, W):
        raise ParameterError(f"girdle {g:g} mm is taller than the stone is long ({max(L, W):g} mm)")
    if isinstance(base, str) and base.lower() == "flat":
        base_profile = None
    else:
        hb = _dome_height("base", base, min(L, W), profile)
        base_profile = Profile(profile, hb, ref_half, 0.0)

    ring_count = max(8, round(n / 6))
    perimeter = float(np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1).sum())
    spacing = perimeter / len(pts)

    rings: list[tuple[float, float]] = []
    z0 = 0.0
    if base_profile is None:
        rings.append((0.0, 0.0))
        rings.append((1.0, 0.0))
    else:
        bs, bz = base_profile.rings(ring_count)
        hb = base_profile.height
        for s, z in zip(bs[::-1], bz[::-1]):
            rings.append((float(s), float(hb - z)))
        rings[0] = (0.0, 0.0)
        rings[-1] = (1.0, hb)
        z0 = hb
    if g > 0:
        bands = int(min(64, max(1, math.ceil(g / spacing))))
        for i in range(1, bands + 1):
            rings.append((1.0, z0 + g * i / bands))
        z0 += g
    cs, cz = crown.rings(ring_count)
    for s, z in zip(cs[1:], cz[1:]):
        rings.append((float(s), float(z0 + z)))
    rings[-1] = (0.0, z0 + H)

    V, F = _grid_mesh(pts, centre, rings)
    man = m3.Manifold(m3.Mesh64(vert_properties=np.ascontiguousarray(V, dtype=np.float64),
                                tri_verts=np.ascontiguousarray(F, dtype=np.uint64)))
    status = man.status()
    if status != m3.Error.NoError or man.is_empty():  # pragma: no cover - construction guarantees a manifold
        raise ParameterError(f"these parameters give an invalid solid ({status}); try a higher resolution")
    if man.volume() < 0:  # pragma: no cover
        raise ParameterError("internal winding error")
    out = man.to_mesh64()
    mesh = trimesh.Trimesh(
        vertices=np.asarray(out.vert_properties)[:, :3].astype(np.float64),
        faces=np.asarray(out.tri_verts).astype(np.int64),
        process=False,
    )
    area = _ol.polygon_area(pts)
    nominal = area * (g + crown.volume_factor() + (base_profile.volume_factor() if base_profile else 0.0))
    mesh.metadata["labcut"] = {
        "kind": "cabochon",
        "units": "mm",
        "outline": label,
        "length_mm": L,
        "width_mm": W,
        "dome_mm": H,
        "profile": profile,
        "girdle_mm": g,
        "base": "flat" if base_profile is None else "domed",
        "base_dome_mm": 0.0 if base_profile is None else base_profile.height,
        "buff_top": table,
        "resolution": n,
        "height_mm": float(rings[-1][1]),
        "outline_area_mm2": area,
        "nominal_volume_mm3": nominal,
        "convex": is_convex_mesh(mesh),
        "watertight": True,
        "repairs": [],
    }
    return mesh
