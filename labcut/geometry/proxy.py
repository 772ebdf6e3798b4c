"""Coarse stand-ins of big meshes (a 3D scan of millions of triangles) for low-resolution renders.

The effect planner's pilot renders (:func:`labcut.planner.measured_interreflection`) are
64 x 64 px: a 5 M-triangle scan puts hundreds of triangles in every pixel, and shading and
tracing them all (trimesh's smooth shading of the whole mesh, three Mitsuba scenes) would
dominate a first plan, where the pilots need only the shape at a fraction of a pixel.
:func:`clustered_proxy` gives that shape: vertex clustering on a regular grid (every vertex of a
cell merged into their mean), in one pass of sorts over the vertices and faces.

Units: mm, the mesh frame.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import MeshError, ParameterError
from .stone import RECORD_KEY, Stone


#: grids of at most this many cells find their occupied cells with a table over the grid (a byte
#: and an int32 per cell: 160 MB at most) instead of sorting every vertex's cell key; the same
#: cells and the same order either way
DENSE_CELLS = 1 << 25


def clustered_proxy(mesh: Any, cell_mm: float) -> Any:
    """A coarse copy of ``mesh`` (a ``trimesh.Trimesh``, mm) for renders whose pixels are several
    times ``cell_mm`` across: the vertices of each cube of a grid of side ``cell_mm`` (from the
    mesh's lower bounds) merged into their mean position, the faces that collapse (two corners
    in one cell) and repeated faces dropped, the winding of the rest kept. Every proxy vertex
    lies within ``cell_mm`` x sqrt(3) of the vertices it replaces. Where two sheets of the surface
    run closer than a cell the proxy can join them (a thin part renders as a slab, its edges
    possibly non-manifold); renders take its triangles as they come. The copy is not certified as
    a closed solid (``validate_mesh`` checks it in full; :func:`labcut.planner.pilot_mesh` certifies
    its copies as the checked mesh's stand-in for the pilots alone) and gets a copy of the mesh's
    metadata (units, labcut's convexity and faceting flags), marked ``labcut["proxy_cell_mm"]``.
    Raises :class:`ParameterError` for a cell that is not a positive number or that splits the mesh
    into more than 2^62 cells, :class:`MeshError` for an empty mesh or non-finite vertices."""

    import trimesh

    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshError("the mesh is empty or not a trimesh.Trimesh (load it with labcut.load_mesh)")
    try:
        cell = float(cell_mm)
    except (TypeError, ValueError):
        cell = math.nan
    if not np.isfinite(cell) or cell <= 0.0:
        raise ParameterError(f"cell_mm must be a positive number of millimetres, got {cell_mm!r}")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.isfinite(v).all():
        raise MeshError("the mesh has non-finite vertex coordinates (NaN or inf): load it with labcut.load_mesh")
    f = np.asarray(mesh.faces, dtype=np.int64)
    span = (v.max(axis=0) - v.min(axis=0)) / cell
    if float(np.log2(np.floor(span) + 1.0).sum()) >= 62.0:  # the cells' keys must fit an int64
        raise ParameterError(f"cell_mm = {cell:g} mm splits this mesh into more than 2^62 cells: use larger cells")
    grid = np.floor((v - v.min(axis=0)) / cell).astype(np.int64)
    dims = grid.max(axis=0) + 1
    key = (grid[:, 0] * dims[1] + grid[:, 1]) * dims[2] + grid[:, 2]
    del grid
    total = int(np.prod(dims))
    if total <= DENSE_CELLS:  # the occupied cells by a table over the grid: no sort of every vertex's key
        present = np.zeros(total, dtype=bool)
        present[key] = True
        cells = np.flatnonzero(present)
        rank = np.cumsum(present, dtype=np.int64 if total > np.iinfo(np.int32).max else np.int32) - 1
        del present
        inverse = rank[key].astype(np.int64)
        del rank
    else:
        cells, inverse = np.unique(key, return_inverse=True)
    del key
    inverse = inverse.ravel()
    count = np.bincount(inverse, minlength=len(cells)).astype(np.float64)
    centre = np.stack([np.bincount(inverse, weights=v[:, k], minlength=len(cells)) for k in range(3)], axis=1)
    centre /= count[:, None]
    faces = inverse[f]
    del f
    proper = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])
    faces = faces[proper]
    if len(faces) == 0:
        raise ParameterError(f"a grid of {cell:g} mm cells leaves no triangle of this mesh: use smaller cells")
    # a face and its repeats (any rotation of the same corners, the same winding) kept once
    lo = np.argmin(faces, axis=1)
    rot = np.stack([faces[np.arange(len(faces)), (lo + k) % 3] for k in range(3)], axis=1)
    _, first = np.unique(rot, axis=0, return_index=True)
    faces = faces[np.sort(first)]
    used = np.zeros(len(centre), dtype=bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    proxy = trimesh.Trimesh(vertices=centre[used], faces=remap[faces], process=False)
    stone = Stone.of(mesh)
    if stone.name is not None:
        proxy.metadata["name"] = stone.name
    proxy.metadata[RECORD_KEY] = {**stone.metadata(), "proxy_cell_mm": cell}
    return proxy
