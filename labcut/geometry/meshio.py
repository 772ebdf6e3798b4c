"""Mesh intake and export: read, validate, repair, convert units, re-centre.

:func:`load_mesh` reads STL, OBJ, PLY, OFF, GLB/GLTF and 3MF through trimesh and
returns a validated :class:`trimesh.Trimesh` in mm, in the labcut frame (DESIGN.md
§3: +Z face-up, base on z = 0). A mesh labcut accepts is

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
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshError, ParameterError

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
UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "um": 1e-3, "in": 25.4}

#: largest share of the surface that hole patches may make up
MAX_PATCH_FRACTION = 0.2

#: relative volume gap between a mesh and its convex hull below which it is convex
CONVEX_RTOL = 1e-6


@dataclass
class MeshReport:
    """What :func:`load_mesh` found and did. Lengths in mm, in the output frame.

    Attributes:
        source: the file read.
        format: the file type (``"stl"``, ``"ply"``, ...).
        units: the file's unit (``"mm"``, ``"in"``, ... or ``"x<factor>"``).
        scale_to_mm: factor applied to the file's coordinates.
        translation_mm: offset added after scaling (re-centring), or zeros.
        repairs: one sentence per repair made to the geometry or topology.
        notes: other things worth knowing (coincident vertices merged, ...).
        convex: the solid equals its convex hull (to :data:`CONVEX_RTOL`).
        watertight: always True for a returned mesh.
        triangles, vertices: counts of the returned mesh.
        bodies: number of separate closed shells.
    """

    source: str
    format: str
    units: str
    scale_to_mm: float
    translation_mm: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    repairs: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    convex: bool = False
    watertight: bool = True
    triangles: int = 0
    vertices: int = 0
    bodies: int = 1

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON dictionary of the report."""
        return asdict(self)


def _one_line(text: object, limit: int = 200) -> str:
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


# ----------------------------------------------------------------------------- helpers
def is_convex_mesh(mesh: Any, rtol: float = CONVEX_RTOL) -> bool:
    """True when a closed mesh is convex: its volume equals that of its convex hull.

    The hull is computed by manifold3d (QuickHull, double precision). A mesh of
    several bodies is never convex.
    """
    import manifold3d as m3

    v = np.ascontiguousarray(np.asarray(mesh.vertices, dtype=np.float64))
    if len(v) < 4:
        return False
    vol = abs(_signed_volume(v, np.asarray(mesh.faces)))
    hull = m3.Manifold.hull_points(v)
    hv = float(hull.volume())
    if hv <= 0:
        return False
    return (hv - vol) <= rtol * hv


def _signed_volume(v: np.ndarray, f: np.ndarray, labels: np.ndarray | None = None, count: int = 1) -> Any:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    det = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    if labels is None:
        return float(det.sum())
    return np.bincount(labels, weights=det, minlength=count)


def _face_components(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, int]:
    """Label faces by connected component (faces sharing a vertex): ``(labels, count)``.

    Min-label propagation over the edges with pointer jumping (numpy only).
    """
    e = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    lab = np.arange(n_vertices)
    while True:
        m = np.minimum(lab[e[:, 0]], lab[e[:, 1]])
        new = lab.copy()
        np.minimum.at(new, e[:, 0], m)
        np.minimum.at(new, e[:, 1], m)
        new = new[new]
        if np.array_equal(new, lab):
            break
        lab = new
    _, inv = np.unique(lab[faces[:, 0]], return_inverse=True)
    inv = inv.ravel().astype(np.int64)
    return inv, int(inv.max()) + 1


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


def _edge_use(faces: np.ndarray) -> tuple[int, int]:
    """(boundary edges, edges shared by more than two faces)."""
    key = np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, cnt = np.unique(key, axis=0, return_counts=True)
    return int((cnt == 1).sum()), int((cnt > 2).sum())


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


def _read(path: Path, fmt: str) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    if fmt == "stl":
        _check_stl(path)
    if fmt == "gltf":
        with open(path, "rb") as fh:
            if fh.read(256).lstrip()[:1] != b"{":
                raise MeshError(f"cannot read {path.name} as GLTF: it is not a JSON glTF file (binary glTF ends in .glb)")

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
    return v, f


