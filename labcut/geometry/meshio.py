"""Mesh intake and export: read, validate, repair, convert units, find the face-up side, re-centre.

:func:`load_mesh` reads STL, OBJ, PLY, OFF, GLB/GLTF and 3MF through trimesh and
returns a validated :class:`trimesh.Trimesh` in mm, in the labcut frame (DESIGN.md
§3: +Z face-up, base on z = 0). Units come from the caller, else from the file
(glTF is metres by specification, 3MF declares its unit), else mm; a stone must then
measure 0.5-500 mm across, and one read in mm by default that is under 2.5 mm across is
probably in inches or centimetres (a warning). The face-up side comes from the caller, else
from the shape (a flat base, a table, a dome: :mod:`labcut.geometry.orient`), else from the
format's convention (+Y for glTF, +Z otherwise). A mesh labcut accepts is

* non-empty, with finite vertex coordinates;
* free of degenerate triangles (repeated or collinear vertices);
* closed (watertight) with consistent winding and outward normals;
* an oriented 2-manifold, as certified by :class:`manifold3d.Manifold`.

What can be repaired is repaired and reported (``mesh.metadata["labcut"]["repairs"]``):
faces that use NaN/inf vertices are dropped, duplicate and degenerate faces are
removed or collapsed, inconsistent winding is made consistent, inward-facing
shells are inverted, holes are closed with fan patches. What cannot be repaired
(no triangles, edges shared by three or more faces, unreadable files) raises a
:class:`~labcut.errors.MeshError` with a one-line message.

``mesh.metadata["labcut"]["convex"]`` tells whether the solid is convex (its
volume equals its convex hull's): the renderer and the optimiser skip occlusion
tests for convex stones.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import LabcutWarning, MeshError, ParameterError
from ..fileio import atomic_output
from .gemcad import load_design
from .orient import check_up_axis, describe_up, detect_up_axis, up_rotation
from .report import MeshReport
from .solid import (
    CHUNK,
    STONE_SIZE_MM,
    centre_on_base,
    cross_rows,
    double_areas,
    extent,
    is_convex_mesh,
    signed_volume,
)

#: suffix -> trimesh file type, for reading
READ_FORMATS = {
    ".stl": "stl",
    ".obj": "obj",
    ".ply": "ply",
    ".off": "off",
    ".glb": "glb",
    ".gltf": "gltf",
    ".3mf": "3mf",
}
#: suffixes :func:`save_mesh` can write
WRITE_FORMATS = (".ply", ".stl", ".obj", ".off", ".glb", ".3mf")

#: length of one file unit in mm
UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "um": 1e-3, "in": 25.4, "ft": 304.8}
#: the units' names in a sentence
UNIT_WORDS = {"mm": "millimetres", "cm": "centimetres", "m": "metres", "um": "microns", "in": "inches", "ft": "feet"}

#: the usual sizes (mm across, the largest extent) of the stones labcut plans for: labradorite
#: cabochons and carvings run about 4-64 mm, from 4 x 3 mm calibrated cabochons to 2.5-inch pendants
#: and carvings; the middle of the range (its geometric mean, 16 mm) is the commonest cabochon. A unit
#: is suggested for a file that does not say its own only when it puts the stone in this range
#: (:func:`_units_warning`), and :func:`_check_size` names first the unit that puts a refused stone
#: nearest the middle
TYPICAL_STONE_MM = (4.0, 64.0)
#: a file that does not say its unit, read in mm, whose stone measures less than this across (mm) is
#: probably in inches or centimetres and is warned about (:func:`_units_warning`): 16-20 mm stones,
#: the commonest cabochons, read 0.63-0.79 mm in inches and 1.6-2.0 mm in centimetres, while real cut
#: labradorite, 3 mm calibrated cabochons included, is larger. Below it, the stone read in inches
#: (under 63.5 mm) or centimetres (5-25 mm) is always in :data:`TYPICAL_STONE_MM`
SMALL_STONE_MM = 2.5


#: largest share of the surface that hole patches may make up
MAX_PATCH_FRACTION = 0.2


#: a mesh of more triangles that needs no repair is certified by labcut's own edge check alone,
#: not rebuilt by manifold3d (:func:`validate_arrays`)
MANIFOLD_CHECK_FACES = 1_000_000


def _one_line(text: object, limit: int = 200) -> str:
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


# ----------------------------------------------------------------------------- helpers
def _face_measures(v: np.ndarray, f: np.ndarray, keep: bool = False) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """One pass over the faces' corners: ``(area2, dets, cross)``. ``area2`` is
    :func:`double_areas`; with ``keep``, also :func:`face_dets` and the (F, 3) cross products
    (b - a) x (c - a) whose norms ``area2`` holds (:func:`labcut.geometry.orient.detect_up_axis`
    reads the normals from them), else None for both. The same expressions as those functions, on
    one gather of each face's three corners."""
    n = len(f)
    area2 = np.empty(n)
    dets = np.empty(n) if keep else None
    cross = np.empty((n, 3)) if keep else None
    for s in range(0, n, CHUNK):
        ff = f[s : s + CHUNK]
        a, b, c = (np.take(v, ff[:, k], axis=0) for k in range(3))  # v[ff[:, k]]: the same rows, twice as fast
        if keep:
            dets[s : s + len(ff)] = (a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1])
                                     + a[:, 1] * (b[:, 2] * c[:, 0] - b[:, 0] * c[:, 2])
                                     + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]))
        b -= a
        c -= a
        block = cross_rows(b, c)
        if keep:
            cross[s : s + len(ff)] = block
        # np.linalg.norm(block, axis=1), a column at a time: its sum of the three squares runs in the
        # same order, (x² + y²) + z² (the test compares them), without a reduction over rows of three
        sq = block[:, 0] * block[:, 0]
        sq += block[:, 1] * block[:, 1]
        sq += block[:, 2] * block[:, 2]
        np.sqrt(sq, out=area2[s : s + len(ff)])
    return area2, dets, cross


