"""The volumetric flash problem: light mirrored below the surface, leaving elsewhere.

The surface-sample problem (:mod:`labcut.orientation.problem`) mirrors the light where it entered:
the schiller of a point is lit through that point's own surface. In a stone the stack is deep
(:attr:`labcut.Labradorite.flash_depth_mm`; the presets' stack is 0.93 mm): light refracted in at
``p`` is mirrored by the lamellae at some depth and leaves at another point ``q``, through a
steeper part of a dome, or not at all where the stone is thinner than the stack. This module builds
the same kind of :class:`~labcut.orientation.problem.FlashProblem` (triples of a mirror orientation
``h`` and a factor ``c``, per (point, view) pair, the same weights and objectives) with the light
carried through the volume, so that the sample estimator's map, optimiser, tolerances and error bars
answer it unchanged.

Each (exit point ``q``, view ``v``) pair is traced backwards. ``b`` is the internal direction that
refracts into ``v`` at ``q`` (as on the surface). For each light ``l`` of the pose and each of
``depths`` depth samples ``u`` (stratified, rotated per pair and light), the path
``p -> r -> q`` is found with (exit leg ``r = q - t b``, entry leg ``p = r + s a``):

- ``a`` refracts into ``l`` at the entry point ``p`` (shading normal there), ``h = normalize(a + b)``
  the lamella orientation that mirrors it into ``b``;
- the reflection lies at depth ``z = s |a·h|`` below the entry (along the lamella normal), ``z`` the
  ``u``-quantile of the stack's depth law (:func:`labcut.physics.depth.depth_law` at ``|a·h|``);
- ``p`` is where the ray from ``r`` along ``a`` leaves the stone (a Mitsuba ray cast).

The three unknowns (``t``, ``p``, ``a``) are solved by :data:`ITERATIONS` fixed-point steps from the
surface answer (``p = q``): each casts one ray from ``r`` along ``a``, takes ``a`` from the normal at
the hit and scales ``t`` by the wanted over the found entry length (exact in one step on a flat
face). A path counts when its exit leg stays inside the stone (``t`` below the distance from ``q``
to the far side along ``-b``: the stone holds the depth), its entry leg lands on a surface the
light faces, the last step moved the entry by less than :data:`CONVERGED` of its length and, on a
stone that is not convex with occlusion on, nothing hides ``p`` from the light.

Its factor is the surface model's, with the light's terms at the entry and the view's at the exit:

    c = E T(n_p·l) (n_p·l) T(n_q·v) R_Y(|a·h|) / (4 |a·h| max(a·n_p, b·n_q) η² L_ref) / depths,

so that on a flat face thicker than the stack it is the surface triple's exactly (``p`` and ``q``
share their normal; every depth counts). Left out, and measured against the volumetric reference
(benchmarks/volume_reference.py, docs/physics-accuracy.md): light mirrored more than once between
lamellae, Fresnel reflections inside the stone, and the focusing of the beam by the curved surface
between ``p`` and ``q`` (of order depth over the inside focal length, a few per cent).
Directions are unit vectors in the mesh frame, lengths in mm.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..colour import luminance_table
from ..errors import ParameterError
from ..geometry import surface as surface_module
from ..geometry.stone import Stone
from ..geometry.surface import FAST_SMOOTH_FACES, corner_incidence, smooth_corner_normals, unit_normals
from ..physics import schiller as lobe
from ..physics.depth import depth_law
from ..physics.material import Labradorite
from ..physics.ops import NUMPY
from ..rendering.rays import escapes_paired, occlusion_scene, ray_variant, surface_offset
from ..scene import Setting
from ..scene.quality import Quality
from .kernels import DEFAULT_KERNELS, KernelOptions
from .problem import FlashProblem, check_problem_inputs, surface_samples, view_pairs, visible_areas
from .radiance import flash_threshold, reference_radiance, view_terms

#: depth samples per (pair, light) (stratified; each pair's and light's strata rotated by a
#: golden-ratio sequence, so that neighbouring pairs and lights fill each other's gaps). One is
#: enough: against four, the answers on the bundled ovals and the carving under a front lamp moved by
#: at most 0.16° and their energy by 0.4 % (docs/accuracy.md, "The volume estimator's cost")
DEPTHS = 1
#: fixed-point steps of each path: against eight, three lost 1.1 % of the high dome's energy under the
#: front spot (draft; the paths still moving are bright ones), four 0.4 % (tests/test_volume.py)
ITERATIONS = 4
#: a path counts when its last step moved the entry leg's length by less than this share
CONVERGED = 0.05
#: (pair, light, depth) paths traced per chunk (a few hundred bytes each)
CHUNK = 1 << 19
#: the most paths a problem traces (about three seconds on two cores). A scene with more (pair, light)
#: combinations (a moving stone under a room's or a map's many directions: 13 poses x a hundred
#: lights) draws each pair's lights instead, in proportion to their irradiance, as many per pair
#: as the budget allows and at least one, each weighted by the pose's irradiance over the draws
#: (an unbiased estimate of the sum over lights; docs/accuracy.md measures what it moves)
PATH_BUDGET = 1_000_000
#: the budget of the error bars' finer problems (their difference from the answer's problem is the
#: discretisation bar: the draws' own noise can only widen it)
BAR_PATH_BUDGET = PATH_BUDGET // 4


@dataclass(frozen=True)
class _Hits:
    """Ray hits: distance (inf: none), shading and geometric normals at the hit (mesh frame)."""

    t: np.ndarray
    n_sh: np.ndarray
    n_geo: np.ndarray


class VolumeRays:
    """Ray casts from inside a stone to its surface, with the smooth shading normal at each hit (as
    the surface samples and the renderer shade: the vertex normals of the stone's smooth-shaded
    split copy, or the split normals of the hit faces for a mesh too big to copy). The casts run on
    the stone's one ray scene (:func:`labcut.rendering.rays.occlusion_scene`, kept by the stone), so
    that the volume estimator adds no Mitsuba scene of its own."""

    def __init__(self, mesh: Any) -> None:
        self.stone = Stone.of(mesh)
        ray_variant()
        self.scene = occlusion_scene(self.stone.mesh)
        self.big = len(self.stone.mesh.faces) > FAST_SMOOTH_FACES
        self.vertices = np.asarray(self.stone.mesh.vertices, dtype=np.float64)
        self.faces = np.asarray(self.stone.mesh.faces, dtype=np.int64)
        self.face_normals = unit_normals(self.vertices[self.faces])  # once, not per hit
        if not self.big:
            self.corners = corner_normals(self.stone)
        else:  # the hits' split normals: the corners around them found through an index, not a pass per cast,
            # and each face's computed once (a face's corner normals depend on its own vertices' fans alone)
            self.incidence = corner_incidence(self.faces, len(self.vertices))
            self._slot = np.full(len(self.faces), -1, dtype=np.int64)
            self._kept = np.empty((0, 3, 3))
            self._n_kept = 0

    @classmethod
    def of(cls, mesh: Any) -> VolumeRays:
        """The stone's rays, made once per stone and Mitsuba variant (its face and corner normals
        are not computed again for the error bars' problems, the variants' and the planner's)."""
        import mitsuba as mi

        stone = Stone.of(mesh)
        ray_variant()
        return stone.cached(f"volume_rays_{mi.variant()}", lambda: cls(stone.mesh))

    def _big_corners(self, face: np.ndarray) -> np.ndarray:
        """(k, 3, 3) split corner normals of ``face`` on a mesh too big to copy: those of faces not met
        before computed (:func:`~labcut.geometry.surface.smooth_corner_normals`) and kept, only for the
        faces the rays meet."""
        uniq = np.unique(face)
        new = uniq[self._slot[uniq] < 0]
        if new.size:
            made = smooth_corner_normals(self.stone.mesh, self.stone.shading_angle_deg, new, self.incidence)
            need = self._n_kept + len(new)
            if need > len(self._kept):  # grow by doubling: each face copied a bounded number of times
                grown = np.empty((max(need, 2 * len(self._kept)), 3, 3))
                grown[: self._n_kept] = self._kept[: self._n_kept]
                self._kept = grown
            self._kept[self._n_kept:need] = made
            self._slot[new] = np.arange(self._n_kept, need)
            self._n_kept = need
        return self._kept[self._slot[face]]

    def cast(self, origins: np.ndarray, dirs: np.ndarray) -> _Hits:
        """The first surface hit of each ray (``origins`` and unit ``dirs``, (N, 3))."""
        import drjit as dr
        import mitsuba as mi

        o, w = np.asarray(origins, dtype=np.float64), np.asarray(dirs, dtype=np.float64)
        ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(w[:, 0], w[:, 1], w[:, 2]))
        pi = self.scene.ray_intersect_preliminary(ray)
        # a miss's face and (u, v) are whatever the ray tracer left there (a signalling NaN among
        # them made numpy's conversion warn): face 0's corner instead, selected on the device, unused
        valid = pi.is_valid()
        prim = dr.select(valid, pi.prim_index, 0)
        prim_uv = dr.select(valid, pi.prim_uv, mi.Point2f(0.0, 0.0))
        dr.eval(pi.t, prim, prim_uv)
        t = np.array(pi.t, dtype=np.float64)
        hit = np.isfinite(t)
        face = np.array(prim, dtype=np.int64)  # a miss: 0 already (the device's select)
        uv = np.array(prim_uv, dtype=np.float64)
        bary = np.stack([1.0 - uv[0] - uv[1], uv[0], uv[1]], axis=1)
        n_geo = self.face_normals[face]
        if self.big:
            corners = self._big_corners(face)
        else:
            corners = self.corners[face]
        n_sh = np.einsum("ij,ijk->ik", bary, corners)
        n_sh /= np.maximum(np.linalg.norm(n_sh, axis=1, keepdims=True), 1e-300)
        t[~hit] = np.inf
        return _Hits(t, n_sh, n_geo)


