"""The fast paths of issue 17 §4-5 give what the slow ones gave.

* runners-up: the vectorised search (``optimize.distinct_optima``) finds the same optima, in the
  same order, as the per-candidate loop it replaced (kept here as the reference);
* the sparse energy map's BLAS-free products equal ``@``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.orientation.optimize import Constraint, distinct_optima, hemisphere_grid, polish_grid
from labcut.orientation.scoring import _cos_matrix, _lobe_sums


class LobeScorer:
    """A stand-in scorer: energy = Σ_k w_k exp(κ(|c_k·m| - 1)) over a few centres (several optima)."""

    objective = "energy"

    def __init__(self, centres: np.ndarray, weights: np.ndarray, kappa: float = 60.0) -> None:
        c = np.asarray(centres, dtype=np.float64)
        self.c = c / np.linalg.norm(c, axis=1, keepdims=True)
        self.w = np.asarray(weights, dtype=np.float64)
        self.kappa = kappa
        self.evaluations = 0

    def energy_map(self, normals: np.ndarray) -> np.ndarray:
        m = np.atleast_2d(normals)
        self.evaluations += len(m)
        return np.exp(self.kappa * (np.abs(m @ self.c.T) - 1.0)) @ self.w


def _axial_angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(a @ b)))))


def _upper(n: np.ndarray) -> np.ndarray:
    n = np.asarray(n, dtype=np.float64)
    n = n / np.linalg.norm(n)
    return -n if n[2] < 0 else n


def _loop_runners_up(scorer, constraint, normals, scores, best, best_score, count=3, separation=12.0, neighbour=4.5):
    """The loop recommend._runners_up ran before it was vectorised (commit b6a2949)."""
    out = []
    taken = [best]
    for i in np.argsort(scores)[::-1]:
        if scores[i] < 0.3 * best_score or len(out) >= count:
            break
        n = normals[i]
        if any(_axial_angle(n, t) < separation for t in taken):
            continue
        near = np.degrees(np.arccos(np.clip(np.abs(normals @ n), 0.0, 1.0))) < neighbour
        if np.any(scores[near] > scores[i]):
            continue
        polished, value = polish_grid(scorer, n, constraint, 2.0, 0.25)
        polished = _upper(polished)
        if any(_axial_angle(polished, t) < separation for t in taken):
            continue
        taken.append(polished)
        out.append((polished, value))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_vectorised_runners_up_equal_the_loop(seed):
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(7, 3)) * [1.0, 1.0, 0.6] + [0.0, 0.0, 1.0]
    centres[:, 2] = np.abs(centres[:, 2])
    scorer = LobeScorer(centres, rng.uniform(0.3, 1.0, size=7))
    constraint = Constraint(75.0)
    normals = hemisphere_grid(3.0, constraint)
    scores = scorer.energy_map(normals)
    best = normals[int(np.argmax(scores))]
    best_score = float(scores.max())
    want = _loop_runners_up(scorer, constraint, normals, scores, best, best_score, count=4)
    got = distinct_optima(scorer, constraint, normals, scores, best, best_score, count=4, separation_deg=12.0, neighbour_deg=4.5)
    assert len(want) >= 2  # the case has runners-up to find
    assert len(got) == len(want)
    for (n1, v1), (n2, v2) in zip(got, want):
        assert np.allclose(n1, n2, atol=1e-12)
        assert v1 == pytest.approx(v2, rel=1e-12)


def test_blas_free_products_equal_matmul():
    rng = np.random.default_rng(5)
    m = rng.normal(size=(7, 3))
    h = rng.normal(size=(50, 3))
    a = rng.uniform(size=50)
    assert np.allclose(_cos_matrix(m, np.ascontiguousarray(h.T)), m @ h.T, rtol=0, atol=1e-13)
    want = np.exp(3.0 * (np.abs(m @ h.T) - 1.0)) @ a
    assert np.allclose(_lobe_sums(m, np.ascontiguousarray(h.T), a, 3.0), want, rtol=1e-13)
