"""The error bars' fast path (issue 17 §4) gives the bars of the whole problems.

``uncertainty_for`` builds its half-direction and finer-pose problems as pairs only
(``labcut.orientation.pairs.build_pairs``: their stencil sums make each term in one kernel,
``tests/test_pairs.py``) and the half-direction one from the answer's own surface samples; the bars
must equal those of the fully built problems.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.orientation.problem import build_problem, surface_samples
from labcut.orientation.question import FlashQuestion
from labcut.orientation.uncertainty import (
    estimate_uncertainty,
    finer_poses,
    finer_directions,
    uncertainty_for,
)

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(MESHES / "oval-16x12-low.ply")


def _full(mesh, setup, quality, occlusion=None):
    other = setup.at_quality(quality)
    return build_problem(mesh, setup.material, quality=other.quality, tau=setup.tau, seed=setup.seed,
                         settings=other.scenario.settings(), occlusion=occlusion)


@pytest.mark.parametrize("scenario, objective, normal", [
    ("bench", "energy", (0.06, -0.01, 1.0)),  # rocks: half-direction and finer-pose problems
    ("pendant", "area", (0.0, 0.1, 1.0)),
    ("ring", "balanced", (0.1, 0.05, 1.0)),
])
def test_reused_error_bars_equal_the_direct_computation(oval, scenario, objective, normal):
    setup = FlashQuestion.build("blue", scenario, quality="draft", objective=objective)
    problem = _full(oval, setup, setup.quality)
    got = uncertainty_for(oval, setup, problem, normal, occlusion=None, tolerance_deg=3.0)
    rocks = setup.scenario.rock_deg > 0.0 or setup.scenario.sway_deg > 0.0
    want = estimate_uncertainty(problem, normal, objective, dense=_full(oval, setup, finer_directions(setup.quality)),
                                fine=_full(oval, setup, finer_poses(setup.quality)) if rocks else None,
                                tolerance_deg=3.0, seed=setup.seed)
    assert got == want


def test_problems_of_one_stone_share_their_surface_samples(oval):
    """The error bars' problems find the answer's surface samples in the mesh's cache (same count
    and seed), and a fresh copy of the mesh (no cache) draws the very same ones."""
    setup = FlashQuestion.build("blue", "bench", quality="draft")
    n = setup.quality.surface_points
    first = surface_samples(oval, n, 3)
    assert surface_samples(oval, n, 3) is first
    assert surface_samples(oval, n, 4) is not first and surface_samples(oval, n // 2, 3) is not first
    settings = setup.scenario.settings()
    a = build_problem(oval, setup.material, quality="draft", settings=settings, seed=3)
    b = build_problem(oval.copy(), setup.material, quality="draft", settings=settings, seed=3)  # drawn again
    for name in ("h", "c", "pair", "pair_view", "pair_weight", "view_weight"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@pytest.mark.parametrize("name, scenario", [("oval-16x12-low.ply", "bench"), ("carving-biplane.ply", "ring"),
                                            ("carving-biplane.ply", "display")])
def test_the_drjit_triple_kernel_equals_the_numpy_reference(name, scenario, monkeypatch):
    """The triple terms in one float32 Dr.Jit kernel (the default) against the float64 numpy passes:
    the same triples in the same order, their terms to float32 rounding, the same answer."""
    from labcut.orientation.kernels import KernelOptions

    mesh = labcut.load_mesh(MESHES / name)
    setup = FlashQuestion.build("blue", scenario, quality="draft")
    settings = setup.scenario.settings()
    fast = build_problem(mesh, setup.material, quality="draft", settings=settings)
    slow = build_problem(mesh, setup.material, quality="draft", settings=settings, kernels=KernelOptions(triples=False))
    for key in ("pair", "pair_view", "pair_weight", "view_weight"):
        np.testing.assert_array_equal(getattr(fast, key), getattr(slow, key))
    np.testing.assert_allclose(fast.h, slow.h, rtol=0, atol=1e-6)
    np.testing.assert_allclose(fast.c, slow.c, rtol=0, atol=1e-5 * float(slow.c.max()))
    asked = FlashQuestion.build("blue", scenario, quality="draft", estimator="samples")
    # no pilot renders (pilot_seconds_max=0): the light between a carving's parts they measure decides
    # between estimators, and this sample answer is asked for (they cost a cold machine 20 s a scene)
    rec_slow = labcut.Study(mesh, question=asked, kernels=KernelOptions(triples=False), pilot_seconds_max=0).recommend()
    rec_fast = labcut.Study(mesh.copy(), question=asked, pilot_seconds_max=0).recommend()
    angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(rec_fast.normal, rec_slow.normal))))))
    assert angle < 0.1 * rec_slow.uncertainty.angle_deg
    assert rec_fast.score == pytest.approx(rec_slow.score, rel=1e-4)
