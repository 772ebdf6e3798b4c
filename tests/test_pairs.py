"""The error bars' partial problems as pairs only (``labcut.orientation.pairs``, issue 17 §4).

``build_pairs`` keeps a problem's (point, view) pairs and sums their radiance at a stencil of
normals in one kernel that makes each (pair, light) term as it goes; the pairs and the sums must
be those of the whole problem built by ``build_problem`` (its triples summed by the pair-sum
kernel and by the numpy reference), for a convex stone and for a carving whose lights and views
are tested with occlusion rays.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.orientation.pairs import build_pairs
from labcut.orientation.problem import build_problem, lobe_reach
from labcut.orientation.question import FlashQuestion
from labcut.orientation.uncertainty import finer_poses, finer_directions, stencil

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def meshes():
    return {name: labcut.load_mesh(MESHES / name) for name in ("oval-16x12-low.ply", "carving-biplane.ply")}


CASES = [
    ("oval-16x12-low.ply", "bench", "dense", (0.06, -0.01, 1.0)),
    ("oval-16x12-low.ply", "bench", "finer", (0.06, -0.01, 1.0)),
    ("oval-16x12-low.ply", "pendant", "dense", (0.0, 0.3, 1.0)),
    ("carving-biplane.ply", "ring", "dense", (0.1, 0.05, 1.0)),  # not convex: occlusion rays
    ("carving-biplane.ply", "bench", "finer", (-0.2, 0.1, 1.0)),
]


def _both(mesh, scenario, which, occlusion=None):
    setup = FlashQuestion.build("blue", scenario, quality="draft")
    q = finer_directions(setup.quality) if which == "dense" else finer_poses(setup.quality)
    other = setup.at_quality(q)
    settings = other.scenario.settings()
    whole = build_problem(mesh, setup.material, quality=other.quality, tau=setup.tau, seed=setup.seed, settings=settings,
                          occlusion=occlusion)
    pairs = build_pairs(mesh, setup.material, other.quality, setup.tau, setup.seed, settings, occlusion=occlusion)
    return whole, pairs


@pytest.mark.parametrize("name, scenario, which, normal", CASES)
def test_pairs_and_stencil_sums_equal_the_whole_problem(meshes, name, scenario, which, normal):
    mesh = meshes[name]
    whole, pairs = _both(mesh, scenario, which)
    assert pairs.convex == whole.convex == (name.startswith("oval"))
    for key in ("pair_view", "pair_weight", "view_weight"):
        np.testing.assert_array_equal(getattr(pairs, key), getattr(whole, key))
    np.testing.assert_array_equal(pairs.info["pair_point"], whole.info["pair_point"])
    assert pairs.n_points == whole.n_points and pairs.kappa == whole.kappa and pairs.tau == whole.tau
    m = np.asarray(normal, dtype=np.float64)
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, 1.5)
    reach = lobe_reach(whole.kappa, np.radians(1.5))
    got = pairs.pair_radiance(normals, reach)
    want = whole.pair_radiance(normals, reach)  # the pair-sum kernel over the stored triples
    assert got.shape == want.shape and float(want.max()) > 0.0
    # the same float32 terms in the same order: equal to the last bits a compiler may round apart
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12 * float(want.max()))
    numpy_ref = whole.pair_radiance_numpy(normals, reach)  # numpy's exp over the stored triples
    np.testing.assert_allclose(got, numpy_ref, rtol=2e-5, atol=1e-9 * float(numpy_ref.max()))
    # without a reach every term counts
    np.testing.assert_allclose(pairs.pair_radiance(normals[:3]), whole.pair_radiance(normals[:3]), rtol=1e-6,
                               atol=1e-12 * float(want.max()))


def test_the_carving_with_and_without_occlusion_rays(meshes):
    """The carving's occlusion rays matter (its sums without them differ), and the pairs follow the
    planner's switch as build_problem does."""
    normals, _ = stencil(np.array([0.0, 0.0, 1.0]), 1.5)
    whole_off, pairs_off = _both(meshes["carving-biplane.ply"], "ring", "dense", occlusion=False)
    whole_on, pairs_on = _both(meshes["carving-biplane.ply"], "ring", "dense", occlusion=True)
    assert pairs_off.pair_view.size > pairs_on.pair_view.size  # the rays hide pairs
    np.testing.assert_allclose(pairs_off.pair_radiance(normals), whole_off.pair_radiance(normals), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(pairs_on.pair_radiance(normals), whole_on.pair_radiance(normals), rtol=1e-6, atol=1e-12)


def test_bad_normals_and_arguments_are_refused(meshes):
    mesh = meshes["oval-16x12-low.ply"]
    setup = FlashQuestion.build("blue", "bench", quality="draft")
    settings = setup.scenario.settings()
    pairs = build_pairs(mesh, setup.material, setup.quality, setup.tau, setup.seed, settings)
    with pytest.raises(ParameterError, match="finite"):
        pairs.pair_radiance(np.array([[np.nan, 0.0, 1.0]]))
    with pytest.raises(ParameterError, match="tau"):
        build_pairs(mesh, setup.material, setup.quality, 0.0, setup.seed, settings)
    with pytest.raises(ParameterError, match="seed"):
        build_pairs(mesh, setup.material, setup.quality, setup.tau, -1, settings)
    with pytest.raises(ParameterError, match="setting"):
        build_pairs(mesh, setup.material, setup.quality, setup.tau, setup.seed, [])
