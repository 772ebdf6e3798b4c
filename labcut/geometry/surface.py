"""Geometry queries of a stone's surface: face areas, surface samples, unit and smooth shading
normals, the smooth-shaded split copy.

Frames and units: the mesh frame, mm, +Z face-up (DESIGN.md §3). The renderer and the flash
estimator shade a stone alike: smooth across edges gentler than its shading angle
(:data:`SMOOTH_ANGLE_DEG`, or :data:`FACETED_ANGLE_DEG` for a faceted design), flat across sharper
ones. These functions compute; a :class:`~labcut.geometry.stone.Stone` keeps what they give for
its mesh (each once per stone).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import MeshError, ParameterError
from .solid import cross_rows, mesh_digest

SMOOTH_ANGLE_DEG = 30.0  # edges sharper than this keep flat shading
FACETED_ANGLE_DEG = 0.5  # a faceted design (GemCad) is flat-shaded at every facet junction


def smooth_split(mesh: Any, angle_deg: float, *, cache: bool = True, digest: str | None = None) -> Any:
    """``trimesh.graph.smooth_shade`` of ``mesh`` at ``angle_deg``: a copy split along edges sharper
    than it, whose vertex normals are the smooth shading normals the renderer and the flash
    estimator use. Built once per stone by :meth:`labcut.geometry.stone.Stone.smooth_split`.

    With ``cache`` the copy's vertices, faces and normals are kept in labcut's user cache,
    keyed by the mesh's bytes, the angle and labcut's and trimesh's versions
    (:func:`labcut.fileio.cached_arrays`): the stone's next process reads them back instead of
    splitting again (``digest``: the mesh's :func:`~labcut.geometry.solid.mesh_digest`, when known). Either way the copy is built from those arrays, so a cached and a fresh
    split are the same to the last bit."""
    import trimesh

    def split() -> dict[str, np.ndarray]:
        made = trimesh.graph.smooth_shade(mesh, angle=math.radians(angle_deg))
        parts = [np.asarray(c, dtype=np.int64).ravel() for c in made.metadata.get("original_components", [])]
        return {"vertices": np.asarray(made.vertices, dtype=np.float64), "faces": np.asarray(made.faces, dtype=np.int64),
                "face_normals": np.asarray(made.face_normals, dtype=np.float64),
                "vertex_normals": np.asarray(made.vertex_normals, dtype=np.float64),
                "component_faces": np.concatenate(parts) if parts else np.arange(len(made.faces), dtype=np.int64),
                "component_sizes": np.array([len(c) for c in parts] or [len(made.faces)], dtype=np.int64)}

    if cache:
        from .. import __version__
        from ..fileio import cached_arrays

        key = (f"smooth split v2 | labcut {__version__} trimesh {trimesh.__version__} | angle {float(angle_deg)!r} | "
               f"{digest or mesh_digest(mesh)}")
        arrays = cached_arrays("smooth-split", key, split)
    else:
        arrays = split()
    made = trimesh.Trimesh(vertices=arrays["vertices"], faces=arrays["faces"], face_normals=arrays["face_normals"],
                           vertex_normals=arrays["vertex_normals"], process=False, validate=False)
    # which of the mesh's faces each patch of the copy came from, in the copy's face order (trimesh's own record)
    made.metadata["original_components"] = np.split(arrays["component_faces"], np.cumsum(arrays["component_sizes"])[:-1])
    return made


#: meshes with more triangles than this are shaded for the flash estimator by
#: :func:`smooth_corner_normals` at the sampled faces (a few million triangles' split copy costs
#: seconds to build and gigabytes to hold); smaller ones by the split copy the renderer uses
FAST_SMOOTH_FACES = 200_000


def face_areas(mesh: Any, chunk: int = 1 << 20) -> np.ndarray:
    """Area of every face, as trimesh's ``area_faces`` has it (the same formula, the same values),
    computed in chunks (no (F, 3, 3) copy of the corners kept). Read-only; kept per stone by
    :attr:`labcut.geometry.stone.Stone.face_areas`."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces)
    out = np.empty(len(f))
    for s in range(0, len(f), chunk):
        ff = f[s : s + chunk]
        b = v[ff[:, 1]]
        crosses = cross_rows(b - v[ff[:, 0]], v[ff[:, 2]] - b)  # trimesh.triangles.cross's edges and values
        crosses **= 2
        out[s : s + len(ff)] = np.sqrt(crosses[:, 0] + crosses[:, 1] + crosses[:, 2]) / 2.0
    out.setflags(write=False)
    return out


def sample_surface(mesh: Any, count: int, seed: int, areas: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``trimesh.sample.sample_surface(mesh, count, seed=seed)`` (the same points and faces, from
    the same random stream) without its copies of every face's corners: the areas come from
    :func:`face_areas` (or ``areas``, the mesh's face areas already made) and only the picked
    faces' corners are gathered. ``(points, face_index)``."""
    weight_cum = np.cumsum(face_areas(mesh) if areas is None else areas)
    random = np.random.default_rng(seed).random
    face_index = np.searchsorted(weight_cum, random(count) * weight_cum[-1])
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)[face_index]
    origins = v[f[:, 0]]
    vectors = v[f[:, 1:]].copy()
    vectors -= np.tile(origins, (1, 2)).reshape((-1, 2, 3))
    lengths = random((len(vectors), 2, 1))
    lengths[lengths.sum(axis=1).reshape(-1) > 1.0] -= 1.0
    lengths = np.abs(lengths)
    return (vectors * lengths).sum(axis=1) + origins, face_index


def unit_normals(tri: np.ndarray) -> np.ndarray:
    """(N, 3) unit geometric normals of the triangles ``tri`` ((N, 3, 3) corners, outward by their
    winding; e.g. ``mesh.face_normals[idx]`` from only those faces' corners); a zero-area face
    gets a zero vector."""
    import trimesh

    unit, valid = trimesh.triangles.normals(tri)
    out = np.zeros((len(tri), 3))
    out[valid] = unit
    return out


def corner_incidence(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """``(order, starts)``: the mesh's corners (flat indices ``face * 3 + corner`` into ``faces``) sorted
    by vertex, and where each vertex's run starts (``n_vertices + 1`` entries): the corners at vertex
    ``v`` are ``order[starts[v]:starts[v + 1]]``, in ascending order. Made once per big stone so that
    :func:`smooth_corner_normals` finds the corners around a few faces without a pass over all of them."""
    flat = np.asarray(faces, dtype=np.int64).ravel()
    order = np.argsort(flat, kind="stable")
    starts = np.zeros(int(n_vertices) + 1, dtype=np.int64)
    np.cumsum(np.bincount(flat, minlength=int(n_vertices)), out=starts[1:])
    return order, starts


def _corners_at(need: np.ndarray, incidence: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The flat corner indices (ascending) of every corner at the vertices ``need`` (unique)."""
    order, starts = incidence
    lo, hi = starts[need], starts[need + 1]
    counts = hi - lo
    total = int(counts.sum())
    offsets = np.repeat(lo - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return np.sort(order[offsets + np.arange(total)])


def smooth_corner_normals(mesh: Any, angle_deg: float, face_idx: Any,
                          incidence: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(k, 3, 3) smooth shading normals at the three corners of the faces ``face_idx`` of ``mesh``
    (in its own face order), split along edges sharper than ``angle_deg``, without building a split
    copy of the whole mesh (:func:`smooth_split`), for a mesh of millions of triangles.

    At a corner (face f, vertex v) the normal is the corner-angle weighted mean of the normals of
    the faces around v that f reaches across edges at v whose faces' normals differ by less than
    ``angle_deg`` (trimesh's vertex normals of the split copy: the same weights and tests).
    trimesh's split goes by connected patches of the whole mesh instead, and keeps flat facets
    larger than a tenth of the surface apart: the two differ only at vertices where two or more
    sharp edges meet and the sectors they part around the vertex are one patch further away
    (trimesh then smooths across those edges there), and at the rims of such large facets. On
    the bundled cabochons they agree at every corner, on the carving at all but 0.03 % of its
    area (``tests/test_speed_big.py`` compares them). ``incidence``: the mesh's
    :func:`corner_incidence`, when made already (a stone that asks many times: the volume
    estimator's ray hits); without it the corners are found by a pass over every face."""
    import trimesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(mesh.faces, dtype=np.int64)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    face_idx = np.asarray(face_idx, dtype=np.int64).ravel()
    nv = len(verts)
    if incidence is None:
        need = np.zeros(nv, dtype=bool)
        need[faces[face_idx].ravel()] = True
        # every corner at a needed vertex: (face g, corner c), sorted by face then corner
        g, c = np.nonzero(need[faces])
    else:
        flat = _corners_at(np.unique(faces[face_idx].ravel()), incidence)
        g, c = flat // 3, flat % 3
    v = faces[g, c]
    w1, w2 = faces[g, (c + 1) % 3], faces[g, (c + 2) % 3]
    inc = np.unique(g)  # incident faces: their normals and corner angles
    tri = verts[faces[inc]]
    normals = unit_normals(tri)
    angles = trimesh.triangles.angles(tri)
    loc = np.searchsorted(inc, g)
    n_c = normals[loc]
    ang_c = angles[loc, c]
    ang_c = np.where(np.einsum("ij,ij->i", n_c, n_c) > 0.5, ang_c, 0.0)  # faces without a normal count for nothing
    # the fan around each vertex: corners whose faces share an edge (v, w) at it
    key = np.concatenate([v * nv + w1, v * nv + w2])
    corner = np.concatenate([np.arange(len(g)), np.arange(len(g))])
    order = np.argsort(key, kind="stable")
    ks, cs = key[order], corner[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    a, b = cs[same], cs[same + 1]
    keep = a != b
    a, b = a[keep], b[keep]
    dots = np.clip(np.einsum("ij,ij->i", n_c[a], n_c[b]), -1.0, 1.0)
    smooth = np.abs(np.arccos(dots)) < math.radians(angle_deg)
    a, b = a[smooth], b[smooth]
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(len(g), len(g)))
    _, comp = connected_components(graph, directed=False)
    summed = np.stack([np.bincount(comp, weights=ang_c * n_c[:, k]) for k in range(3)], axis=1)
    length = np.sqrt(np.einsum("ij,ij->i", summed, summed))
    unit = summed / np.where(length > 0, length, 1.0)[:, None]
    # the corners of the faces asked: their rows among the sorted (face, corner) pairs
    rows = np.searchsorted(g * 3 + c, (face_idx[:, None] * 3 + np.arange(3)[None, :]).ravel())
    return unit[comp[rows]].reshape(len(face_idx), 3, 3)


def _smooth_normals(split: Any, face_idx: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Smooth shading normals at sample points of the smooth-shaded mesh (as the renderer shades)."""
    vn = split.vertex_normals[split.faces[face_idx]]
    n = np.einsum("ij,ijk->ik", bary, vn)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


@dataclass(frozen=True)
class SurfaceSamples:
    """Area-uniform samples of a stone's smooth-shaded surface (:func:`draw_samples`)."""

    points: np.ndarray  # (N, 3) positions, mesh frame
    n_geo: np.ndarray  # (N, 3) geometric (face) normals
    n_sh: np.ndarray  # (N, 3) smooth shading normals, as the renderer shades
    seed: int
    convex: bool

    @property
    def count(self) -> int:
        return len(self.points)


#: how the surface samples are placed (:func:`draw_samples`)
SAMPLINGS = ("stratified", "random")


#: bits of each axis of the Morton cells the faces are grouped in (:func:`face_cells`): 2^21 cells
#: over the stone's bounding box, about a hundred times the faces of a bundled stone and fewer
#: than those of a million-triangle scan, so a cell holds one face or a few
CELL_BITS = 7


def _spread_bits(n: int) -> np.ndarray:
    """The Morton spread of 0 .. 2^n - 1: bit ``i`` moved to bit ``3 i``."""
    k = np.arange(1 << n, dtype=np.int64)
    out = np.zeros_like(k)
    for i in range(n):
        out |= ((k >> i) & 1) << (3 * i)
    return out


_SPREAD = _spread_bits(CELL_BITS)


def morton_cells(points: np.ndarray, lo: np.ndarray | None = None, hi: np.ndarray | None = None) -> np.ndarray:
    """Each of ``points``' ((n, 3)) cell on a 3-D Morton (Z-order) curve through the box ``lo``-``hi``
    (default: their bounding box), :data:`CELL_BITS` an axis (int64 codes, x the lowest bit): cells
    near each other on the curve lie near each other in space, so equal stretches of the curve are
    compact patches."""
    p = np.asarray(points)
    lo = p.min(axis=0) if lo is None else np.asarray(lo, dtype=p.dtype)
    hi = p.max(axis=0) if hi is None else np.asarray(hi, dtype=p.dtype)
    side = (1 << CELL_BITS) - 1
    width = hi - lo
    scale = np.where(width > 0, side / np.where(width > 0, width, 1), 0).astype(p.dtype)  # a flat axis: one cell
    q = np.clip((p - lo) * scale, 0, side).astype(np.uint8)
    return _SPREAD[q[:, 0]] | (_SPREAD[q[:, 1]] << 1) | (_SPREAD[q[:, 2]] << 2)


def _stratified_faces(prob: np.ndarray, cells: np.ndarray, count: int,
                      rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Faces and first barycentric uniforms of ``count`` jittered stratified samples: the faces laid
    end to end by area (``prob``) along the Morton curve of their cells (``cells``: each face's
    cell as :func:`face_cells` ranks it, or any non-negative integer codes in the curve's order;
    within a cell in face order), the total cut into ``count`` equal strata, one sample uniform in
    each. Every patch of the surface then holds its share of the samples to within one or two
    (random draws scatter by the square root of it), and each sample is still uniform over the
    area; the uniform's place within its face's stretch is the sample's first barycentric
    coordinate. Only the faces of the cells the strata land in are sorted, so a
    scan of millions of faces costs a few passes over them."""
    cell_area = np.bincount(cells, weights=prob)
    cum = np.cumsum(cell_area)
    # below the total (rounding), the first cell whose running total exceeds u has area
    u = np.minimum((np.arange(count, dtype=np.float64) + rng.random(count)) * (cum[-1] / count), np.nextafter(cum[-1], 0.0))
    cell = np.searchsorted(cum, u, side="right")
    rest = u - (cum[cell] - cell_area[cell])  # how far into its cell's area each sample lies
    chosen = np.zeros(len(cum), dtype=bool)
    chosen[cell] = True
    faces = np.flatnonzero(chosen[cells] & (prob > 0))
    faces = faces[np.argsort(cells[faces], kind="stable")]
    fc, fa = cells[faces], prob[faces]
    run = np.cumsum(fa)
    first = np.searchsorted(fc, cell, side="left")
    last = np.searchsorted(fc, cell, side="right") - 1
    target = np.concatenate([[0.0], run])[first] + rest
    j = np.clip(np.searchsorted(run, target, side="right"), first, last)
    r1 = np.clip((target - (run[j] - fa[j])) / fa[j], 0.0, 1.0)
    return faces[j], r1


def draw_samples(mesh: Any, count: int, seed: int, angle: float, convex: bool, split: Any = None,
                 areas: np.ndarray | None = None, sampling: str = "stratified",
                 cells: np.ndarray | None = None) -> SurfaceSamples:
    """``count`` area-uniform samples of the smooth-shaded surface of ``mesh`` (as the renderer
    shades it: split along edges sharper than ``angle`` degrees), drawn from
    ``numpy.random.default_rng(seed)``, mesh frame. A mesh of more than :data:`FAST_SMOOTH_FACES`
    triangles is sampled in its own face order (``areas``: its face areas) and shaded at the sampled
    faces only (:func:`smooth_corner_normals`); a smaller one on its split copy ``split``
    (:func:`smooth_split`, its own face order). ``convex`` travels with the samples.

    ``sampling``: ``"stratified"`` (default) places one sample in each of ``count`` equal-area
    stretches of the faces laid along a Morton curve (:func:`_stratified_faces`; ``cells``: the
    faces' :func:`face_cells`, when known). A flash lives on a small patch of a dome,
    and its energy is that patch's share of the samples: on the high oval under a front lamp,
    8,000 random samples put the answer anywhere within ±2° by seed, stratified ones within ±0.25°
    (docs/accuracy.md, "Stratified surface samples"). ``"random"``: independent draws, each face by
    its area (the samples before stratification)."""
    if sampling not in SAMPLINGS:
        raise ParameterError(f"surface sampling must be one of {', '.join(SAMPLINGS)}, got {sampling!r}", parameter="quality")
    big = len(mesh.faces) > FAST_SMOOTH_FACES
    if not big and split is None:
        split = smooth_split(mesh, angle)
    area_faces = (face_areas(mesh) if areas is None else areas) if big else split.area_faces
    ok = np.isfinite(area_faces) & (area_faces > 0)
    if not np.any(ok):
        raise MeshError("the mesh has no face with positive area")
    rng = np.random.default_rng(seed)
    prob = np.where(ok, area_faces, 0.0)
    del area_faces, ok
    if sampling == "stratified":
        if cells is None:
            cells = face_cells(mesh if big else split)
        face_idx, r1 = _stratified_faces(prob, cells, count, rng)
    else:
        face_idx = rng.choice(len(prob), size=count, p=prob / prob.sum())
        r1 = rng.random(count)
    del prob
    r2 = rng.random(count)
    sq = np.sqrt(r1)
    bary = np.stack([1 - sq, sq * (1 - r2), sq * r2], axis=1)
    if big:
        tri = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)[face_idx]]
        n_geo = unit_normals(tri)
        n_sh = np.einsum("ij,ijk->ik", bary, smooth_corner_normals(mesh, angle, face_idx))
        n_sh /= np.linalg.norm(n_sh, axis=1, keepdims=True)
    else:
        tri = split.vertices[split.faces[face_idx]]  # = split.triangles[face_idx], without every face's corners
        n_geo = split.face_normals[face_idx]
        n_sh = _smooth_normals(split, face_idx, bary)
    points = np.einsum("ij,ijk->ik", bary, tri)
    for a in (points, n_geo, n_sh):
        a.setflags(write=False)
    return SurfaceSamples(points, n_geo, n_sh, seed, convex)


def face_codes(mesh: Any) -> np.ndarray:
    """The faces of ``mesh`` (anything with ``vertices`` and ``faces``): each one's
    :func:`morton_cells` code by its centroid, in the box of the vertices (centroids summed in
    float32, so the box is three times the vertices': the cells need no more precision, and the
    vertices' box is found in a third of the time of the centroids')."""
    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces)
    return morton_cells(v[f[:, 0]] + v[f[:, 1]] + v[f[:, 2]], 3.0 * v.min(axis=0), 3.0 * v.max(axis=0))


def dense_ranks(key: np.ndarray, n_keys: int, dtype: Any = np.int64) -> np.ndarray:
    """Each integer key in ``[0, n_keys)``: its rank among the distinct keys present, in ascending
    key order (``np.unique(key, return_inverse=True)[1]``), through one mask as long as the key
    range instead of a sort: O(N + n_keys). The faces' cells here (:func:`face_cells`) and the
    score map's bins (:func:`labcut.orientation.scoring.grid_inverse`) both rank so."""
    present = np.zeros(n_keys, dtype=bool)
    present[key] = True
    rank = np.cumsum(present, dtype=dtype)
    rank -= 1
    return rank[key]


def face_cells(mesh: Any) -> np.ndarray:
    """Each face's :func:`face_codes` cell as the rank of its cell among the occupied ones (int32,
    0 .. occupied - 1, in curve order: :func:`dense_ranks`). The ranks order the faces as the codes
    do, and a stratified draw over them (:func:`_stratified_faces`) sums and searches arrays as long
    as the occupied cells, not the 2^21 of the grid: a bundled stone's faces occupy about a
    hundredth of it, and two grid-long arrays in every draw cost more than the draw."""
    return dense_ranks(face_codes(mesh), 1 << (3 * CELL_BITS), np.int32)