def _face_components(faces: np.ndarray, n_vertices: int, graph: Any = None) -> tuple[np.ndarray, int]:
    """Label faces by connected component (faces sharing a vertex): ``(labels, count)``, the
    components numbered in the order of their smallest vertex index.

    scipy's ``connected_components`` over the vertex graph (linear time; the label propagation
    it replaced took seconds a million triangles). ``graph``: a sparse matrix of the mesh's edges
    (each once, any direction: :func:`_clean_edge_graph`'s), when the caller has one; else the graph
    of two edges of each face is built here. Either graph joins the same vertices, so the labels
    are the same."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = np.asarray(faces, dtype=np.int64)
    if graph is None:
        rows = np.concatenate([f[:, 0], f[:, 1]])
        cols = np.concatenate([f[:, 1], f[:, 2]])
        graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n_vertices, n_vertices))
        _, comp = connected_components(graph, directed=False)  # numbered by first vertex reached, in index order
    else:
        _, comp = connected_components(graph, directed=True, connection="weak")  # the same numbering
    face_comp = np.take(comp, f[:, 0])
    present = np.bincount(face_comp, minlength=int(comp.max(initial=0)) + 1) > 0  # components that have faces
    rank = np.cumsum(present) - 1
    return rank[face_comp].astype(np.int64), int(present.sum())


def _boundary_loops(faces: np.ndarray) -> list[list[int]] | None:
    """Simple directed boundary loops (edges used by one face), or None if not traceable.

    A vertex where two holes touch is split so every loop visits a vertex once.
    """
    e = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    boundary = e[cnt[inv] == 1]
    out_edges: dict[int, list[int]] = {}
    for u, v in boundary:
        out_edges.setdefault(int(u), []).append(int(v))
    loops: list[list[int]] = []
    while out_edges:
        start = next(iter(out_edges))
        path = [start]
        pos = {start: 0}
        cur = start
        while True:
            nxts = out_edges.get(cur)
            if not nxts:
                return None  # open chain: the boundary does not close
            nxt = nxts.pop()
            if not nxts:
                del out_edges[cur]
            if nxt in pos:
                i = pos[nxt]
                loop = path[i:]
                for w in loop[1:]:
                    pos.pop(w, None)
                path = path[: i + 1]
                loops.append(loop)
                if nxt == start and len(path) == 1:
                    break
                cur = nxt
                continue
            pos[nxt] = len(path)
            path.append(nxt)
            cur = nxt
    if any(len(lp) < 3 for lp in loops):
        return None
    return loops


def _same_orientation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row: do triangles ``a`` and ``b`` (same vertices) have the same cyclic order?"""
    def canon(t: np.ndarray) -> np.ndarray:
        k = np.argmin(t, axis=1)
        idx = (k[:, None] + np.arange(3)[None, :]) % 3
        return np.take_along_axis(t, idx, axis=1)

    return np.all(canon(a) == canon(b), axis=1)


def _closed_and_consistent(f: np.ndarray, nv: int) -> bool:
    """True when every edge of the (int64) faces is walked exactly once each way: a closed mesh,
    every edge shared by two faces, consistently wound (:func:`_clean_edge_graph`)."""
    return _clean_edge_graph(f, nv) is not None


def _clean_edge_graph(f: np.ndarray, nv: int) -> Any:
    """The check of :func:`_closed_and_consistent`; when it passes, the mesh's edges as a sparse
    (nv x nv) CSR matrix, each edge once, from its lower vertex to its higher (what
    :func:`_face_components` needs), else None.

    The edges walked upwards (src < dst) must equal the edges walked downwards, reversed, each
    once. Each set becomes a canonical CSR matrix (scipy's counting sort by row, then each row's
    few columns sorted, duplicates summed: linear time, where a sort of edge keys took twice as
    long); the two must have the same rows and columns, and as many entries as edges (none
    repeated). A reversed downward edge that is a loop (src == dst) sits on the diagonal, where no
    upward edge does. It also rules out a repeated face (its upward edges would repeat) but for a
    face and its reverse standing alone (a flat two-face pocket)."""
    from scipy.sparse import coo_matrix

    g32 = np.ascontiguousarray(f, dtype=np.int32 if nv < 2**31 - 1 else np.int64)  # scipy's index type
    src = g32.ravel()
    dst = g32[:, [1, 2, 0]].ravel()
    del g32
    up = src < dst
    n_up = int(np.count_nonzero(up))
    if 2 * n_up != len(src):
        return None

    def graph(rows: np.ndarray, cols: np.ndarray) -> Any:
        g = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(nv, nv)).tocsr()
        g.sum_duplicates()  # canonical: each row's columns sorted, repeats merged (a no-op after tocsr)
        return g

    fwd = graph(src[up], dst[up])
    if fwd.nnz != n_up:  # an edge walked twice the same way
        return None
    down = ~up
    bwd = graph(dst[down], src[down])
    del up, down, src, dst
    if not (np.array_equal(fwd.indptr, bwd.indptr) and np.array_equal(fwd.indices, bwd.indices)):
        return None
    return fwd


