"""The error bars' discretisation problems as (point, view) pairs only: stencil sums in one Dr.Jit kernel.

The error bars (:mod:`labcut.orientation.uncertainty`) fit the objective at a small stencil of
normals around the answer on two more problems of the same question: half the directions, and
twice the rocking poses at a quarter of the surface points. All they need of such a problem is
``L_s/L_ref`` of every (point, view) pair at the stencil's normals (and the pairs' weights): no
binned map, no optimiser, no triples kept. :func:`build_pairs` therefore builds only the pairs
(the facing tests and, for a stone that is not convex, occlusion rays towards the views), and
:class:`PairProblem` sums the pairs' radiance in one kernel that makes each (pair, light) term as
it goes: a thread per pair runs over its pose's lights, tests that the light reaches the point
(the facing tests of :func:`~labcut.orientation.problem.build_problem`, in float64 as there, and
the occlusion rays' answers for a stone that is not convex), makes the triple's mirror orientation
``h`` and factor ``c`` in float32 (the lobe functions of :mod:`labcut.physics.schiller`, the
operations of the triple kernel :class:`~labcut.orientation.problem._TripleKernel`) and adds, for
each normal, the lobe term ``q_norm c exp(κ(|h·m| - 1))`` within reach of the first normal to a
float64 sum, in light order.

These are the terms and the order of :func:`~labcut.orientation.problem.build_problem`'s triples
summed by :meth:`FlashProblem.pair_radiance <labcut.orientation.problem.FlashProblem.pair_radiance>`
(the reference ``tests/test_pairs.py`` compares with), without writing the triples out, reading
them back, culling them on the host and copying them to the device again: the error bars cost
a third of what the two culled :class:`~labcut.orientation.problem.FlashProblem` builds it replaced did.

Frames and units: the mesh frame; directions unit vectors towards the light or the viewer;
radiance in units of ``L_ref`` (DESIGN.md §4); angles in radians.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..backend import Launched
from ..colour import luminance_table
from ..errors import ParameterError
from ..physics.material import Labradorite
from ..scene import Setting
from ..scene.quality import Quality
from .problem import (DeviceTerms, add_lobe_terms, check_problem_inputs, light_rows, lights_reach, opaque_stencil, pair_major,
                      surface_samples, view_pairs)
from .radiance import flash_threshold, reference_radiance


@dataclass
class PairProblem:
    """The (point, view) pairs of a flash problem and what its stencil sums need (no triples).

    The fields mean what :class:`~labcut.orientation.problem.FlashProblem`'s of the same name do;
    ``info["pair_point"]`` is each pair's surface point."""

    pair_view: np.ndarray  # (P,) view index of each pair (all poses' views, in pose order)
    pair_weight: np.ndarray  # (P,) projected-area weight, sums to 1 within each view
    view_weight: np.ndarray  # (V,) normalised view weights (pose weight x view weight)
    kappa: float
    q_norm: float
    tau: float
    threshold: float
    convex: bool
    n_points: int
    info: dict[str, Any] = field(default_factory=dict)
    _sums: _TermSums | None = None

    @functools.cached_property
    def pair_alpha(self) -> np.ndarray:
        """Per pair: its projected-area weight x its view's weight (float64)."""
        return self.pair_weight * self.view_weight[self.pair_view]

    def pair_radiance(self, normals: np.ndarray, reach: float | None = None) -> np.ndarray:
        """``L_s/L_ref`` of every pair at each unit normal (rows, mesh frame): (P, K) float64 sums of
        the float32 lobe terms, each pair's in light order; ``reach`` (radians): only the terms whose
        mirror orientation lies within it of ``normals[0]`` (None: every term)."""
        return self.launch_pair_radiance(normals, reach).value

    def launch_pair_radiance(self, normals: np.ndarray, reach: float | None = None) -> Launched[np.ndarray]:
        """:meth:`pair_radiance`, launched: the kernel runs on Dr.Jit's threads while the caller goes
        on, and the result's ``value`` waits for it."""
        normals = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        if normals.ndim != 2 or normals.shape[1] != 3 or not np.all(np.isfinite(normals)):
            raise ParameterError("normals must be rows of three finite numbers")
        if self._sums is None or self.pair_view.size == 0:
            return Launched.ready(np.zeros((int(self.pair_view.size), len(normals))))
        return Launched(self._sums.launch(normals, reach))


