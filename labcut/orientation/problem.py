"""The flash problem of one cut: (point, light, view) triples and their lamella-independent weights.

For a surface point ``x`` (smooth shading normal ``n``), a light ``l`` and a view
``v`` the schiller radiance is (the BSDF's lobe, one implementation in
:mod:`labcut.physics.schiller`)::

    L_s(x, v; m) = Σ_l E_l T_i T_o R_Y(|a·h|) (n·l) / (4 |a·h| max(a·n, b·n) η²) · q(h·m)

``a``, ``b`` are the internal directions refracted from ``l`` and ``v`` and
``h = normalize(a + b)`` the lamella orientation that mirrors the light into the eye
(DESIGN.md §4). Everything but ``q(h·m)`` is independent of the lamella normal
``m``, so one pass builds, per triple, ``h_t`` and ``c_t`` (the factor in front of
``q``, divided by ``L_ref``); any orientation is then scored by summing
``c_t q(h_t·m)``, and the whole hemisphere at once by binning ``h_t``
(:meth:`labcut.orientation.scoring.Scorer.energy_map`).

``L_ref``, the unit of flash values, and the flash threshold ``τ P`` (``P`` the brightest schiller
the scene's lights can give a flat face) are defined in :mod:`labcut.orientation.radiance`.

Projected areas: points are sampled uniformly by area; a point counts for view
``v`` when its geometric normal faces ``v`` and (non-convex meshes only) nothing
hides it, with weight ``n_g·v``. Lights are tested the same way (lights below a
face's horizon or hidden by another part contribute nothing).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..backend import Launched
from ..colour import luminance_table
from ..errors import MeshError, ParameterError
from ..geometry.stone import Stone
from ..geometry.surface import SurfaceSamples
from ..physics import schiller as lobe
from ..physics.material import Labradorite
from ..physics.ops import NUMPY
from ..scene import Lights, Setting, Views
from ..scene.quality import Quality
from .kernels import DEFAULT_KERNELS, KernelOptions
from .radiance import flash_threshold, light_terms, reference_radiance, view_terms


#: triples per chunk of :meth:`FlashProblem.pair_radiance`: its (stencil normals x chunk) float32 lobe
#: values stay near 17 MB (bigger chunks pay for fresh pages at a process's first call)
PAIR_CHUNK = 1 << 18


@dataclass
class FlashProblem:
    """Precomputed triples for one (mesh, material, lights, views, quality)."""

    #: (T, 3) float32 lamella orientation per triple, mesh frame, h_z >= 0 (axial fold), read as
    #: :attr:`h`; a :class:`~labcut.backend.Launched` copy from the device where the triple kernel made
    #: them, taken only if something reads :attr:`h` (the kernels read :attr:`device_triples`)
    host_h: np.ndarray | Launched[np.ndarray]
    c: np.ndarray  # (T,) float32 weight in front of q, in units of L_ref
    pair: np.ndarray  # (T,) int32 index of the (point, view) pair
    pair_view: np.ndarray  # (P,) view index of each pair
    pair_weight: np.ndarray  # (P,) projected-area weight, sums to 1 within each view
    view_weight: np.ndarray  # (V,) normalised view weights
    kappa: float
    q_norm: float
    tau: float  # the flash threshold's factor τ
    threshold: float  # the flash threshold τ P in units of L_ref (P: the scene's peak, orientation/radiance.py)
    material: Labradorite
    lights: Lights
    views: Views
    convex: bool
    n_points: int
    info: dict[str, Any] = field(default_factory=dict)
    #: which steps run as Dr.Jit kernels (:class:`~labcut.orientation.kernels.KernelOptions`): the
    #: problem's own pair sums and its scorer's binning and energy map read them from here
    kernels: KernelOptions = DEFAULT_KERNELS

    @property
    def h(self) -> np.ndarray:
        """The triples' mirror orientations on the host, (T, 3) float32 (:attr:`host_h`, copied
        from the device the first time it is read)."""
        h = self.host_h
        if isinstance(h, Launched):
            h = self.host_h = h.value
        return h

    @h.setter
    def h(self, value: np.ndarray) -> None:
        self.host_h = value

    @property
    def n_triples(self) -> int:
        return int(self.c.size)

    @functools.cached_property
    def pair_alpha(self) -> np.ndarray:
        """Per (point, view) pair: its projected-area weight x its view's weight (float64), the
        factor :meth:`alpha` gives each of the pair's triples."""
        return self.pair_weight * self.view_weight[self.pair_view]

    def alpha(self, rows: slice | np.ndarray = slice(None)) -> np.ndarray:
        """Per-triple weight of the (linear) energy objective: Σ_t alpha_t q(h_t·m) = energy; of the
        triples ``rows`` only (a chunk: the same values as those rows of the whole). One gather per
        triple (:attr:`pair_alpha`)."""
        return self.c[rows] * self.pair_alpha[self.pair[rows]]

    @functools.cached_property
    def pairs_sorted(self) -> bool:
        """Whether the triples are sorted by pair (:func:`build_problem`'s order), checked once."""
        return self.pair.size < 2 or bool(np.all(self.pair[1:] >= self.pair[:-1]))

    def _near_chunks(self, normals: np.ndarray, reach: float | None) -> Iterator[tuple[int, Any]]:
        """``(start, rows)`` per chunk of :data:`PAIR_CHUNK` triples: the rows (indices into the chunk,
        or ``slice(None)``) whose mirror orientation lies within ``reach`` (radians) of ``normals[0]``
        (float32 test, as the triples are stored); chunks with none are skipped."""
        c32 = normals[0].astype(np.float32)
        cos_reach = -1.0 if reach is None else math.cos(min(float(reach), math.pi / 2))
        for s0 in range(0, self.n_triples, PAIR_CHUNK):
            if reach is None:
                yield s0, slice(None)
                continue
            hc = self.h[s0:s0 + PAIR_CHUNK]
            cos_c = np.abs(hc[:, 0] * c32[0] + hc[:, 1] * c32[1] + hc[:, 2] * c32[2])
            near = np.nonzero(cos_c >= cos_reach)[0]
            del cos_c
            if near.size:
                yield s0, near

    @functools.cached_property
    def device_triples(self) -> tuple[Any, Any]:
        """``(h, c)``: the triples' mirror orientations (``Array3f``) and schiller factors (``Float``)
        on the Dr.Jit device, float32 as stored (16 bytes a triple), copied once per problem and
        shared by the pair-sum kernel (:class:`_PairSums`) and the scorer's device objectives
        (:class:`labcut.orientation.scoring.Scorer`)."""
        from ..backend import ad_types

        _, t = ad_types()
        h = self.h
        return t.Array3f(*(np.ascontiguousarray(h[:, k]) for k in range(3))), t.Float(self.c)

    @functools.cached_property
    def _pair_sums(self) -> _PairSums | None:
        """The Dr.Jit pair-sum kernel of these triples (:class:`_PairSums`), or None where the numpy
        path sums them (:attr:`kernels` without ``pair_sums``, or over its ``pair_sums_max_triples``;
        triples not sorted by pair); made at the first sum, kept with the problem."""
        if not self.kernels.pair_kernel_takes(self.n_triples) or not self.pairs_sorted:
            return None
        return _PairSums(self)

    def pair_radiance(self, normals: np.ndarray, reach: float | None = None) -> np.ndarray:
        """``L_s/L_ref`` of every (point, view) pair at each unit normal (rows, mesh frame): (P, K)
        float64 sums of the float32 lobe terms ``c_t q(|h_t·m|)``, each pair's in triple order (no
        BLAS, no atomics: the same sums run after run). ``reach`` (radians): only the triples whose
        mirror orientation lies within it of ``normals[0]`` (the error bars' stencil sums,
        :func:`labcut.orientation.uncertainty.pair_radiance`); None: every triple. Summed by the
        Dr.Jit kernel (:class:`_PairSums`) where there is one, else :meth:`pair_radiance_numpy`."""
        return self.launch_pair_radiance(normals, reach).value

    def launch_pair_radiance(self, normals: np.ndarray, reach: float | None = None) -> Launched[np.ndarray]:
        """:meth:`pair_radiance`, launched: the Dr.Jit kernel runs on Dr.Jit's threads while the caller
        goes on, and the result's ``value`` waits for it. Where no kernel sums them, the sums are made now."""
        normals = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        kernel = self._pair_sums
        if kernel is None:
            return Launched.ready(self.pair_radiance_numpy(normals, reach))
        kept = self.__dict__.get("_full_first")
        if reach is None and len(normals) == 1 and kept is not None and kept[0] == normals[0].tobytes():
            return Launched.ready(kept[1][:, None])  # every triple's sum at this normal, made by the last stencil call
        if reach is None:
            pending = kernel.launch(normals, None)
            return Launched(lambda: pending()[0])
        pending = kernel.launch(normals, reach, full_first=True)

        def finish() -> np.ndarray:
            sums, full = pending()
            # the first normal's sum over every triple came with the stencil's (one more add a triple):
            # a recommendation's metrics at its answer, the error bars' stencil centre, read it here
            self.__dict__["_full_first"] = (normals[0].tobytes(), full)
            return sums

        return Launched(finish)

    def pair_radiance_numpy(self, normals: np.ndarray, reach: float | None = None) -> np.ndarray:
        """:meth:`pair_radiance` in numpy passes, one normal at a time over chunks of
        :data:`PAIR_CHUNK` triples (the reference the kernel is tested against; the path of problems
        the kernel does not take)."""
        normals = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        n32 = normals.astype(np.float32)
        n_pairs = int(self.pair_view.size)
        out = np.zeros((n_pairs, len(normals)))
        # in chunks of triples (bounded temporaries: (K, chunk) float32 lobe values); a pair split
        # between two chunks gets the sum of its two partial sums
        for s0, near in self._near_chunks(normals, reach):
            hc = self.h[s0:s0 + PAIR_CHUNK]
            # float32, one normal at a time over the chunk's near triples (a row stays in cache:
            # 1.6x faster than the (K, n) block), the products as fixed multiply-adds
            hx, hy, hz = (np.ascontiguousarray(hc[near, k]) for k in range(3))
            cq = np.float32(self.q_norm) * self.c[s0:s0 + PAIR_CHUNK][near]
            pairs = self.pair[s0:s0 + PAIR_CHUNK][near]
            sorted_pairs = self.pairs_sorted  # build_problem's order: one segmented sum per normal
            if sorted_pairs:
                first = np.flatnonzero(np.r_[True, pairs[1:] != pairs[:-1]])
                rows = pairs[first]
            term = np.empty(hx.size, dtype=np.float32)
            wide = np.empty(hx.size, dtype=np.float64) if sorted_pairs else None
            for k in range(len(normals)):
                np.multiply(hx, n32[k, 0], out=term)
                term += hy * n32[k, 1]
                term += hz * n32[k, 2]
                np.abs(term, out=term)
                term -= np.float32(1.0)
                term *= np.float32(self.kappa)
                np.exp(term, out=term)
                term *= cq
                if sorted_pairs:
                    wide[:] = term  # float64 sums (reduceat(dtype=float64) is slower)
                    out[rows, k] += np.add.reduceat(wide, first)
                else:
                    out[:, k] += np.bincount(pairs, weights=term, minlength=n_pairs)
            del hx, hy, hz, term, wide
        return out