def _units_scale(units: str | float) -> tuple[str, float]:
    if isinstance(units, str):
        key = units.strip().lower()
        if key in ("µm", "micron", "microns"):
            key = "um"
        if key in ("inch", "inches"):
            key = "in"
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

    The result is an oriented, outward-wound, closed 2-manifold certified by
    manifold3d. Raises :class:`MeshError` when that cannot be reached (or when
    ``repair`` is False and anything needed repairing).
    """
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
    _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
    if len(first) < len(f):
        fix(f"removed {len(f) - len(first)} duplicate faces")
        f = f[np.sort(first)]
    area2 = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    scale = float(np.ptp(v[np.unique(f)], axis=0).max())
    if scale <= 0:
        raise MeshError(f"{name} has no extent (all vertices coincide)")
    flat = area2 <= 1e-12 * scale * scale
    if flat.all():
        raise MeshError(f"{name} has only zero-area triangles")

    n_boundary, n_nonmanifold = _edge_use(f)
    if n_nonmanifold:
        raise MeshError(
            f"{name} is not a 2-manifold: {n_nonmanifold} edges are shared by three or more faces; "
            "fix it in a mesh editor (e.g. separate the touching parts)"
        )

    # consistent winding
    original = f.copy()
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if not mesh.is_winding_consistent:
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
        patch_area = 0.5 * np.linalg.norm(
            np.cross(v[patch[:, 1]] - v[patch[:, 0]], v[patch[:, 2]] - v[patch[:, 0]]), axis=1
        ).sum()
        own_area = 0.5 * np.linalg.norm(
            np.cross(v[original[:, 1]] - v[original[:, 0]], v[original[:, 2]] - v[original[:, 0]]), axis=1
        ).sum()
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
    labels, count = _face_components(f, len(v))
    vols = _signed_volume(v, f, labels, count)
    inward = vols < 0
    if inward.any():
        flip = inward[labels]
        f = f.copy()
        f[flip] = f[flip][:, ::-1]
    # report orientation changes against the file's own faces
    flipped = ~_same_orientation(original, f[: len(original)])
    if flipped.all():
        fix("inverted all faces: the normals pointed inward")
    elif flipped.any():
        fix(f"reversed {int(flipped.sum())} of {len(original)} faces whose winding disagreed with the rest")

    man = m3.Manifold(m3.Mesh64(vert_properties=np.ascontiguousarray(v), tri_verts=np.ascontiguousarray(f, dtype=np.uint64)))
    status = man.status()
    if status != m3.Error.NoError:
        raise MeshError(f"{name} is not a closed oriented 2-manifold (manifold3d: {status.name})")
    out = man.to_mesh64()
    v2 = np.asarray(out.vert_properties)[:, :3].astype(np.float64)
    f2 = np.asarray(out.tri_verts).astype(np.int64)
    ext = np.ptp(v2, axis=0) if len(v2) else np.zeros(3)
    if len(f2) == 0 or man.volume() <= 1e-9 * max(float(np.prod(ext)), 1e-300) or ext.min() <= 0:
        raise MeshError(f"{name} encloses no volume (a flat or empty surface)")
    if len(f2) < len(f):
        fix(f"collapsed {len(f) - len(f2)} degenerate (zero-area or sliver) triangles")
    elif flat.any():
        notes.append(f"kept {int(flat.sum())} near-zero-area triangles")
    bodies = int(len(man.decompose())) if count > 1 else 1
    return v2, f2, repairs, notes, bodies


def load_mesh(
    path: str | os.PathLike[str],
    units: str | float = "mm",
    recentre: bool = True,
    repair: bool = True,
):
    """Read, validate and repair a stone mesh; return a ``trimesh.Trimesh`` in mm.

    Args:
        path: an STL, OBJ, PLY, OFF, GLB/GLTF or 3MF file. Multi-object files
            (GLB scenes, 3MF) are flattened into one mesh.
        units: the file's length unit, ``"mm"`` (default), ``"cm"``, ``"m"``,
            ``"um"``, ``"in"``, or a number of mm per file unit; coordinates are
            converted to mm.
        recentre: translate so the bounding box is centred on the Z axis and
            its bottom (the base) lies on z = 0. The file's +Z stays face-up.
        repair: repair what can be repaired (default); False makes every defect
            an error.

    Returns:
        The validated mesh; ``mesh.metadata["labcut"]`` is a
        :meth:`MeshReport.to_dict` (``repairs``, ``notes``, ``convex``, ...).

    Raises:
        MeshError: missing, empty, unreadable or irreparable file.
        ParameterError: bad ``units``.
    """
    import trimesh

    unit_name, factor = _units_scale(units)
    p = Path(path)
    if not p.exists():
        raise MeshError(f"mesh file {str(path)!r} does not exist")
    if p.is_dir():
        raise MeshError(f"{str(path)!r} is a folder, not a mesh file")
    fmt = READ_FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise MeshError(
            f"{p.name}: unsupported mesh format {p.suffix or '(no suffix)'!r}; use one of {', '.join(READ_FORMATS)}"
        )
    if p.stat().st_size == 0:
        raise MeshError(f"{p.name} is empty (0 bytes)")
    v, f = _read(p, fmt)
    v, f, repairs, notes, bodies = validate_arrays(v, f, name=p.name, repair=repair)
    v = v * factor
    shift = np.zeros(3)
    if recentre:
        lo, hi = v.min(axis=0), v.max(axis=0)
        shift = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
        v = v + shift
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):  # pragma: no cover
        raise MeshError(f"{p.name} could not be made a closed, outward-wound solid")
    report = MeshReport(
        source=str(p),
        format=fmt,
        units=unit_name,
        scale_to_mm=factor,
        translation_mm=[float(x) for x in shift],
        repairs=repairs,
        notes=notes,
        convex=is_convex_mesh(mesh),
        watertight=True,
        triangles=len(f),
        vertices=len(v),
        bodies=bodies,
    )
    mesh.metadata["labcut"] = {"kind": "loaded", **report.to_dict()}
    return mesh


def save_mesh(mesh: Any, path: str | os.PathLike[str]) -> Path:
    """Write ``mesh`` (mm) to ``path``, format by suffix, atomically.

    ``.ply`` and ``.stl`` are binary; ``.glb`` is binary glTF; ``.obj``, ``.off``
    are text; ``.3mf`` is a zipped XML model in millimetres.
    """
    from ..fileio import atomic_output

    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in WRITE_FORMATS:
        raise ParameterError(f"output file {out.name!r} must end in one of {', '.join(WRITE_FORMATS)}")
    with atomic_output(out, WRITE_FORMATS + tuple(s.upper() for s in WRITE_FORMATS)) as tmp:
        plain = mesh.copy()
        plain.metadata = {}
        data = plain.export(file_type=suffix[1:])
        if isinstance(data, str):
            data = data.encode()
        tmp.write_bytes(data)
    return out
