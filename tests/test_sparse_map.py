"""The tile-culled energy map and the bincount binning give what the dense forms give."""

from __future__ import annotations

from dataclasses import replace
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labcut
from labcut.orientation import scoring as scoring_module
from labcut.orientation.kernels import KernelOptions
from labcut.orientation.problem import build_problem
from labcut.orientation.scoring import Scorer, SparseLobeMap, grid_inverse
from labcut.scene import resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def scorer() -> Scorer:
    mesh = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")
    problem = build_problem(mesh, lab, quality="draft", settings=resolve_scene("bench", None, None, "draft").settings())
    return Scorer(problem)


def _random_bins(seed: int, n: int, spread: float) -> tuple[np.ndarray, np.ndarray]:
    """Clustered lamella orientations (upper hemisphere) with positive weights."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(4, 3))
    centres[:, 2] = np.abs(centres[:, 2]) + 0.2
    h = centres[rng.integers(0, 4, n)] / np.linalg.norm(centres[rng.integers(0, 4, n)], axis=1, keepdims=True)
    h = h + spread * rng.normal(size=(n, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[h[:, 2] < 0] *= -1
    return h, rng.random(n) ** 3


def _unit_normals(seed: int, k: int) -> np.ndarray:
    m = np.random.default_rng(seed + 1).normal(size=(k, 3))
    return m / np.linalg.norm(m, axis=1, keepdims=True)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), kappa=st.floats(20.0, 3000.0), spread=st.floats(0.0, 1.0),
       k=st.sampled_from([1, 7, 64, 65, 300]))
def test_sparse_map_equals_the_dense_sum(seed, kappa, spread, k):
    """Random bins, lobe widths and normals (either hemisphere: the lobe is axial): the culled sum
    agrees with the full float64 sum to 1e-6 of the map's largest value, in every code path
    (one product over the union of the tiles needed; a product per tile; the Dr.Jit kernel's
    float32 terms about the tiles' centres) and in the one chosen."""
    h, a = _random_bins(seed, 3000, spread)
    norm = kappa / (2 * math.pi * (1 - math.exp(-kappa)))
    sparse = SparseLobeMap(h, a, kappa, norm)
    m = _unit_normals(seed, k)
    m = np.vstack([m, h[:3]])  # and normals right on a bin: the peak values
    want = sparse.dense(m)
    for path in ("auto", "union", "tiles", "device"):
        got = sparse(m, path=path)
        assert np.all(np.abs(got - want) <= 1e-6 * want.max() + 1e-300), path
    # the analytic gradient of one normal's value is the derivative of the same sum
    value, grad = sparse.value_and_grad(m[0])
    assert value == pytest.approx(want[0], rel=1e-6, abs=1e-6 * want.max())
    tangent = np.cross(m[0], [0.3, -0.5, 0.8])
    tangent /= np.linalg.norm(tangent)
    eps = 1e-6
    m_plus, m_minus = m[0] + eps * tangent, m[0] - eps * tangent
    fd = (sparse.dense(m_plus[None])[0] - sparse.dense(m_minus[None])[0]) / (2 * eps)
    assert grad @ tangent == pytest.approx(fd, rel=1e-4, abs=1e-6 * max(want.max(), 1e-300) * kappa)


def test_sparse_map_culls_most_terms(scorer):
    """The point of the exercise: over the hemisphere map, a normal needs a small share of the bins."""
    from labcut.orientation.optimize import Constraint, hemisphere_grid

    sm = scorer.sparse_map
    normals = hemisphere_grid(3.0, Constraint())
    need = np.abs(normals @ sm.centre.T) >= sm.cos_reach[None, :]
    share = float((need * sm.counts[None, :]).sum()) / (len(normals) * len(sm.a))
    assert share < 0.15


def test_scorer_map_matches_dr_jit_dense_map(scorer):
    """Scorer.energy_map (sparse, float64) against the Dr.Jit kernel over every bin (float32)."""
    from labcut.orientation.optimize import Constraint, hemisphere_grid

    normals = hemisphere_grid(5.0, Constraint())
    sparse = scorer.energy_map(normals)
    dense = scorer.energy_map_dense(normals)
    assert np.max(np.abs(sparse - dense)) <= 1e-4 * dense.max()
    assert int(np.argmax(sparse)) == int(np.argmax(dense))


def test_energy_score_and_gradient_match_dr_jit(scorer):
    """score_uv / value_and_grad_uv (numpy for energy) against Dr.Jit's objective and AD gradient."""
    dr = scorer.dr
    for u, v in [(0.01, -0.03), (0.2, 0.1), (-0.4, 0.3)]:
        value, grad = scorer.value_and_grad_uv(u, v)
        uu, vv = scorer._scalar(u), scorer._scalar(v)
        dr.enable_grad(uu, vv)
        ref = scorer._objective_dr(scorer._normal(uu, vv), smooth=True)
        dr.backward(ref)
        ref_v = float(np.array(dr.detach(ref)).ravel()[0])
        ref_g = np.array([float(np.array(dr.grad(uu)).ravel()[0]), float(np.array(dr.grad(vv)).ravel()[0])])
        assert value == pytest.approx(ref_v, rel=1e-4)
        assert scorer.score_uv(u, v) == pytest.approx(value, rel=1e-12)
        assert np.allclose(grad, ref_g, rtol=1e-3, atol=1e-4 * np.abs(ref_g).max())


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 5000), cells=st.sampled_from([3, 64, 1000, 5000]))
def test_grid_inverse_is_unique_inverse(seed, n, cells):
    """bincount ranks of grid keys == np.unique's inverse, for dense and sorted (huge) grids."""
    rng = np.random.default_rng(seed)
    key = rng.integers(0, cells * cells, n) if rng.random() < 0.5 else rng.integers(0, cells, n) * cells
    want = np.unique(key, return_inverse=True)[1].ravel()
    assert np.array_equal(grid_inverse(key, cells * cells), want)