def _edge_table(faces: np.ndarray, n_vertices: int | None = None, *, try_clean: bool = True) -> tuple[int, int, bool]:
    """One sort of the directed edges: ``(boundary edges, edges shared by more than two faces,
    winding consistent)``. The winding is consistent when every edge two faces share is walked
    in opposite directions by them (trimesh's ``is_winding_consistent``)."""
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return 0, 0, True
    nv = int(n_vertices if n_vertices is not None else f.max() + 1)
    if try_clean and _closed_and_consistent(f, nv):  # the common case of a big clean mesh, checked first
        # (``try_clean`` False: the caller has just found these very faces not clean)
        return 0, 0, True
    src = f.ravel()
    dst = f[:, [1, 2, 0]].ravel()
    # undirected edge, then its direction bit, built in place (a few arrays of 3F at most)
    key = np.minimum(src, dst)
    key *= nv
    key += np.maximum(src, dst)
    key <<= 1
    key |= src < dst
    del dst
    key.sort()
    edge = key >> 1
    starts = np.flatnonzero(np.r_[True, edge[1:] != edge[:-1]])
    counts = np.diff(np.r_[starts, len(edge)])
    pairs = starts[counts == 2]
    consistent = bool(np.all((key[pairs] & 1) != (key[pairs + 1] & 1)))
    return int((counts == 1).sum()), int((counts > 2).sum()), consistent


def _edge_use(faces: np.ndarray) -> tuple[int, int]:
    """(boundary edges, edges shared by more than two faces)."""
    n_boundary, n_nonmanifold, _ = _edge_table(faces)
    return n_boundary, n_nonmanifold


#: odd 64-bit multipliers of the row hashes (:func:`_row_hash`)
_HASH_MUL = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9], dtype=np.uint64)


def _row_hash(rows: np.ndarray) -> np.ndarray:
    """A 64-bit hash of each row of a (N, 3) integer array: equal rows hash equal (distinct rows
    may collide; a caller that sees a repeated hash checks exactly)."""
    r = np.ascontiguousarray(rows, dtype=np.int64).view(np.uint64)
    with np.errstate(over="ignore"):
        h = r[:, 0] * _HASH_MUL[0]
        h ^= (h >> np.uint64(29)) + r[:, 1] * _HASH_MUL[1]
        h ^= (h >> np.uint64(31)) + r[:, 2] * _HASH_MUL[2]
    return h


def _all_distinct(rows: np.ndarray) -> bool:
    """True when no two rows of a (N, 3) integer array are equal (a sort of one 64-bit hash per
    row; False may also mean a hash collision: check exactly then)."""
    h = np.sort(_row_hash(rows))
    return not bool(np.any(h[1:] == h[:-1]))


def _merge_key(v: np.ndarray) -> np.ndarray:
    """trimesh's vertex-merge key: coordinates x 10^8 (``tol.merge`` = 1e-8), rounded to integers."""
    return np.round(v * (10**8)).astype(np.int64)


def _check_stl(path: Path) -> None:
    """Refuse a truncated or padded binary STL before trimesh guesses at it."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(min(size, 4096))
    stripped = head.lstrip()
    if stripped[:5].lower() == b"solid" and (b"facet" in head.lower() or size < 84):
        return  # ASCII STL
    if size < 84:
        raise MeshError(f"{path.name} is not a valid STL: {size} bytes is shorter than a binary STL header")
    count = int.from_bytes(head[80:84], "little")
    expected = 84 + 50 * count
    if size != expected:
        if stripped[:5].lower() == b"solid":
            return  # an ASCII STL whose first facet is beyond 4 kB
        raise MeshError(
            f"{path.name} is a truncated or corrupt binary STL: its header announces {count} triangles "
            f"({expected} bytes) but the file has {size} bytes"
        )


#: what a file format says about its length unit
DECLARED_UNITS = {"glb": "m", "gltf": "m"}  # glTF 2.0: "the units for all linear distances are meters"
#: 3MF ``<model unit="...">`` values (3MF core specification §3.4; millimeter by default)
THREEMF_UNITS = {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in", "foot": "ft", "meter": "m"}


def _read_ply_arrays(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and triangles of a PLY file straight from trimesh's PLY reader: what
    ``trimesh.load(..., process=False, force="mesh")`` returns, without its scene and the copies
    it makes of a mesh of millions of triangles (seconds). None when the file is anything but
    one plain triangle mesh: the general path reads (or refuses) it then."""
    import trimesh

    try:
        with open(path, "rb") as fh:
            kw = trimesh.exchange.ply.load_ply(fh)
    except Exception:  # noqa: BLE001 - the general path reports what is wrong
        return None
    if not isinstance(kw, dict) or "geometry" in kw or "vertices" not in kw or "faces" not in kw:
        return None
    v, f = kw["vertices"], kw["faces"]
    if not (isinstance(v, np.ndarray) and isinstance(f, np.ndarray)):
        return None
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        return None
    if not np.issubdtype(f.dtype, np.integer):
        return None
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64)


def _first_byte(fh: Any) -> bytes:
    """The first byte of a file that is not white space (b"" when there is none): JSON may open
    with any amount of it."""
    while chunk := fh.read(4096):
        rest = chunk.lstrip()
        if rest:
            return rest[:1]
    return b""


