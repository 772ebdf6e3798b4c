"""The per-pair lobe sums in one Dr.Jit kernel (``FlashProblem.pair_radiance``, issue 17 §4) give
the numpy reference's sums: the same terms in the same order per pair, float64 sums.

The kernel (``problem._PairSums``: a thread per (point, view) pair over its triples) serves the
error bars' bootstrap and discretisation energies and the metrics of every
answer; the numpy passes (``FlashProblem.pair_radiance_numpy``) stay as the reference and the
path of problems the kernel does not take (over ``KernelOptions.pair_sums_max_triples`` triples, or not sorted by pair).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labcut
from labcut.orientation import problem as problem_module
from labcut.orientation.kernels import KernelOptions
from labcut.orientation.problem import build_problem, lobe_reach
from labcut.orientation.uncertainty import _reach, stencil
from labcut.scene import resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(MESHES / "oval-16x12-low.ply")


@pytest.fixture(scope="module")
def bench(oval):
    lab = labcut.Labradorite.preset("blue")
    return build_problem(oval, lab, quality="draft", settings=resolve_scene("bench", None, None, "draft").settings())


def _fresh(problem):
    """A copy of ``problem`` without its kernel (the cached property is made again)."""
    return replace(problem, info=dict(problem.info))


@settings(max_examples=12, deadline=None)
@given(x=st.floats(-0.6, 0.6), y=st.floats(-0.6, 0.6), radius=st.floats(0.3, 3.0), reach=st.booleans())
def test_the_kernel_sums_what_the_numpy_passes_sum(bench, x, y, radius, reach):
    m = np.array([x, y, 1.0])
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, radius)
    r = _reach(bench.kappa, normals) if reach else None
    assert bench._pair_sums is not None
    got = bench.pair_radiance(normals, r)
    want = bench.pair_radiance_numpy(normals, r)
    assert got.shape == want.shape == (bench.pair_view.size, len(normals))
    # float32 terms (exp to within an ulp of numpy's), float64 sums of the same terms in the same order
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9 * float(want.max()))


def test_the_reach_drops_the_far_triples_in_the_kernel_too(bench):
    """With a reach the kernel sums only the triples near normals[0], as the numpy path does: a
    kernel that ignored the reach (or tested another normal) would sum far more at a far normal."""
    m = np.array([0.0, 0.0, 1.0])
    far = np.array([m, [math.sin(0.5), 0.0, math.cos(0.5)]])  # the second normal 28.6° from the first
    reach = lobe_reach(bench.kappa)  # five lobe widths around the first normal
    assert reach < 0.3
    whole = bench.pair_radiance(far)
    near = bench.pair_radiance(far, reach=reach)
    np.testing.assert_allclose(near, bench.pair_radiance_numpy(far, reach=reach), rtol=1e-6, atol=1e-12)
    assert near[:, 1].sum() < 0.01 * whole[:, 1].sum()
    assert near[:, 0].sum() == pytest.approx(whole[:, 0].sum(), rel=1e-4)


def test_stencil_sums_within_reach_from_the_kernel_equal_the_numpy_path(bench, monkeypatch):
    m = np.array([0.03, -0.05, 1.0])
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, 1.5)
    r = _reach(bench.kappa, normals)
    got = bench.pair_radiance(normals, r)
    slow = replace(bench, info=dict(bench.info), kernels=KernelOptions(pair_sums=False))
    assert slow._pair_sums is None
    np.testing.assert_allclose(slow.pair_radiance(normals, r), got, rtol=1e-6, atol=1e-12)


def test_problems_the_kernel_does_not_take_use_the_numpy_path(bench, monkeypatch):
    """Over pair_sums_max_triples triples, or triples not sorted by pair: the numpy passes, the same sums."""
    normals = np.array([[0.0, 0.0, 1.0], [0.1, 0.0, 0.995]])
    want = bench.pair_radiance(normals)
    big = replace(bench, info=dict(bench.info), kernels=KernelOptions(pair_sums_max_triples=bench.n_triples - 1))
    assert big._pair_sums is None
    np.testing.assert_allclose(big.pair_radiance(normals), want, rtol=1e-6, atol=1e-12)
    assert replace(bench, info=dict(bench.info),
                   kernels=KernelOptions(pair_sums_max_triples=bench.n_triples))._pair_sums is not None
    order = np.random.default_rng(1).permutation(bench.n_triples)
    shuffled = replace(bench, host_h=bench.h[order], c=bench.c[order], pair=bench.pair[order], info=dict(bench.info))
    assert not shuffled.pairs_sorted and shuffled._pair_sums is None
    np.testing.assert_allclose(shuffled.pair_radiance(normals), want, rtol=1e-6, atol=1e-12)


def test_a_stone_with_pairs_and_no_triples_sums_to_zero(oval):
    """A problem with pairs and no triple (every triple of a stone dropped): zero sums (the numpy
    path: the kernel declines a problem without triples)."""
    lab = labcut.Labradorite.preset("blue")
    whole = build_problem(oval, lab, quality="draft", settings=resolve_scene("bench", None, None, "draft").settings())
    part = replace(whole, host_h=whole.h[:0], c=whole.c[:0], pair=whole.pair[:0])
    assert part._pair_sums is None and part.pair_view.size > 0
    for reach in (None, 0.005):
        got = part.pair_radiance(np.array([[1.0, 0.0, 0.0]]), reach=reach)
        assert got.shape == (part.pair_view.size, 1) and not got.any()


def test_the_stencil_call_brings_every_triples_sum_at_its_centre(oval):
    """A stencil's sums within reach also give its centre's sum over every triple: the next call
    for that one normal without a reach (a recommendation's metrics at its answer) reads it, the
    same as summing it afresh; another normal is summed afresh."""
    lab = labcut.Labradorite.preset("blue")
    settings_ = resolve_scene("bench", None, None, "draft").settings()
    p = build_problem(oval, lab, quality="draft", settings=settings_)
    fresh = build_problem(oval, lab, quality="draft", settings=settings_)
    m = np.array([0.04, -0.03, 1.0])
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, 1.5)
    reach = _reach(p.kappa, normals)
    within = p.pair_radiance(normals, reach)
    np.testing.assert_array_equal(within, fresh.pair_radiance(normals, reach))
    kept = p.pair_radiance(m[None, :])
    want = fresh._pair_sums(m[None, :], None)[0]
    np.testing.assert_array_equal(kept, want)
    assert float(np.abs(kept[:, 0] - within[:, 0]).max()) > 0.0  # the reach dropped some terms
    other = normals[3]
    np.testing.assert_array_equal(p.pair_radiance(other[None, :]), fresh._pair_sums(other[None, :], None)[0])
    np.testing.assert_allclose(kept, p.pair_radiance_numpy(m[None, :]), rtol=2e-5, atol=1e-9 * float(kept.max()))
