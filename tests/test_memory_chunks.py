"""The problem's memory-bounded passes (issue 17: high quality under an environment map, tens of
millions of triples, within 2 GB) give what the whole-array forms they replaced give.

Each pass runs over the triples in chunks; the tests shrink the chunk so that every pass crosses
many chunk boundaries on a small problem, and compare with the one-pass reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labcut
from labcut.orientation import problem as problem_module
from labcut.orientation import scoring as scoring_module
from labcut.orientation.problem import build_problem
from labcut.orientation.scoring import Scorer, _padded_rows
from labcut.scene import resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def problem():
    mesh = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")
    return build_problem(mesh, lab, quality="draft", settings=resolve_scene("bench", None, None, "draft").settings())


def _reference_rows(owner: np.ndarray, n_rows: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The argsort formulation of the padded rows (what _padded_rows did for every owner array)."""
    counts = np.bincount(owner, minlength=n_rows)
    width = max(1, int(counts.max(initial=0)))
    order = np.argsort(owner, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rows = np.repeat(np.arange(n_rows), counts)
    cols = np.arange(order.size) - np.repeat(starts, counts)
    index = np.zeros(n_rows * width, dtype=np.uint32)
    valid = np.zeros(n_rows * width, dtype=bool)
    index[rows * width + cols] = order
    valid[rows * width + cols] = True
    return index, valid, width


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 3000), rows=st.integers(1, 60), chunk=st.integers(1, 700),
       sort=st.booleans())
def test_padded_rows_sorted_chunks_match_the_argsort_form(seed, n, rows, chunk, sort):
    """Sorted owners (a problem's triples by pair) are placed chunk by chunk without a sort;
    unsorted ones by the argsort form: both as the reference, empty rows included."""
    from labcut.backend import ad_types

    _, t = ad_types()
    rng = np.random.default_rng(seed)
    owner = rng.integers(0, rows, n).astype(np.int32)
    if sort:
        owner = np.sort(owner)
    old = scoring_module.CHUNK
    scoring_module.CHUNK = chunk
    try:
        index, valid, width = _padded_rows(owner, rows, t)
    finally:
        scoring_module.CHUNK = old
    want_index, want_valid, want_width = _reference_rows(owner, rows)
    assert width == want_width
    np.testing.assert_array_equal(np.asarray(valid), want_valid)
    np.testing.assert_array_equal(np.asarray(index)[want_valid], want_index[want_valid])


def test_pair_radiance_in_chunks_matches_one_pass(problem, monkeypatch):
    """FlashProblem.pair_radiance's numpy path (the reference, and the path of problems too big for
    the kernel) with a chunk far smaller than the problem (pairs split between chunks) equals the
    one-chunk sums to float64 rounding, with and without a reach."""
    normals = np.array([[0.0, 0.0, 1.0], [0.1, 0.05, 0.99], [-0.2, 0.1, 0.97]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    whole = problem.pair_radiance_numpy(normals)
    near = problem.pair_radiance_numpy(normals, reach=0.6)
    monkeypatch.setattr(problem_module, "PAIR_CHUNK", 777)
    assert problem.n_triples > 20 * 777
    np.testing.assert_allclose(problem.pair_radiance_numpy(normals), whole, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(problem.pair_radiance_numpy(normals, reach=0.6), near, rtol=1e-12, atol=1e-15)
    # a reach drops only far terms: the near sums stay below the whole and close to it at the centre
    assert np.all(near <= whole * (1 + 1e-12) + 1e-15)
    assert near[:, 0].sum() == pytest.approx(whole[:, 0].sum(), rel=1e-3)


def test_metrics_from_numpy_sums_match_the_device_sums(problem):
    """Scorer.metrics sums every triple in numpy (float64); the Dr.Jit pair sums the non-energy
    objectives use agree to float32 rounding."""
    scorer = Scorer(problem, "area")
    m = np.array([0.05, -0.1, 1.0])
    m /= np.linalg.norm(m)
    t = scorer.t
    device = np.array(scorer._pair_radiance(t.Array3f(*(scorer._scalar(x) for x in m))), dtype=np.float64)
    numpy_sums = problem.pair_radiance(m[None, :])[:, 0]
    np.testing.assert_allclose(numpy_sums, device, rtol=2e-5, atol=1e-7 * device.max())
    metrics = scorer.metrics(m)
    assert metrics.flash_area == pytest.approx(scorer.score(m), rel=1e-3)


def test_energy_scorer_puts_no_triples_on_the_device(problem):
    """The energy objective sums binned triples and its metrics in numpy: the per-triple device
    copy (16 bytes a triple) is never made; another objective makes it on first use."""
    energy = Scorer(problem, "energy")
    m = np.array([0.0, 0.0, 1.0])
    energy.score(m)
    energy.metrics(m)
    assert energy._device is None
    area = Scorer(problem, "area")
    area.score(m)
    assert area._device is not None


@pytest.fixture(scope="module")
def weighted_problem():
    """Views of unequal weights (every scenario's are equal): a weight applied to the wrong view shows."""
    mesh = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")
    views = labcut.Views([[0.0, 0.0, 1.0], [0.3, 0.0, 0.95], [0.0, -0.4, 0.92]], weights=[0.6, 0.3, 0.1])
    lights = labcut.Lights([[0.0, 0.1, 1.0], [0.2, 0.0, 0.98]])
    return build_problem(mesh, lab, lights=lights, views=views, quality="draft")


@pytest.mark.parametrize("which", ["problem", "weighted_problem"])
def test_energy_weights_sum_to_the_metrics_energy(which, request):
    """The energy objective's per-triple weights (FlashProblem.alpha, whole or in chunks of rows)
    summed against the lobe give the view-weighted flash energy of the metrics: the same linear
    objective from the pair sums (DESIGN.md §4)."""
    problem = request.getfixturevalue(which)
    m = np.array([0.05, -0.1, 1.0])
    m /= np.linalg.norm(m)
    q = problem.q_norm * np.exp(problem.kappa * (np.abs(problem.h.astype(np.float64) @ m) - 1.0))
    whole = float(np.dot(problem.alpha(), q))
    step = 1000
    chunked = sum(float(np.dot(problem.alpha(slice(s, s + step)), q[s:s + step])) for s in range(0, problem.n_triples, step))
    energy = Scorer(problem, "energy").metrics(m).flash_energy
    assert energy > 0
    assert whole == pytest.approx(energy, rel=1e-5)
    assert chunked == pytest.approx(whole, rel=1e-12)