@pytest.mark.parametrize("device_keys, device_bins", [(True, True), (True, False), (False, False)])
@pytest.mark.parametrize("chunk", [None, 1000])
def test_binned_triples_match_the_unique_reference(scorer, chunk, device_keys, device_bins, monkeypatch):
    """_bin_triples (bincount on the grid key, in chunks of triples; the keys from the Dr.Jit
    kernel or from numpy; or every step in Dr.Jit kernels with 64-bit fixed-point sums) against the
    np.unique formulation it replaced: the same bins, their sums to rounding (a bin whose triples
    straddle two chunks sums its parts; with a small chunk every bin straddles some), the
    fixed-point sums within about 1e-13 of the total weight (their units: 2^-62 of it)."""
    from labcut.orientation import scoring as scoring_module

    scorer = Scorer(replace(scorer.problem, kernels=KernelOptions(grid_keys=device_keys, bins=device_bins)))
    assert scoring_module._device_keys_apply(scorer.problem, 612 * 612) is device_keys
    if chunk is not None:
        monkeypatch.setattr(scoring_module, "CHUNK", chunk)
        assert scorer.problem.n_triples > 10 * chunk
    hb, ab = scorer._bin_triples()
    p = scorer.problem
    spread = 1.0 / math.sqrt(p.kappa)
    bins = int(min(16384, max(512, math.ceil(32.0 / spread))))
    alpha = p.alpha()
    keep = alpha > 0
    a, h = alpha[keep], p.h[keep]
    hu, hv = h[:, 0] / (1.0 + h[:, 2]), h[:, 1] / (1.0 + h[:, 2])
    iu = np.clip(((hu + 1.0) * 0.5 * bins).astype(np.int64), 0, bins - 1)
    iv = np.clip(((hv + 1.0) * 0.5 * bins).astype(np.int64), 0, bins - 1)
    _, inv = np.unique(iu * bins + iv, return_inverse=True)
    weight = np.bincount(inv.ravel(), weights=a)
    centroid = np.stack([np.bincount(inv.ravel(), weights=a * h[:, k]) for k in range(3)], axis=1)
    centroid /= np.linalg.norm(centroid, axis=1, keepdims=True)
    assert ab.shape == weight.shape and hb.shape == centroid.shape  # the same bins
    if device_bins:  # fixed point (chunks do not apply): each bin within its count of units
        total = float(a.sum())
        assert np.abs(ab - weight).max() <= 1e-13 * total
        assert np.abs(weight[:, None] * (hb - centroid)).max() <= 1e-13 * total
        assert np.abs(ab - weight).max() > 0.0  # not the float path by mistake
        # each term rounded to the nearest unit: no bias in the total (truncation loses half a
        # unit a term, ~1e-13 of it over the 0.7 M triples)
        assert abs(float(ab.sum()) - total) <= 1e-14 * total  # the float64 reference sum itself rounds by ~1e-15
        again = scorer._bin_triples()  # the same sums whatever order the threads add in
        np.testing.assert_array_equal(again[0], hb)
        np.testing.assert_array_equal(again[1], ab)
    else:
        np.testing.assert_allclose(ab, weight, rtol=1e-12, atol=0)
        np.testing.assert_allclose(hb, centroid, rtol=0, atol=1e-13)
    assert ab.sum() == pytest.approx(a.sum(), rel=1e-12)


