"""Where in the stack the flash is mirrored: the depth law of a lamella stack.

A labradorite stack of ``N`` pairs of period ``d`` is ``D = N d`` deep (the presets: 6000 pairs of
155 nm, 0.93 mm). Its reflectance builds up over that depth: the first ``N' = N z / D`` pairs (the
top ``z`` of the stack, measured along the lamella normal from where the light entered it) reflect
``R(λ, θ; N')``, the model's own reflectance of a shorter stack (kinematic ``x = 2 N' r² I`` through
the random-medium saturation law of :mod:`labcut.physics.lamella`). So the share of the flash
mirrored above depth ``z`` is

    G(z; θ) = R_Y(θ; N z / D) / R_Y(θ; N),

``R_Y`` the luminance-weighted reflectance (D65, the flash metrics' luminance,
:func:`labcut.colour.stack_table`). ``G`` is the cumulative law from which the volumetric flash
estimator (:mod:`labcut.orientation.volume`) draws the depth of each reflection, and its mean at
normal incidence is the material's **flash depth** (:attr:`labcut.Labradorite.flash_depth_mm`):
the depth below which a stone part no longer holds the stack that makes its flash.

For the presets ``R_kin`` at the peak is about 0.6, where ``F(x) ≈ x`` still, so ``G`` is nearly
linear: the flash is mirrored almost evenly over the whole stack, the mean a little above half
its depth (docs/physics.md, "Depth"). Lengths in mm, angles as internal cosines to the lamella
normal.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..colour import material_key, stack_table
from ..fileio import cached_array
from ..errors import ParameterError

#: depths tabulated between 0 and the stack's depth (the law is smooth: linear interpolation
#: between 64 steps is exact to 1e-4 of the share)
DEPTH_STEPS = 64
#: internal cosines tabulated between :data:`COS_MIN` and 1 (the law's shape barely moves with the
#: angle; beyond 78° from the lamella normal there is no flash worth a depth)
COS_STEPS = 16
COS_MIN = 0.2


@dataclass(frozen=True)
class DepthLaw:
    """The cumulative share ``G(z; θ)`` of a stack's flash mirrored above depth ``z`` (module
    docstring), tabulated: ``share[i, j]`` at internal cosine ``cos[i]`` and depth ``z_mm[j]``."""

    depth_mm: float  # D: the whole stack's depth, mm
    z_mm: np.ndarray  # (DEPTH_STEPS + 1,) depths 0..D
    cos: np.ndarray  # (COS_STEPS,) internal cosines COS_MIN..1
    share: np.ndarray  # (COS_STEPS, DEPTH_STEPS + 1) G, 0 at z = 0, 1 at z = D

    def share_above(self, z_mm: Any, cos_theta: Any = 1.0) -> np.ndarray:
        """``G(z; θ)``: the share of the flash mirrored above depth ``z_mm`` (mm; 1 below the
        stack), at internal cosine ``cos_theta`` (clipped to the table), broadcast. NaN inputs are
        read as depth 0 and normal incidence (callers drop such paths themselves)."""
        z = np.clip(np.nan_to_num(np.asarray(z_mm, dtype=np.float64), nan=0.0), 0.0, self.depth_mm)
        c = np.clip(np.nan_to_num(np.asarray(cos_theta, dtype=np.float64), nan=1.0), self.cos[0], 1.0)
        z, c = np.broadcast_arrays(z, c)
        return self._bilinear(self.share, c, z / self.depth_mm * DEPTH_STEPS)

    def quantile(self, u: Any, cos_theta: Any = 1.0) -> np.ndarray:
        """The depth ``z`` (mm) with ``G(z; θ) = u``, ``u`` in [0, 1] (inverse transform sampling
        of the depth of a reflection), broadcast."""
        u = np.clip(np.nan_to_num(np.asarray(u, dtype=np.float64), nan=0.0), 0.0, 1.0)
        c = np.clip(np.nan_to_num(np.asarray(cos_theta, dtype=np.float64), nan=1.0), self.cos[0], 1.0)
        u, c = np.broadcast_arrays(u, c)
        return self._bilinear(self._inverse, c, u * DEPTH_STEPS) * self.depth_mm / DEPTH_STEPS

    def mean_mm(self, cos_theta: float = 1.0) -> float:
        """The mean depth (mm) of a reflection: ``∫ (1 - G) dz`` over the stack."""
        g = self.share_above(self.z_mm, cos_theta)
        return float(np.sum(0.5 * ((1.0 - g[1:]) + (1.0 - g[:-1])) * np.diff(self.z_mm)))

    @functools.cached_property
    def _inverse(self) -> np.ndarray:
        """(COS_STEPS, DEPTH_STEPS + 1): the depth index at u = 0, 1/DEPTH_STEPS, ..., 1 per cosine."""
        u = np.linspace(0.0, 1.0, DEPTH_STEPS + 1)
        steps = np.arange(DEPTH_STEPS + 1, dtype=np.float64)
        return np.stack([np.interp(u, row, steps) for row in self.share])

    def _bilinear(self, table: np.ndarray, c: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``table`` interpolated at cosines ``c`` and (fractional) depth-step indices ``x``."""
        fi = np.interp(c, self.cos, np.arange(COS_STEPS, dtype=np.float64))
        i0 = np.minimum(fi.astype(np.int64), COS_STEPS - 2)
        wi = fi - i0
        x = np.clip(x, 0.0, float(DEPTH_STEPS))
        j0 = np.minimum(x.astype(np.int64), DEPTH_STEPS - 1)
        wj = x - j0
        row0 = table[i0, j0] * (1.0 - wj) + table[i0, j0 + 1] * wj
        row1 = table[i0 + 1, j0] * (1.0 - wj) + table[i0 + 1, j0 + 1] * wj
        return row0 * (1.0 - wi) + row1 * wi


