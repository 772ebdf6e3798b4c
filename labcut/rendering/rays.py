"""Ray queries against a stone (mesh frame, mm): does a ray from a surface point escape the stone?

One Mitsuba scene of the bare mesh answers every query (``scene.ray_test``, shadow rays: no
shading, no BSDF): :func:`occlusion_scene`, built once per mesh. Used by the effect planner (how
much of the sky above the surface is the stone itself) and by the surface-sample estimator's
occlusion (``labcut.orientation.problem``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..geometry.solid import column_bounds
from ..geometry.stone import Stone
from ..geometry.surface import sample_surface, unit_normals


def escapes(mesh: Any, origins: np.ndarray, normals: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """(N, D) bool: the ray from each point (offset along its normal by 1e-4 of the mesh's
    diagonal) towards each distant direction leaves the mesh without meeting it again.

    ``origins``/``normals``: (N, 3) surface points and their outward normals; ``dirs``: (D, 3)
    unit directions, all in the mesh frame."""
    origins, normals, dirs = (np.asarray(x, dtype=np.float64).reshape(-1, 3) for x in (origins, normals, dirs))
    n, d = len(origins), len(dirs)
    eps = surface_offset(mesh)
    return escapes_paired(mesh, np.repeat(origins + eps * normals, d, axis=0), np.tile(dirs, (n, 1))).reshape(n, d)


def surface_offset(mesh: Any) -> float:
    """1e-4 of the mesh's bounding-box diagonal (``mesh.extents``, the same value: the bounds of
    the vertices the faces use), the distance ray origins are lifted off the surface. Once per mesh,
    from the coordinate columns (trimesh's bounds reduce rows of three: half a second on a
    five-million-triangle mesh)."""
    stone = Stone.of(mesh)
    mesh = stone.mesh

    def build() -> float:
        v = np.asarray(mesh.vertices, dtype=np.float64)
        used = np.zeros(len(v), dtype=bool)
        used[np.asarray(mesh.faces)] = True
        lo, hi = column_bounds(v if used.all() else v[used])
        return 1e-4 * float(np.linalg.norm(hi - lo))

    return stone.cached("ray_surface_offset", build)


#: the colour mode of the variant the ray queries run in when no JIT variant of this machine's
#: backend is active: a shadow ray's answer is the triangles' alone, the same in every mode, and
#: the flash estimators' renders (the planner's pilots, the render estimator) run in mono too, so a
#: carving's recommendation never switches variant (each switch reloads Mitsuba's Python modules:
#: 0.06-0.1 s, five of them in a carving's first plan when the rays ran in rgb) and builds its ray
#: scene once. Where such a variant is active already (an rgb render came first: the explorer, a
#: recommendation with its render) the rays run in it: no switch (:func:`ray_variant`)
RAY_MODE = "mono"

#: Mitsuba variants whose ray scene is an instance of a shape group (:func:`occlusion_scene`)
INSTANCED = ("llvm_", "scalar_")


def occlusion_scene(mesh: Any) -> Any:
    """A Mitsuba scene of the mesh's bare triangles for ``ray_test`` (shadow rays), once per mesh and
    variant (kept by the stone: :meth:`labcut.geometry.stone.Stone.cached`).

    On the CPU (Embree) the triangles sit in a shape group seen through one instance of identity
    transform: Mitsuba builds its top-level scene at Embree's highest build quality (spatial
    splits, slow on millions of triangles) but a shape group's at the default (binned SAH: faster
    to build, less memory), and a ray's hit test is the triangles' own, whatever
    tree finds them: the same answers (tests). The arrays go to Mitsuba as float32 positions and
    uint32 indices, flat, one copy each. On the GPU (OptiX) the mesh is the scene's own shape."""
    import mitsuba as mi

    stone = Stone.of(mesh)
    return stone.cached(f"occlusion_scene_{mi.variant()}", lambda: _build_occlusion_scene(stone.mesh))


def _build_occlusion_scene(mesh: Any, instanced: bool | None = None) -> Any:
    import mitsuba as mi

    v = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    f = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    stone = mi.Mesh("stone", vertex_count=len(v), face_count=len(f), has_vertex_normals=False, props=mi.Properties())
    params = mi.traverse(stone)
    params["vertex_positions"] = mi.Float(v.ravel())
    params["faces"] = mi.UInt32(f.ravel())
    params.update()
    del v, f, params
    stone.set_bsdf(mi.load_dict({"type": "diffuse"}))
    if instanced is None:
        instanced = mi.variant().startswith(INSTANCED)
    if not instanced:
        return mi.load_dict({"type": "scene", "stone": stone})
    return mi.load_dict({"type": "scene", "group": {"type": "shapegroup", "stone": stone},
                         "stone": {"type": "instance", "shapegroup": {"type": "ref", "id": "group"}}})


def ray_variant() -> str:
    """The variant shadow rays run in, selected: the active one when it is a JIT variant of this
    machine's backend (any colour mode: the answers are the triangles'), else :data:`RAY_MODE`'s.
    A switch of variant costs 0.06-0.1 s (Mitsuba reloads its Python modules), so a ray query
    never switches away from a JIT variant in use."""
    import mitsuba as mi

    from ..backend import device, set_variant

    current = mi.variant()
    if current is not None and current.startswith(f"{device()}_ad_"):
        return current
    return set_variant(RAY_MODE)


def escapes_paired(mesh: Any, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """(M,) bool: ray ``i`` from ``origins[i]`` along ``dirs[i]`` (mesh frame) meets no part of
    the mesh. The origins are used as given (offset them off the surface first)."""
    import drjit as dr
    import mitsuba as mi

    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(dirs, dtype=np.float64).reshape(-1, 3)
    ray_variant()
    scene = occlusion_scene(mesh)  # the bare triangles, built once per mesh
    ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(w[:, 0], w[:, 1], w[:, 2]))
    hit = scene.ray_test(ray)
    dr.eval(hit)
    return ~np.array(hit, dtype=bool)


def self_view_fraction(mesh: Any, points: int = 1024, directions: int = 64, seed: int = 0) -> float:
    """Cosine-weighted share of the hemisphere above the surface that is the stone itself.

    The mean, over ``points`` area-uniform surface samples, of the fraction of cosine-weighted
    directions (about each face's outward normal) whose ray meets the stone again. 0 for a
    convex stone; for a carving it bounds how much of the light reaching the surface arrives
    by way of another part of it (times that part's reflectance)."""
    stone = Stone.of(mesh)
    mesh = stone.mesh
    rng = np.random.default_rng(seed)
    # trimesh.sample.sample_surface's points, without its copies of every face's corners
    pts, face = sample_surface(mesh, int(points), seed=int(rng.integers(2**31)), areas=stone.face_areas)
    pts = np.asarray(pts, dtype=np.float64)
    n = unit_normals(np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)[face]])  # the picked faces' only
    # a cosine-weighted direction set about +Z, rotated onto each point's normal
    u1, u2 = rng.random(directions), rng.random(directions)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - u1))], axis=1)
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(n, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    world = local[None, :, 0:1] * t[:, None] + local[None, :, 1:2] * b[:, None] + local[None, :, 2:3] * n[:, None]
    eps = surface_offset(mesh)
    origins = np.repeat(pts + eps * n, directions, axis=0)
    free = escapes_paired(mesh, origins, world.reshape(-1, 3))
    return float(1.0 - free.mean())