def _numpy_keys(h: np.ndarray, bins: int) -> np.ndarray:
    """The numpy grid keys of :meth:`Scorer._bin_triples` (float32 h, its operations)."""
    hu, hv = h[:, 0] / (1.0 + h[:, 2]), h[:, 1] / (1.0 + h[:, 2])
    iu = np.clip(((hu + 1.0) * 0.5 * bins).astype(np.int64), 0, bins - 1)
    iv = np.clip(((hv + 1.0) * 0.5 * bins).astype(np.int64), 0, bins - 1)
    return iu * bins + iv


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), bins=st.integers(2, 16384), n=st.integers(1, 3000))
def test_device_grid_keys_are_the_numpy_keys(seed, bins, n):
    """The Dr.Jit kernel's stereographic keys equal numpy's float32 keys bit for bit, on random
    upper-hemisphere directions and on the awkward ones: the pole, the horizon (h_z = 0, where the
    stereographic coordinates reach ±1 and the clip acts) and directions on cell boundaries."""
    from labcut.backend import ad_types

    rng = np.random.default_rng(seed)
    h = rng.normal(size=(n, 3))
    h[:, 2] = np.abs(h[:, 2])
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    edge = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 1.0, 0.0],
                     [math.sqrt(0.5), math.sqrt(0.5), 0.0]])
    u = (rng.integers(0, bins + 1, 8) / bins) * 2.0 - 1.0  # stereographic coordinates on cell boundaries
    r2 = u * u
    boundary = np.stack([2 * u / (1 + r2), np.zeros_like(u), (1 - r2) / (1 + r2)], axis=1)
    h = np.vstack([h, edge, boundary]).astype(np.float32)
    _, t = ad_types()
    got = scoring_module._device_grid_keys(t.Array3f(h[:, 0], h[:, 1], h[:, 2]), bins)
    np.testing.assert_array_equal(got, _numpy_keys(h, bins))
    assert got.min() >= 0 and got.max() < bins * bins


def test_tile_unions_are_contiguous_and_the_path_is_checked(scorer):
    """The union of tiles is a C-contiguous (3, n) array (a strided one made every product over it
    slower: benchmarks/lobe_sums.py's strided row), the same bins as the
    tiles' slices; an unknown path is refused."""
    from labcut.errors import ParameterError

    sm = scorer.sparse_map
    tiles = np.arange(0, sm.n_tiles, 3)
    ht, a = sm._union(tiles)
    assert ht.flags.c_contiguous and ht.shape == (3, int(sm.counts[tiles].sum()))
    want_h = np.concatenate([sm.ht[:, s:s + c] for s, c in zip(sm.starts[tiles], sm.counts[tiles])], axis=1)
    want_a = np.concatenate([sm.a[s:s + c] for s, c in zip(sm.starts[tiles], sm.counts[tiles])])
    assert np.array_equal(ht, want_h) and np.array_equal(a, want_a)
    with pytest.raises(ParameterError, match="path"):
        sm(np.array([[0.0, 0.0, 1.0]]), path="dense")


def test_auto_path_takes_the_union_for_a_ring_and_the_tiles_for_a_map(scorer, monkeypatch):
    """The numpy cost model (the kernel off, or fewer normals than it takes): a ring of normals 2°
    around one normal (all need nearly the same tiles) is one block over their union; the
    hemisphere map (spread-out normals) is a block per tile."""
    from labcut.orientation.optimize import Constraint, hemisphere_grid
    from labcut.reports.analysis import ring

    sm = scorer.sparse_map
    unions = []
    real = sm._union
    monkeypatch.setattr(sm, "_union", lambda tiles: unions.append(len(tiles)) or real(tiles))
    centre = np.array([0.05, -0.05, 1.0]) / np.linalg.norm([0.05, -0.05, 1.0])
    sm(ring(centre, 2.0, 4))
    assert len(unions) == 1
    monkeypatch.setattr(sm, "kernels", KernelOptions(energy_map=False))
    sm(ring(centre, 2.0, 16))
    assert len(unions) == 2
    sm(hemisphere_grid(3.0, Constraint()))
    assert len(unions) == 2