def pair_major(sums: Any) -> np.ndarray:
    """(P, K) float64 array of K evaluated Dr.Jit ``Float64`` arrays of P pair sums each: their
    host views stacked as rows (K contiguous copies) and returned transposed, a view with the
    pairs first (stacking them as columns would be a strided copy, slower)."""
    if not len(sums):
        return np.zeros((0, 0))
    return np.stack([np.asarray(s, dtype=np.float64) for s in sums], axis=0).T


def opaque_stencil(normals: np.ndarray, reach: float | None, kappa: float, q_norm: float) -> tuple[Any, Any, Any, Any]:
    """The stencil of a pair-sum kernel as opaque Dr.Jit scalars (one compiled kernel serves every
    stencil of the same number of normals): the float32 normals (a list of (x, y, z)), κ, the
    reach's cosine (the numpy path's test in float32, ``|h·m_0| >= cos(reach)``; no reach: -1, every
    term) and the lobe's norm."""
    from ..backend import ad_types

    dr, t = ad_types()
    m = [[dr.opaque(t.Float, float(x)) for x in row] for row in np.asarray(normals, dtype=np.float32)]
    cos_reach = float(np.float32(-1.0 if reach is None else math.cos(min(float(reach), math.pi / 2))))
    return (m, dr.opaque(t.Float, float(np.float32(kappa))), dr.opaque(t.Float, cos_reach),
            dr.opaque(t.Float, float(np.float32(q_norm))))