def build_pairs(mesh: Any, material: Labradorite, quality: Quality | str, tau: float, seed: int, settings: list[Setting],
                occlusion: bool | None = None) -> PairProblem:
    """The pairs of :func:`~labcut.orientation.problem.build_problem`'s problem of the same
    arguments (``settings``: a scenario's poses in the mesh frame; ``occlusion``: as there) and the
    kernel that sums their radiance (module docstring). The surface samples are the mesh's cached
    ones of this point count and seed."""
    if not settings:
        raise ParameterError("build_pairs needs at least one setting")
    quality = Quality.coerce(quality)
    mesh = check_problem_inputs(mesh, seed, tau)
    count = int(quality.surface_points)
    samples = surface_samples(mesh, count, int(seed), quality.surface_sampling)
    points, n_geo, n_sh, convex = samples.points, samples.n_geo, samples.n_sh, samples.convex
    occluded = not (convex if occlusion is None else not occlusion)
    l_ref = reference_radiance(material, 1.0)
    if not l_ref > 0:
        raise ParameterError("the material reflects nothing at normal incidence: no flash can be scored")
    pose_w = np.array([float(st.weight) for st in settings])
    pose_w = pose_w / pose_w.sum()
    n_pose = len(settings)
    # each pose's lights (irradiance normalised to 1: L_ref is per unit irradiance) in a row of
    # `width` slots, as the triple kernel has them
    L, E, width = light_rows(settings, [1.0 / float(st.lights.weights.sum()) for st in settings])
    blocked = np.zeros((n_pose, count, width), dtype=bool) if occluded else None
    pp_parts, pv_parts, pw_parts, vw_parts, pose_parts = [], [], [], [], []
    view_offset = 0
    for k, st in enumerate(settings):
        pi, pv, pw = view_pairs(st.views.directions, points, n_geo, n_sh, mesh, occluded)
        if occluded:  # the lights' occlusion rays, as build_problem's lit tests cast them
            from ..rendering.rays import escapes

            blocked[k, :, :len(st.lights.directions)] = ~escapes(mesh, points, n_geo, st.lights.directions)
        pp_parts.append(pi)
        pv_parts.append(pv + view_offset)
        pw_parts.append(pw)
        vw_parts.append(pose_w[k] * st.views.weights)
        pose_parts.append(np.full(len(pi), k, dtype=np.int64))
        view_offset += len(st.views.weights)
    pair_point = np.concatenate(pp_parts)
    pair_view = np.concatenate(pv_parts).astype(np.int64)
    view_weight = np.concatenate(vw_parts)
    V = np.concatenate([st.views.directions for st in settings])
    sums = None
    if pair_point.size:
        sums = _TermSums(n_sh, n_geo, L, E, V, pair_point, pair_view,
                         np.concatenate(pose_parts), width, None if blocked is None else blocked.reshape(-1),
                         count, material.n_surface, luminance_table(material), l_ref,
                         float(material.lobe_kappa), float(material.lobe_norm))
    return PairProblem(
        pair_view=pair_view, pair_weight=np.concatenate(pw_parts), view_weight=view_weight / view_weight.sum(),
        kappa=float(material.lobe_kappa), q_norm=float(material.lobe_norm), tau=float(tau),
        threshold=flash_threshold(material, settings[0].lights, tau), convex=convex, n_points=count,
        info={"l_ref": l_ref, "pairs": int(pair_point.size), "poses": n_pose, "pair_point": pair_point.astype(np.int32),
              "sampling": quality.surface_sampling},
        _sums=sums,
    )


