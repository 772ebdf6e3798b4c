"""The flash problem of one cut: (point, light, view) triples and their lamella-independent weights.

For a surface point ``x`` (smooth shading normal ``n``), a light ``l`` and a view
``v`` the schiller radiance is (the BSDF of :mod:`labcut.rendering.bsdf`)::

    L_s(x, v; m) = Σ_l E_l T_i T_o R_Y(|a·h|) (n·l) / (4 |a·h| max(a·n, b·n) η²) · q(h·m)

``a``, ``b`` are the internal directions refracted from ``l`` and ``v`` and
``h = normalize(a + b)`` the lamella orientation that mirrors the light into the eye
(DESIGN.md §4). Everything but ``q(h·m)`` is independent of the lamella normal
``m``, so one pass builds, per triple, ``h_t`` and ``c_t`` (the factor in front of
``q``, divided by ``L_ref``); any orientation is then scored by summing
``c_t q(h_t·m)``, and the whole hemisphere at once by binning ``h_t``
(:mod:`labcut.orientation.scoremap`).

``L_ref`` (DESIGN.md §4) is ``L_s`` of a flat polished face with the lamellae
parallel to it, lit and viewed along its normal by one light carrying the total
irradiance: ``E T(0)² R_Y(1) q(1) / (4 η²)``.

Projected areas: points are sampled uniformly by area; a point counts for view
``v`` when its geometric normal faces ``v`` and (non-convex meshes only) nothing
hides it, with weight ``n_g·v``. Lights are tested the same way (lights below a
face's horizon or hidden by another part contribute nothing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..colour import luminance_table
from ..errors import MeshError, ParameterError
from ..physics.material import Labradorite
from .models import Lights, Views

QUALITY_POINTS = {"draft": 3000, "standard": 8000, "high": 24000}


def fresnel_dielectric(cos_i: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance from outside (index 1) into index ``eta``."""
    c = np.clip(cos_i, 0.0, 1.0)
    s2t = (1.0 - c * c) / (eta * eta)
    ct = np.sqrt(np.clip(1.0 - s2t, 0.0, None))
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 0.5 * (rs * rs + rp * rp)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _internal(w: np.ndarray, n: np.ndarray, eta: float) -> np.ndarray:
    """Internal direction (pointing out of the surface) that refracts into external ``w``."""
    cos = _dot(w, n)[:, None]
    tangent = (w - cos * n) / eta
    return tangent + n * np.sqrt(np.clip(1.0 - _dot(tangent, tangent), 0.0, None))[:, None]


def reference_radiance(material: Labradorite, total_irradiance: float) -> float:
    """L_ref (DESIGN.md §4): flat polished face, lamellae parallel, lit and viewed along its
    normal by one light of irradiance ``total_irradiance``: ``E T(0)² R_Y(1) q(1) / (4 η²)``."""
    eta = material.n_surface
    t0 = 1.0 - float(fresnel_dielectric(np.array(1.0), eta))
    return total_irradiance * t0 * t0 * float(luminance_table(material)[1][-1]) * material.lobe_norm / (4.0 * eta * eta)


@dataclass
class FlashProblem:
    """Precomputed triples for one (mesh, material, lights, views, quality)."""

    h: np.ndarray  # (T, 3) float32 lamella orientation per triple, mesh frame, h_z >= 0 (axial fold)
    c: np.ndarray  # (T,) float32 weight in front of q, in units of L_ref
    pair: np.ndarray  # (T,) int32 index of the (point, view) pair
    pair_view: np.ndarray  # (P,) view index of each pair
    pair_weight: np.ndarray  # (P,) projected-area weight, sums to 1 within each view
    view_weight: np.ndarray  # (V,) normalised view weights
    kappa: float
    q_norm: float
    tau: float
    material: Labradorite
    lights: Lights
    views: Views
    convex: bool
    n_points: int
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_triples(self) -> int:
        return int(self.c.size)

    def alpha(self) -> np.ndarray:
        """Per-triple weight of the (linear) energy objective: Σ_t alpha_t q(h_t·m) = energy."""
        return self.c * self.pair_weight[self.pair] * self.view_weight[self.pair_view[self.pair]]


