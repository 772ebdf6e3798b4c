"""Measures of a closed triangle mesh's vertex and face arrays: volumes, convexity (kept between
processes with ``keep``: :func:`is_convex_mesh`), extents, face cross products, the arrays' digest, labcut's
placement on its base.

Plain numpy (and manifold3d's or Qhull's hulls) on (N, 3) float64 vertices in mm and (F, 3)
integer faces, mesh frame. The loaders (:mod:`labcut.geometry.meshio`, :mod:`labcut.geometry.gemcad`,
the cabochon and carving builders) and a :class:`~labcut.geometry.stone.Stone` share them; this
module imports no other of labcut's geometry modules.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: a stone's largest size must lie in this range (mm) once converted: outside it, the units are wrong
STONE_SIZE_MM = (0.5, 500.0)

#: relative volume gap between a mesh and its convex hull below which it is convex
CONVEX_RTOL = 1e-6


def is_convex_mesh(mesh: Any, rtol: float = CONVEX_RTOL, *, volume: float | None = None, keep: bool = False) -> bool:
    """True when a closed mesh is convex: its volume equals that of its convex hull.

    The hull volume is the smaller of manifold3d's and Qhull's (scipy): a hull can only be
    overestimated by a hull program that mishandles many coplanar or collinear points (the
    densified edges of a polygonal outline made manifold3d's QuickHull 0.03 % too large),
    so the flag no longer depends on float32 rounding in a saved file. A mesh of several
    bodies is never convex. ``volume``: the mesh's signed volume, when the caller has it.
    ``keep``: the whole hulls' verdict of a stone of at least :data:`KEPT_CONVEXITY_VERTICES`
    vertices is kept between processes (:func:`_kept_verdict`; the loaders' choice).
    """
    v, vol = _hull_inputs(mesh, volume)
    if v is None or _probed_concave(v, vol, rtol):
        return False
    if keep and len(v) >= KEPT_CONVEXITY_VERTICES:
        return _kept_verdict(mesh, v, vol, rtol)
    return _convex_by_hulls(v, vol, rtol)


def _hull_inputs(mesh: Any, volume: float | None) -> tuple[np.ndarray | None, float]:
    """The mesh's vertices (float64, contiguous) and |volume|; ``(None, 0)`` where no hull can say
    (fewer than four vertices, a non-finite one): not convex."""
    v = np.ascontiguousarray(np.asarray(mesh.vertices, dtype=np.float64))
    if len(v) < 4 or not np.all(np.isfinite(v)):
        return None, 0.0
    return v, abs(signed_volume(v, np.asarray(mesh.faces)) if volume is None else float(volume))


def _probed_concave(v: np.ndarray, vol: float, rtol: float) -> bool:
    """Whether the hull of a subset of the vertices (over :data:`CONVEX_PROBE_VERTICES` of them)
    already proves the stone concave: it lies inside the whole hull, so a volume gap to it is the
    answer the whole hull gives, without its seconds."""
    if len(v) <= CONVEX_PROBE_VERTICES:
        return False
    sub = hull_volume(v[:: max(1, len(v) // CONVEX_PROBE_VERTICES)])
    return sub > 0 and (sub - vol) > rtol * sub


def _convex_by_hulls(v: np.ndarray, vol: float, rtol: float) -> bool:
    """The whole hulls' verdict (:func:`is_convex_mesh`). The smaller hull volume is the truer one,
    and a smaller hull can only make a stone more convex (|V| >= (1 - rtol) hull): where
    manifold3d's hull already proves it convex, Qhull's cannot change the answer and is not computed."""
    import manifold3d as m3

    manifold_hull = float(m3.Manifold.hull_points(v).volume())
    if manifold_hull > 0 and (manifold_hull - vol) <= rtol * manifold_hull:
        return True
    volumes = [manifold_hull]
    try:
        from scipy.spatial import ConvexHull

        volumes.append(float(ConvexHull(v).volume))
    except Exception:  # noqa: BLE001 - Qhull refuses flat input: manifold3d's value stands
        pass
    hv = min(x for x in volumes if x > 0) if any(x > 0 for x in volumes) else 0.0
    if hv <= 0:
        return False
    return (hv - vol) <= rtol * hv


def mesh_digest(mesh: Any) -> str:
    """A hash of a mesh's vertices (float64) and faces (int64) with their counts: the key under which
    what is derived from its geometry is kept between processes (labcut's user cache). A stone's is
    kept by it (:attr:`labcut.geometry.stone.Stone.digest`)."""
    import hashlib

    h = hashlib.blake2b(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes(), digest_size=16)
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return f"{len(mesh.vertices)} vertices {len(mesh.faces)} faces {h.hexdigest()}"


#: vertices from which :func:`is_convex_mesh` with ``keep`` keeps a stone's convexity in labcut's user
#: cache (below, the hull takes about a millisecond and is computed each time)
KEPT_CONVEXITY_VERTICES = 2000


def _kept_verdict(mesh: Any, v: np.ndarray, vol: float, rtol: float) -> bool:
    """:func:`_convex_by_hulls`, kept in labcut's user cache (``convexity.json``,
    :func:`labcut.fileio.calibrations`): a new process that loads the same file reads the flag back
    instead of computing two convex hulls again (a few hundredths of a second for the bundled
    stones, seconds for a scan of millions of triangles). Asked only once the subset's hull has
    not proved the stone concave, so a concave scan is answered without hashing its arrays. The key
    holds everything that shapes the flag: :func:`mesh_digest`, ``rtol``, labcut's and SciPy's
    versions, manifold3d's installed file, and a hash of this module's code; a damaged entry is
    computed again with one warning."""
    import os

    import manifold3d as m3
    import scipy

    from .. import __version__
    from ..fileio import calibrations, code_hash

    m3_file = os.stat(m3.__file__)
    key = (f"convex | labcut {__version__} scipy {scipy.__version__} manifold3d {m3_file.st_size}:{m3_file.st_mtime_ns} "
           f"| code {code_hash(__file__)} | rtol {rtol!r} | {mesh_digest(mesh)}")
    value = calibrations("convexity.json", [key], lambda missing: [{"convex": _convex_by_hulls(v, vol, rtol)}],
                         check=_check_convex)[0]
    return value["convex"]


def _check_convex(value: dict[str, Any]) -> None:
    """Refuse a kept flag that is not a boolean (a damaged or foreign file: computed again)."""
    if not isinstance(value["convex"], bool):
        raise ValueError(f"not a convexity flag: {value['convex']!r}")


def hull_volume(v: np.ndarray) -> float:
    """Volume of the convex hull of points (Qhull; manifold3d's where Qhull refuses them)."""
    try:
        from scipy.spatial import ConvexHull

        return float(ConvexHull(v).volume)
    except Exception:  # noqa: BLE001 - flat or too few points
        import manifold3d as m3

        return float(m3.Manifold.hull_points(np.ascontiguousarray(v)).volume())


#: vertices above which :func:`is_convex_mesh` first tries the hull of a subset
CONVEX_PROBE_VERTICES = 50_000
#: faces per chunk of the per-face sums (bounded temporaries on meshes of millions of triangles)
CHUNK = 1 << 20


def face_dets(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """a·(b x c) of every face's corners, in chunks (three gathers, no (F, 3, 3) copy)."""
    out = np.empty(len(f))
    for s in range(0, len(f), CHUNK):
        ff = f[s : s + CHUNK]
        a, b, c = v[ff[:, 0]], v[ff[:, 1]], v[ff[:, 2]]
        out[s : s + len(ff)] = (a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1])
                                + a[:, 1] * (b[:, 2] * c[:, 0] - b[:, 0] * c[:, 2])
                                + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]))
    return out