def test_auto_path_takes_the_kernel_for_a_map_of_many_terms(scorer, monkeypatch):
    """A call of map_min_normals normals or more (a tolerance's ring of 16, a map), or of fewer
    with at least map_min_terms terms within reach, goes to the Dr.Jit kernel; a few normals to
    the numpy union; energy_map off: never the kernel."""
    from labcut.orientation.optimize import Constraint, hemisphere_grid
    from labcut.reports.analysis import ring

    sm = scorer.sparse_map
    grid = hemisphere_grid(3.0, Constraint())
    calls = []
    real = sm._device_sums
    monkeypatch.setattr(sm, "_device_sums", lambda *a: calls.append(len(a[0])) or real(*a))
    monkeypatch.setattr(sm, "kernels", KernelOptions(map_min_terms=10_000))
    want = sm(grid, path="tiles")
    got = sm(grid)
    assert calls == [len(grid)]
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-6 * want.max())
    monkeypatch.setattr(sm, "kernels", KernelOptions(map_min_terms=1 << 20))
    centre = np.array([0.05, -0.05, 1.0]) / np.linalg.norm([0.05, -0.05, 1.0])
    few = ring(centre, 0.5, KernelOptions().map_min_normals - 1)
    sm(few)
    assert calls == [len(grid)]  # fewer normals and terms than the kernel takes
    monkeypatch.setattr(sm, "kernels", KernelOptions(map_min_terms=1000))
    np.testing.assert_allclose(sm(few), sm(few, path="union"), rtol=0.0, atol=1e-6 * want.max())
    assert calls == [len(grid), len(few)]  # as many terms as the kernel takes
    monkeypatch.setattr(sm, "kernels", KernelOptions(map_min_terms=1 << 20))
    sixteen = ring(centre, 0.5, 16)
    np.testing.assert_allclose(sm(sixteen), sm(sixteen, path="union"), rtol=0.0, atol=1e-6 * want.max())
    assert calls == [len(grid), len(few), 16]  # a tolerance's ring
    monkeypatch.setattr(sm, "kernels", KernelOptions(energy_map=False))
    sm(grid)
    assert calls == [len(grid), len(few), 16]