class _TermSums:
    """The pair sums of :class:`PairProblem` as one Dr.Jit kernel (module docstring): the points'
    normals, the poses' lights and views and each pair's indices live on the device once per
    problem; the normals, κ, the lobe's norm and the reach are opaque, so one compiled kernel serves
    every problem and stencil of the same number of normals (with and without occlusion)."""

    def __init__(self, n_sh: np.ndarray, n_geo: np.ndarray, L: np.ndarray, E: np.ndarray, V: np.ndarray,
                 point: np.ndarray, view: np.ndarray, pose: np.ndarray, width: int, blocked: np.ndarray | None,
                 n_points: int, eta: float, table: tuple[np.ndarray, np.ndarray], l_ref: float, kappa: float,
                 q_norm: float) -> None:
        from ..backend import ad_types

        dr, t = ad_types()
        self.dr, self.t = dr, t
        self.n_pairs = int(point.size)
        n32 = np.asarray(n_sh, dtype=np.float32)
        self.n32 = t.Array3f(n32[:, 0], n32[:, 1], n32[:, 2])
        # the facing tests in float64, as build_problem's (n_geo @ L.T > 1e-6 and n_sh @ L.T > 1e-6)
        self.ng64 = t.Array3f64(*(np.ascontiguousarray(n_geo[:, k], dtype=np.float64) for k in range(3)))
        self.ns64 = t.Array3f64(*(np.ascontiguousarray(n_sh[:, k], dtype=np.float64) for k in range(3)))
        self.L32 = t.Array3f(*(np.ascontiguousarray(L[:, k], dtype=np.float32) for k in range(3)))
        self.L64 = t.Array3f64(*(np.ascontiguousarray(L[:, k], dtype=np.float64) for k in range(3)))
        self.E32 = t.Float(np.asarray(E, dtype=np.float32))
        self.lit_E = t.Bool(np.asarray(E) > 0)
        v32 = np.asarray(V, dtype=np.float32)
        self.V32 = t.Array3f(v32[:, 0], v32[:, 1], v32[:, 2])
        self.point = t.UInt32(np.asarray(point, dtype=np.uint32))
        self.view = t.UInt32(np.asarray(view, dtype=np.uint32))
        self.light0 = t.UInt32((np.asarray(pose, dtype=np.int64) * width).astype(np.uint32))
        # occlusion: blocked[(pose x points + point) x width + slot]
        self.blocked = None if blocked is None else t.Bool(blocked)
        self.row0 = (None if blocked is None else
                     t.UInt32(((np.asarray(pose, dtype=np.int64) * n_points + point) * width).astype(np.uint32)))
        self.width = dr.opaque(t.UInt32, int(width))
        self.terms = DeviceTerms(eta, table, l_ref)
        self.kappa, self.q_norm = float(kappa), float(q_norm)

    def __call__(self, normals: np.ndarray, reach: float | None) -> np.ndarray:
        """(P, K) float64 pair sums at the unit ``normals`` (K, 3); ``reach`` as in :meth:`PairProblem.pair_radiance`."""
        return self.launch(normals, reach)()

    def launch(self, normals: np.ndarray, reach: float | None) -> Callable[[], np.ndarray]:
        """:meth:`__call__`, launched: the returned function waits for the kernel and gives the sums."""
        dr, t = self.dr, self.t
        stencil = opaque_stencil(normals, reach, self.kappa, self.q_norm)
        q_norm, terms = stencil[3], self.terms
        # per pair: its point's normals, its view's direction and terms (the same for all its lights)
        n = dr.gather(t.Array3f, self.n32, self.point)
        ng = dr.gather(t.Array3f64, self.ng64, self.point)
        ns = dr.gather(t.Array3f64, self.ns64, self.point)
        b, t_v = terms.view(dr.gather(t.Array3f, self.V32, self.view), n)
        light0, row0, blocked = self.light0, self.row0, self.blocked

        def body(j: Any, *sums: Any) -> tuple[Any, ...]:
            i_l = light0 + j
            lit = lights_reach(ng, ns, dr.gather(t.Array3f64, self.L64, i_l), dr.gather(t.Bool, self.lit_E, i_l))
            if blocked is not None:
                lit &= ~dr.gather(t.Bool, blocked, row0 + j)
            # the triple kernel's terms (problem.DeviceTerms), in float32
            h, c = terms.light(dr.gather(t.Array3f, self.L32, i_l), dr.gather(t.Float, self.E32, i_l), n, b, t_v)
            ok = lit & dr.isfinite(c) & dr.isfinite(h.x) & dr.isfinite(h.y) & dr.isfinite(h.z)
            out, _ = add_lobe_terms(sums, h, q_norm * c, stencil, valid=ok)  # the pair-sum kernel's float32 q_norm c_t
            return (j + 1, *out)

        state = (dr.zeros(t.UInt32, self.n_pairs), *(dr.zeros(t.Float64, self.n_pairs) for _ in range(len(normals))))
        width = self.width
        result = dr.while_loop(state, lambda j, *sums: j < width, body)
        sums = result[1:]
        dr.eval(*sums)  # launched: the host reads the sums when asked
        return lambda: pair_major(sums)
