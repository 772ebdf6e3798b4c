"""One set of elementary functions over numpy (float64) and Dr.Jit (float32 or float64) arrays.

The lamella physics in :mod:`labcut.physics.lamella` is written once against an
``ops`` namespace; :func:`ops_for` picks numpy's or Dr.Jit's from the arguments.
The API and the tests call it with numpy arrays, the Mitsuba BSDF with Dr.Jit
float32 arrays inside a traced kernel, so the same expression serves both; the colour
tables' spectra evaluate it over Dr.Jit float64 arrays
(:meth:`labcut.physics.lamella.Stack.spectra`: every step in float64, as numpy's, on Dr.Jit's
threads).

Dr.Jit has no ``expm1`` or ``log1p``: they use Kahan's tricks
``(u - 1) * x / log(u)`` with ``u = exp(x)`` and ``x log(u) / (u - 1)`` with
``u = 1 + x``, accurate to a few ulp for small ``x``; all branches are kept
finite so reverse-mode AD sees no NaN.

``wide``/``narrow`` move a value to float64 and back (identity for numpy and for Dr.Jit's
float64 namespace): the Bragg phase, whose peak in I is only ~10 float32 units wide for a
nearly perfect thick stack, is reduced modulo 2π in float64.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np


def _np_safe_sqrt(x: Any) -> Any:
    return np.sqrt(np.maximum(x, 0.0))


def _identity(x: Any) -> Any:
    return x


def _np_dot(a: Any, b: Any) -> Any:
    """Dot product over the last axis ((..., 3) arrays)."""
    return np.einsum("...i,...i->...", a, b)


def _np_scale(v: Any, s: Any) -> Any:
    """A (..., 3) vector times a (...) scalar."""
    return v * np.asarray(s)[..., None]


NUMPY = SimpleNamespace(
    name="numpy",
    wide=_identity,
    narrow=_identity,
    round=np.round,
    exp=np.exp,
    expm1=np.expm1,
    log1p=np.log1p,
    sin=np.sin,
    cos=np.cos,
    tanh=np.tanh,
    sqrt=np.sqrt,
    safe_sqrt=_np_safe_sqrt,
    abs=np.abs,
    maximum=np.maximum,
    minimum=np.minimum,
    select=np.where,
    dot=_np_dot,
    scale=_np_scale,
    tiny=1e-300,
)

_DRJIT: dict[bool, SimpleNamespace] = {}


def _drjit_ops(double: bool = False) -> SimpleNamespace:
    """Dr.Jit's namespace: float32 working precision (``double`` False: ``narrow`` to float32,
    ``tiny`` 1e-30) or float64 throughout (``narrow`` keeps float64, ``tiny`` 1e-300, as numpy's)."""
    if double not in _DRJIT:
        import drjit as dr

        def expm1(x: Any) -> Any:
            u = dr.exp(x)
            um1 = u - 1.0
            small = um1 == 0.0
            log_u = dr.log(dr.select(small, 1.5, u))  # finite in both branches
            big = dr.abs(x) > 0.5  # exp(x) - 1 is already accurate here
            kahan = um1 * x / dr.select(small, 1.0, log_u)
            return dr.select(small, x, dr.select(big, um1, kahan))

        def log1p(x: Any) -> Any:
            """log(1 + x) for x >= 0, accurate for small x (Kahan: x log(u)/(u - 1), u = 1 + x)."""
            u = 1.0 + x
            um1 = u - 1.0
            small = um1 == 0.0
            return dr.select(small, x, dr.log(u) * x / dr.select(small, 1.0, um1))

        def wide(x: Any) -> Any:
            """Float64 copy of a Dr.Jit float array (same backend, AD kept)."""
            if not dr.is_array_v(x):
                return x
            return dr.float64_array_t(type(x))(x)

        def narrow(x: Any) -> Any:
            if not dr.is_array_v(x):
                return x
            return dr.float32_array_t(type(x))(x)

        _DRJIT[double] = SimpleNamespace(
            name="drjit64" if double else "drjit",
            wide=wide,
            narrow=wide if double else narrow,
            round=dr.round,
            exp=dr.exp,
            expm1=expm1,
            log1p=log1p,
            sin=dr.sin,
            cos=dr.cos,
            tanh=dr.tanh,
            sqrt=dr.sqrt,
            safe_sqrt=dr.safe_sqrt,
            abs=dr.abs,
            maximum=dr.maximum,
            minimum=dr.minimum,
            select=dr.select,
            dot=dr.dot,
            scale=lambda v, s: v * s,
            tiny=1e-300 if double else 1e-30,
        )
    return _DRJIT[double]


def is_drjit(x: Any) -> bool:
    """True for a Dr.Jit array (without importing drjit for plain numbers)."""
    return type(x).__module__.startswith("drjit")


def _is_double(x: Any) -> bool:
    import drjit as dr

    return dr.type_v(x) == dr.VarType.Float64


def ops_for(*args: Any) -> SimpleNamespace:
    """numpy ops for numpy arrays and numbers; Dr.Jit ops if any argument is a Dr.Jit array:
    the float64 namespace when every Dr.Jit argument is float64, else the float32 one."""
    jit = [a for a in args if is_drjit(a)]
    if not jit:
        return NUMPY
    return _drjit_ops(all(_is_double(a) for a in jit))


def drjit_ops(double: bool = False) -> SimpleNamespace:
    """The Dr.Jit ops namespace (for code that always runs inside a Dr.Jit kernel): float32
    working precision, or float64 throughout with ``double``."""
    return _drjit_ops(double)