def signed_volume(v: np.ndarray, f: np.ndarray, labels: np.ndarray | None = None, count: int = 1,
                   dets: np.ndarray | None = None) -> Any:
    """Signed volume of the faces (per component when ``labels`` is given); ``dets``: the faces'
    :func:`face_dets`, when the caller has them."""
    det = (face_dets(v, f) if dets is None else dets) / 6.0
    if labels is None:
        return float(det.sum())
    return np.bincount(labels, weights=det, minlength=count)


def cross_rows(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``np.cross`` of (N, 3) rows, as its own products and differences (the same values), without
    its generic machinery (several times faster on millions of rows)."""
    out = np.empty_like(x)
    np.multiply(x[:, 1], y[:, 2], out=out[:, 0])
    out[:, 0] -= x[:, 2] * y[:, 1]
    np.multiply(x[:, 2], y[:, 0], out=out[:, 1])
    out[:, 1] -= x[:, 0] * y[:, 2]
    np.multiply(x[:, 0], y[:, 1], out=out[:, 2])
    out[:, 2] -= x[:, 1] * y[:, 0]
    return out


def double_areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """|(b - a) x (c - a)| of every face (twice its area), in chunks."""
    out = np.empty(len(f))
    for s in range(0, len(f), CHUNK):
        ff = f[s : s + CHUNK]
        a = v[ff[:, 0]]
        out[s : s + len(ff)] = np.linalg.norm(cross_rows(v[ff[:, 1]] - a, v[ff[:, 2]] - a), axis=1)
    return out


def extent(v: np.ndarray) -> np.ndarray:
    """``np.ptp(v, axis=0)`` of (N, 3) points (the same values): a column at a time, not numpy's
    axis-0 reduction over rows of three (twenty times slower on millions of vertices)."""
    lo, hi = column_bounds(v)
    return hi - lo


def column_bounds(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(v.min(axis=0), v.max(axis=0))`` of (N, 3) points (the same values), a column at a time."""
    v = np.asarray(v)
    lo = np.array([v[:, k].min() for k in range(v.shape[1])])
    hi = np.array([v[:, k].max() for k in range(v.shape[1])])
    return lo, hi


def centre_on_base(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """labcut's placement (DESIGN.md §3): the bounding box centred in XY, the lowest point on
    z = 0. Returns the moved vertices (mm) and the shift that was added."""
    lo, hi = column_bounds(vertices)
    shift = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    return vertices + shift, shift