def stack_depth_mm(material: Any) -> float:
    """``D = N (d_a + d_b)``: the depth of ``material``'s whole stack, mm."""
    return float(material.pairs) * float(material.d_a + material.d_b) * 1e-6


@functools.lru_cache(maxsize=32)
def depth_law(material: Any, illuminant: str = "D65") -> DepthLaw:
    """The :class:`DepthLaw` of ``material`` (a :class:`~labcut.Labradorite`): its luminance
    reflectance with the stack cut at every tabulated depth, over the tabulated cosines."""
    depth = stack_depth_mm(material)
    if not (math.isfinite(depth) and depth > 0):
        raise ParameterError(f"the stack has no depth ({material.pairs} pairs of {material.d_a + material.d_b} nm)")
    z = np.linspace(0.0, depth, DEPTH_STEPS + 1)
    cos = np.linspace(COS_MIN, 1.0, COS_STEPS)

    def build() -> np.ndarray:
        pairs = (float(material.pairs) * np.arange(1, DEPTH_STEPS + 1) / DEPTH_STEPS)[:, None, None]
        cut = material.stack._replace(pairs=pairs)
        return stack_table(cut, cos, "mono", illuminant)[..., 0]  # (DEPTH_STEPS, COS_STEPS)

    # kept on disk as the colour tables are (a plan's first question about a stone asks it)
    key = f"depth law v1 {DEPTH_STEPS} x {COS_STEPS} from cos {COS_MIN} {illuminant} {material_key(material)}"
    y = cached_array("depth-law", key, build, shape=(DEPTH_STEPS, COS_STEPS), dtype=np.float64)
    full = y[-1]
    share = np.zeros((COS_STEPS, DEPTH_STEPS + 1))
    ok = full > 0
    share[ok, 1:] = (y[:, ok] / full[ok]).T
    share[~ok, 1:] = np.linspace(1.0 / DEPTH_STEPS, 1.0, DEPTH_STEPS)  # no flash at that angle: any law, even
    share = np.maximum.accumulate(np.clip(share, 0.0, 1.0), axis=1)  # a share only grows with depth
    share[:, -1] = 1.0
    for a in (z, cos, share):
        a.setflags(write=False)
    return DepthLaw(depth, z, cos, share)