def _smooth_normals(split: Any, face_idx: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Smooth shading normals at sample points of the smooth-shaded mesh (as the renderer shades)."""
    vn = split.vertex_normals[split.faces[face_idx]]
    n = np.einsum("ij,ijk->ik", bary, vn)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _visibility(mesh: Any, origins: np.ndarray, normals: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """(N, D) bool: the ray from each point towards each distant direction escapes the mesh."""
    import drjit as dr
    import mitsuba as mi

    from ..backend import set_variant
    from ..rendering.scene import to_mitsuba_mesh

    set_variant("rgb")
    scene = mi.load_dict({"type": "scene", "stone": to_mitsuba_mesh(mesh, mi.load_dict({"type": "diffuse"}))})
    scale = float(np.linalg.norm(mesh.extents))
    eps = 1e-4 * scale
    n, d = len(origins), len(dirs)
    o = np.repeat(origins + eps * normals, d, axis=0)
    w = np.tile(dirs, (n, 1))
    ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(w[:, 0], w[:, 1], w[:, 2]))
    hit = scene.ray_test(ray)
    dr.eval(hit)
    return ~np.array(hit, dtype=bool).reshape(n, d)


def build_problem(
    mesh: Any,
    material: Labradorite,
    lights: Lights,
    views: Views,
    quality: str = "standard",
    tau: float = 0.1,
    seed: int = 0,
    n_points: int | None = None,
) -> FlashProblem:
    """Sample the surface and build every (point, light, view) triple (see the module docstring)."""
    import trimesh

    if quality not in QUALITY_POINTS:
        raise ParameterError(f"quality must be one of {', '.join(QUALITY_POINTS)}, got {quality!r}")
    if not (isinstance(seed, int | np.integer) and 0 <= int(seed) < 2**63):
        raise ParameterError(f"seed must be a whole number >= 0, got {seed!r}")
    if not (isinstance(tau, int | float) and math.isfinite(tau) and 0.0 < tau < 10.0):
        raise ParameterError(f"flash threshold tau must lie in (0, 10), got {tau!r}")
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshError("the mesh is empty or not a trimesh.Trimesh (load it with labcut.load_mesh)")
    count = int(n_points or QUALITY_POINTS[quality])
    # sample the smooth-shaded copy the renderer uses (split along edges sharper than
    # 30°; same surface, its own face order), so both estimators shade alike
    split = trimesh.graph.smooth_shade(mesh, angle=math.radians(30.0))
    area_faces = split.area_faces
    ok = np.isfinite(area_faces) & (area_faces > 0)
    if not np.any(ok):
        raise MeshError("the mesh has no face with positive area")
    rng = np.random.default_rng(seed)
    prob = np.where(ok, area_faces, 0.0)
    face_idx = rng.choice(len(area_faces), size=count, p=prob / prob.sum())
    r1, r2 = rng.random(count), rng.random(count)
    s = np.sqrt(r1)
    bary = np.stack([1 - s, s * (1 - r2), s * r2], axis=1)
    tri = split.triangles[face_idx]
    points = np.einsum("ij,ijk->ik", bary, tri)
    n_geo = split.face_normals[face_idx]
    n_sh = _smooth_normals(split, face_idx, bary)

    info = mesh.metadata.get("labcut", {}) if hasattr(mesh, "metadata") else {}
    if "convex" in info:
        convex = bool(info["convex"])
    else:
        from ..geometry.meshio import is_convex_mesh

        convex = bool(is_convex_mesh(mesh))

    L, E = lights.directions, lights.weights
    V, wv = views.directions, views.weights
    eta = material.n_surface

    # facing and visibility: point x view, point x light
    face_v = (n_geo @ V.T > 1e-6) & (n_sh @ V.T > 1e-6)
    lit = (n_geo @ L.T > 1e-6) & (n_sh @ L.T > 1e-6) & (E[None, :] > 0)
    if not convex:
        face_v &= _visibility(mesh, points, n_geo, V)
        lit &= _visibility(mesh, points, n_geo, L)

    # projected-area weights per (point, view) pair
    pi, pv = np.nonzero(face_v)
    proj = np.einsum("ij,ij->i", n_geo[pi], V[pv])
    per_view = np.bincount(pv, weights=proj, minlength=len(V))
    pair_weight = proj / np.where(per_view[pv] > 0, per_view[pv], 1.0)

    table_c, table_r = luminance_table(material)
    l_ref = reference_radiance(material, float(E.sum()))
    if not l_ref > 0:
        raise ParameterError("the material reflects nothing at normal incidence: no flash can be scored")

    # triples: each pair x the lights its point sees; built in chunks of points and
    # stored in float32 (20 bytes a triple) so high quality stays within memory
    pair_first = np.searchsorted(pi, np.arange(count + 1))  # pairs are sorted by point
    h_parts, c_parts, pair_parts = [], [], []
    chunk = max(1, 4_000_000 // max(1, len(V) * max(1, int(lit.sum(axis=1).max(initial=1)))))
    for p0 in range(0, count, chunk):
        p1 = min(count, p0 + chunk)
        q0, q1 = pair_first[p0], pair_first[p1]
        if q1 == q0:
            continue
        c_pi = pi[q0:q1]
        lit_i, lit_l = np.nonzero(lit[p0:p1])
        lit_i = lit_i + p0
        counts = np.bincount(lit_i - p0, minlength=p1 - p0)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        reps = counts[c_pi - p0]
        if reps.sum() == 0:
            continue
        pair_of_t = np.repeat(np.arange(q0, q1), reps)
        offs = np.arange(reps.sum()) - np.repeat(np.cumsum(reps) - reps, reps)
        lit_of_t = np.repeat(starts[c_pi - p0], reps) + offs  # index into this chunk's lit (point, light)

        # per (point, light) and per (point, view) first, then gathered per triple
        n_lit = n_sh[lit_i]
        wl = L[lit_l]
        a_lit = _internal(wl, n_lit, eta)
        cos_li_lit = _dot(wl, n_lit)
        w_lit = E[lit_l] * (1.0 - fresnel_dielectric(cos_li_lit, eta)) * cos_li_lit  # E T_i (n·l)
        n_pair = n_sh[c_pi]
        wo = V[pv[q0:q1]]
        b_pair = _internal(wo, n_pair, eta)
        t_o_pair = 1.0 - fresnel_dielectric(_dot(wo, n_pair), eta)

        local = pair_of_t - q0
        a = a_lit[lit_of_t]
        b = b_pair[local]
        hsum = a + b
        h = hsum / np.sqrt(_dot(hsum, hsum))[:, None]
        cos_l = np.clip(_dot(a, h), 1e-6, 1.0)
        r_y = np.interp(cos_l, table_c, table_r)
        n_t = n_pair[local]
        c = w_lit[lit_of_t] * t_o_pair[local] * r_y / (4.0 * cos_l * np.maximum(_dot(a, n_t), _dot(b, n_t)) * eta * eta) / l_ref
        h = np.where(h[:, 2:3] < 0.0, -h, h)  # axial: fold into the upper hemisphere
        finite = np.isfinite(c) & np.all(np.isfinite(h), axis=1)
        c_parts.append(np.where(finite, c, 0.0).astype(np.float32))
        h_parts.append(np.where(finite[:, None], h, np.array([0.0, 0.0, 1.0])).astype(np.float32))
        pair_parts.append(pair_of_t.astype(np.int32))
    if not c_parts or not any(float(part.sum()) > 0.0 for part in c_parts):
        raise ParameterError(
            "no light reaches a part of the stone that a viewer sees: check that the lights are above "
            "the surfaces the views look at (+Z is face-up)"
        )
    if c_parts:
        h, c, pair_of_t = np.concatenate(h_parts), np.concatenate(c_parts), np.concatenate(pair_parts)
    else:  # nothing lit and seen: an all-dark problem, scored 0 everywhere
        h, c, pair_of_t = np.array([[0.0, 0.0, 1.0]], np.float32), np.zeros(1, np.float32), np.zeros(1, np.int32)
        if len(pi) == 0:
            pi, pv, pair_weight = np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros(1)
    return FlashProblem(
        h=h,
        c=c,
        pair=pair_of_t,
        pair_view=pv.astype(np.int64),
        pair_weight=pair_weight,
        view_weight=wv,
        kappa=material.lobe_kappa,
        q_norm=material.lobe_norm,
        tau=float(tau),
        material=material,
        lights=lights,
        views=views,
        convex=convex,
        n_points=count,
        info={"l_ref": l_ref, "pairs": int(len(pi)), "triples": int(c.size)},
    )
