"""Other stone shapes built with manifold3d: slab, cube, sphere, step cut, CSG carvings.

All builders return a watertight, outward-wound :class:`trimesh.Trimesh` in mm in
the labcut frame (DESIGN.md §3: +Z face-up; the lowest point on z = 0, centred on
the Z axis) with ``mesh.metadata["labcut"]`` holding ``kind`` and ``convex``.
They are used by ``examples/make_meshes.py`` to make the bundled ``meshes/``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError
from .outlines import check_size
from .solid import is_convex_mesh


def to_trimesh(man: Any, kind: str, **meta: Any):
    """A certified manifold3d solid as a trimesh, base on z = 0 and centred on the Z axis."""
    import manifold3d as m3
    import trimesh


    if man.status() != m3.Error.NoError or man.is_empty():
        raise ParameterError(f"the {kind} solid is empty or invalid ({man.status().name})")
    out = man.to_mesh64()
    v = np.asarray(out.vert_properties)[:, :3].astype(np.float64)
    f = np.asarray(out.tri_verts).astype(np.int64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    v = v - np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    mesh.metadata["labcut"] = {
        "kind": kind,
        "units": "mm",
        "convex": is_convex_mesh(mesh),
        "watertight": bool(mesh.is_watertight),
        "bodies": int(len(man.decompose())),
        "repairs": [],
        **meta,
    }
    return mesh


def slab(length: float = 20.0, width: float = 20.0, thickness: float = 3.0):
    """A rectangular plate ``length`` x ``width`` x ``thickness`` mm (a polished slab or tile)."""
    import manifold3d as m3

    L, W, T = check_size("length", length), check_size("width", width), check_size("thickness", thickness)
    return to_trimesh(m3.Manifold.cube([L, W, T]), "slab", length_mm=L, width_mm=W, thickness_mm=T)


def cube(size: float = 10.0):
    """A cube of edge ``size`` mm."""
    import manifold3d as m3

    s = check_size("size", size)
    return to_trimesh(m3.Manifold.cube([s, s, s]), "cube", size_mm=s)


def sphere(diameter: float = 10.0, segments: int = 160):
    """A sphere (a polished bead) of ``diameter`` mm with ``segments`` around its equator."""
    import manifold3d as m3

    d = check_size("diameter", diameter)
    if int(segments) < 8:
        raise ParameterError(f"segments must be at least 8, got {segments}")
    return to_trimesh(m3.Manifold.sphere(d / 2, int(segments)), "sphere", diameter_mm=d)


def _octagon(a: float, b: float, c: float) -> np.ndarray:
    """Octagon with edges x = +-a, y = +-b and 45-degree corner cuts of ``c`` (CCW)."""
    c = min(max(c, 0.0), a, b)
    return np.array([[a, -b + c], [a, b - c], [a - c, b], [-a + c, b], [-a, b - c], [-a, -b + c], [-a + c, -b], [a - c, -b]])


def step_cut(
    length: float = 12.0,
    width: float = 10.0,
    corner: float = 0.25,
    girdle: float = 0.3,
    crown_steps: tuple[tuple[float, float], ...] = ((0.14, 38.0), (0.12, 30.0), (0.10, 22.0)),
    pavilion_steps: tuple[tuple[float, float], ...] = ((0.14, 50.0), (0.14, 44.0), (0.16, 40.0)),
):
    """A faceted step (emerald) cut: octagonal outline, stepped crown with a table, stepped pavilion.

    Args:
        length, width: girdle outline in mm (X, Y).
        corner: corner cut as a fraction of the width.
        girdle: girdle thickness in mm.
        crown_steps: ``(inset as a fraction of the width, facet angle in degrees)``
            per crown step, from the girdle up; the last step ends at the table.
        pavilion_steps: the same for the pavilion, from the girdle down; the
            pavilion closes in a keel line along X.

    Each step insets all eight edges by the same amount, so every facet is a
    planar trapezoid; the solid is the convex hull of the facet rings (exact,
    since the rings are convex and the angles steepen towards the girdle).
    """
    import manifold3d as m3

    L, W = check_size("length", length), check_size("width", width)
    if W > L:
        raise ParameterError("a step cut needs length >= width")
    g = float(girdle)
    a, b, c = L / 2, W / 2, corner * W
    shrink_c = 2.0 - math.sqrt(2.0)  # a 45-degree edge's corner cut shrinks by this per unit inset
    rings: list[tuple[np.ndarray, float]] = []
    # pavilion: from the girdle down to the keel
    z = 0.0
    inset = 0.0
    pav = []
    for frac, ang in pavilion_steps:
        d = frac * W
        inset += d
        z -= d * math.tan(math.radians(ang))
        pav.append((inset, z))
    keel_inset = b  # the pavilion closes in a line of length L - W
    last_in, last_z = pav[-1]
    z_keel = last_z - (keel_inset - last_in) * math.tan(math.radians(pavilion_steps[-1][1] + 8.0))
    for d, zz in pav:
        rings.append((_octagon(a - d, b - d, c - shrink_c * d), zz))
    rings.append((np.array([[a - b, 0.0], [-(a - b), 0.0]]), z_keel))
    # girdle
    rings.append((_octagon(a, b, c), 0.0))
    rings.append((_octagon(a, b, c), g))
    # crown: up to the table
    z = g
    inset = 0.0
    for frac, ang in crown_steps:
        d = frac * W
        inset += d
        z += d * math.tan(math.radians(ang))
        rings.append((_octagon(a - inset, b - inset, c - shrink_c * inset), z))
    pts = np.vstack([np.column_stack([r, np.full(len(r), zz)]) for r, zz in rings])
    man = m3.Manifold.hull_points(np.ascontiguousarray(pts))
    return to_trimesh(man, "step-cut", length_mm=L, width_mm=W)


def _ellipsoid(rx: float, ry: float, rz: float, segments: int):
    import manifold3d as m3

    return m3.Manifold.sphere(1.0, segments).scale([rx, ry, rz])


def _box(size: tuple[float, float, float], centre: tuple[float, float, float]):
    import manifold3d as m3

    return m3.Manifold.cube(list(size), center=True).translate(list(centre))


def _rounded_box(size: tuple[float, float, float], radius: float, centre: tuple[float, float, float], segments: int):
    """A box with rounded vertical edges (a wing): hull of four vertical cylinders."""
    import manifold3d as m3

    sx, sy, sz = size
    r = min(radius, sx / 2, sy / 2)
    cyl = m3.Manifold.cylinder(sz, r, r, segments, center=True)
    parts = [cyl.translate([x * (sx / 2 - r), y * (sy / 2 - r), 0.0]) for x in (-1, 1) for y in (-1, 1)]
    return m3.Manifold.batch_hull(parts).translate(list(centre))


def _rod(p0: tuple[float, float, float], p1: tuple[float, float, float], radius: float, segments: int):
    """A cylinder of ``radius`` from ``p0`` to ``p1`` (hull of two thin discs)."""
    import manifold3d as m3

    disc = m3.Manifold.sphere(radius, segments)
    return m3.Manifold.batch_hull([disc.translate(list(p0)), disc.translate(list(p1))])


def biplane(span: float = 30.0, segments: int = 64):
    """A small biplane carving (several CSG parts in one non-convex solid), nose along +X.

    Fuselage (an ellipsoid) with a cockpit cut into it, an upper and a lower wing
    joined by four struts, a tailplane, a fin, a propeller hub with two blades,
    and two wheels on legs; the wheels stand on z = 0. ``span`` (mm) is the wing
    span along Y; everything else scales with it. Like the paper's Fig. 13
    carvings, it has concave regions and parts that hide one another.
    """
    import manifold3d as m3

    k = check_size("span", span) / 30.0
    seg = int(segments)
    if seg < 12:
        raise ParameterError(f"segments must be at least 12, got {segments}")
    s = lambda *v: tuple(k * x for x in v)  # noqa: E731 - scale a coordinate tuple
    z0 = 4.5  # fuselage axis height (unscaled mm)
    fuselage = _ellipsoid(12.0 * k, 2.2 * k, 2.4 * k, seg).translate(list(s(0.0, 0.0, z0)))
    cockpit = _ellipsoid(2.2 * k, 1.5 * k, 1.5 * k, seg).translate(list(s(0.5, 0.0, z0 + 2.5)))
    fuselage = fuselage - cockpit
    lower = _rounded_box(s(5.0, 30.0, 0.7), 1.4 * k, s(2.0, 0.0, z0 - 1.6), seg // 2)
    upper = _rounded_box(s(5.0, 30.0, 0.7), 1.4 * k, s(2.6, 0.0, z0 + 4.4), seg // 2)
    struts = [
        _rod(s(x, y, z0 - 1.6), s(x + 0.6, y, z0 + 4.4), 0.35 * k, 12)
        for x in (0.8, 3.2)
        for y in (-9.0, 9.0)
    ]
    cabane = [_rod(s(2.0, y, z0 + 1.5), s(2.6, y, z0 + 4.4), 0.3 * k, 12) for y in (-1.2, 1.2)]
    tailplane = _rounded_box(s(3.0, 10.0, 0.5), 1.0 * k, s(-10.6, 0.0, z0 + 0.3), seg // 2)
    fin = _rounded_box(s(3.2, 0.5, 3.6), 0.2 * k, s(-10.8, 0.0, z0 + 2.0), 8)
    hub = m3.Manifold.cylinder(2.0 * k, 0.9 * k, 0.5 * k, seg // 2).rotate([0.0, 90.0, 0.0]).translate(list(s(11.6, 0.0, z0)))
    blade = _rounded_box(s(0.5, 0.9, 9.0), 0.2 * k, s(13.0, 0.0, z0), 8).rotate([20.0, 0.0, 0.0])
    # rotate() turns about the origin: move the blade back onto the hub axis
    bc = np.asarray(blade.bounding_box()).reshape(2, 3).mean(axis=0)
    blade = blade.translate([0.0, -bc[1], k * z0 - bc[2]])
    wheels = [
        m3.Manifold.cylinder(0.8 * k, 1.3 * k, 1.3 * k, seg // 2, center=True)
        .rotate([90.0, 0.0, 0.0])
        .translate(list(s(3.5, y, 1.3)))
        for y in (-2.6, 2.6)
    ]
    axle = _rod(s(3.5, -2.6, 1.3), s(3.5, 2.6, 1.3), 0.3 * k, 12)
    legs = [_rod(s(3.5, y, 1.3), s(2.0, 0.6 * y, z0 - 1.6), 0.3 * k, 12) for y in (-2.6, 2.6)]
    parts = [fuselage, lower, upper, *struts, *cabane, tailplane, fin, hub, blade, *wheels, axle, *legs]
    plane = m3.Manifold.batch_boolean(parts, m3.OpType.Add)
    if len(plane.decompose()) != 1:  # pragma: no cover - the parts are built to overlap
        raise ParameterError("the biplane parts do not form one solid")
    return to_trimesh(plane, "carving-biplane", span_mm=float(span))
