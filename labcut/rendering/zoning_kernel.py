"""Colour zoning inside the ``labradorite`` BSDF: the textures and the lookup at a hit.

The data model (:class:`~labcut.rendering.zoning.Zoning`) bakes a noise grid and a
parameter path; this module turns them into Mitsuba textures and reflectance tables
(built by :func:`labcut.colour.stack_table`) and evaluates R at a hit point.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..physics.lamella import Stack, stack_reflectance
from .textures import texture_box, texture_data
from .zoning import COS_SIZE, ZONED_KEYS


def _reflectance_rows(path: np.ndarray, shared: dict[str, Any], cos: np.ndarray, luminance: bool) -> np.ndarray:
    """Linear sRGB (rows, C, 3) or luminance (rows, C, 1) reflectance along a parameter path
    (:func:`labcut.colour.stack_table` of each distinct row)."""
    from ..colour import stack_table

    uniq, inverse = np.unique(path.astype(np.float64), axis=0, return_inverse=True)
    out = []
    for d_a, d_b, s_a, s_b, pairs in uniq:
        stack = Stack(shared["n_a"], shared["n_b"], d_a, d_b, s_a, s_b, pairs, shared["n_surface"])
        table = stack_table(stack, cos, "mono" if luminance else "rgb")
        out.append(table if luminance else np.clip(table, 0.0, None))
    return np.stack(out)[np.asarray(inverse).ravel()]


@functools.lru_cache(maxsize=16)
def _table_cached(path_bytes: bytes, rows: int, shared_items: tuple, kind: str) -> np.ndarray:
    path = np.frombuffer(path_bytes, dtype=np.float32).reshape(rows, len(ZONED_KEYS))
    cos = np.linspace(0.0, 1.0, COS_SIZE)
    return _reflectance_rows(path, dict(shared_items), cos, kind == "mono").astype(np.float32)


def reflectance_table(path: np.ndarray, shared: dict[str, Any], kind: str) -> np.ndarray:
    """(rows, COS_SIZE, 3 or 1) float32 table of R over (x, cos θ) for ``kind`` ``rgb`` / ``mono`` (cached)."""
    p = np.ascontiguousarray(path, dtype=np.float32)
    return _table_cached(p.tobytes(), p.shape[0], tuple(sorted(shared.items())), kind)


def schiller_weight(path: np.ndarray, shared: dict[str, Any]) -> float:
    """Mean luminance reflectance over x and over cos θ in [0.5, 1]: the schiller lobe's sampling weight."""
    rows = np.asarray(path)[:: max(1, len(path) // 16)]
    lum = reflectance_table(rows, shared, "mono")[..., 0]
    return float(max(np.mean(lum[:, COS_SIZE // 2 :]), 0.02))


class ZoningKernel:
    """The zoning inside a ``labradorite`` BSDF instance: textures and the lookup at a hit.

    Built from the plugin properties ``zoning_grid`` (TensorXf, nz x ny x nx x 1, values of
    x in [0, 1]), ``zoning_path`` (TensorXf, N x 5: ``d_a, d_b, sigma_a, sigma_b, pairs``
    at ``x = i / (N - 1)``), ``zoning_lo`` and ``zoning_hi`` (the grid's box, scene coordinates: labcut's renders use the stone's render frame).
    """

    def __init__(self, props: Any, shared: dict[str, Any]) -> None:
        import drjit as dr
        import mitsuba as mi

        grid = props["zoning_grid"]
        path = props.get("zoning_path", None)
        if path is None or "zoning_lo" not in props or "zoning_hi" not in props:
            raise ParameterError("zoning needs zoning_grid, zoning_path, zoning_lo and zoning_hi together")
        g = np.array(grid, dtype=np.float32)
        p = np.array(path, dtype=np.float32)
        if g.ndim != 4 or g.shape[3] != 1 or min(g.shape[:3]) < 2:
            raise ParameterError(f"zoning_grid must be a (nz, ny, nx, 1) tensor, got shape {g.shape}")
        if p.ndim != 2 or p.shape[1] != len(ZONED_KEYS) or p.shape[0] < 2:
            raise ParameterError(f"zoning_path must be an (N, {len(ZONED_KEYS)}) tensor, got shape {p.shape}")
        if not (np.all(np.isfinite(g)) and np.all(np.isfinite(p))):
            raise ParameterError("zoning tensors must be finite")
        if np.any(p[:, :2] <= 0) or np.any(p[:, 2:4] < 0) or np.any(p[:, 4] < 1):
            raise ParameterError("zoning_path needs d > 0, sigma >= 0 and pairs >= 1")
        lo = np.array([float(props["zoning_lo"][k]) for k in range(3)])
        hi = np.array([float(props["zoning_hi"][k]) for k in range(3)])
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            raise ParameterError("zoning_lo must lie below zoning_hi on every axis")
        self.shared = dict(shared)
        self.path = p
        self.rows = p.shape[0]
        self.lo, self.inv_ext = texture_box(lo, hi)
        self.grid = mi.Texture3f(texture_data(g), use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        self.spectral = bool(mi.is_spectral)
        if self.spectral:
            self.table = mi.Texture1f(texture_data(p), use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        else:
            data = reflectance_table(p, shared, "rgb" if mi.is_rgb else "mono")
            self.table = mi.Texture2f(texture_data(data), use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        self.weight = schiller_weight(p, shared)

    def x_at(self, p: Any) -> Any:
        """Noise value x in [0, 1] at world points ``p`` (trilinear)."""
        import mitsuba as mi

        u = (mi.Point3f(p) - self.lo) * self.inv_ext
        return self.grid.eval(u)[0]

    def reflectance(self, si: Any, cos_l: Any) -> Any:
        """R at the hit ``si`` and internal cos θ ``cos_l`` as an UnpolarizedSpectrum."""
        import drjit as dr
        import mitsuba as mi

        x = self.x_at(si.p)
        n = float(self.rows)
        ux = (x * (n - 1.0) + 0.5) / n  # row k sits at texel centre (k + 0.5) / n
        if self.spectral:
            d_a, d_b, s_a, s_b, pairs = self.table.eval(mi.Point1f(ux))
            s = self.shared
            r = stack_reflectance(si.wavelengths, cos_l, Stack(s["n_a"], s["n_b"], d_a, d_b, s_a, s_b, dr.maximum(pairs, 1.0), s["n_surface"]))
            return mi.UnpolarizedSpectrum(r)
        c = float(COS_SIZE)
        uc = (dr.clip(cos_l, 0.0, 1.0) * (c - 1.0) + 0.5) / c
        values = self.table.eval(mi.Point2f(uc, ux))
        if len(values) == 1:
            return mi.UnpolarizedSpectrum(values[0])
        return mi.UnpolarizedSpectrum(values[0], values[1], values[2])