def _read(path: Path, fmt: str) -> tuple[np.ndarray, np.ndarray, str | None]:
    """Vertices, faces and the unit the file declares (None when the format does not say)."""
    import trimesh

    if fmt == "stl":
        _check_stl(path)
    if fmt == "gltf":
        with open(path, "rb") as fh:
            if _first_byte(fh) != b"{":
                raise MeshError(f"cannot read {path.name} as GLTF: it is not a JSON glTF file (binary glTF ends in .glb)")

    if fmt == "ply":
        fast = _read_ply_arrays(path)
        if fast is not None:
            return fast[0], fast[1], None
    try:
        loaded = trimesh.load(str(path), file_type=fmt, process=False, force="mesh")
    except ImportError:
        # trimesh only reaches for a charset detector when a text format is not UTF-8
        raise MeshError(f"cannot read {path.name} as {fmt.upper()}: it is not a UTF-8 text {fmt.upper()} file") from None
    except Exception as exc:  # trimesh raises many kinds on a bad file
        detail = _one_line(exc) if len(str(exc)) > 12 else f"{type(exc).__name__}: {_one_line(exc)}"
        raise MeshError(f"cannot read {path.name} as {fmt.upper()} ({detail})") from None
    if isinstance(loaded, trimesh.Scene):  # pragma: no cover - force="mesh" flattens scenes
        geoms = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)]
        loaded = trimesh.util.concatenate(geoms) if geoms else trimesh.Trimesh()
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshError(f"{path.name} holds no triangle mesh (a point cloud or curves?)")
    v = np.asarray(loaded.vertices, dtype=np.float64)
    f = np.asarray(loaded.faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0 or f.ndim != 2 or len(f) == 0:
        raise MeshError(f"{path.name} contains no triangles")
    declared = DECLARED_UNITS.get(fmt)
    if fmt == "3mf":
        unit = str(getattr(loaded, "units", None) or loaded.metadata.get("units") or "millimeter").strip().lower()
        declared = THREEMF_UNITS.get(unit.rstrip("s"), THREEMF_UNITS.get(unit))
        if declared is None:
            raise MeshError(f"{path.name} declares the unit {unit!r}, which is not a 3MF unit ({', '.join(THREEMF_UNITS)})")
    return v, f, declared


def units_scale(units: str | float) -> tuple[str, float]:
    if isinstance(units, str):
        key = units.strip().lower()
        if key in ("µm", "micron", "microns"):
            key = "um"
        if key in ("inch", "inches"):
            key = "in"
        key = {"millimeter": "mm", "millimeters": "mm", "centimeter": "cm", "centimeters": "cm", "meter": "m",
               "meters": "m", "metre": "m", "metres": "m", "foot": "ft", "feet": "ft"}.get(key, key)
        if key not in UNITS:
            raise ParameterError(f"unknown units {units!r}; use one of {', '.join(UNITS)} or a number of mm per unit")
        return key, UNITS[key]
    if isinstance(units, bool):
        raise ParameterError(f"units must be a name or a number of mm per unit, got {units!r}")
    try:
        f = float(units)
    except (TypeError, ValueError):
        raise ParameterError(f"units must be a name or a number of mm per unit, got {units!r}") from None
    if not math.isfinite(f) or f <= 0:
        raise ParameterError(f"units factor must be positive and finite, got {units!r}")
    return f"x{f:g}", f


# ----------------------------------------------------------------------------- repair pipeline
def validate_arrays(
    vertices: np.ndarray,
    faces: np.ndarray,
    name: str = "mesh",
    repair: bool = True,
) -> tuple[np.ndarray, np.ndarray, list[str], list[str], int]:
    """Validate (and repair) raw arrays; return ``(V, F, repairs, notes, bodies)``.

    The result is an oriented, outward-wound, closed 2-manifold certified by manifold3d (a mesh
    of more than :data:`MANIFOLD_CHECK_FACES` triangles that needs no repair by the same edge
    check manifold3d makes, done here, and kept in its own order). Raises :class:`MeshError`
    when that cannot be reached (or when ``repair`` is False and anything needed repairing).
    """
    return _validate_arrays(vertices, faces, name, repair)[:5]


def _validate_arrays(vertices: np.ndarray, faces: np.ndarray, name: str, repair: bool, fast: bool = True) -> tuple[Any, ...]:
    """:func:`validate_arrays`, then the solid's volume when it was summed on the way (else None) and
    the (3, F) cross products of the returned faces (:func:`_face_measures`) when they were (else
    None). ``fast``: a big mesh that passes the edge check skips the duplicate-face check."""
    import manifold3d as m3
    import trimesh

    repairs: list[str] = []
    notes: list[str] = []

    def fix(msg: str) -> None:
        if not repair:
            raise MeshError(f"{name}: {msg.split(';')[0]} (repair disabled)")
        repairs.append(msg)

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(v) == 0 or len(f) == 0:
        raise MeshError(f"{name} contains no triangles")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshError(f"{name} has faces that refer to missing vertices")

    bad_v = ~np.all(np.isfinite(v), axis=1)
    if bad_v.any():
        bad_f = bad_v[f].any(axis=1)
        if bad_f.all():
            raise MeshError(f"{name}: every triangle uses a non-finite (NaN or inf) vertex")
        if bad_f.any():
            fix(f"removed {int(bad_f.sum())} faces that use {int(bad_v.sum())} non-finite (NaN/inf) vertices")
            f = f[~bad_f]
        else:
            notes.append(f"ignored {int(bad_v.sum())} unused non-finite vertices")

    used = np.zeros(len(v), dtype=bool)
    used[f] = True
    # every vertex used and none coincident (one hash sort): nothing for trimesh to drop or merge
    if not (used.all() and np.all(np.isfinite(v)) and _all_distinct(_merge_key(v))):
        mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
        mesh.remove_unreferenced_vertices()
        nv = len(mesh.vertices)
        mesh.merge_vertices()
        if len(mesh.vertices) < nv:
            notes.append(f"merged {nv - len(mesh.vertices)} coincident vertices")
        f = np.asarray(mesh.faces, dtype=np.int64)
        v = np.asarray(mesh.vertices, dtype=np.float64)

    rep = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])
    if rep.any():
        fix(f"removed {int(rep.sum())} degenerate faces (repeated vertices)")
        f = f[~rep]
    if len(f) == 0:
        raise MeshError(f"{name} has only degenerate triangles")
    # a big mesh walked once each way along every edge has no repeated face but in a flat
    # two-face pocket of its own (a shell of zero volume: then everything again, in full below):
    # its duplicate check is skipped
    edges = _clean_edge_graph(f, len(v)) if fast and len(f) > MANIFOLD_CHECK_FACES else None
    clean = edges is not None
    found_unclean = f if (fast and len(f) > MANIFOLD_CHECK_FACES and not clean) else None
    if not clean:
        sorted_faces = np.sort(f, axis=1)
        if not _all_distinct(sorted_faces):  # a repeated hash: find the duplicates exactly
            _, first = np.unique(sorted_faces, axis=0, return_index=True)
            if len(first) < len(f):
                fix(f"removed {len(f) - len(first)} duplicate faces")
                f = f[np.sort(first)]
        del sorted_faces
    # a clean big mesh keeps its faces: their volumes and normals are read from this same pass
    area2, dets, cross = _face_measures(v, f, keep=clean)
    measured = f
    used = np.zeros(len(v), dtype=bool)
    used[f] = True
    scale = float(extent(v if used.all() else v[used]).max())
    if scale <= 0:
        raise MeshError(f"{name} has no extent (all vertices coincide)")
    flat = area2 <= 1e-12 * scale * scale
    if flat.all():
        raise MeshError(f"{name} has only zero-area triangles")

    n_boundary, n_nonmanifold, consistent = (0, 0, True) if clean else _edge_table(f, len(v),
                                                                                   try_clean=f is not found_unclean)
    if n_nonmanifold:
        raise MeshError(
            f"{name} is not a 2-manifold: {n_nonmanifold} edges are shared by three or more faces; "
            "fix it in a mesh editor (e.g. separate the touching parts)"
        )

    # consistent winding
    original = f  # the file's faces (every step below makes new arrays, none writes into this one)
    # (the edge sort found two faces walking a shared edge the same way: trimesh confirms, repairs)
    mesh = None if consistent else trimesh.Trimesh(vertices=v, faces=f, process=False)
    if mesh is not None and not mesh.is_winding_consistent:
        if not repair:
            raise MeshError(f"{name}: its faces are not consistently wound (repair disabled)")
        trimesh.repair.fix_winding(mesh)
        f = np.asarray(mesh.faces, dtype=np.int64)
        if not trimesh.Trimesh(vertices=v, faces=f, process=False).is_winding_consistent:
            raise MeshError(f"{name} has a winding that cannot be made consistent (a non-orientable surface?)")

    # holes
    if n_boundary:
        if not repair:
            raise MeshError(f"{name} is not watertight: {n_boundary} open edges (repair disabled)")
        loops = _boundary_loops(f)
        if loops is None:
            raise MeshError(f"{name} is not watertight and its {n_boundary} open edges do not form simple holes")
        new_v = [v]
        new_f = [f]
        nxt_index = len(v)
        for loop in loops:
            if len(loop) == 3:
                new_f.append(np.array([[loop[2], loop[1], loop[0]]]))
                continue
            c = v[loop].mean(axis=0)
            new_v.append(c[None, :])
            lp = np.array(loop)
            new_f.append(np.column_stack([np.roll(lp, -1), lp, np.full(len(lp), nxt_index)]))
            nxt_index += 1
        v = np.vstack(new_v)
        patch = np.vstack(new_f[1:])
        f = np.vstack(new_f)
        patch_area = 0.5 * float(double_areas(v, patch).sum())
        own_area = 0.5 * float(area2.sum())  # the file's faces (``original``), summed above
        if patch_area > MAX_PATCH_FRACTION * (patch_area + own_area):
            raise MeshError(
                f"{name} is too open to repair: closing its {len(loops)} holes would make up "
                f"{100 * patch_area / (patch_area + own_area):.0f} % of its surface"
            )
        fix(f"closed {len(loops)} hole{'s' if len(loops) != 1 else ''} ({n_boundary} open edges) with fan patches")
        nb2, nm2 = _edge_use(f)
        if nb2 or nm2:
            raise MeshError(f"{name} is not watertight and filling its holes failed")

    # outward orientation, per closed shell
    labels, count = _face_components(f, len(v), edges if f is measured else None)
    vols = signed_volume(v, f, labels, count, dets if f is measured else None)
    if clean and not np.all(vols > 0):  # a flat pocket (or worse) slipped past the skipped check: in full
        return _validate_arrays(vertices, faces, name, repair, fast=False)
    inward = vols < 0
    if inward.any():
        flip = inward[labels]
        f = f.copy()
        f[flip] = f[flip][:, ::-1]
    # report orientation changes against the file's own faces
    flipped = np.zeros(len(original), dtype=bool) if f is original else ~_same_orientation(original, f[: len(original)])
    if flipped.all():
        fix("inverted all faces: the normals pointed inward")
    elif flipped.any():
        fix(f"reversed {int(flipped.sum())} of {len(original)} faces whose winding disagreed with the rest")

    if len(f) > MANIFOLD_CHECK_FACES and f is original and not repairs and not flat.any() and bool(np.all(vols > 0)):
        # a big mesh that needed nothing: the edge table above certified every edge shared by
        # exactly two faces walking it in opposite directions (a closed, oriented 2-manifold, what
        # manifold3d checks) and every shell encloses a positive volume; manifold3d's rebuild
        # (seconds a few million triangles, and twice the memory) would only reorder it
        ext = extent(v)
        if float(vols.sum()) <= 1e-9 * max(float(np.prod(ext)), 1e-300) or ext.min() <= 0:
            raise MeshError(f"{name} encloses no volume (a flat or empty surface)")
        return v, f, repairs, notes, int(count), float(vols.sum()), (cross if f is measured else None)

    man = m3.Manifold(m3.Mesh64(vert_properties=np.ascontiguousarray(v), tri_verts=np.ascontiguousarray(f, dtype=np.uint64)))
    status = man.status()
    if status != m3.Error.NoError:
        raise MeshError(f"{name} is not a closed oriented 2-manifold (manifold3d: {status.name})")
    out = man.to_mesh64()
    v2 = np.asarray(out.vert_properties)[:, :3].astype(np.float64)
    f2 = np.asarray(out.tri_verts).astype(np.int64)
    ext = extent(v2) if len(v2) else np.zeros(3)
    if len(f2) == 0 or man.volume() <= 1e-9 * max(float(np.prod(ext)), 1e-300) or ext.min() <= 0:
        raise MeshError(f"{name} encloses no volume (a flat or empty surface)")
    if len(f2) < len(f):
        fix(f"collapsed {len(f) - len(f2)} degenerate (zero-area or sliver) triangles")
    elif flat.any():
        notes.append(f"kept {int(flat.sum())} near-zero-area triangles")
    bodies = int(len(man.decompose())) if count > 1 else 1
    return v2, f2, repairs, notes, bodies, None, None


