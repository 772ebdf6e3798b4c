"""Stand-in scorers for the optimiser's and the recommendation's pinned tests: sums of axial von
Mises lobes ``w exp(k (|n.p| - 1))`` over the lamella normal, whose peaks, scores and 90 % angles
(``acos(1 + ln 0.9 / k)``) are known in closed form."""

from __future__ import annotations

import math

import numpy as np

from labcut.backend import Launched
from labcut.orientation.scoring import stereo_jacobian, stereo_to_normal


def unit(*v: float) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return a / np.linalg.norm(a)


def tilted(tilt_deg: float, azimuth_deg: float = 0.0) -> np.ndarray:
    t, p = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(unit(*a) @ unit(*b))))))


class Lobes:
    """A stand-in :class:`~labcut.orientation.scoring.Scorer`: ``sum_i w_i exp(k_i (|n.p_i| - 1))``."""

    def __init__(self, peaks, kappas, weights=None, objective: str = "energy") -> None:
        self.p = np.array([unit(*p) for p in peaks])
        self.k = np.asarray(kappas, dtype=np.float64)
        self.w = np.ones(len(self.p)) if weights is None else np.asarray(weights, dtype=np.float64)
        self.objective = objective
        self.evaluations = 0

    def _f(self, n: np.ndarray) -> np.ndarray:
        n = np.atleast_2d(np.asarray(n, dtype=np.float64))
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        return (self.w * np.exp(self.k * (np.abs(n @ self.p.T) - 1.0))).sum(axis=1)

    def score(self, normal) -> float:
        self.evaluations += 1
        return float(self._f(normal)[0])

    def scores(self, normals) -> np.ndarray:
        self.evaluations += len(normals)
        return self._f(normals)

    def score_uv(self, u: float, v: float) -> float:
        return self.score(stereo_to_normal(u, v))

    def value_and_grad_uv(self, u: float, v: float):
        self.evaluations += 1
        n = stereo_to_normal(u, v)
        d = n @ self.p.T
        g_n = ((self.w * self.k * np.sign(d) * np.exp(self.k * (np.abs(d) - 1.0)))[:, None] * self.p).sum(axis=0)
        return float(self._f(n)[0]), stereo_jacobian(u, v).T @ g_n

    def energy_map(self, normals) -> np.ndarray:
        self.evaluations += len(normals)
        return self._f(normals)

    def launch_energy_map(self, normals) -> Launched:
        return Launched.ready(self.energy_map(normals))

    def energy_batch_value_and_grad(self, us, vs):
        out = [self.value_and_grad_uv(float(u), float(v)) for u, v in zip(us, vs)]
        return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def ninety_percent_deg(kappa: float) -> float:
    """The angle at which one lobe falls to 90 % of its peak."""
    return math.degrees(math.acos(1.0 + math.log(0.9) / kappa))