def add_lobe_terms(sums: Any, h: Any, cq: Any, stencil: tuple[Any, Any, Any, Any], valid: Any = None,
                   every_first: Any = None) -> tuple[list[Any], Any]:
    """One triple's lobe terms ``cq exp(κ(|h·m_k| - 1))`` (float32; ``cq`` the triple's ``q_norm c``)
    added to the stencil's float64 sums, the terms beyond the reach of the first normal (and, with
    ``valid``, those of invalid triples) adding 0: the step of :class:`_PairSums` and of the pairs'
    kernel (:mod:`labcut.orientation.pairs`), the terms and order of
    :meth:`FlashProblem.pair_radiance_numpy`. ``every_first``: a sum of the first normal's terms
    without the reach, also stepped (None: none). Returns the new sums and that one."""
    from ..backend import ad_types

    dr, t = ad_types()
    m, kappa, cos_reach, _ = stencil
    out = []
    near = every = None
    for k, (mx, my, mz) in enumerate(m):
        d = dr.abs(h.x * mx + h.y * my + h.z * mz)
        term = dr.exp((d - 1.0) * kappa) * cq
        if k == 0:
            near = d >= cos_reach if valid is None else valid & (d >= cos_reach)
            if every_first is not None:
                every = every_first + t.Float64(term)
        out.append(sums[k] + t.Float64(dr.select(near, term, 0.0)))
    return out, every