def corner_normals(stone: Stone) -> np.ndarray:
    """(faces, 3, 3) smooth shading normals at the corners of each of the stone's faces, in the
    mesh's face order: the vertex normals of its smooth-shaded split copy (the copy's face ``i`` is
    the mesh's face ``order[i]``, trimesh's record of the split's patches). For a mesh of at most
    :data:`~labcut.geometry.surface.FAST_SMOOTH_FACES` faces (a bigger one is not copied: its split
    normals are computed at the faces asked, :func:`~labcut.geometry.surface.smooth_corner_normals`)."""
    faces = np.asarray(stone.mesh.faces, dtype=np.int64)
    split = stone.smooth_split()
    order = np.concatenate([np.asarray(c, dtype=np.int64) for c in split.metadata["original_components"]])
    corners = np.empty((len(faces), 3, 3))
    corners[order] = np.asarray(split.vertex_normals, dtype=np.float64)[np.asarray(split.faces)]
    return corners


def convex_thickness(mesh: Any, points: np.ndarray, dirs: np.ndarray, chunk: int = 128) -> np.ndarray:
    """How far each ray (``points`` inside a convex ``mesh``, unit ``dirs``) runs to the surface: the
    nearest of the faces' planes it meets going out (a convex solid is the meet of its faces'
    half-spaces), without a ray scene; float32 sums (a few micrometres on a centimetre stone)."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    n = np.asarray(mesh.face_normals, dtype=np.float64)
    h = np.einsum("ij,ij->i", n, v[faces[:, 0]]).astype(np.float32)
    n32 = np.ascontiguousarray(n.T, dtype=np.float32)
    out = np.empty(len(points))
    with np.errstate(divide="ignore", invalid="ignore"):
        for s0 in range(0, len(points), chunk):
            p = np.asarray(points[s0:s0 + chunk], dtype=np.float32)
            along = np.asarray(dirs[s0:s0 + chunk], dtype=np.float32) @ n32  # (chunk, faces)
            t = (h[None, :] - p @ n32) / along
            t[along <= 1e-6] = np.inf
            out[s0:s0 + chunk] = t.min(axis=1)
    return out


#: the rotations of :func:`depth_strata`: the golden ratio's for the depths, √2's for the lights a pair
#: draws. Two sequences of one index with the same rotation are one number shifted (the light drawn
#: would decide the depth): 1, φ and √2 are rationally independent, so the pairs (depth, light) of
#: successive paths fill the unit square
DEPTH_ROTATION = (math.sqrt(5.0) - 1.0) / 2.0
LIGHT_ROTATION = math.sqrt(2.0) - 1.0


def depth_strata(n: int, depths: int, salt: int, rotation: float = DEPTH_ROTATION) -> np.ndarray:
    """(n, depths) quantiles in (0, 1): stratum ``k`` of path group ``i`` at ``(k + frac(i α + salt α²)) /
    depths`` (``α``: ``rotation``, the golden ratio's by default): stratified within a group, rotated
    between groups."""
    a = float(rotation)
    shift = np.mod(np.arange(n, dtype=np.float64) * a + salt * a * a, 1.0)
    return (np.arange(depths)[None, :] + shift[:, None]) / depths


def build_volume_problem(
    mesh: Any,
    material: Labradorite,
    quality: Quality | str = "standard",
    tau: float = 0.1,
    seed: int = 0,
    *,
    settings: list[Setting],
    occlusion: bool | None = None,
    depths: int = DEPTHS,
    iterations: int = ITERATIONS,
    path_budget: int = PATH_BUDGET,
    n_points: int | None = None,
    kernels: KernelOptions = DEFAULT_KERNELS,
) -> FlashProblem:
    """The volumetric flash problem (module docstring) of ``mesh`` under the poses ``settings``
    (:meth:`labcut.Scenario.settings`), with the surface samples, pairs, weights, flash threshold and
    units of :func:`~labcut.orientation.problem.build_problem`'s; ``occlusion`` as there (default:
    when the stone is not convex). ``depths``: depth samples per (pair, light); ``iterations``: the
    fixed-point steps of each path; ``path_budget``: the most paths before each pair's lights are
    drawn (:data:`PATH_BUDGET`)."""
    if not settings:
        raise ParameterError("build_volume_problem needs at least one setting")
    if not (isinstance(depths, int) and 1 <= depths <= 64):
        raise ParameterError(f"depths must be a whole number in [1, 64], got {depths!r}")
    if not (isinstance(iterations, int) and 1 <= iterations <= 16):
        raise ParameterError(f"iterations must be a whole number in [1, 16], got {iterations!r}")
    quality = Quality.coerce(quality)
    mesh = check_problem_inputs(mesh, seed, tau)
    count = int(n_points or quality.surface_points)
    samples = surface_samples(mesh, count, int(seed), quality.surface_sampling)
    points, n_geo, n_sh, convex = samples.points, samples.n_geo, samples.n_sh, samples.convex
    occluded = not (convex if occlusion is None else not occlusion)
    table = luminance_table(material)
    law = depth_law(material)
    eta = float(material.n_surface)
    l_ref = reference_radiance(material, 1.0)
    if not l_ref > 0:
        raise ParameterError("the material reflects nothing at normal incidence: no flash can be scored")
    rays = VolumeRays.of(mesh)
    eps = surface_offset(mesh)
    pose_w = np.array([float(st.weight) for st in settings])
    pose_w = pose_w / pose_w.sum()
    area_per_point = float(Stone.of(mesh).face_areas.sum()) / count

    h_parts, c_parts, pair_parts = [], [], []
    pv_parts, pp_parts, pw_parts, vw_parts, view_area = [], [], [], [], []
    pair_offset = view_offset = 0
    stats = {"paths": 0, "kept": 0, "thin": 0, "unlit": 0, "unconverged": 0, "lights_drawn": False}
    pose_pairs = [view_pairs(np.asarray(st.views.directions, dtype=np.float64), points, n_geo, n_sh, mesh, occluded)
                  for st in settings]
    every = sum(len(pp[0]) * int(np.count_nonzero(st.lights.weights > 0)) for pp, st in zip(pose_pairs, settings)) * depths
    share = 1.0 if every <= path_budget else path_budget / every  # of each pair's lights traced
    for k, st in enumerate(settings):
        V = np.asarray(st.views.directions, dtype=np.float64)
        L = np.asarray(st.lights.directions, dtype=np.float64)
        E = np.asarray(st.lights.weights, dtype=np.float64) / float(st.lights.weights.sum())
        pi, pv, pw = pose_pairs[k]
        view_area.append(visible_areas(V, SimpleNamespace(pi=pi, pv=pv), n_geo, area_per_point))
        pv_parts.append(pv + view_offset)
        pp_parts.append(pi)
        pw_parts.append(pw)
        vw_parts.append(pose_w[k] * np.asarray(st.views.weights, dtype=np.float64))
        bright = np.flatnonzero(E > 0)
        draws = None if share >= 1.0 else max(1, int(round(share * bright.size)))
        draws = None if draws is not None and draws >= bright.size else draws
        stats["lights_drawn"] = stats["lights_drawn"] or draws is not None
        if pi.size and bright.size:
            nq = n_sh[pi]
            b, t_v = view_terms(nq, V[pv], eta)
            q0 = points[pi] - eps * n_geo[pi]  # just inside the surface
            back = rays.cast(q0, -b).t  # how far the stone reaches behind each exit point along -b
            for h, c, pair in _paths(rays, law, table, eta, l_ref, L[bright], E[bright], q0, nq, b, t_v, back, depths,
                                     iterations, mesh if occluded else None, eps, salt=k, stats=stats, draws=draws):
                h_parts.append(h)
                c_parts.append(c)
                pair_parts.append(pair + pair_offset)
        pair_offset += len(pi)
        view_offset += len(V)
    h = np.concatenate(h_parts) if h_parts else np.zeros((0, 3), dtype=np.float32)
    c = np.concatenate(c_parts) if c_parts else np.zeros(0, dtype=np.float32)
    pair_of_t = np.concatenate(pair_parts) if pair_parts else np.zeros(0, dtype=np.int32)
    if not (c.size and float(c.sum(dtype=np.float64)) > 0.0):
        raise ParameterError("no light reaches, through the stone, a part of it that a viewer sees: check that the "
                             "lights are above the surfaces the views look at (+Z is face-up)")
    order = np.argsort(pair_of_t, kind="stable")  # sorted by pair, as build_problem's
    h, c, pair_of_t = h[order], c[order], pair_of_t[order]
    view_weight = np.concatenate(vw_parts)
    pair_point = np.concatenate(pp_parts)
    return FlashProblem(
        host_h=h, c=c, pair=pair_of_t, pair_view=np.concatenate(pv_parts).astype(np.int64),
        pair_weight=np.concatenate(pw_parts), view_weight=view_weight / view_weight.sum(),
        kappa=material.lobe_kappa, q_norm=material.lobe_norm, tau=float(tau),
        threshold=flash_threshold(material, settings[0].lights, tau), material=material,
        lights=settings[0].lights, views=settings[0].views, convex=convex, n_points=count, kernels=kernels,
        info={"view_area_mm2": np.concatenate(view_area), "l_ref": l_ref, "pairs": int(pair_offset),
              "triples": int(c.size), "poses": len(settings), "pair_point": pair_point.astype(np.int32),
              "sampling": quality.surface_sampling, "volume": {"depths": depths, "iterations": iterations, "flash_depth_mm": law.mean_mm(1.0),
                         "stack_depth_mm": law.depth_mm, **stats}},
    )


def _paths(rays: VolumeRays, law: Any, table: tuple[np.ndarray, np.ndarray], eta: float, l_ref: float,
           L: np.ndarray, E: np.ndarray, q0: np.ndarray, nq: np.ndarray, b: np.ndarray, t_v: np.ndarray,
           back: np.ndarray, depths: int, iterations: int, occluder: Any, eps: float, *, salt: int,
           stats: dict[str, Any], draws: int | None = None) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``(h, c, pair)`` (float32, float32, int32) of the kept paths of one pose, chunk by chunk:
    every (pair, light, depth) of the pairs' exit points ``q0`` (just inside the surface), shading
    normals ``nq``, internal view directions ``b``, transmissions ``t_v`` and back distances ``back``;
    with ``draws``, that many lights per pair drawn in proportion to ``E`` (stratified, rotated per
    pair by a golden-ratio sequence), each carrying ``sum(E) / draws``."""
    n_pairs = len(q0)
    n_lights = len(L) if draws is None else draws
    cdf = np.cumsum(E) / E.sum()
    per_pair = n_lights * depths
    step = max(1, CHUNK // per_pair)
    for g0 in range(0, n_pairs, step):
        g1 = min(n_pairs, g0 + step)
        pair = np.repeat(np.arange(g0, g1), per_pair)
        if draws is None:
            light = np.tile(np.repeat(np.arange(n_lights), depths), g1 - g0)
            e = E[light]
        else:
            slot = depth_strata(g1 - g0, draws, salt, LIGHT_ROTATION)  # (pairs, draws): stratified in (0, 1)
            light = np.repeat(np.minimum(np.searchsorted(cdf, slot.ravel()), len(E) - 1), depths)
            e = np.full(len(light), float(E.sum()) / draws)
        u = depth_strata((g1 - g0) * n_lights, depths, salt).ravel()
        l = L[light]
        bq, nqq, q = b[pair], nq[pair], q0[pair]
        a = lobe.internal_direction(l, nqq, eta, NUMPY)  # the surface answer: entry at the exit point
        t = None
        moved = np.full(len(pair), np.inf)
        for _ in range(iterations):
            h, cos_l, _unused = lobe.mirror_terms(a, bq, nqq, NUMPY)
            s_in = law.quantile(u, cos_l) / np.maximum(cos_l, 1e-6)
            t = s_in.copy() if t is None else t
            r = q - bq * t[:, None]
            hit = rays.cast(r, a)
            p = r + a * np.where(np.isfinite(hit.t), hit.t, 0.0)[:, None]
            found = np.where(np.isfinite(hit.t) & (hit.t > 0), hit.t, np.nan)
            moved = np.abs(found - s_in) / np.maximum(s_in, 1e-12)
            t = t * s_in / found
            n_p, n_pg = hit.n_sh, hit.n_geo
            a = lobe.internal_direction(l, n_p, eta, NUMPY)
        cos_pl = NUMPY.dot(l, n_p)
        lit = (cos_pl > 1e-6) & (NUMPY.dot(l, n_pg) > 1e-6)
        inside = np.isfinite(t) & (t > 0) & (t <= back[pair])
        converged = moved < CONVERGED
        keep = lit & inside & converged
        if occluder is not None and keep.any():
            idx = np.flatnonzero(keep)
            keep[idx] = escapes_paired(occluder, p[idx] + 2.0 * eps * n_pg[idx], l[idx])
        stats["paths"] += int(len(pair))
        stats["thin"] += int(np.count_nonzero(~inside))
        stats["unlit"] += int(np.count_nonzero(inside & ~lit))
        stats["unconverged"] += int(np.count_nonzero(inside & lit & ~converged))
        stats["kept"] += int(np.count_nonzero(keep))
        if not keep.any():
            continue
        a, l, n_p, bq, nqq = a[keep], l[keep], n_p[keep], bq[keep], nqq[keep]
        h, cos_l, _unused = lobe.mirror_terms(a, bq, nqq, NUMPY)
        max_ab = np.maximum(NUMPY.dot(a, n_p), NUMPY.dot(bq, nqq))
        cos_np = NUMPY.dot(l, n_p)
        e_t_l = e[keep] * lobe.transmission(cos_np, eta) * cos_np
        r_y = np.interp(np.clip(cos_l, 0.0, 1.0), table[0], table[1])
        c = lobe.schiller_factor(e_t_l, t_v[pair[keep]], cos_l, max_ab, eta, NUMPY) * r_y / (l_ref * depths)
        h = np.where(h[:, 2:3] < 0.0, -h, h)  # axial: fold into the upper hemisphere
        finite = np.isfinite(c) & np.all(np.isfinite(h), axis=1)
        yield (h[finite].astype(np.float32), c[finite].astype(np.float32), pair[keep][finite].astype(np.int32))


#: surface samples of :func:`depth_exposure` (stratified): enough that the thin share's own error
#: stays well inside the planner's margin to its 20 % line (600 random samples were not: the low
#: oval with the 560 nm material's deeper stack sits near the line; the thin shares in docs/planner.md)
EXPOSURE_POINTS = 2000
#: how they are placed (:func:`labcut.geometry.surface.draw_samples`)
EXPOSURE_SAMPLING = "stratified"
#: faces whose normal turn :func:`depth_exposure` averages on a mesh too big to copy (drawn by area)
EXPOSURE_FACES = 20_000
#: depth exposures kept in the user cache file (the newest stones')
EXPOSURES_ON_DISK = 256


def volume_paths(settings: list[Setting], surface_points: int, depths: int = DEPTHS) -> float:
    """About how many paths :func:`build_volume_problem` traces: every surface point seen by half
    the views (a convex stone shows a view about half its surface), times each pose's lights and
    the depths, down to :data:`PATH_BUDGET` or one light a pair (the effect planner's time prediction)."""
    pairs = sum(0.5 * surface_points * len(st.views.directions) for st in settings)
    every = float(sum(0.5 * surface_points * len(st.views.directions) * len(st.lights.directions) for st in settings)) * depths
    return min(every, max(float(PATH_BUDGET), pairs * depths))


def depth_exposure(mesh: Any, material: Labradorite) -> dict[str, float]:
    """How much the depth of ``material``'s stack can matter in ``mesh``: the facts the effect
    planner weighs (docs/planner.md, "Depth").

    - ``thin_share``: the share of the surface (by area) behind which the stone is thinner than the
      stack (along the inward shading normal): there light passes out of the stone before the stack
      has mirrored all it would, and the surface model is too bright;
    - ``turn_deg``: the mean angle (area-weighted, degrees) by which the surface normal turns across
      twice the flash depth (:attr:`~labcut.Labradorite.flash_depth_mm`: the typical distance between
      where a mirrored ray enters and where it leaves): the entry's refraction differs from the
      exit's by about this much (reported; on the bundled cuts, up to 14°, it moved no answer by
      more than half a degree: docs/planner.md);
    - ``flash_depth_mm`` and ``stack_depth_mm`` of the material.

    Kept by the stone per stack depth (:meth:`~labcut.geometry.stone.Stone.cached`), and its geometry
    (the thicknesses and the normals' turn rates) once for every material."""
    stone = Stone.of(mesh)
    law = depth_law(material)
    flash = law.mean_mm(1.0)
    key = f"depth_exposure_{law.depth_mm:.6g}_{flash:.6g}"

    def build() -> dict[str, float]:
        thick = stone.cached(f"depth_exposure_thickness_{EXPOSURE_POINTS}_{EXPOSURE_SAMPLING}",
                             lambda: _exposure_thickness(stone))
        rate, weight = stone.cached(f"depth_exposure_turn_rates_{EXPOSURE_FACES}", lambda: _exposure_turn_rates(stone))
        thin = float(np.mean(thick < law.depth_mm))
        turn_deg = float(np.degrees(np.sum(weight * np.minimum(rate * 2.0 * flash, math.pi / 2)) / max(weight.sum(), 1e-300)))
        return {"thin_share": round(thin, 4), "turn_deg": round(turn_deg, 3), "flash_depth_mm": round(flash, 4),
                "stack_depth_mm": round(law.depth_mm, 4)}

    return dict(stone.cached(key, lambda: _kept_exposure(stone, key, build)))


def _exposure_thickness(stone: Stone) -> np.ndarray:
    """The stone's thickness (mm) behind :data:`EXPOSURE_POINTS` surface samples, along the inward
    shading normal: :func:`depth_exposure`'s geometry, the same for every material (kept by the
    stone: a new material, a flash peak typed into the explorer, compares its stack depth with it)."""
    samples = stone.surface_samples(EXPOSURE_POINTS, 0, EXPOSURE_SAMPLING)
    eps = surface_offset(stone.mesh)
    inside = samples.points - eps * samples.n_geo
    if stone.convex and len(stone.mesh.faces) <= FAST_SMOOTH_FACES:  # no ray scene: a convex stone needs none anywhere else either
        return convex_thickness(stone.mesh, inside, -samples.n_sh)
    # a carving's ray scene is kept for its occlusion rays anyway; a scan's planes are too many
    return VolumeRays.of(stone.mesh).cast(inside, -samples.n_sh).t


def _exposure_turn_rates(stone: Stone) -> tuple[np.ndarray, np.ndarray]:
    """``(rate, weight)``: radians of shading-normal turn per mm across each face (its steepest edge)
    and the face's weight in :func:`depth_exposure`'s mean (its area; a scan's faces drawn by area,
    each weighing one), the same for every material (kept by the stone)."""
    faces = np.asarray(stone.mesh.faces, dtype=np.int64)
    area = stone.face_areas
    if len(stone.mesh.faces) > FAST_SMOOTH_FACES:  # the mean over faces drawn by area, their split normals computed at them alone
        pick = np.random.default_rng(0).choice(len(faces), size=EXPOSURE_FACES, p=area / area.sum())
        vn = smooth_corner_normals(stone.mesh, stone.shading_angle_deg, pick)
        weight = np.ones(len(pick))
    else:
        pick, vn, weight = np.arange(len(faces)), corner_normals(stone), area
    tri = np.asarray(stone.mesh.vertices, dtype=np.float64)[faces[pick]]
    rate = np.zeros(len(tri))
    for i, j in ((0, 1), (1, 2), (2, 0)):
        length = np.linalg.norm(tri[:, i] - tri[:, j], axis=1)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", vn[:, i], vn[:, j]), -1.0, 1.0))
        rate = np.maximum(rate, np.where(length > 0, turn / np.maximum(length, 1e-300), 0.0))
    return rate, weight


def _kept_exposure(stone: Stone, key: str, build: Callable[[], dict[str, float]]) -> dict[str, float]:
    """``build()`` (:func:`depth_exposure`'s figures), kept in labcut's user cache
    (``depth-exposure.json``) under the stone's geometry, its convexity and shading angle, the
    material's depths, the sampling's sizes and kind, labcut's, numpy's and trimesh's versions and a
    hash of this module's, the depth law's and the surface samples' code: the planner's depth decision in a new process for a stone
    it has seen is a read, not its thickness rays and a pass over every face."""
    import trimesh

    from .. import __version__
    from ..fileio import calibrations, code_hash
    from ..physics import depth as depth_module

    full = (f"{key} | labcut {__version__} numpy {np.__version__} trimesh {trimesh.__version__} | "
            f"code {code_hash(__file__, depth_module.__file__, surface_module.__file__)} | stone {stone.digest} "
            f"convex {stone.convex} angle {stone.shading_angle_deg!r} | points {EXPOSURE_POINTS} {EXPOSURE_SAMPLING} "
            f"faces {EXPOSURE_FACES} "
            f"copied up to {FAST_SMOOTH_FACES}")
    fields = ("thin_share", "turn_deg", "flash_depth_mm", "stack_depth_mm")

    def check(value: dict[str, Any]) -> None:
        if sorted(value) != sorted(fields) or not all(isinstance(value[f], float) and math.isfinite(value[f]) for f in fields):
            raise ValueError("not a depth exposure")

    return calibrations("depth-exposure.json", [full], lambda missing: [build()], check=check, keep=EXPOSURES_ON_DISK)[0]
