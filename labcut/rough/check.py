"""Checks of a plan against the rough itself, with manifold3d: every stone inside, the stones
apart, the margin kept. A convex rough's plans hold by construction (exact half-spaces); these
checks are what a non-convex rough's plans rest on, and what every returned plan passes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: a stone may leave the rough by at most this share of its own volume (numerical slack)
OUTSIDE_LIMIT = 1e-3


def solid(mesh: Any) -> Any:
    """The manifold3d solid of a watertight trimesh (mm)."""
    import manifold3d

    m = manifold3d.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                        tri_verts=np.asarray(mesh.faces, dtype=np.uint32))
    return manifold3d.Manifold(m)


def outside_share(rough: Any, stone: Any, rough_solid: Any = None) -> float:
    """Volume of ``stone`` outside ``rough``, as a share of the stone's volume (manifold3d;
    ``rough_solid``: the rough's solid already made)."""
    s = solid(stone)
    vol = s.volume()
    if vol <= 0:
        return 1.0
    return float((s - (solid(rough) if rough_solid is None else rough_solid)).volume() / vol)


def overlap_mm3(a: Any, b: Any) -> float:
    """Volume (mm³) two stones share (manifold3d)."""
    return float((solid(a) ^ solid(b)).volume())


def triangle_distances(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distance (mm) from each point ``p[i]`` to the triangle ``(a[i], b[i], c[i])`` (rows;
    Ericson, Real-Time Collision Detection §5.1.5: the closest point by Voronoi region)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v_in, w_in = vb / denom, vc / denom
        closest = a + ab * v_in[:, None] + ac * w_in[:, None]  # inside the face
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    closest = np.where(((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0))[:, None], b + (c - b) * t_bc[:, None], closest)
    closest = np.where(((vb <= 0) & (d2 >= 0) & (d6 <= 0))[:, None], a + ac * t_ac[:, None], closest)
    closest = np.where(((vc <= 0) & (d1 >= 0) & (d3 <= 0))[:, None], a + ab * t_ab[:, None], closest)
    closest = np.where(((d6 >= 0) & (d5 <= d6))[:, None], c, closest)
    closest = np.where(((d3 >= 0) & (d4 <= d3))[:, None], b, closest)
    closest = np.where(((d1 <= 0) & (d2 <= 0))[:, None], a, closest)
    return np.linalg.norm(p - closest, axis=1)


#: triangles near a point (by their centroids) whose exact distance :func:`surface_distance` takes
NEAR_TRIANGLES = 24


def surface_distance(mesh: Any, points: np.ndarray, tree: Any = None) -> np.ndarray:
    """Distance (mm) from each point to the surface of ``mesh``: exact point-triangle distances
    to the :data:`NEAR_TRIANGLES` triangles whose centroids lie nearest (all of them for a small
    mesh), so a well-tessellated surface's nearest triangle is among them. ``tree``: the
    centroids' ``cKDTree`` already made."""
    from scipy.spatial import cKDTree

    tri = np.asarray(mesh.triangles, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64)
    k = min(NEAR_TRIANGLES, len(tri))
    _, idx = (cKDTree(tri.mean(axis=1)) if tree is None else tree).query(pts, k=k)
    idx = np.asarray(idx).reshape(len(pts), k)
    rep = np.repeat(pts, k, axis=0)
    t = tri[idx.ravel()]
    return triangle_distances(rep, t[:, 0], t[:, 1], t[:, 2]).reshape(len(pts), k).min(axis=1)


def inside(mesh: Any, points: np.ndarray, chunk: int = 2_000_000) -> np.ndarray:
    """Whether each point lies inside the closed ``mesh``: its generalised winding number (the
    solid angles of the triangles seen from the point, van Oosterom and Strackee) is near 1."""
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    total = np.zeros(len(pts))
    step = max(1, chunk // max(1, len(tri)))
    for k in range(0, len(pts), step):
        r = tri[None, :, :, :] - pts[k : k + step, None, None, :]  # (p, f, 3 corners, 3)
        n = np.linalg.norm(r, axis=3)
        a, b, c = r[..., 0, :], r[..., 1, :], r[..., 2, :]
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (n[..., 0] * n[..., 1] * n[..., 2] + np.einsum("pfi,pfi->pf", a, b) * n[..., 2]
               + np.einsum("pfi,pfi->pf", a, c) * n[..., 1] + np.einsum("pfi,pfi->pf", b, c) * n[..., 0])
        total[k : k + step] = 2.0 * np.arctan2(det, den).sum(axis=1)
    return total / (4.0 * np.pi) > 0.5


def clearance_mm(rough: Any, stone: Any, samples: int = 2000, tree: Any = None) -> float:
    """The least distance (mm) from the stone's surface to the rough's, over the stone's vertices
    and ``samples`` points of its surface: the margin kept (for a stone inside the rough)."""
    from ..geometry.surface import sample_surface

    pts = np.asarray(stone.vertices, dtype=np.float64)
    if samples:
        extra, _ = sample_surface(stone, samples, seed=0)
        pts = np.vstack([pts, extra])
    return float(np.min(surface_distance(rough, pts, tree)))


class Checker:
    """The checks of stones against one rough, its manifold3d solid and its triangles' tree made
    once (a non-convex rough's plan asks them for every step of every shrink)."""

    def __init__(self, rough: Any) -> None:
        from scipy.spatial import cKDTree

        self.rough = rough
        self.solid = solid(rough)
        self.tree = cKDTree(np.asarray(rough.triangles, dtype=np.float64).mean(axis=1))

    def outside_share(self, stone: Any) -> float:
        return outside_share(self.rough, stone, self.solid)

    def clearance_mm(self, stone: Any, samples: int = 500) -> float:
        return clearance_mm(self.rough, stone, samples, self.tree)

    def distance(self, points: np.ndarray) -> np.ndarray:
        return surface_distance(self.rough, points, self.tree)


def gap_mm(a: Any, b: Any, samples: int = 2000) -> float:
    """The least distance (mm) between the surfaces of two disjoint stones (sampled as :func:`clearance_mm`)."""
    return min(clearance_mm(a, b, samples), clearance_mm(b, a, samples))