def load_mesh(
    path: str | os.PathLike[str],
    units: str | float = "auto",
    up_axis: str = "auto",
    size: float | None = None,
    recentre: bool = True,
    repair: bool = True,
    progress: Callable[[str, float], None] | None = None,
):
    """Read, validate and repair a stone mesh; return a ``trimesh.Trimesh`` in mm, +Z face-up.

    Args:
        path: an STL, OBJ, PLY, OFF, GLB/GLTF or 3MF file. Multi-object files
            (GLB scenes, 3MF) are flattened into one mesh. A GemCad design (``.asc``,
            ``.gem``) is cut into its stone by :func:`labcut.geometry.gemcad.load_design`.
        units: the file's length unit: ``"auto"`` (default: what the file declares, glTF/GLB
            metres by specification, 3MF its ``unit`` attribute; mm for formats that do not
            say), ``"mm"``, ``"cm"``, ``"m"``, ``"um"``, ``"in"``, ``"ft"``, or a number of mm
            per file unit. A given unit overrides the file's (with a note). The converted
            stone must measure 0.5-500 mm across (:data:`STONE_SIZE_MM`): anything else is a
            unit mistake and a :class:`~labcut.errors.ParameterError` that names ``--units``.
            A file that does not say its unit and is under :data:`SMALL_STONE_MM` (2.5 mm)
            across in mm is probably in inches or centimetres: a warning names the ``--units``
            that would fit (:func:`_units_warning`); a given ``units="mm"`` is not warned about.
        up_axis: the file's axis that is face-up: ``"auto"`` (default: read from the shape,
            a flat base or a table or a dome, see :mod:`labcut.geometry.orient`; else the
            format's convention, +Y for glTF and +Z otherwise), or ``"+Z"``, ``"-Z"``, ``"+Y"``,
            ``"-Y"``, ``"+X"``, ``"-X"``. The mesh is rotated so that axis becomes +Z; a file
            that looks upside down or Y-up, or a given axis the shape contradicts, adds a
            warning (``metadata["labcut"]["warnings"]`` and a :class:`~labcut.errors.LabcutWarning`).
        size: girdle width in mm (along X) of a dimensionless GemCad design; None: 10 mm
            (:data:`labcut.geometry.gemcad.DEFAULT_SIZE_MM`). Designs take no ``units``;
            meshes take no ``size``.
        recentre: translate so the bounding box is centred on the Z axis and
            its bottom (the base) lies on z = 0.
        repair: repair what can be repaired (default); False makes every defect
            an error.
        progress: optional ``callback(stage, fraction)`` for long loads (reading,
            validating, convexity, orienting).

    Returns:
        The validated mesh; ``mesh.metadata["labcut"]`` is a
        :meth:`MeshReport.to_dict` (``units``, ``up_axis``, ``rotation``, ``repairs``,
        ``notes``, ``warnings``, ``convex``, ``bodies``, ...).

    Raises:
        MeshError: missing, empty, unreadable or irreparable file.
        ParameterError: bad ``units`` or ``up_axis``, or a stone outside 0.5-500 mm.
    """
    import warnings as _warnings

    import trimesh


    report_stage = progress or (lambda stage, fraction: None)
    units_given = not (isinstance(units, str) and units.strip().lower() == "auto")
    if units_given:
        unit_name, factor = units_scale(units)
    up_key = check_up_axis(up_axis)
    p = Path(path)
    if not p.exists():
        raise MeshError(f"mesh file {str(path)!r} does not exist")
    if p.is_dir():
        raise MeshError(f"{str(path)!r} is a folder, not a mesh file")
    if p.suffix.lower() in (".asc", ".gem"):  # a GemCad design: dimensionless, sized by its girdle width

        if units_given and factor != 1.0:
            raise ParameterError(f"{p.name} is a GemCad design, which has no length unit: give its girdle width "
                                 f"with --size MM (size=MM), not --units")
        return load_design(p, size=size, up_axis=up_key, recentre=recentre, progress=progress)
    if size is not None:
        raise ParameterError(f"--size (size=) is the girdle width of a GemCad design (.asc, .gem); {p.name} is a mesh "
                             f"with its own size: give its unit with --units")
    fmt = READ_FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise MeshError(
            f"{p.name}: unsupported mesh format {p.suffix or '(no suffix)'!r}; use one of {', '.join(READ_FORMATS)}"
            f", or a GemCad design (.asc, .gem)"
        )
    if p.stat().st_size == 0:
        raise MeshError(f"{p.name} is empty (0 bytes)")
    report_stage(f"reading {p.name}", 0.0)
    v, f, declared = _read(p, fmt)
    notes: list[str] = []
    warns: list[str] = []
    if units_given:
        units_source = "given"
        if declared is not None and declared != unit_name:
            notes.append(f"read in {unit_name} as asked, although the file declares {declared}")
    elif declared is not None:
        unit_name, factor = declared, UNITS[declared]
        units_source = "file"
        if fmt in ("glb", "gltf"):
            notes.append("read in metres: glTF lengths are metres by specification")
    else:
        unit_name, factor = "mm", 1.0
        units_source = "default"
    report_stage("validating and repairing", 0.2)
    v, f, repairs, more_notes, bodies, volume, cross = _validate_arrays(v, f, p.name, repair)
    notes.extend(more_notes)
    _check_size(v, factor, unit_name, units_source, p.name, fmt)
    if units_source == "default":
        suspect = _units_warning(float(extent(v).max()), p.name)
        if suspect:
            warns.append(suspect)
    report_stage("checking convexity", 0.6)
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if volume is None:
        volume = signed_volume(v, f)
    convex = is_convex_mesh(mesh, volume=volume, keep=True)

    report_stage("finding the face-up side", 0.8)
    convention = "+Y" if fmt in ("glb", "gltf") else "+Z"
    guess = detect_up_axis(v, f, convex, cross=cross)  # the cross products validation computed, if it did
    del cross
    if up_key == "auto":
        if guess.axis is not None:
            up, up_source = guess.axis, f"shape: {guess.reason}"
            if up != convention:
                warns.append(
                    f"{p.name} looks {describe_up(up)}, from {guess.reason}: turned so that its {up} side is face-up; "
                    f"pass --up-axis {convention} (up_axis={convention!r}) to keep the file's orientation"
                )
        else:
            up = convention
            why = "glTF is Y-up by specification" if convention == "+Y" else "+Z, as the file has it"
            up_source = f"convention: {why}; the shape does not say ({guess.reason})"
    else:
        up, up_source = up_key, "given"
        if guess.axis is not None and guess.axis != up_key:
            warns.append(
                f"{p.name}: you gave up axis {up_key}, but its shape says {guess.axis} is face-up ({guess.reason}); "
                f"--up-axis auto (up_axis='auto') would use {guess.axis}"
            )
    rot = up_rotation(up)
    v = (v @ rot.T) * factor
    v, shift = centre_on_base(v) if recentre else (v, np.zeros(3))
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    # manifold3d certified the faces closed and consistently wound; the turn and the unit keep that
    # (a turn keeps the volume, the unit scales it by factor³ > 0)
    if not volume * float(np.linalg.det(rot)) > 0:  # pragma: no cover
        raise MeshError(f"{p.name} could not be made a closed, outward-wound solid")
    mark_valid(mesh)
    report = MeshReport(
        source=str(p),
        format=fmt,
        units=unit_name,
        scale_to_mm=factor,
        translation_mm=[float(x) for x in shift],
        repairs=repairs,
        notes=notes,
        warnings=warns,
        units_source=units_source,
        up_axis=up,
        up_axis_source=up_source,
        rotation=rot.tolist(),
        dimensions_mm=[float(x) for x in extent(v)],
        convex=convex,
        watertight=True,
        triangles=len(f),
        vertices=len(v),
        bodies=bodies,
    )
    mesh.metadata["labcut"] = {"kind": "loaded", **report.to_dict()}
    for w in warns:
        _warnings.warn(w, LabcutWarning, stacklevel=2)
    report_stage("loaded", 1.0)
    return mesh


