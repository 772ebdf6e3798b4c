"""One-dimensional maximum search used to locate spectral peaks."""

from __future__ import annotations

import math
from collections.abc import Callable


def golden_section_max(f: Callable[[float], float], lo: float, hi: float, tol: float = 1e-4) -> float:
    """Position of the maximum of a unimodal ``f`` on ``[lo, hi]``, to within ``tol``."""
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    while hi - lo > tol:
        if f1 < f2:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = f(x2)
        else:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = f(x1)
    return 0.5 * (lo + hi)