class _PairSums:
    """:meth:`FlashProblem.pair_radiance` as one Dr.Jit kernel: a thread per (point, view) pair
    runs over the pair's triples (contiguous: the problem is sorted by pair) in their order and
    adds, for each normal, the float32 lobe term ``q_norm c_t exp(κ(|h_t·m| - 1))`` to a float64
    sum, the numpy path's terms and order (no atomics: the same sums run after run). The triples
    are the problem's :attr:`FlashProblem.device_triples` (on the device once per problem, shared
    with the scorer); the normals, κ, the lobe's norm and the reach are opaque, so one compiled
    kernel serves every problem and stencil of the same number of normals."""

    def __init__(self, problem: FlashProblem) -> None:
        from ..backend import ad_types

        dr, t = ad_types()
        self.dr, self.t = dr, t
        self.h, self.c = problem.device_triples
        self.q_norm = float(problem.q_norm)
        starts = np.searchsorted(problem.pair, np.arange(problem.pair_view.size + 1)).astype(np.uint32)
        self.first, self.end = t.UInt32(starts[:-1]), t.UInt32(starts[1:])
        self.kappa = float(problem.kappa)
        self.n_pairs = int(problem.pair_view.size)

    def __call__(self, normals: np.ndarray, reach: float | None, full_first: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """``(sums, full)``: (P, K) float64 pair sums at the unit ``normals`` (K, 3), ``reach`` as in
        :meth:`FlashProblem.pair_radiance`; with ``full_first`` also the first normal's (P,) sums
        over every triple (its terms and order, without the reach), else None."""
        return self.launch(normals, reach, full_first)()

    def launch(self, normals: np.ndarray, reach: float | None,
               full_first: bool = False) -> Callable[[], tuple[np.ndarray, np.ndarray | None]]:
        """:meth:`__call__`, launched: Dr.Jit's LLVM threads (or the GPU) run the kernel while the
        caller goes on; the returned function waits for it and gives ``(sums, full)``."""
        dr, t = self.dr, self.t
        k_count = len(normals)
        stencil = opaque_stencil(normals, reach, self.kappa, self.q_norm)
        q_norm = stencil[3]
        h_all, c_all, end = self.h, self.c, self.end

        def body(j: Any, *sums: Any) -> tuple[Any, ...]:
            cq = q_norm * dr.gather(t.Float, c_all, j)  # the numpy path's float32 q_norm c_t
            out, every = add_lobe_terms(sums, dr.gather(t.Array3f, h_all, j), cq, stencil,
                                        every_first=sums[k_count] if full_first else None)
            return (j + 1, *out, *([every] if full_first else []))

        columns = k_count + int(full_first)
        state = (t.UInt32(self.first), *(dr.zeros(t.Float64, self.n_pairs) for _ in range(columns)))
        result = dr.while_loop(state, lambda j, *sums: j < end, body)
        sums = result[1:]
        dr.eval(*sums)  # launched: the host reads the sums below, when asked
        return lambda: (pair_major(sums[:k_count]), np.asarray(sums[k_count], dtype=np.float64) if full_first else None)


def surface_samples(mesh: Any, count: int, seed: int, sampling: str = "stratified") -> SurfaceSamples:
    """The stone's :meth:`~labcut.geometry.stone.Stone.surface_samples` (drawn once per stone,
    point count, seed and sampling: a recommendation's error bars and a repeated question reuse them)."""
    return Stone.of(mesh).surface_samples(count, seed, sampling)


def lobe_reach(kappa: float, spread_rad: float = 0.0) -> float:
    """Angle (radians) beyond which a triple's lobe term is dropped by the error bars' sums
    (:func:`labcut.orientation.uncertainty.pair_radiance`): ``spread`` (the farthest stencil normal
    from the centre) plus five lobe widths (terms below ``exp(-12.5)`` of the peak)."""
    return float(spread_rad) + 5.0 / math.sqrt(max(float(kappa), 1e-6))


def check_problem_inputs(mesh: Any, seed: Any, tau: Any) -> Any:
    """Refuse, with a :class:`~labcut.errors.ParameterError` or :class:`~labcut.errors.MeshError`,
    a seed that is not a whole number in [0, 2^63), a flash threshold outside (0, 10) and a mesh
    that is not a non-empty ``trimesh.Trimesh`` or :class:`~labcut.Stone` (what a flash problem,
    whole or as pairs, is built from). Returns the stone's trimesh."""
    import trimesh

    if isinstance(mesh, Stone):
        mesh = mesh.mesh

    if not (isinstance(seed, int | np.integer) and 0 <= int(seed) < 2**63):
        raise ParameterError(f"seed must be a whole number >= 0, got {seed!r}", parameter="seed")
    if not (isinstance(tau, int | float) and math.isfinite(tau) and 0.0 < tau < 10.0):
        raise ParameterError(f"flash threshold tau must lie in (0, 10), got {tau!r}")
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshError("the mesh is empty or not a trimesh.Trimesh (load it with labcut.load_mesh)")
    return mesh


def build_problem(
    mesh: Any,
    material: Labradorite,
    lights: Lights | None = None,
    views: Views | None = None,
    quality: Quality | str = "standard",
    tau: float = 0.1,
    seed: int = 0,
    n_points: int | None = None,
    *,
    settings: list[Setting] | None = None,
    occlusion: bool | None = None,
    kernels: KernelOptions = DEFAULT_KERNELS,
) -> FlashProblem:
    """Sample the surface and build every (point, light, view) triple (see the module docstring).

    Give either ``lights`` and ``views`` (mesh frame, one still pose) or ``settings``: the
    poses of a scenario (:meth:`labcut.Scenario.settings`), each with its own lights and
    views in the mesh frame and a weight. A light of one pose is only ever paired with the
    views of the same pose; the problem's views are all poses' views, weighted by
    pose weight x view weight. ``occlusion``: test each sample's lights and views for parts of
    the stone in the way (default: when the stone is not convex; the effect planner may switch it).

    The surface samples are :func:`surface_samples` of this mesh, point count and ``seed`` (drawn
    once, then found in the mesh's cache: problems of the same stone share them). ``kernels``: which
    steps run as Dr.Jit kernels (:class:`~labcut.orientation.kernels.KernelOptions`), kept with the problem.
    """
    if settings is None:
        if lights is None or views is None:
            raise ParameterError("build_problem needs lights and views, or settings")
        settings = [Setting(lights, views, 1.0, np.eye(3))]
    if not settings:
        raise ParameterError("build_problem needs at least one setting")
    quality = Quality.coerce(quality)
    mesh = check_problem_inputs(mesh, seed, tau)
    count = int(n_points or quality.surface_points)
    samples = surface_samples(mesh, count, int(seed), quality.surface_sampling)
    points, n_geo, n_sh, convex = samples.points, samples.n_geo, samples.n_sh, samples.convex

    table = luminance_table(material)
    total_irradiance = [float(st.lights.weights.sum()) for st in settings]
    l_ref = reference_radiance(material, 1.0)
    if not l_ref > 0:
        raise ParameterError("the material reflects nothing at normal incidence: no flash can be scored")
    pose_w = np.array([float(st.weight) for st in settings])
    pose_w = pose_w / pose_w.sum()

    kernel = _TripleKernel(n_sh, material.n_surface, table, l_ref) if kernels.triples else None
    occluded = not (convex if occlusion is None else not occlusion)
    # each pose's pairs and lit lights first (the facing tests and occlusion rays); each pose's
    # lights are normalised to total irradiance 1: L_ref is per unit irradiance. Without occlusion
    # rays the kernel path tests the lights itself (KernelOptions.lit_cells): only the pairs here
    lit_on_device = kernels.lit_cells_on_device and not occluded
    poses = [_PosePairs(*view_pairs(st.views.directions, points, n_geo, n_sh, mesh, False), None) if lit_on_device
             else _setting_pairs(st.lights.directions, st.lights.weights / total_irradiance[k], st.views.directions,
                                 points, n_geo, n_sh, mesh, not occluded)
             for k, st in enumerate(settings)]
    pv_parts, pp_parts, pw_parts, vw_parts, offsets = [], [], [], [], []
    pair_offset = view_offset = 0
    area_per_point = float(Stone.of(mesh).face_areas.sum()) / count  # the samples are uniform over the surface
    view_area = [visible_areas(st.views.directions, pose, n_geo, area_per_point) for st, pose in zip(settings, poses)]
    for k, (st, pose) in enumerate(zip(settings, poses)):
        pv_parts.append(pose.pv + view_offset)
        pp_parts.append(pose.pi)
        pw_parts.append(pose.pair_weight)
        vw_parts.append(pose_w[k] * st.views.weights)
        offsets.append(pair_offset)
        pair_offset += len(pose.pi)
        view_offset += len(st.views.weights)
    # the triples are written into arrays of their count (known from the pairs and lit lights)
    pair_point = np.concatenate(pp_parts)
    pair_view = np.concatenate(pv_parts)
    cells = None
    if lit_on_device:  # each chunk's lit (pair, light) cells, found on the device: their count sizes the arrays
        cells = _lit_cells(settings, poses, pair_point, n_geo, n_sh, kernels.dense_chunk)
        total = cells.total
    else:
        total = sum(pose.n_triples for pose in poses)
    at = [0]
    whole: list[Any] = []  # every triple in one chunk: that chunk's own arrays, kept as they are (no copy)
    out: list[np.ndarray] = []  # else (h, c, pair) of every triple, allocated at the first chunk

    def sink(h_t: np.ndarray | Launched[np.ndarray], c_t: np.ndarray, pair_t: np.ndarray) -> None:
        n = len(c_t)
        if at[0] == 0 and n == total:  # h_t kept as it came (the kernel's: copied to the host only if read)
            whole.append((h_t, c_t, np.asarray(pair_t, dtype=np.int32)))
        else:
            if isinstance(h_t, Launched):
                h_t = h_t.value
            if not out:
                out.extend([np.empty((total, 3), dtype=np.float32), np.empty(total, dtype=np.float32),
                            np.empty(total, dtype=np.int32)])
            h, c, pair_of_t = out
            h[at[0]:at[0] + n], c[at[0]:at[0] + n], pair_of_t[at[0]:at[0] + n] = h_t, c_t, pair_t
        at[0] += n

    if kernel is not None:  # every pose's triples in one kernel call per chunk of pairs
        _all_triples(settings, [1.0 / e for e in total_irradiance], poses, np.array(offsets + [pair_offset]), pair_point,
                     pair_view, kernel, sink, cells, kernels.dense_chunk)
    else:
        for k, (st, pose) in enumerate(zip(settings, poses)):
            _setting_triples(st.lights.directions, st.lights.weights / total_irradiance[k], st.views.directions, pose,
                             n_sh, material.n_surface, table, l_ref, count, kernels.dense_chunk,
                             lambda h_t, c_t, pair_t, off=offsets[k]: sink(h_t, c_t, pair_t + off))
    del poses
    if at[0] != total:  # pragma: no cover - the count and the triples written must agree
        raise RuntimeError(f"built {at[0]} triples, counted {total}")
    if whole:
        h, c, pair_of_t = whole[0]
    elif out:
        h, c, pair_of_t = out[0][:at[0]], out[1][:at[0]], out[2][:at[0]]
    else:  # no triple at all
        h, c, pair_of_t = np.zeros((0, 3), dtype=np.float32), np.zeros(0, dtype=np.float32), np.zeros(0, dtype=np.int32)
    lit_any = c.size > 0 and float(c.sum(dtype=np.float64)) > 0.0
    if not lit_any:
        raise ParameterError(
            "no light reaches a part of the stone that a viewer sees: check that the lights are above "
            "the surfaces the views look at (+Z is face-up)"
        )
    view_weight = np.concatenate(vw_parts)
    problem = FlashProblem(
        host_h=h,
        c=c,
        pair=pair_of_t,
        pair_view=pair_view.astype(np.int64),
        pair_weight=np.concatenate(pw_parts),
        view_weight=view_weight / view_weight.sum(),
        kappa=material.lobe_kappa,
        q_norm=material.lobe_norm,
        tau=float(tau),
        threshold=flash_threshold(material, settings[0].lights, tau),
        material=material,
        lights=settings[0].lights,
        views=settings[0].views,
        convex=convex,
        n_points=count,
        kernels=kernels,
        info={"view_area_mm2": np.concatenate(view_area), "l_ref": l_ref, "pairs": int(pair_offset), "triples": int(c.size), "poses": len(settings),
              "pair_point": pair_point.astype(np.int32), "sampling": quality.surface_sampling},
    )
    if kernel is not None and whole and kernel.last_device is not None:
        # one kernel call made every triple: its device arrays are the problem's device copy
        # (FlashProblem.device_triples), not copied back from the host arrays
        problem.__dict__["device_triples"] = kernel.last_device
    return problem




def lights_reach(n_geo: Any, n_sh: Any, light: Any, bright: Any) -> Any:
    """Whether a light reaches a surface point, as Dr.Jit operations: the light (unit direction,
    ``Array3f64``) faces the point's geometric and shading normals (``Array3f64``; > 1e-6, the
    host's tests of :func:`_setting_pairs` in float64) and carries irradiance (``bright``)."""
    from ..backend import ad_types

    dr, _ = ad_types()
    return (dr.dot(n_geo, light) > 1e-6) & (dr.dot(n_sh, light) > 1e-6) & bright


class DeviceTerms:
    """The schiller triple terms of :func:`triple_terms` as Dr.Jit operations in float32 (lobe
    functions of :mod:`labcut.physics.schiller`; the luminance table interpolated on its uniform
    cos grid as ``np.interp`` does): one implementation for the triple kernel
    (:class:`_TripleKernel`) and the pairs' kernel (:mod:`labcut.orientation.pairs`). The
    material's numbers are opaque, so one compiled kernel serves every stone and material."""

    def __init__(self, eta: float, table: tuple[np.ndarray, np.ndarray], l_ref: float) -> None:
        from ..backend import ad_types
        from ..physics.ops import drjit_ops

        dr, t = ad_types()
        self.dr, self.t, self.ops = dr, t, drjit_ops()
        self.eta = dr.opaque(t.Float, float(eta))
        self.inv_l_ref = dr.opaque(t.Float, 1.0 / float(l_ref))
        self.table = t.Float(np.asarray(table[1], dtype=np.float32))
        self.cells = dr.opaque(t.Float, float(len(table[1]) - 1))  # the table is a uniform grid over cos 0..1
        self.last = dr.opaque(t.UInt32, len(table[1]) - 2)

    def view(self, w_v: Any, n: Any) -> tuple[Any, Any]:
        """Per (point, view): the internal direction ``b`` and ``T(n·v)``."""
        return lobe.internal_direction(w_v, n, self.eta, self.ops), lobe.transmission(self.dr.dot(w_v, n), self.eta, self.ops)

    def light(self, w_l: Any, irradiance: Any, n: Any, b: Any, t_v: Any) -> tuple[Any, Any]:
        """Per triple (light direction ``w_l`` and its irradiance, shading normal ``n``, the view's
        :meth:`view` terms): the mirror orientation ``h`` (not folded) and the factor ``c`` in front
        of the lobe, in units of L_ref."""
        dr, t, ops = self.dr, self.t, self.ops
        cos_nl = dr.dot(w_l, n)
        a = lobe.internal_direction(w_l, n, self.eta, ops)
        e_t_l = irradiance * lobe.transmission(cos_nl, self.eta, ops) * cos_nl
        h, cos_l, max_ab = lobe.mirror_terms(a, b, n, ops)
        x = dr.clip(cos_l, 0.0, 1.0) * self.cells  # np.interp on the uniform cos grid of the luminance table
        cell = dr.minimum(t.UInt32(x), self.last)
        frac = x - t.Float(cell)
        y0 = dr.gather(t.Float, self.table, cell)
        r_y = y0 + frac * (dr.gather(t.Float, self.table, cell + 1) - y0)
        return h, lobe.schiller_factor(e_t_l, t_v, cos_l, max_ab, self.eta, ops) * r_y * self.inv_l_ref


class _TripleKernel:
    """The schiller triple terms of :func:`triple_terms` (lobe functions of
    :mod:`labcut.physics.schiller`, Dr.Jit ops) for triples given by (point, light, view) indices:
    the shading normals live on the device once per problem, each pose's lights and views with
    its call. Deterministic (elementwise, no atomics); the material's numbers are opaque, so one
    compiled kernel serves every stone and material."""

    def __init__(self, n_sh: np.ndarray, eta: float, table: tuple[np.ndarray, np.ndarray], l_ref: float) -> None:
        from ..backend import ad_types

        dr, t = ad_types()
        self.dr, self.t = dr, t
        n = np.asarray(n_sh, dtype=np.float32)
        self.n = t.Array3f(n[:, 0], n[:, 1], n[:, 2])
        self.terms = DeviceTerms(eta, table, l_ref)
        #: the device arrays (h, c) of the last call's triples (the host arrays hold the same values)
        self.last_device: tuple[Any, Any] | None = None

    def dense(self, L: np.ndarray, E: np.ndarray, V: np.ndarray, point: np.ndarray, view: np.ndarray,
              light0: np.ndarray, width: int, index: np.ndarray) -> tuple[Launched[np.ndarray], np.ndarray]:
        """(h (T, 3) float32 folded into the upper hemisphere, its host copy made when read, c (T,) float32 in units of L_ref,
        non-finite terms replaced by (0, 0, 1) and 0) of the triples of a block of pairs (their
        ``point``, ``view`` and first light ``light0`` indices, each (P,)) with the ``width``
        lights from each pair's first: triple ``index[t]`` (uint32, < P x width, numpy or a Dr.Jit
        ``UInt32`` already on the device) is pair ``index // width`` with light ``light0 + index %
        width``. The per-triple indices are made
        on the device, from one array."""
        dr, t = self.dr, self.t
        idx = index if isinstance(index, t.UInt32) else t.UInt32(np.asarray(index, dtype=np.uint32))
        w = dr.opaque(t.UInt32, int(width))
        j = idx // w
        p_point, p_view, p_light = (t.UInt32(np.asarray(x, dtype=np.uint32)) for x in (point, view, light0))
        i_l = dr.gather(t.UInt32, p_light, j) + (idx - j * w)
        return self._terms(L, E, V, dr.gather(t.UInt32, p_point, j), i_l, dr.gather(t.UInt32, p_view, j))

    def _terms(self, L: np.ndarray, E: np.ndarray, V: np.ndarray, i_p: Any, i_l: Any, i_v: Any) -> tuple[Launched[np.ndarray], np.ndarray]:
        dr, t = self.dr, self.t
        L32, V32 = np.asarray(L, dtype=np.float32), np.asarray(V, dtype=np.float32)
        lights = t.Array3f(L32[:, 0], L32[:, 1], L32[:, 2])
        views = t.Array3f(V32[:, 0], V32[:, 1], V32[:, 2])
        irr = t.Float(np.asarray(E, dtype=np.float32))
        n = dr.gather(t.Array3f, self.n, i_p)
        b, t_v = self.terms.view(dr.gather(t.Array3f, views, i_v), n)
        h, c = self.terms.light(dr.gather(t.Array3f, lights, i_l), dr.gather(t.Float, irr, i_l), n, b, t_v)
        h = dr.select(h.z < 0.0, -h, h)  # axial: fold into the upper hemisphere
        # a non-finite term (a degenerate refraction) is no triple: (0, 0, 1) and 0, on the device
        finite = dr.isfinite(c) & dr.isfinite(h.x) & dr.isfinite(h.y) & dr.isfinite(h.z)
        h = dr.select(finite, h, t.Array3f(0.0, 0.0, 1.0))
        c = dr.select(finite, c, 0.0)
        dr.eval(h, c)
        self.last_device = (h, c)
        # the host's copy of h only when read (FlashProblem.h): the kernels that follow read the device's
        return Launched(lambda: np.stack([np.asarray(h.x), np.asarray(h.y), np.asarray(h.z)], axis=1)), np.asarray(c)


@dataclass(frozen=True)
class _PosePairs:
    """One pose's (point, view) pairs (sorted by point) with their projected-area weights (summing
    to 1 within each view), and which lights each surface point sees (``lit``: points x lights;
    None where the triple kernel tests the lights on the device, ``KernelOptions.lit_cells``)."""

    pi: np.ndarray
    pv: np.ndarray
    pair_weight: np.ndarray
    lit: np.ndarray | None

    @property
    def n_triples(self) -> int:
        """Every pair times the lights its point sees (a point without pairs has no triples): the
        points' pair counts times their lit lights, one float64 product (whole numbers below 2^53:
        exact), no per-pair gather and no row sums of the (points x lights) table (slow over short rows)."""
        if self.pi.size == 0:
            return 0
        pairs_per_point = np.bincount(self.pi, minlength=self.lit.shape[0]).astype(np.float64)
        return int(round(float((pairs_per_point @ self.lit).sum())))


def view_pairs(V: np.ndarray, points: np.ndarray, n_geo: np.ndarray, n_sh: np.ndarray, mesh: Any,
               occluded: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One pose's (point, view) pairs, sorted by point, and their projected-area weights (summing
    to 1 within each view): a point counts for a view (unit directions ``V``, mesh frame) when its
    geometric and shading normals face it and, ``occluded``, the ray towards it leaves the stone.
    ``(point index, view index, weight)`` per pair."""
    cos_v = n_geo @ V.T  # (points, views): the facing test, then the pairs' projected areas
    face_v = (cos_v > 1e-6) & (n_sh @ V.T > 1e-6)
    if occluded:
        from ..rendering.rays import escapes  # one cached ray scene per mesh

        face_v &= escapes(mesh, points, n_geo, V)
    pi, pv = np.nonzero(face_v)
    proj = cos_v[pi, pv]
    per_view = np.bincount(pv, weights=proj, minlength=len(V))
    return pi, pv, proj / np.where(per_view[pv] > 0, per_view[pv], 1.0)


def visible_areas(V: np.ndarray, pose: Any, n_geo: np.ndarray, area_per_point: float) -> np.ndarray:
    """Each view's visible projected area of the stone (mm²): Σ over the view's pairs (the points
    it sees, :func:`view_pairs`) of cos(normal, view) x the surface area each point stands for.
    The denominator of the view's flash area, in mm² (a Monte Carlo estimate of the area of the
    stone's outline from that direction)."""
    cos = np.einsum("ij,ij->i", n_geo[pose.pi], np.asarray(V, dtype=np.float64)[pose.pv])
    return np.bincount(pose.pv, weights=cos, minlength=len(V)) * area_per_point


def _setting_pairs(L, E, V, points, n_geo, n_sh, mesh, convex) -> _PosePairs:
    """The pairs (:func:`view_pairs`) and lit lights of one pose: facing tests (geometric and
    shading normal) and, for a stone that is not convex, occlusion rays."""
    pi, pv, pair_weight = view_pairs(V, points, n_geo, n_sh, mesh, not convex)
    lit = (n_geo @ L.T > 1e-6) & (n_sh @ L.T > 1e-6) & (E[None, :] > 0)
    if not convex:
        from ..rendering.rays import escapes  # one cached ray scene per mesh

        lit &= escapes(mesh, points, n_geo, L)
    return _PosePairs(pi, pv, pair_weight, lit)




def light_rows(settings: list[Setting], scale: list[float] | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Every pose's lights in a row of ``width`` slots (the most lights of a pose): directions
    (poses x width, 3) and irradiances times ``scale`` (poses x width; empty slots: 0, never lit),
    and ``width``."""
    width = max(1, max(len(st.lights.directions) for st in settings))
    L = np.zeros((len(settings), width, 3))
    L[..., 2] = 1.0
    E = np.zeros((len(settings), width))
    for k, st in enumerate(settings):
        n = len(st.lights.directions)
        L[k, :n], E[k, :n] = st.lights.directions, st.lights.weights * (1.0 if scale is None else scale[k])
    return L.reshape(-1, 3), E.reshape(-1), width


class _LitCells:
    """The (pair, light slot) cells of :func:`_all_triples`'s chunks whose light reaches the pair's
    point, found on the device (:func:`_lit_cells`): their count over every chunk (:attr:`total`,
    which sizes the problem's arrays) and each chunk's compacted cell indices (:meth:`chunk`).
    A problem of one chunk keeps its indices from the count; one of several finds a chunk's again
    when it is made (the test is a few multiply-adds a cell), so that only one chunk's indices
    live at a time (a high-quality problem under an environment map has tens of millions)."""

    def __init__(self, test: Callable[[int], Any], chunks: int) -> None:
        from ..backend import ad_types

        dr, _ = ad_types()
        self._test = test
        self._kept: dict[int, Any] = {}
        counts = []
        for k in range(chunks):
            index = dr.compress(test(k))
            counts.append(int(dr.width(index)))
            if chunks == 1:
                self._kept[k] = index
        self.total = sum(counts)

    def chunk(self, k: int) -> Any:
        """The Dr.Jit ``UInt32`` indices ``(pair - first pair of the chunk) x width + slot`` of chunk
        ``k``'s lit cells, in order."""
        from ..backend import ad_types

        dr, _ = ad_types()
        kept = self._kept.pop(k, None)
        return kept if kept is not None else dr.compress(self._test(k))


def _lit_cells(settings: list[Setting], poses: list[_PosePairs], point: np.ndarray, n_geo: np.ndarray,
               n_sh: np.ndarray, dense_chunk: int) -> _LitCells:
    """The lit cells of every chunk of ``dense_chunk`` (pair, light slot) cells of
    :func:`_all_triples` (:class:`_LitCells`): a cell counts, as in the host's table, where the
    pose's light faces the pair's point's geometric and shading normals (> 1e-6, float64, the
    host's tests) and carries irradiance. For a stone without occlusion rays."""
    from ..backend import ad_types

    dr, t = ad_types()
    L, E, width = light_rows(settings)
    L64 = t.Array3f64(*(np.ascontiguousarray(L[:, k]) for k in range(3)))
    bright = t.Bool(E > 0)
    ng = t.Array3f64(*(np.ascontiguousarray(n_geo[:, k], dtype=np.float64) for k in range(3)))
    ns = t.Array3f64(*(np.ascontiguousarray(n_sh[:, k], dtype=np.float64) for k in range(3)))
    pose_of = np.concatenate([np.full(len(pose.pi), k, dtype=np.int64) for k, pose in enumerate(poses)])
    w = dr.opaque(t.UInt32, width)
    chunk = max(1, dense_chunk // width)

    def test(k: int) -> Any:
        g0 = k * chunk
        g1 = min(point.size, g0 + chunk)
        p_point = t.UInt32(np.asarray(point[g0:g1], dtype=np.uint32))
        p_light = t.UInt32((pose_of[g0:g1] * width).astype(np.uint32))
        cell = dr.arange(t.UInt32, (g1 - g0) * width)
        j = cell // w
        i_p = dr.gather(t.UInt32, p_point, j)
        i_l = dr.gather(t.UInt32, p_light, j) + (cell - j * w)
        return lights_reach(dr.gather(t.Array3f64, ng, i_p), dr.gather(t.Array3f64, ns, i_p),
                            dr.gather(t.Array3f64, L64, i_l), dr.gather(t.Bool, bright, i_l))

    return _LitCells(test, -(-point.size // chunk))


def _all_triples(settings: list[Setting], scale: list[float], poses: list[_PosePairs], first_pair: np.ndarray,
                 point: np.ndarray, view: np.ndarray, kernel: _TripleKernel,
                 sink: Any, lit_cells: _LitCells | None, dense_chunk: int) -> None:
    """The triples of every pose at once (:func:`_setting_triples`'s triples, in its order: pose,
    pair, light), handed to ``sink(h, c, pair)`` chunk by chunk, ``pair`` an index into all poses'
    pairs (``first_pair``: each pose's first pair among all, and their count last; ``point`` and
    ``view``: each pair's point and view index, the views of all poses in pose order, as
    :func:`build_problem` concatenates them). Each pose's lights (irradiance times ``scale``) fill a row of ``width`` slots (the
    most lights of a pose; empty slots unlit); the (pair, light slot) cells a pair's point sees
    lit are its triples, evaluated by :meth:`_TripleKernel.dense` per chunk of
    ``dense_chunk`` cells: one call for a problem at standard quality rather than one per pose,
    the per-triple indices made on the device. ``lit_cells``: the lit cells of each chunk found on
    the device (:func:`_lit_cells`; the poses then carry no ``lit`` tables)."""
    L, E, width = light_rows(settings, scale)
    V = np.concatenate([st.views.directions for st in settings])
    pose_of = np.concatenate([np.full(len(pose.pi), k, dtype=np.int64) for k, pose in enumerate(poses)])
    light0 = pose_of * width
    chunk = max(1, dense_chunk // width)
    for n_chunk, g0 in enumerate(range(0, point.size, chunk)):
        g1 = min(point.size, g0 + chunk)
        if lit_cells is not None:
            index = lit_cells.chunk(n_chunk)
            if kernel.dr.width(index) == 0:
                continue
        else:
            # (pairs x slots): the lit lights of each pair's point, from each pose's own (points x lights) table
            cells = np.zeros((g1 - g0, width), dtype=bool)
            for k, pose in enumerate(poses):
                a, b = max(g0, first_pair[k]), min(g1, first_pair[k + 1])
                if a < b:
                    cells[a - g0:b - g0, :pose.lit.shape[1]] = pose.lit[pose.pi[a - first_pair[k]:b - first_pair[k]]]
            index = np.flatnonzero(cells.ravel())
            if index.size == 0:
                continue
        h, c = kernel.dense(L, E, V, point[g0:g1], view[g0:g1], light0[g0:g1], width, index)
        sink(h, c, _pairs_of_cells(kernel, index, width, g0))


def _pairs_of_cells(kernel: _TripleKernel, index: Any, width: int, first: int) -> np.ndarray:
    """The pair of each (pair, light slot) cell ``index`` (``pair - first`` x ``width`` + slot: numpy,
    or a Dr.Jit ``UInt32`` of the lit cells found on the device) as int32 indices among all pairs:
    ``index // width + first``. Device cells are divided there and copied to the host once (a
    standard problem's 720k cells: one 2.9 MB array, where the host's division, cast and offset
    made three more, pages a live view touches anew at every lamp)."""
    if isinstance(index, np.ndarray):
        return (index // width).astype(np.int32) + np.int32(first)
    dr, t = kernel.dr, kernel.t
    pairs = index // dr.opaque(t.UInt32, int(width)) + dr.opaque(t.UInt32, int(first))
    return np.asarray(pairs).view(np.int32)  # below 2^31 pairs: the same values as int32


def _setting_triples(L, E, V, pose, n_sh, eta, table, l_ref, count, dense_chunk, sink) -> None:
    """Triples of one pose (its :class:`_PosePairs`) in float64 numpy passes: the reference of
    :func:`_all_triples`'s kernel for the tests (``KernelOptions.triples`` off), handed to ``sink(h, c, pair)`` chunk
    by chunk (pair: index into the pose's pairs)."""
    pi, pv, lit = pose.pi, pose.pv, pose.lit

    # triples: each pair x the lights its point sees; built in chunks of points and
    # stored in float32 (20 bytes a triple) so high quality stays within memory
    pair_first = np.searchsorted(pi, np.arange(count + 1))  # pairs are sorted by point
    chunk = max(1, dense_chunk // max(1, len(V) * max(1, int(lit.sum(axis=1).max(initial=1)))))
    for p0 in range(0, count, chunk):
        p1 = min(count, p0 + chunk)
        q0, q1 = pair_first[p0], pair_first[p1]
        if q1 == q0:
            continue
        c_pi = pi[q0:q1]
        seen = np.zeros(p1 - p0, dtype=bool)  # points a view of this pose sees: only their lights matter
        seen[c_pi - p0] = True
        lit_i, lit_l = np.nonzero(lit[p0:p1] & seen[:, None])
        lit_i = lit_i + p0
        counts = np.bincount(lit_i - p0, minlength=p1 - p0)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        reps = counts[c_pi - p0]
        if reps.sum() == 0:
            continue
        pair_of_t = np.repeat(np.arange(q0, q1), reps)
        offs = np.arange(reps.sum()) - np.repeat(np.cumsum(reps) - reps, reps)
        lit_of_t = np.repeat(starts[c_pi - p0], reps) + offs  # index into this chunk's lit (point, light)

        # refraction and Fresnel per (point, light) and per (point, view), then gathered per triple
        # (:func:`triple_terms`, with a·n and b·n taken once per (point, light) and per pair)
        n_lit = n_sh[lit_i]
        a_lit, etl_lit = light_terms(n_lit, L[lit_l], E[lit_l], eta)
        an_lit = NUMPY.dot(a_lit, n_lit)
        del n_lit
        n_pair = n_sh[c_pi]
        b_pair, t_v_pair = view_terms(n_pair, V[pv[q0:q1]], eta)
        bn_pair = NUMPY.dot(b_pair, n_pair)
        local = pair_of_t - q0
        a_t = a_lit[lit_of_t]
        s_t = a_t + b_pair[local]
        ss = NUMPY.dot(s_t, s_t)
        # lobe.mirror_terms and triple_terms, term by term
        h = NUMPY.scale(s_t, 1.0 / np.sqrt(np.maximum(ss, NUMPY.tiny)))
        del s_t, ss
        cos_l = np.abs(NUMPY.dot(a_t, h))
        del a_t
        max_ab = np.maximum(an_lit[lit_of_t], bn_pair[local])
        r_y = np.interp(np.clip(cos_l, 0.0, 1.0), table[0], table[1])
        c = lobe.schiller_factor(etl_lit[lit_of_t], t_v_pair[local], cos_l, max_ab, eta, NUMPY) * r_y
        del cos_l, max_ab, r_y
        c /= l_ref
        down = h[:, 2] < 0.0
        if down.any():  # axial: fold into the upper hemisphere
            h[down] = -h[down]
        if np.isfinite(c).all() and np.isfinite(h).all():
            sink(h.astype(np.float32), c.astype(np.float32), pair_of_t)
        else:
            finite = np.isfinite(c) & np.all(np.isfinite(h), axis=1)
            sink(np.where(finite[:, None], h, np.array([0.0, 0.0, 1.0])).astype(np.float32),
                 np.where(finite, c, 0.0).astype(np.float32), pair_of_t)