def _check_size(v: np.ndarray, factor: float, unit_name: str, units_source: str, name: str, fmt: str) -> None:
    """Refuse a stone whose largest size in mm lies outside :data:`STONE_SIZE_MM`: wrong units.
    The message names the unit that would make it 2-200 mm across, the one nearest the middle of
    :data:`TYPICAL_STONE_MM` when several would (a 10 mm stone in inches reads 0.39 mm: inches give
    10 mm, centimetres 3.9 mm, feet 120 mm; inches are named)."""
    size_file = float(extent(v).max())
    size = size_file * factor
    lo, hi = STONE_SIZE_MM
    if lo <= size <= hi:
        return
    why = {"given": "as given", "file": "glTF is metres by specification" if fmt in ("glb", "gltf") else "as the file declares",
           "default": "the default: the file does not say"}[units_source]
    fits = sorted((u for u, k in UNITS.items() if 2.0 <= size_file * k <= 200.0 and u != unit_name),
                  key=lambda u: _atypicality(size_file * UNITS[u]))
    hint = f"if the file is in {fits[0]}, pass --units {fits[0]} (units={fits[0]!r})" if fits else "give its unit with --units (units=)"
    raise ParameterError(
        f"{name} is {_mm(size)} mm across read in {unit_name} ({why}), outside the {lo:g}-{hi:g} mm of a stone; {hint}"
    )


