"""Dome profiles: height of a cabochon's dome as a function of normalised radial position.

A cabochon's dome is built by scaling its outline towards a centre point: the
horizontal section at height ``z`` above the dome's foot is the outline scaled by
``s`` (``s = 1`` at the foot, ``s = 0`` at the apex). A profile gives ``z(s)`` in
mm. Because every section is a scaled copy of the outline, any outline that is
star-shaped about the centre works, and the dome volume has the closed form

    V = A * integral_0^1 2 s z(s) ds          (A: outline area, mm^2)

Profiles (``H`` the dome height in mm):

* ``elliptic``: ``z = H sqrt(1 - s^2)``. Over a round outline this is half a
  spheroid (half-ellipsoid), volume ``2/3 A H``; the classic calibrated cabochon.
* ``spherical``: a spherical cap. Its sphere passes through the foot of the dome
  at ``s = 1`` across the outline's *reference half-width* ``a`` (half the smaller
  of length and width), radius ``R = (a^2 + H^2) / 2H``, and
  ``z = sqrt(R^2 - a^2 s^2) - (R - H)``. Over a round outline this is exactly a
  spherical cap (``V = pi H (3 a^2 + H^2) / 6``). Needs ``H <= a`` (at most a
  hemisphere): a taller cap would overhang the outline.
* ``tallow``: a "tallow-top", flatter on top and steeper at the edge than the
  elliptic dome: the superellipse ``(z/H)^n + s^n = 1`` with
  ``n =`` :data:`TALLOW_EXPONENT` (``n = 2`` would be elliptic). Volume
  ``A H (2/n) B(2/n, 1 + 1/n)``.

Buff-top: a flat table of linear fraction ``t`` of the outline (``t = 0.5``: the
table spans half the stone's length and width) is cut on the dome. The dome is
made taller, ``z = min(z_v(s), H)``, with the virtual dome ``z_v`` chosen so that
``z_v(t) = H``: the stone keeps the requested total dome height ``H`` and the
crest line between table and dome is a crisp edge, as on a cut buff-top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError

PROFILES = ("elliptic", "spherical", "tallow")

#: superellipse exponent of the tallow-top profile; 3 is visibly flatter than an
#: ellipse (2) without turning into a flat-topped plateau (n >> 4).
TALLOW_EXPONENT = 3.0

#: largest allowed table fraction of a buff-top
MAX_TABLE = 0.95


def _virtual(kind: str, hv: float, a: float, s: np.ndarray) -> np.ndarray:
    """Untruncated dome of height ``hv`` (mm) at radial positions ``s`` in [0, 1]."""
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    if kind == "elliptic":
        return hv * np.sqrt(np.maximum(0.0, 1.0 - s * s))
    if kind == "tallow":
        n = TALLOW_EXPONENT
        return hv * np.maximum(0.0, 1.0 - s**n) ** (1.0 / n)
    # spherical cap through (a, 0) and (0, hv)
    R = (a * a + hv * hv) / (2.0 * hv)
    return np.maximum(0.0, np.sqrt(np.maximum(0.0, R * R - (a * s) ** 2)) - (R - hv))


@dataclass(frozen=True)
class Profile:
    """A dome profile ``z(s)`` in mm (see the module docstring).

    Attributes:
        kind: ``"elliptic"``, ``"spherical"`` or ``"tallow"``.
        height: dome height ``H`` in mm (of the finished dome, table included).
        ref_half_width: the outline's reference half-width ``a`` in mm (half the
            smaller of length and width); sets the sphere of the spherical cap and
            the horizontal scale used to space rings.
        table: buff-top table fraction ``t`` in [0, 0.95]; 0 for a full dome.
    """

    kind: str
    height: float
    ref_half_width: float
    table: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in PROFILES:
            raise ParameterError(f"unknown profile {self.kind!r}; use one of {', '.join(PROFILES)}")
        for name in ("height", "ref_half_width"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"profile {name} must be a positive finite number of mm, got {v!r}")
        if not (math.isfinite(self.table) and 0.0 <= self.table <= MAX_TABLE):
            raise ParameterError(f"buff-top table fraction must be in [0, {MAX_TABLE}], got {self.table!r}")
        if self.kind == "spherical":
            a, t = self.ref_half_width, self.table
            limit = a * math.sqrt(1.0 - t * t)
            if self.height > limit * (1 + 1e-12):
                what = f"with a {t:g} buff-top table " if t > 0 else ""
                raise ParameterError(
                    f"a spherical dome {what}on this outline can be at most {limit:.4g} mm high "
                    f"(a hemisphere over half-width {a:g} mm), got {self.height:g} mm"
                )
        object.__setattr__(self, "_hv", self._solve_virtual_height())

    # ---------------------------------------------------------------- internals
    def _solve_virtual_height(self) -> float:
        """Height of the untruncated dome whose value at s = table is ``height``."""
        H, t, a = self.height, self.table, self.ref_half_width
        if t == 0.0:
            return H
        if self.kind in ("elliptic", "tallow"):
            return H / float(_virtual(self.kind, 1.0, 1.0, np.array(t)))
        # spherical: z_v(t) increases with hv on (0, a]; bisect
        lo, hi = H, min(a, max(H, a))
        if float(_virtual("spherical", hi, a, np.array(t))) < H:
            hi = a
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if float(_virtual("spherical", mid, a, np.array(t))) < H:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    @property
    def virtual_height(self) -> float:
        """Height (mm) of the full dome that the buff-top table truncates (= height without table)."""
        return float(self._hv)  # type: ignore[attr-defined]

    # ---------------------------------------------------------------- public
    def z(self, s: np.ndarray | float) -> np.ndarray:
        """Dome height (mm) above its foot at radial position(s) ``s`` in [0, 1]."""
        zv = _virtual(self.kind, self.virtual_height, self.ref_half_width, s)
        return np.minimum(zv, self.height) if self.table > 0 else zv

    def volume_factor(self) -> float:
        """``integral_0^1 2 s z(s) ds`` in mm: dome volume = outline area x this factor.

        Closed forms for the elliptic and spherical domes, a graded numerical
        quadrature (relative error < 1e-9) for the tallow-top and buff-tops.
        """
        H, t, a, hv = self.height, self.table, self.ref_half_width, self.virtual_height
        if self.kind == "elliptic":
            return H * t * t + hv * (2.0 / 3.0) * (1.0 - t * t) ** 1.5
        if self.kind == "spherical":
            R = (a * a + hv * hv) / (2.0 * hv)
            ring = (2.0 / (3.0 * a * a)) * ((R * R - a * a * t * t) ** 1.5 - (R * R - a * a) ** 1.5)
            return H * t * t + ring - (R - hv) * (1.0 - t * t)
        if t == 0.0:
            n = TALLOW_EXPONENT
            beta = math.gamma(2.0 / n) * math.gamma(1.0 + 1.0 / n) / math.gamma(2.0 / n + 1.0 + 1.0 / n)
            return H * (2.0 / n) * beta
        # numeric: graded towards s = 1 where the tallow slope is infinite
        w = np.linspace(0.0, 1.0, 200001)
        s = t + (1.0 - t) * (1.0 - (1.0 - w) ** 4)
        f = 2.0 * s * self.z(s)
        return H * t * t + float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(s)))

    def rings(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """Ring positions for a mesh: ``(s, z)`` with ``s`` from 1 (foot, z = 0) to 0 (apex).

        ``count`` intervals are spaced evenly by arc length of the normalised
        profile curve ``(s, z / H_v)``; the table edge of a buff-top (where the slope breaks) is
        always a ring. The last ring has ``s = 0`` (the apex or table centre).
        """
        count = max(2, int(count))
        # arc length of the normalised curve (s, z / H_v): the spacing, and so the
        # relative volume error, does not depend on how low or high the dome is
        a = self.virtual_height
        th = np.linspace(0.0, math.pi / 2, 20001)
        s = np.cos(th)  # dense near s = 1, where elliptic and tallow domes are steep
        s[-1] = 0.0
        if self.table > 0:
            s = np.union1d(s, [self.table])[::-1]
        z = self.z(s)
        z[0] = 0.0
        seg = np.hypot(np.diff(a * s), np.diff(z))
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        targets = np.linspace(0.0, cum[-1], count + 1)
        if self.table > 0:
            # snap the nearest target to the table edge
            k_edge = int(np.argmin(np.abs(s - self.table)))
            i = int(np.argmin(np.abs(targets - cum[k_edge])))
            i = min(max(i, 1), count - 1)
            targets[i] = cum[k_edge]
            targets = np.sort(targets)
        s_out = np.interp(targets, cum, s)
        s_out[0], s_out[-1] = 1.0, 0.0
        z_out = self.z(s_out)
        z_out[0] = 0.0
        if self.table > 0:
            z_out[s_out <= self.table + 1e-12] = self.height
        else:
            z_out[-1] = self.height
        # drop accidental duplicates
        keep = np.ones(len(s_out), bool)
        keep[1:] = np.abs(np.diff(s_out)) > 1e-12
        return s_out[keep], z_out[keep]


def dome_limit(kind: str, ref_half_width: float, table: float = 0.0) -> float:
    """Largest dome height (mm) allowed for a profile over an outline of half-width ``a``.

    Spherical: a hemisphere (``a sqrt(1 - t^2)`` with a buff-top table ``t``).
    Elliptic and tallow: twice the half-width, i.e. a dome as high as the stone is
    wide (taller "bullet" shapes are carvings, not cabochons).
    """
    if kind == "spherical":
        return ref_half_width * math.sqrt(max(0.0, 1.0 - table * table))
    return 2.0 * ref_half_width
