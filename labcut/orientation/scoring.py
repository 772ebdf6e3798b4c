"""Flash metrics and objectives of a lamella normal, in Dr.Jit (DESIGN.md §4).

:class:`Scorer` holds a :class:`~labcut.orientation.problem.FlashProblem` on the
Dr.Jit device (CUDA if it works, else LLVM) and evaluates, for a lamella normal
``m``, ``L_s/L_ref`` of every (point, view) pair as ``Σ_l c_t q(h_t·m)`` and from it:

* ``flash_area(v)``: projected-area fraction of the surface facing ``v`` with ``L_s >= τ L_ref``;
* ``flash_intensity(v)``: mean ``L_s/L_ref`` over that flash region (0 if empty);
* ``flash_energy(v)``: mean ``L_s/L_ref`` over the whole facing surface;
* view-weighted aggregates, and ``coverage`` = weight of views with flash_area > 0.05.

Objectives: ``energy`` (default; linear in ``q``, so its hemisphere map is exact and
cheap), ``area``, ``intensity``, ``balanced`` = sqrt(area x intensity). For gradients
the hard threshold is replaced by a logistic step of width 0.02 τ (``smooth=True``);
reported metrics always use the hard threshold.

Normals are parametrised by stereographic coordinates ``(u, v)`` from the south
pole: ``m = (2u, 2v, 1 - u² - v²)/(1 + u² + v²)``; the upper hemisphere is the unit
disc, tilt θ sits at radius tan(θ/2), and nothing is singular at the pole.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np

from ..errors import ParameterError
from ..physics.ops import drjit_ops
from ..physics.schiller import lobe_density
from ..geometry.surface import dense_ranks
from .problem import FlashProblem
from ..backend import Launched
from .kernels import DEFAULT_KERNELS, KernelOptions

OBJECTIVES = ("energy", "area", "intensity", "balanced")
COVERAGE_AREA = 0.05


def stereo_to_normal(u: float, v: float) -> np.ndarray:
    r2 = u * u + v * v
    return np.array([2 * u, 2 * v, 1 - r2]) / (1 + r2)


def stereo_jacobian(u: float, v: float) -> np.ndarray:
    """(3, 2) derivative of :func:`stereo_to_normal` with respect to ``(u, v)``."""
    d = 1.0 + u * u + v * v
    return np.array([[2.0 * (1.0 + v * v - u * u), -4.0 * u * v],
                     [-4.0 * u * v, 2.0 * (1.0 + u * u - v * v)],
                     [-4.0 * u, -4.0 * v]]) / (d * d)


def normal_to_stereo(m: np.ndarray) -> tuple[float, float]:
    m = np.asarray(m, dtype=np.float64)
    m = m / np.linalg.norm(m)
    if m[2] < 0:
        m = -m
    return float(m[0] / (1 + m[2])), float(m[1] / (1 + m[2]))


#: elements per chunk of the index and binning passes over the triples (bounded temporaries:
#: high quality under an environment map has tens of millions of triples)
CHUNK = 1 << 22


def _padded_rows(owner: np.ndarray, n_rows: int, t: Any) -> tuple[Any, Any, int]:
    """Index rows for segment sums: row r lists the positions i with owner[i] == r, padded.

    Returns (index, valid, width) for ``block_sum(gather(values, index, valid), width)``. Owners
    sorted (a problem's triples by pair) are placed in chunks, without a sort or per-element
    int64 temporaries of the whole array."""
    owner = np.asarray(owner)
    counts = np.bincount(owner, minlength=n_rows)
    width = max(1, int(counts.max(initial=0)))
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    index = np.zeros(n_rows * width, dtype=np.uint32)
    valid = np.zeros(n_rows * width, dtype=bool)
    if owner.size < 2 or bool(np.all(owner[1:] >= owner[:-1])):
        shift = np.arange(n_rows, dtype=np.int64) * width - starts  # position i of row r sits at r*width + i - starts[r]
        for s0 in range(0, owner.size, CHUNK):
            i = np.arange(s0, min(owner.size, s0 + CHUNK), dtype=np.int64)
            slot = shift[owner[s0:s0 + CHUNK]]
            slot += i
            index[slot] = i
            valid[slot] = True
    else:
        order = np.argsort(owner, kind="stable")
        rows = np.repeat(np.arange(n_rows), counts)
        cols = np.arange(order.size) - np.repeat(starts, counts)
        index[rows * width + cols] = order
        valid[rows * width + cols] = True
    return t.UInt32(index), t.Bool(valid), width


def _device_keys_apply(problem: Any, n_keys: int) -> bool:
    """Whether :meth:`Scorer._bin_triples` takes the grid keys from the problem's device copy of
    the triples (:func:`_device_grid_keys`): :meth:`KernelOptions.device_keys_apply` of the
    problem's kernel options."""
    return problem.kernels.device_keys_apply(problem.n_triples, n_keys)


def _device_grid_keys(h: Any, bins: int) -> np.ndarray:
    """int32 stereographic grid keys ``iu * bins + iv`` of the device mirror orientations ``h``
    (``Array3f``, upper hemisphere): the float32 operations of the numpy path
    (:meth:`Scorer._bin_triples`'s ``grid_key``) in its order, truncated and clipped alike."""
    from ..backend import ad_types

    dr, _ = ad_types()
    key = _device_grid_key_array(h, bins)
    dr.eval(key)
    return np.asarray(key)


def _device_grid_key_array(h: Any, bins: int) -> Any:
    """The keys of :func:`_device_grid_keys` as a Dr.Jit ``Int32`` array (not evaluated)."""
    from ..backend import ad_types

    dr, t = ad_types()
    b = dr.opaque(t.Float, float(bins))
    z1 = 1.0 + h.z
    top = dr.opaque(t.Int32, bins - 1)
    iu = dr.clip(t.Int32((h.x / z1 + 1.0) * 0.5 * b), 0, top)
    iv = dr.clip(t.Int32((h.y / z1 + 1.0) * 0.5 * b), 0, top)
    return iu * dr.opaque(t.Int32, bins) + iv


#: largest grid (cells) binned with a dense bincount; finer grids sort the occupied keys instead
DENSE_KEY_LIMIT = 1 << 24

#: headroom of the fixed-point bin sums: every sum's magnitude stays below 2^(63 - FIXED_HEADROOM)
FIXED_HEADROOM = 1

#: size classes per doubling of :func:`size_class` (a power of two)
SIZE_CLASSES_PER_OCTAVE = 8


def size_class(n: int) -> int:
    """``n`` rounded up to one of :data:`SIZE_CLASSES_PER_OCTAVE` sizes per power of two (at most
    1/8 larger): the length of a Dr.Jit scatter-reduction's target whose exact length changes from
    call to call. On the LLVM backend Dr.Jit expands such a target to one copy per thread
    (``ReduceMode.Expand``, its choice for small targets and the fastest here) and writes the
    target's length into the kernel, so a length never seen before is a kernel compiled anew (and
    one more file in Dr.Jit's kernel cache): the bins of every new lamp and material in ``labcut
    explore``, and of every new stone (docs/performance.md, "Kernels compiled anew for every new
    lamp"). Rounded to a class, the kernels repeat: at most 8 per doubling, each compiled once per
    machine and read from Dr.Jit's cache after."""
    n = max(int(n), 1)
    shift = n.bit_length() - SIZE_CLASSES_PER_OCTAVE.bit_length()  # log2(n) - log2(classes), floored
    if shift <= 0:
        return n
    step = 1 << shift
    return -(-n // step) * step


def _device_bins(problem: Any, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Scorer._bin_triples` in Dr.Jit kernels over the problem's device copy of the triples
    (:attr:`~labcut.orientation.problem.FlashProblem.device_triples`): each triple's energy weight
    ``alpha_t = c_t x pair_alpha[pair_t]`` (float64, the host's product), its grid key
    (:func:`_device_grid_keys`), the occupied cells ranked in key order (a prefix sum), and the
    bins' weights and weighted directions summed as 64-bit integers: ``round(x 2^S)`` with ``S``
    such that the sum of every |alpha| stays below 2^62, so each sum is exact in its units and the
    same whatever order the threads add in (float atomics are not); each bin's sums lie within
    ``count x 2^-S`` (about 1e-13 of the total weight over all bins together) of the float64 sums.
    ``(centroids (B, 3), weights (B,))`` in ascending key order, as the numpy path gives them."""
    from ..backend import ad_types

    dr, t = ad_types()
    h, c = problem.device_triples
    pair = t.UInt32(np.asarray(problem.pair, dtype=np.uint32))
    alpha = t.Float64(c) * dr.gather(t.Float64, t.Float64(problem.pair_alpha), pair)
    keep = alpha > 0.0
    n_keys = bins * bins
    key = t.UInt32(_device_grid_key_array(h, bins))
    present = dr.zeros(t.UInt32, n_keys)
    dr.scatter(present, t.UInt32(1), key, keep)
    rank = dr.prefix_sum(present)  # exclusive: the cell's bin index among the occupied cells
    total_a = dr.sum(dr.select(keep, alpha, 0.0))
    dr.eval(rank, alpha, total_a)
    last = t.UInt32(n_keys - 1)
    n_bins = int(dr.gather(t.UInt32, rank, last)[0] + dr.gather(t.UInt32, present, last)[0])
    if n_bins == 0:
        return np.array([[0.0, 0.0, 1.0]]), np.zeros(1)
    total = float(total_a[0])
    shift = 62 - FIXED_HEADROOM - max(0, math.ceil(math.log2(max(total, 1e-300))))
    unit = math.ldexp(1.0, shift)
    inv = dr.gather(t.UInt32, rank, key, keep)
    scaled = alpha * dr.opaque(t.Float64, unit)
    sums = []
    for value in (scaled, scaled * t.Float64(h.x), scaled * t.Float64(h.y), scaled * t.Float64(h.z)):
        out = dr.zeros(t.Int64, size_class(n_bins))  # the bins, then zeros up to the size class
        dr.scatter_reduce(dr.ReduceOp.Add, out, t.Int64(dr.round(value)), inv, keep)
        sums.append(out)
    dr.eval(*sums)
    weight, cx, cy, cz = (np.asarray(x)[:n_bins].astype(np.float64) * math.ldexp(1.0, -shift) for x in sums)
    centroid = np.stack([cx, cy, cz], axis=1)
    norm = np.linalg.norm(centroid, axis=1, keepdims=True)
    # a bin whose every weight lies below half a unit sums to zero: it holds under 2^-62 of the
    # total weight per triple, nothing a map can see, and has no direction: dropped
    kept = (weight > 0.0) & (norm[:, 0] > 0.0)
    if not kept.all():
        centroid, weight, norm = centroid[kept], weight[kept], norm[kept]
        if weight.size == 0:
            return np.array([[0.0, 0.0, 1.0]]), np.zeros(1)
    return centroid / norm, weight


def grid_inverse(key: np.ndarray, n_keys: int) -> np.ndarray:
    """For integer grid keys in ``[0, n_keys)``: each key's rank among the distinct keys present,
    in ascending key order (``np.unique(key, return_inverse=True)[1]``, without the sort when the
    grid is small enough for one mask, :func:`labcut.geometry.surface.dense_ranks`: O(N + n_keys)
    instead of O(N log N))."""
    key = np.asarray(key, dtype=np.int64).ravel()
    if n_keys > DENSE_KEY_LIMIT:
        return np.unique(key, return_inverse=True)[1].ravel().astype(np.int64)
    return dense_ranks(key, n_keys)


def _cos_matrix(m: np.ndarray, ht: np.ndarray) -> np.ndarray:
    """(k, n) dot products of the rows of ``m`` (k, 3) and the columns of ``ht`` (3, n), float64,
    without BLAS (``m @ ht``): one ``einsum`` pass, which writes each (k, n) entry once from its
    three products. Not BLAS: OpenBLAS threads the product and, next to Dr.Jit's own thread pool
    on few cores, a small product then waits far longer for its threads than it computes;
    ``einsum``'s order of the three products is also fixed, whatever
    BLAS and thread count the machine has. (Three broadcast multiply-adds would make two (k, n)
    temporaries and five passes over them: ``benchmarks/lobe_sums.py`` compares them.)"""
    return np.einsum("kj,jn->kn", m, ht)


def _lobe_sums(m: np.ndarray, ht: np.ndarray, a: np.ndarray, kappa: float) -> np.ndarray:
    """Σ_b a_b exp(κ(|h_b·m_k| - 1)) for each row ``m_k``, ``ht`` the (3, n) bin directions
    (without BLAS, see :func:`_cos_matrix`). κ is folded into the normals (``|κm·h| = κ|m·h|``,
    κ > 0): four passes over the (k, n) block, its dot products, abs, shift and exp, then the sum."""
    d = _cos_matrix(m * kappa, ht)
    np.abs(d, out=d)
    d -= kappa
    np.exp(d, out=d)
    return np.einsum("kb,b->k", d, a)


#: largest (normals x bins) block of the union path, in terms (8 bytes each)
UNION_BLOCK = 1 << 21

#: relative accuracy of the sparse energy map: every dropped lobe term lies below this share
#: of a lower bound of the hemisphere's best energy
SPARSE_RTOL = 1e-8
#: (tile, normal) pairs tested for reach per kernel call (bounded temporaries for huge maps)
DEVICE_PAIR_BLOCK = 1 << 24


class SparseLobeMap:
    """Σ_b A_b q(|h_b·m|) at many normals, summing only the terms that matter (tile culling).

    The lobe ``q = norm·exp(κ(|h·m| - 1))`` falls below ``e^{-T}`` of its peak beyond the
    angle ``acos(1 - T/κ)``. Bins are grouped in tiles of a stereographic grid (upper
    hemisphere, mesh frame); a tile whose bounding cap (centre, angular radius) lies further
    than that from a normal (or from its antipode: the lobe is axial) is skipped whole. ``T``
    is chosen so that all skipped terms together stay below :data:`SPARSE_RTOL` x a lower bound
    of the best energy on the hemisphere (the largest energy at a few probe normals, computed
    densely), so the map agrees with the dense sum to that relative accuracy. float64 numpy,
    deterministic (fixed summation order).
    """

    def __init__(self, h: np.ndarray, a: np.ndarray, kappa: float, norm: float, rtol: float = SPARSE_RTOL,
                 *, kernels: KernelOptions = DEFAULT_KERNELS) -> None:
        h = np.asarray(h, dtype=np.float64)
        a = np.asarray(a, dtype=np.float64)
        self.kappa, self.norm = float(kappa), float(norm)
        #: which of its paths may run as a Dr.Jit kernel, and the cost constants that choose them
        self.kernels = kernels
        self._unions: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._device: Any = None  # the packed bins on the Dr.Jit device (:meth:`_device_sums`), made at its first call
        total = float(a.sum())
        if total <= 0 or len(a) == 0:
            self.h, self.a, self.cos_cut = h, a, -1.0
            self.ht = np.ascontiguousarray(h.T)
            self.centre = np.zeros((0, 3))
            self.centre_t = np.zeros((3, 0))
            self.starts = self.counts = np.zeros(0, dtype=np.int64)
            self.cos_reach = self.cos_reach_device = np.zeros(0)
            return
        # probe normals: the heaviest bins' directions give a lower bound of the best energy
        heavy = np.argpartition(a, len(a) - 16)[-16:] if len(a) > 16 else np.arange(len(a))  # the 16 heaviest, any order
        probes = h[heavy]
        lower = float(np.max(self._dense(h, a, probes)))
        def t_of(share: float) -> float:  # the lobe exponent below which the dropped terms stay under share x lower
            return max(12.5, math.log(max(self.norm * total / max(share * lower, 1e-300), 1.0)))

        t_cut = t_of(rtol)
        self.cos_cut = 1.0 - t_cut / self.kappa
        cut = math.acos(max(-1.0, self.cos_cut))
        cut_device = math.acos(max(-1.0, 1.0 - min(t_cut, t_of(max(rtol, kernels.map_kernel_rtol))) / self.kappa))
        # tiles about a quarter of the cut-off angle across (a stereographic cell of side s spans <= 2s rad)
        g = int(min(128, max(4, math.ceil(16.0 / max(cut, 1e-6)))))
        zp = 1.0 + np.maximum(h[:, 2], 0.0)
        iu = np.clip(((h[:, 0] / zp + 1.0) * 0.5 * g).astype(np.int64), 0, g - 1)
        iv = np.clip(((h[:, 1] / zp + 1.0) * 0.5 * g).astype(np.int64), 0, g - 1)
        key = iu * g + iv
        # stable, on keys below 2^14: numpy's radix sort of 16-bit integers (linear, not a merge sort)
        order = np.argsort(key.astype(np.int16), kind="stable")
        self.h, self.a = h[order], a[order]
        self.ht = np.ascontiguousarray(self.h.T)  # (3, B): contiguous coordinate rows for the products
        key = key[order]
        self.starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        self.counts = np.diff(np.r_[self.starts, len(key)])
        tile = np.repeat(np.arange(len(self.starts)), self.counts)
        centre = np.add.reduceat(self.h, self.starts, axis=0)
        centre /= np.maximum(np.linalg.norm(centre, axis=1, keepdims=True), 1e-300)
        self.centre = centre
        self.centre_t = np.ascontiguousarray(centre.T)  # (3, tiles): einsum over a transposed view is 7x slower
        cos_in = np.clip(np.einsum("ij,ij->i", self.h, centre[tile]), -1.0, 1.0)
        radius = np.maximum.reduceat(np.arccos(cos_in), self.starts) + 1e-6
        def cos_within(reach: np.ndarray) -> np.ndarray:  # -1 (every normal) from a quarter turn on
            return np.where(reach < math.pi / 2, np.cos(np.minimum(reach, math.pi / 2)), -1.0)

        #: a normal m needs tile j when |m·centre_j| >= cos(radius_j + cut)
        self.cos_reach = cos_within(radius + cut)
        #: the same for the Dr.Jit kernel's cull (``kernels.map_kernel_rtol``)
        self.cos_reach_device = cos_within(radius + cut_device)

    def _dense(self, h: np.ndarray, a: np.ndarray, m: np.ndarray) -> np.ndarray:
        return self.norm * _lobe_sums(m, np.ascontiguousarray(h.T), a, self.kappa)

    @property
    def n_tiles(self) -> int:
        return len(self.starts)

    def _union(self, tiles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(directions (3, n), weights (n,)) of every bin of ``tiles``, in tile order. The last few
        unions are kept: an optimiser's steps and a tolerance's rings need the same tiles again."""
        key = tiles.tobytes()
        hit = self._unions.get(key)
        if hit is not None:
            return hit
        cnt = self.counts[tiles]
        idx = np.repeat(self.starts[tiles] - (np.cumsum(cnt) - cnt), cnt) + np.arange(int(cnt.sum()))
        if len(self._unions) >= 8:
            self._unions.pop(next(iter(self._unions)))
        # np.take, not fancy indexing along the columns: that lays the rows out with a stride of 3
        # (every product over the union slower: benchmarks/lobe_sums.py) and gathers slower; take's (3, n) is contiguous
        self._unions[key] = out = (self.ht.take(idx, axis=1), self.a[idx])
        return out

    def __call__(self, normals: np.ndarray, path: str = "auto") -> np.ndarray:
        """Energy at each unit normal (rows of ``normals``, mesh frame). ``path``: ``auto`` (the
        cheapest), ``union`` (one block over the union of the tiles needed), ``tiles`` (one block
        per tile needed), both float64 numpy, or ``device`` (every (normal, tile) pair within reach
        in one Dr.Jit kernel, :meth:`_device_sums`: float32 terms, float64 sums, within 2e-8 of the
        best energy of the numpy paths' sums on the bundled oval's map, 1e-6 in the tests); ``auto``
        takes the kernel (:attr:`kernels`' ``energy_map``) for a call of at least its ``map_min_normals``
        normals (a tolerance's ring, a map: the kernel also finds their tiles) or of at least
        ``map_min_terms`` terms, numpy's cheaper block form for fewer (an optimiser's step)."""
        if path not in ("auto", "union", "tiles", "device"):
            raise ParameterError(f"path must be 'auto', 'union', 'tiles' or 'device', got {path!r}")
        m = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        out = np.zeros(len(m))
        if self.n_tiles == 0 or len(m) == 0:
            return out
        if path == "device" or (path == "auto" and self._kernel_takes(len(m))):
            return self._device_sums(m)
        # (tiles, k) cosines of the tiles' centres and the normals, and which pairs lie within reach
        cos_tm = _cos_matrix(self.centre, np.ascontiguousarray(m.T))
        need = np.abs(cos_tm) >= self.cos_reach[:, None]
        per_tile = np.count_nonzero(need, axis=1)
        tiles = np.flatnonzero(per_tile)
        if len(tiles) == 0:
            return out
        # one block over the union of the tiles any normal needs (a ring, a probe, a cluster of
        # normals), or one block per tile over the normals that need it (spread-out normals: a
        # map), whichever costs less (a block's call costs ``kernels.tile_call_terms`` terms); a
        # map of many normals in one kernel
        union_terms = len(m) * int(self.counts[tiles].sum())
        need_terms = int(per_tile @ self.counts)
        if path == "auto" and self.kernels.energy_map and need_terms >= self.kernels.map_min_terms:
            return self._device_sums(m)
        tile_terms = need_terms + self.kernels.tile_call_terms * len(tiles)
        if path == "union" or (path == "auto" and union_terms <= tile_terms):
            ht, a = self._union(tiles)
            step = max(1, UNION_BLOCK // max(ht.shape[1], 1))  # bounded (normals x bins) blocks
            for s in range(0, len(m), step):
                out[s : s + step] = _lobe_sums(m[s : s + step], ht, a, self.kappa)
            return self.norm * out
        for j in tiles:
            sel = np.flatnonzero(need[j])
            s, c = self.starts[j], self.counts[j]
            out[sel] += _lobe_sums(m[sel], self.ht[:, s : s + c], self.a[s : s + c], self.kappa)
        return self.norm * out

    def launch(self, normals: np.ndarray) -> Launched[np.ndarray]:
        """:meth:`__call__` (path ``auto``), launched: where the Dr.Jit kernel sums the call, its sums
        run on Dr.Jit's threads while the caller goes on (e.g. an optimiser's single-normal steps in
        numpy) and the result's ``value`` waits for them; else they are made now."""
        m = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        if self.n_tiles and self._kernel_takes(len(m)):
            return self._launch_device_sums(m)
        return Launched.ready(self(m))

    def _kernel_takes(self, count: int) -> bool:
        """Whether path ``auto`` sends a call of ``count`` normals to the kernel straight away."""
        return self.kernels.energy_map and count >= self.kernels.map_min_normals

    def _device_sums(self, m: np.ndarray) -> np.ndarray:
        """:meth:`_launch_device_sums`, waited for."""
        return self._launch_device_sums(m).value

    def _launch_device_sums(self, m: np.ndarray) -> Launched[np.ndarray]:
        """The map at the normals ``m`` (K, 3) in Dr.Jit kernels: the (tile, normal) pairs within
        the kernel's reach (``kernels.map_kernel_rtol``: ``|m·c_tile| >= cos(radius + cut)``, float64)
        found and compacted on the device, in tile order; then a thread per pair runs over the
        tile's bins and adds ``a_b exp(κ(|m·h_b| - 1))`` to a float64 sum; numpy adds each
        normal's pairs. The exponent is taken about the tile's centre c, where float32 keeps it
        exact to about 1e-6: with s = sign(m·c), ``κ(s m·h_b - 1) = κ(|m·c| - 1) + κ s m·(h_b -
        c)``, the first part per pair in float64, the bins' offsets ``h_b - c`` from their centre
        in float32; the axial lobe's other side, ``κ(-s m·h_b - 1)``, is the larger where the tile
        straddles the normal's equator. Threads go in tile order (a SIMD packet's lanes run over
        the same bins)."""
        from ..backend import ad_types

        dr, t = ad_types()
        if self._device is None:  # (offset from the tile's centre, weight) of each bin, packed: one load a bin
            tile = np.repeat(np.arange(self.n_tiles), self.counts)
            packed = np.empty((len(self.a), 4), dtype=np.float32)
            packed[:, :3] = self.h - self.centre[tile]
            packed[:, 3] = self.a
            self._device = (t.Float(packed.ravel()), t.Array3f64(*(np.ascontiguousarray(self.centre[:, k]) for k in range(3))),
                            t.Float64(self.cos_reach_device), t.UInt32(self.starts.astype(np.uint32)),
                            t.UInt32((self.starts + self.counts).astype(np.uint32)))
        bins, centre, cos_reach, starts, ends = self._device
        pending: list[tuple[int, int, Any, Any]] = []
        kappa = dr.opaque(t.Float64, self.kappa)
        two_kappa = dr.opaque(t.Float, float(np.float32(2.0 * self.kappa)))
        step = max(1, DEVICE_PAIR_BLOCK // max(self.n_tiles, 1))
        for s0 in range(0, len(m), step):
            block = m[s0:s0 + step]
            k_count = len(block)
            mv = t.Array3f64(*(np.ascontiguousarray(block[:, k]) for k in range(3)))
            width = dr.opaque(t.UInt32, k_count)
            pair = dr.arange(t.UInt32, self.n_tiles * k_count)  # tile-major: tile * K + normal
            ti = pair // width
            ni = pair - ti * width
            c = dr.dot(dr.gather(t.Array3f64, centre, ti), dr.gather(t.Array3f64, mv, ni))
            sel = dr.compress(dr.abs(c) >= dr.gather(t.Float64, cos_reach, ti))  # the pairs within reach, in order
            if dr.width(sel) == 0:
                continue
            ti = sel // width
            ni = sel - ti * width
            c = dr.dot(dr.gather(t.Array3f64, centre, ti), dr.gather(t.Array3f64, mv, ni))
            sign = dr.select(c >= 0.0, 1.0, -1.0)
            base = t.Float(kappa * (dr.abs(c) - 1.0))
            ms = dr.gather(t.Array3f64, mv, ni) * (sign * kappa)
            mx, my, mz = t.Float(ms.x), t.Float(ms.y), t.Float(ms.z)
            end = dr.gather(t.UInt32, ends, ti)

            def body(j: Any, acc: Any) -> tuple[Any, Any]:
                d = dr.gather(t.Array4f, bins, j)
                y = dr.fma(d.x, mx, dr.fma(d.y, my, dr.fma(d.z, mz, base)))  # κ(s m·h_b - 1)
                term = dr.exp(dr.maximum(y, -two_kappa - y)) * d.w
                return j + 1, acc + t.Float64(term)

            _, acc = dr.while_loop((dr.gather(t.UInt32, starts, ti), dr.zeros(t.Float64, dr.width(sel))),
                                   lambda j, acc: j < end, body)
            dr.eval(acc)  # launched: read below, when asked
            pending.append((s0, k_count, sel, acc))
        def finish() -> np.ndarray:
            out = np.zeros(len(m))
            for s0, k_count, sel, acc in pending:
                normal = np.asarray(sel).astype(np.int64) % k_count
                out[s0:s0 + k_count] = np.bincount(normal, weights=np.asarray(acc, dtype=np.float64), minlength=k_count)
            return self.norm * out

        return Launched(finish)

    def value_and_grad(self, m: np.ndarray) -> tuple[float, np.ndarray]:
        """Energy at one unit normal ``m`` and its gradient with respect to ``m`` (a 3-vector,
        the lobe's ``dq/dm = κ q sign(h·m) h``), from the same culled terms."""
        m = np.asarray(m, dtype=np.float64).reshape(3)
        if self.n_tiles == 0:
            return 0.0, np.zeros(3)
        tiles = np.flatnonzero(np.abs(_cos_matrix(m[None, :], self.centre_t)[0]) >= self.cos_reach)
        if len(tiles) == 0:
            return 0.0, np.zeros(3)
        ht, a = self._union(tiles)
        d = _cos_matrix(m[None, :], ht)[0]
        w = a * np.exp(self.kappa * (np.abs(d) - 1.0))
        return self.norm * float(w.sum()), self.norm * self.kappa * np.einsum("j,ij->i", w * np.sign(d), ht)

    def dense(self, normals: np.ndarray) -> np.ndarray:
        """Reference: every term, float64 (for tests and benchmarks)."""
        m = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        return np.concatenate([self._dense(self.h, self.a, m[s : s + 256]) for s in range(0, len(m), 256)]) if len(m) else np.zeros(0)


@dataclass
class FlashMetrics:
    """Flash metrics of one lamella normal: aggregates and per-view values."""

    flash_area: float
    flash_intensity: float
    flash_energy: float
    coverage: float
    balanced: float
    per_view: dict[str, list[float]]
    #: the stone's visible projected area (mm²) as the viewers see it, view-weighted mean; None
    #: where the estimator does not know it. Flash area and energy are scale-free (geometric optics:
    #: a stone twice the size flashes over the same share); this is the size that the share is of
    visible_area_mm2: float | None = None
    #: the flashing part's projected area (mm²): Σ_v weight_v x flash area_v x visible area_v
    flash_area_mm2: float | None = None

    @classmethod
    def from_views(cls, area_v: Any, intensity_v: Any, energy_v: Any, weights: Any,
                   view_area_mm2: Any = None) -> FlashMetrics:
        """Aggregate per-view flash area, intensity and energy with view weights (summing to 1):
        the view-weighted means, coverage = weight of views whose area exceeds 5 %, and
        balanced = sqrt(area x intensity) (DESIGN.md §4). One constructor for both estimators.
        ``view_area_mm2``: each view's visible projected area of the stone (mm²), when known: then
        :attr:`visible_area_mm2` and :attr:`flash_area_mm2` are filled in."""
        a, i, e, w = (np.asarray(x, dtype=np.float64) for x in (area_v, intensity_v, energy_v, weights))
        area, intensity, energy = float(w @ a), float(w @ i), float(w @ e)
        visible = flash_mm2 = None
        if view_area_mm2 is not None and len(view_area_mm2) == len(w):
            s = np.asarray(view_area_mm2, dtype=np.float64)
            visible, flash_mm2 = float(w @ s), float(w @ (a * s))
        return cls(
            flash_area=area, flash_intensity=intensity, flash_energy=energy,
            coverage=float(w @ (a > COVERAGE_AREA)), balanced=math.sqrt(max(area * intensity, 0.0)),
            per_view={"flash_area": a.tolist(), "flash_intensity": i.tolist(), "flash_energy": e.tolist(), "weight": w.tolist()},
            visible_area_mm2=visible, flash_area_mm2=flash_mm2,
        )

    def score(self, objective: str) -> float:
        return {"energy": self.flash_energy, "area": self.flash_area, "intensity": self.flash_intensity,
                "balanced": self.balanced}[objective]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def __repr__(self) -> str:
        return (f"FlashMetrics(area={self.flash_area:.1%}, intensity={self.flash_intensity:.3f}, "
                f"energy={self.flash_energy:.4f}, coverage={self.coverage:.0%}, views={len(self.per_view.get('weight', []))})")

    def _repr_html_(self) -> str:
        """A small table for notebooks."""
        rows = [("flash area", f"{self.flash_area:.1%}"), ("flash intensity", f"{self.flash_intensity:.3f}"),
                ("flash energy", f"{self.flash_energy:.4f}"), ("coverage", f"{self.coverage:.0%}"),
                ("balanced", f"{self.balanced:.4f}")]
        body = "".join(f"<tr><td>{k}</td><td style='text-align:right'>{v}</td></tr>" for k, v in rows)
        return f"<table><thead><tr><th>flash metric</th><th>value</th></tr></thead><tbody>{body}</tbody></table>"


class _DeviceTriples(NamedTuple):
    """A problem's triples on the Dr.Jit device (:meth:`Scorer._triples`)."""

    h: Any
    c: Any
    pair_rows: tuple[Any, Any, int]
    view_rows: tuple[Any, Any, int]
    pair_weight: Any
    view_weight: Any


class Scorer:
    """Dr.Jit evaluation of flash metrics and objectives for one problem."""

    def __init__(self, problem: FlashProblem, objective: str = "energy") -> None:
        if objective not in OBJECTIVES:
            raise ParameterError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}", parameter="objective")
        from ..backend import ad_types

        dr, t = ad_types()
        self.dr, self.t = dr, t
        self.problem = problem
        self.objective = objective
        p = problem
        self.n_pairs = int(p.pair_view.size)
        self.n_views = int(p.view_weight.size)
        self._device: _DeviceTriples | None = None  # the triples on the Dr.Jit device, built on first use
        # opaque scalars: one compiled kernel serves every spread and threshold
        self.kappa = dr.opaque(t.Float, float(p.kappa))
        self.q_norm = dr.opaque(t.Float, float(p.q_norm))
        self.tau = dr.opaque(t.Float, float(p.threshold))
        self.evaluations = 0
        self._bins_np: tuple[np.ndarray, np.ndarray] | None = None  # binned energy weights, built on first use
        self._bins: tuple[Any, Any, int, Any] | None = None  # the same on the Dr.Jit device
        self._sparse: SparseLobeMap | None = None

    def _bins_numpy(self) -> tuple[np.ndarray, np.ndarray]:
        """(bin directions (B, 3), bin weights (B,)) of :meth:`_bin_triples`, built the first time the
        energy objective or an energy map needs them (a caller that only scores metrics never pays)."""
        if self._bins_np is None:
            self._bins_np = self._bin_triples()
        return self._bins_np

    def _binned(self) -> tuple[Any, Any, int, Any]:
        """(bin directions, bin weights, bin count, opaque bin count) on the Dr.Jit device."""
        if self._bins is None:
            dr, t = self.dr, self.t
            hb, ab = self._bins_numpy()
            self._bins = (t.Array3f(hb[:, 0], hb[:, 1], hb[:, 2]), t.Float(ab), len(ab), dr.opaque(t.UInt32, len(ab)))
        return self._bins

    @property
    def sparse_map(self) -> SparseLobeMap:
        """The tile-culled energy map of the binned triples (:class:`SparseLobeMap`), built once."""
        if self._sparse is None:
            hb, ab = self._bins_numpy()
            self._sparse = SparseLobeMap(hb, ab, float(self.problem.kappa), float(self.problem.q_norm),
                                         kernels=self.problem.kernels)
        return self._sparse

    @property
    def bin_h(self) -> Any:
        return self._binned()[0]

    @property
    def bin_a(self) -> Any:
        return self._binned()[1]

    @property
    def n_bins(self) -> int:
        return self._binned()[2]

    @property
    def _nb(self) -> Any:
        return self._binned()[3]

    def _bin_triples(self, bins: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Energy weights alpha_t binned by h on a stereographic grid (weighted centroids).

        The energy objective is linear in q, so Σ_t alpha_t q(h_t·m) equals
        Σ_b A_b q(h_b·m) up to the bin size (~0.2°, far below the lobe width):
        ~30x fewer terms than the triples for the same value.
        """
        p = self.problem
        if bins is None:  # cells (4/bins rad at the pole) at most 1/8 of the lobe width
            spread = 1.0 / math.sqrt(p.kappa)
            bins = int(min(16384, max(512, math.ceil(32.0 / spread))))
        # in chunks of triples (bounded temporaries): each chunk's weights and grid keys, the
        # distinct keys present, then every chunk's sums into its bins
        n_keys = bins * bins

        single: list[tuple[np.ndarray, np.ndarray]] = []  # the one chunk of a problem of <= CHUNK triples, kept

        def chunk(s0: int) -> tuple[np.ndarray, np.ndarray]:
            """A chunk's kept weights alpha_t > 0 (:meth:`FlashProblem.alpha`) and their mirror orientations."""
            if single:
                return single[0]
            alpha = p.alpha(slice(s0, s0 + CHUNK))
            keep = alpha > 0
            out = (alpha, p.h[s0:s0 + CHUNK]) if keep.all() else (alpha[keep], p.h[s0:s0 + CHUNK][keep])
            if p.n_triples <= CHUNK:  # both passes need it: computed once (a bigger problem recomputes per chunk)
                single.append(out)
            return out

        def grid_key(h: np.ndarray) -> np.ndarray:
            """The stereographic grid cell of each h."""
            hu = h[:, 0] / (1.0 + h[:, 2])
            hv = h[:, 1] / (1.0 + h[:, 2])
            iu = np.clip(((hu + 1.0) * 0.5 * bins).astype(np.int64), 0, bins - 1)
            iv = np.clip(((hv + 1.0) * 0.5 * bins).astype(np.int64), 0, bins - 1)
            return iu * bins + iv

        starts = range(0, p.n_triples, CHUNK)
        if p.kernels.bins and n_keys <= DENSE_KEY_LIMIT and _device_keys_apply(p, n_keys):
            return _device_bins(p, bins)
        if _device_keys_apply(p, n_keys):  # one kernel over the device copy the pair sums read anyway
            every = _device_grid_keys(p.device_triples[0], bins)
            keys = [every[s0:s0 + CHUNK] for s0 in starts]
            for s0, key in zip(starts, keys):
                if chunk(s0)[0].size != key.size:  # zero weights dropped from the chunk: their keys too
                    keys[s0 // CHUNK] = key[p.alpha(slice(s0, s0 + CHUNK)) > 0]
        else:
            keys = [grid_key(chunk(s0)[1]).astype(np.int32 if n_keys < 2**31 else np.int64) for s0 in starts]
        if n_keys <= DENSE_KEY_LIMIT:
            present = np.zeros(n_keys, dtype=bool)
            for key in keys:
                present[key] = True
            rank = np.cumsum(present, dtype=np.int32) - 1
            del present
            n_bins = int(rank[-1]) + 1 if n_keys else 0
            inverse = lambda key: rank[key]  # noqa: E731
        else:
            distinct = np.unique(np.concatenate([np.unique(key) for key in keys] or [np.zeros(0, np.int64)]))
            n_bins = distinct.size
            inverse = lambda key: np.searchsorted(distinct, key)  # noqa: E731
        if n_bins == 0:
            return np.array([[0.0, 0.0, 1.0]]), np.zeros(1)
        weight = np.zeros(n_bins)
        centroid = np.zeros((n_bins, 3))
        for s0, key in zip(starts, keys):
            a, h = chunk(s0)
            inv = inverse(key)
            weight += np.bincount(inv, weights=a, minlength=n_bins)
            for k in range(3):
                centroid[:, k] += np.bincount(inv, weights=a * h[:, k], minlength=n_bins)
        centroid /= np.linalg.norm(centroid, axis=1, keepdims=True)
        return centroid, weight

    # ------------------------------------------------------------------ core
    def _scalar(self, x: float) -> Any:
        """An opaque Dr.Jit scalar: a value, not a literal baked into (and recompiling) the kernel."""
        return self.dr.opaque(self.t.Float, float(x))

    def _normal(self, u: Any, v: Any) -> Any:
        t = self.t
        r2 = u * u + v * v
        inv = 1.0 / (1.0 + r2)
        return t.Array3f(2.0 * u * inv, 2.0 * v * inv, (1.0 - r2) * inv)

    def _q(self, h: Any, m: Any) -> Any:
        return lobe_density(self.dr.dot(h, m), self.kappa, self.q_norm, drjit_ops())

    def _triples(self) -> _DeviceTriples:
        """(h, c, pair rows, view rows, pair weights, view weights) on the Dr.Jit device, built the
        first time an objective other than energy is scored (the energy objective sums the binned
        triples). h and c are the problem's own device copy
        (:attr:`FlashProblem.device_triples`, which the metrics' pair sums also read), not a second one.

        Deterministic segment sums: every pair's triples (and every view's pairs) are gathered
        into fixed-width padded rows and summed with block_sum, so results do not depend on the
        order in which threads add (atomic scatter-adds would)."""
        if self._device is None:
            t, p = self.t, self.problem
            h, c = p.device_triples
            self._device = _DeviceTriples(h, c,
                                          _padded_rows(p.pair, self.n_pairs, t), _padded_rows(p.pair_view, self.n_views, t),
                                          t.Float(p.pair_weight), t.Float(p.view_weight))
        return self._device

    def _segment_sum(self, values: Any, rows: tuple[Any, Any, int]) -> Any:
        dr, t = self.dr, self.t
        index, valid, width = rows
        return dr.block_sum(dr.gather(t.Float, values, index, valid), width)

    def _pair_radiance(self, m: Any) -> Any:
        """L_s / L_ref of every (point, view) pair (Dr.Jit, float32)."""
        d = self._triples()
        return self._segment_sum(d.c * self._q(d.h, m), d.pair_rows)

    def _view_sum(self, values: Any) -> Any:
        return self._segment_sum(values, self._triples().view_rows)

    def _objective_dr(self, m: Any, smooth: bool) -> Any:
        """The objective at the normal ``m`` as Dr.Jit operations (``smooth``: a logistic threshold,
        differentiable). The thresholded objectives (area, intensity, balanced) are scored so; the
        energy objective is scored from the sparse map (float64, an analytic gradient), and its
        branch here, every bin's term through Dr.Jit's automatic differentiation, is the independent
        reference that map's value and gradient are tested against (``tests/test_sparse_map.py``)."""
        dr = self.dr
        if self.objective == "energy":
            return dr.sum(self.bin_a * self._q(self.bin_h, m))
        radiance = self._pair_radiance(m)
        if smooth:
            flash = 1.0 / (1.0 + dr.exp(-(radiance - self.tau) / (0.02 * self.tau)))
        else:
            flash = dr.select(radiance >= self.tau, 1.0, 0.0)
        d = self._triples()
        pair_weight, view_weight = d.pair_weight, d.view_weight
        area_v = self._view_sum(pair_weight * flash)
        inflash_v = self._view_sum(pair_weight * flash * radiance)
        intensity_v = dr.select(area_v > 1e-12, inflash_v / dr.maximum(area_v, 1e-12), 0.0)
        area = dr.sum(view_weight * area_v)
        intensity = dr.sum(view_weight * intensity_v)
        if self.objective == "area":
            return area
        if self.objective == "intensity":
            return intensity
        # the floor keeps the gradient finite where nothing flashes; reported scores have none
        return dr.sqrt(dr.maximum(area * intensity, 1e-20 if smooth else 0.0))

    # ------------------------------------------------------------------ public
    def score(self, normal: np.ndarray) -> float:
        """Objective value at a unit normal (hard threshold)."""
        u, v = normal_to_stereo(normal)
        return self.score_uv(u, v)

    def scores(self, normals: np.ndarray) -> np.ndarray:
        """Objective at several unit normals (one kernel for the energy objective)."""
        normals = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        if self.objective == "energy":
            return self.energy_map(normals)
        return np.array([self.score(n) for n in normals])

    def score_uv(self, u: float, v: float) -> float:
        """Objective (hard threshold) at stereographic ``(u, v)``; energy from the sparse map."""
        if self.objective == "energy":
            self.evaluations += 1
            return float(self.sparse_map(stereo_to_normal(u, v)[None, :])[0])
        self.evaluations += 1
        value = self._objective_dr(self._normal(self._scalar(u), self._scalar(v)), smooth=False)
        return float(np.array(value).ravel()[0])

    def value_and_grad_uv(self, u: float, v: float) -> tuple[float, np.ndarray]:
        """Objective (smooth threshold) and its gradient in (u, v): for energy analytic, from the
        sparse map (float64), otherwise by Dr.Jit automatic differentiation."""
        dr = self.dr
        self.evaluations += 1
        if self.objective == "energy":
            value, g_m = self.sparse_map.value_and_grad(stereo_to_normal(u, v))
            return value, stereo_jacobian(u, v).T @ g_m
        uu, vv = self._scalar(u), self._scalar(v)
        dr.enable_grad(uu, vv)
        value = self._objective_dr(self._normal(uu, vv), smooth=True)
        dr.backward(value)
        g = np.array([float(np.array(dr.grad(uu)).ravel()[0]), float(np.array(dr.grad(vv)).ravel()[0])])
        return float(np.array(dr.detach(value)).ravel()[0]), g

    def metrics(self, normal: np.ndarray) -> FlashMetrics:
        """All flash metrics (hard threshold) of a lamella normal, from every triple's term
        (:meth:`FlashProblem.pair_radiance`, float64 sums, whatever the objective)."""
        m = np.asarray(normal, dtype=np.float64)
        m = m / np.linalg.norm(m)
        p = self.problem
        radiance = p.pair_radiance(m[None, :])[:, 0]
        flash = radiance >= p.threshold
        V = self.n_views
        area_v = np.bincount(p.pair_view, weights=p.pair_weight * flash, minlength=V)
        energy_v = np.bincount(p.pair_view, weights=p.pair_weight * radiance, minlength=V)
        inflash_v = np.bincount(p.pair_view, weights=p.pair_weight * radiance * flash, minlength=V)
        intensity_v = np.where(area_v > 1e-12, inflash_v / np.maximum(area_v, 1e-12), 0.0)
        return FlashMetrics.from_views(area_v, intensity_v, energy_v, p.view_weight, p.info.get("view_area_mm2"))

    def _energy_many(self, m: Any) -> Any:
        """Energy at each of the normals ``m`` (Array3f of width k): Σ_b A_b q(h_b·m).

        Built from gathers over an index of width k·n_bins with an opaque bin count,
        so one compiled kernel serves every number of normals (literal widths in
        tile/repeat would compile a kernel per distinct k); rows are summed with
        block_sum, deterministically.
        """
        dr, t = self.dr, self.t
        k = dr.width(m)
        idx = dr.arange(t.UInt32, k * self.n_bins)
        i_m = idx // self._nb
        i_b = idx - i_m * self._nb
        values = dr.gather(t.Float, self.bin_a, i_b) * self._q(dr.gather(t.Array3f, self.bin_h, i_b), dr.gather(t.Array3f, m, i_m))
        return dr.block_sum(values, self.n_bins)  # normal-major rows: deterministic, no atomics

    def energy_map(self, normals: np.ndarray) -> np.ndarray:
        """Energy at many unit normals (rows, mesh frame) at once from the binned triples: the
        tile-culled sparse sum (:class:`SparseLobeMap`, float64, relative accuracy
        :data:`SPARSE_RTOL`); :meth:`energy_map_dense` sums every term on the Dr.Jit device."""
        normals = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        out = self.sparse_map(normals)
        self.evaluations += len(normals)
        return out

    def launch_energy_map(self, normals: np.ndarray) -> Launched[np.ndarray]:
        """:meth:`energy_map`, launched (:meth:`SparseLobeMap.launch`): the result's ``value`` is
        the energies (waited for once, kept)."""
        normals = np.atleast_2d(np.asarray(normals, dtype=np.float64))
        self.evaluations += len(normals)
        return self.sparse_map.launch(normals)

    def energy_map_dense(self, normals: np.ndarray) -> np.ndarray:
        """Energy at many unit normals from every binned term, on the Dr.Jit device, in blocks."""
        t = self.t
        normals = np.asarray(normals, dtype=np.float64)
        out = np.empty(len(normals))
        chunk = max(1, 16_000_000 // max(self.n_bins, 1))
        for s in range(0, len(normals), chunk):
            m = normals[s : s + chunk]
            out[s : s + len(m)] = np.array(self._energy_many(t.Array3f(m[:, 0], m[:, 1], m[:, 2])), dtype=np.float64)
        self.evaluations += len(normals)
        return out

    def energy_batch_value_and_grad(self, us: np.ndarray, vs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Energy and its Dr.Jit gradient in (u, v) at several points in one kernel (multi-start ascent)."""
        dr, t = self.dr, self.t
        k = len(us)
        uu, vv = t.Float(np.asarray(us, dtype=np.float64)), t.Float(np.asarray(vs, dtype=np.float64))
        dr.enable_grad(uu, vv)
        values = self._energy_many(self._normal(uu, vv))
        dr.backward(dr.sum(values))
        self.evaluations += k
        grads = np.stack([np.array(dr.grad(uu), dtype=np.float64), np.array(dr.grad(vv), dtype=np.float64)], axis=1)
        return np.array(dr.detach(values), dtype=np.float64), grads