def _atypicality(size_mm: float) -> float:
    """How far a stone's size (mm) is from the middle of :data:`TYPICAL_STONE_MM`, in log scale:
    0 at its geometric mean (16 mm), larger further away, the same for half and double."""
    lo, hi = TYPICAL_STONE_MM
    return abs(math.log(size_mm / math.sqrt(lo * hi)))


def _units_warning(size_file: float, name: str) -> str | None:
    """A warning for a stone read in mm by default (the file does not say) that is probably in
    inches or centimetres, or None: it is under :data:`SMALL_STONE_MM` across, and the unit puts it
    in :data:`TYPICAL_STONE_MM`; the units that do are named, most typical size first.

    The size is the only clue: the shape of a stone is the same at any scale, and inches and
    centimetres both land within the 0.5-500 mm that :func:`_check_size` accepts. The threshold
    trades misses for false alarms. At 2.5 mm it catches the stones of 12.7-63.5 mm saved in
    inches (16 and 20 mm read 0.63 and 0.79 mm) and those of 5-25 mm saved in centimetres (16 and
    20 mm read 1.6 and 2.0 mm), and leaves alone a real 3 mm calibrated cabochon in mm. A stone of
    25 mm or more saved in centimetres reads 2.5 mm or more, as a real stone of that size would: no
    rule on size can tell them apart, and it is not warned about. A real stone under 2.5 mm (melee)
    is warned about; ``--units mm`` says the file is in mm and silences the warning."""
    if size_file >= SMALL_STONE_MM:
        return None
    lo, hi = TYPICAL_STONE_MM
    fits = sorted((u for u in ("in", "cm") if lo <= size_file * UNITS[u] <= hi),
                  key=lambda u: _atypicality(size_file * UNITS[u]))
    if not fits:
        return None
    options = [f"{UNIT_WORDS[u]}, {'pass ' if i == 0 else ''}--units {u} (units={u!r}) for {_mm(size_file * UNITS[u])} mm"
               for i, u in enumerate(fits)]
    return (f"{name} is {_mm(size_file)} mm across read in mm (the default: the file does not say), and cut stones are "
            f"rarely under {SMALL_STONE_MM:g} mm: if the file is in {'; in '.join(options)}; if it is in mm, --units mm "
            f"(units='mm') says so")


