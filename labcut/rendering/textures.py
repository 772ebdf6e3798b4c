"""Texture data for the BSDF's kernels: the same kernel code whatever numpy's memory layout and
whatever box the texture spans."""

from __future__ import annotations

from typing import Any

import numpy as np


def texture_data(values: Any) -> Any:
    """``values`` (an array of floats, any layout) as a float32 ``mi.TensorXf`` of the current
    Mitsuba variant, in memory Dr.Jit owns.

    A tensor made straight from a numpy array maps the array's memory when numpy happened to
    place it 64-byte aligned, and copies it otherwise (``dr.copy`` keeps that difference); a
    texture over mapped memory is read by other kernel code than one over a copy, so the same
    scene compiled one kernel or the other at random, from one process to the next
    (``tests/test_render_frame.py``). The values are therefore passed through one evaluated
    kernel (an addition of an opaque zero: the same floats, -0 read as +0), whose output is
    memory Dr.Jit allocated, read by the same code every time."""
    import drjit as dr
    import mitsuba as mi

    a = np.ascontiguousarray(values, dtype=np.float32)
    flat = mi.Float(a.ravel()) + dr.opaque(mi.Float, 0.0)
    dr.eval(flat)
    return mi.TensorXf(flat, a.shape)


def texture_box(lo: Any, hi: Any) -> tuple[Any, Any]:
    """``(lo, 1 / (hi - lo))`` of a texture's box as an opaque ``mi.Point3f`` and ``mi.Vector3f``
    (a point ``p`` is looked up at ``(p - lo) * inv_ext``): values the kernel reads, not
    constants written into it, so a stone of another shape reads its textures with the kernels
    already compiled."""
    import drjit as dr
    import mitsuba as mi

    lo_a, hi_a = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return (mi.Point3f(*(dr.opaque(mi.Float, float(x)) for x in lo_a)),
            mi.Vector3f(*(dr.opaque(mi.Float, float(x)) for x in 1.0 / (hi_a - lo_a))))