@pytest.mark.parametrize("kappa", [1.0, 4.0, 30.0])
def test_the_kernel_keeps_the_axial_lobes_far_side(kappa):
    """Broad lobes over big tiles: a tile can straddle a normal's equator, where some of its bins
    lie on the lobe's far (axial) side; the kernel's terms there are exp(κ(|m·h| - 1)) too."""
    rng = np.random.default_rng(3)
    h = rng.normal(size=(4000, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[h[:, 2] < 0] *= -1
    a = rng.random(4000)
    sparse = SparseLobeMap(h, a, kappa, 1.0)
    t = np.radians(np.linspace(0.0, 360.0, 73))
    m = np.stack([np.cos(t), np.sin(t), np.full_like(t, 0.02)], axis=1)  # normals at the equator
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    want = sparse.dense(m)
    np.testing.assert_allclose(sparse(m, path="device"), want, rtol=1e-6, atol=0.0)


def test_a_map_started_and_read_later_is_the_map(scorer, monkeypatch):
    """SparseLobeMap.launch launches the kernel and returns at once; its value, read later, is the map
    (made once); a call the kernel does not take is summed at once, the same as calling the map."""
    from labcut.orientation.optimize import Constraint, hemisphere_grid
    from labcut.reports.analysis import ring

    sm = scorer.sparse_map
    grid = hemisphere_grid(3.0, Constraint())
    launched = sm.launch(grid)
    np.testing.assert_array_equal(launched.value, sm(grid))
    assert launched.value is launched.value
    few = ring(np.array([0.0, 0.0, 1.0]), 1.0, 3)
    np.testing.assert_array_equal(sm.launch(few).value, sm(few))
    monkeypatch.setattr(sm, "kernels", KernelOptions(energy_map=False))
    np.testing.assert_allclose(sm.launch(grid).value, sm(grid, path="tiles"), rtol=0.0, atol=0.0)
    counted = scorer.evaluations
    scorer.launch_energy_map(grid)
    assert scorer.evaluations == counted + len(grid)


def test_a_bin_whose_fixed_point_sum_is_zero_is_dropped(scorer, monkeypatch):
    """A triple far lighter than half a unit of the fixed-point sums (2^-62 of the total weight)
    alone in its cell sums to zero there: that bin has no direction and is dropped, not a NaN
    centroid; the others are as the numpy path's."""
    from dataclasses import replace

    from labcut.orientation import scoring as scoring_module

    p = scorer.problem
    keep = slice(0, 2000)
    h = p.h[keep].copy()
    c = p.c[keep].copy()
    h[-1] = np.array([0.6, 0.0, 0.8], dtype=np.float32)  # a cell of its own, far from the bench's flash near +z
    c[-1] = np.float32(1e-30)
    small = replace(p, host_h=h, c=c, pair=p.pair[keep])
    assert scoring_module._device_keys_apply(small, 612 * 612)
    hb, ab = Scorer(small)._bin_triples()
    assert np.all(np.isfinite(hb)) and np.all(ab > 0)
    assert not np.any(np.all(np.abs(hb - [0.6, 0.0, 0.8]) < 1e-6, axis=1))  # the light one's bin is gone
    hn, an = Scorer(replace(small, kernels=KernelOptions(bins=False)))._bin_triples()
    assert len(an) == len(ab) + 1  # numpy keeps its float64 weight of 1e-30-ish
    np.testing.assert_allclose(ab, an[an > 1e-20], rtol=1e-10, atol=1e-13 * float(an.sum()))


def test_size_class_rounds_up_by_at_most_an_eighth():
    """Each length rounds up to one of 8 sizes per doubling, never below itself nor past 1/8 above
    it, and lengths up to 15 stay as they are."""
    from labcut.orientation.scoring import size_class

    n = np.arange(1, 300_000)
    got = np.array([size_class(int(k)) for k in n])
    assert np.all(got >= n) and np.all(got <= n * 1.125)
    assert np.array_equal(got[:15], n[:15])
    assert size_class(0) == 1
    for lo in (2**10, 2**14, 2**17):  # 8 classes in each doubling
        assert len({size_class(k) for k in range(lo + 1, 2 * lo + 1)}) == 8
    assert [size_class(k) for k in (52629, 52630, 53248, 53249)] == [53248, 53248, 53248, 57344]


def test_the_device_bins_kernel_repeats_for_a_new_bin_count(scorer):
    """A new lamp, material or stone occupies a new number of grid cells. The device sums' kernel
    must not change with it: Dr.Jit writes a scatter-reduction target's length into the LLVM
    kernel, so an exact length compiled a new kernel for every new lamp in `labcut explore`. Over
    problems of one size class and many bin counts the sums' kernel (the one with the most inputs)
    is one program: its LLVM code the same but for its name and the alignment Dr.Jit notes of each
    input it maps from numpy (64 bytes or not: a few variants, each compiled once and cached)."""
    from mitsuba_helpers import launched

    from labcut.orientation import scoring as scoring_module

    p = scorer.problem

    def program(ir: str) -> str:  # the kernel's code without its name and its inputs' alignment
        return re.sub(r"align \d+", "align _", re.sub(r"drjit_[0-9a-f]{32}", "drjit_", ir))

    def bins_kernel(n: int) -> tuple[int, str]:
        sub = replace(p, host_h=p.h[:n].copy(), c=p.c[:n].copy(), pair=p.pair[:n])
        assert scoring_module._device_keys_apply(sub, 612 * 612)
        sub.device_triples  # copied to the device before the history starts
        (_, weights), history = launched(lambda: scoring_module._device_bins(sub, 612))
        return len(weights), program(max(history, key=lambda k: k["input_count"])["ir"].getvalue())

    by_class: dict[int, list[tuple[int, str]]] = {}
    for n in range(20_000, 60_001, 1_000):
        length, kernel = bins_kernel(n)
        by_class.setdefault(scoring_module.size_class(length), []).append((length, kernel))
    runs = max(by_class.values(), key=lambda r: len({length for length, _ in r}))
    assert len({length for length, _ in runs}) >= 8
    assert len({kernel for _, kernel in runs}) == 1