def _mm(x: float) -> str:
    """A length in mm for a message: 16000, 16.5, 0.016, and 1.6e+07, 1.6e-05 (never a hundred digits
    of a size scaled by a huge or tiny ``units`` factor)."""
    if 100 <= x < 1e6:
        return f"{x:.0f}"
    return f"{x:.3g}"


def _fingerprint(mesh: Any) -> tuple[int, int, int, int]:
    """Identity and content hashes of a trimesh's vertex and face arrays (trimesh caches the hashes
    of its tracked arrays until they change)."""
    return (id(mesh.vertices), hash(mesh.vertices), id(mesh.faces), hash(mesh.faces))


def mark_valid(mesh: Any) -> None:
    """Remember that this mesh, as it is now, passed :func:`validate_mesh` (load_mesh certifies it):
    a later check of the unchanged arrays costs two cached hashes instead of three sorts."""
    try:
        mesh._labcut_valid = _fingerprint(mesh)
    except Exception:  # noqa: BLE001 - not a trimesh with tracked arrays: it is checked in full
        pass


def validate_mesh(mesh: Any, name: str = "mesh") -> None:
    """Check a mesh given to the API directly (not through :func:`load_mesh`): a non-empty
    ``trimesh.Trimesh`` with finite vertices, closed (watertight), consistently wound, enclosing a
    positive volume (outward normals). Raises :class:`MeshError` with a one-line message that
    says how to fix it. Any size is accepted (mm)."""
    import trimesh

    if not isinstance(mesh, trimesh.Trimesh):
        raise MeshError(f"{name} must be a trimesh.Trimesh (labcut.load_mesh or labcut.cabochon), got {type(mesh).__name__}")
    if getattr(mesh, "_labcut_valid", None) is not None and mesh._labcut_valid == _fingerprint(mesh):
        return  # checked (or certified by load_mesh) and not changed since
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)
    if len(v) == 0 or len(f) == 0:
        raise MeshError(f"{name} is empty: it has no triangles")
    if not np.all(np.isfinite(v)):
        bad = int((~np.all(np.isfinite(v), axis=1)).sum())
        raise MeshError(f"{name} has {bad} non-finite (NaN or inf) vertices; load it with labcut.load_mesh, which repairs them")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshError(f"{name} has faces that refer to missing vertices")
    proper = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
    if not proper.all():  # triangles that repeat a vertex bound nothing: judge the solid without them
        if not proper.any():
            raise MeshError(f"{name} has only degenerate triangles")
        mesh = trimesh.Trimesh(vertices=v, faces=f[proper], process=False)
    if not mesh.is_watertight:
        raise MeshError(f"{name} is not closed (watertight): an open shell has no inside; load it with labcut.load_mesh, which closes holes")
    if not mesh.is_winding_consistent:
        raise MeshError(f"{name} has inconsistently wound faces; load it with labcut.load_mesh, which repairs them")
    volume = float(mesh.volume)
    if not volume > 0:
        raise MeshError(f"{name} encloses no positive volume (normals point inward, or it is flat); load it with labcut.load_mesh")
    if proper.all():
        mark_valid(mesh)


def save_mesh(mesh: Any, path: str | os.PathLike[str]) -> Path:
    """Write ``mesh`` (mm, labcut frame) to ``path``, format by suffix, atomically.

    ``.ply`` and ``.stl`` are binary, in mm, +Z face-up; ``.obj``, ``.off`` are text, in mm,
    +Z face-up; ``.3mf`` is a zipped XML model that declares millimetres. ``.glb`` is binary
    glTF as the glTF specification has it, so other tools see the stone at its true size and
    right side up: metres, +Y up, the front of the stone facing +Z (labcut's -Y), i.e.
    ``(x, y, z) mm -> (x, z, -y) / 1000 m``; :func:`load_mesh` turns it back.
    """

    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in WRITE_FORMATS:
        raise ParameterError(f"output file {out.name!r} must end in one of {', '.join(WRITE_FORMATS)}")
    with atomic_output(out, WRITE_FORMATS + tuple(s.upper() for s in WRITE_FORMATS)) as tmp:
        plain = mesh.copy()
        plain.metadata = {}
        if suffix == ".glb":

            to_gltf = np.eye(4)
            to_gltf[:3, :3] = up_rotation("+Y").T * 1e-3  # inverse of the +Y-up intake, mm -> m
            plain.apply_transform(to_gltf)
        data = plain.export(file_type=suffix[1:])
        if isinstance(data, str):
            data = data.encode()
        tmp.write_bytes(data)
    return out
