"""Environment maps: distant light given as radiance over all directions.

Map convention (Mitsuba's ``envmap`` plugin, placed in labcut's world with +Z up):
an equirectangular (lat-long) RGB image, ``W`` x ``H``, linear radiance. Row 0 is
straight up (world +Z), the bottom row straight down; column ``u`` in [0, 1) has
azimuth ``90° - 360° u`` from +X toward +Y, so the centre column looks at the front
of the stone (-Y, azimuth 270°), the left edge at the back (+Y) and u = 0.25 at +X.
In Mitsuba's own envmap frame (+Y up) a pixel's direction is
``(sin φ sin θ, cos θ, -cos φ sin θ)`` with φ = 2π u, θ = π v; labcut's world is
that frame rotated by :data:`MAP_TO_WORLD` (+90° about X), and the renderer passes
the same rotation to Mitsuba as ``to_world``, so one map lights the optimiser's
directions and the render alike.

:class:`Environment` holds the radiance array and the rotation from the map's
world frame into the frame it is used in (the mesh frame after a scenario's pose).
:meth:`Environment.sample` importance-samples it into weighted distant lights.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from .directions import frame_to

MAP_TO_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""Mitsuba's envmap frame (+Y up) into labcut's world frame (+Z up): +90° about X."""

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # linear sRGB -> Y
ENVMAP_SUFFIXES = (".exr", ".hdr")


def pixel_directions(width: int, height: int) -> np.ndarray:
    """(H, W, 3) unit directions of the pixel centres, in the map's world frame (+Z up)."""
    theta = (np.arange(height) + 0.5) * (math.pi / height)
    phi = (np.arange(width) + 0.5) * (2.0 * math.pi / width)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    sp, cp = np.sin(phi)[None, :], np.cos(phi)[None, :]
    return np.stack(np.broadcast_arrays(sp * st, cp * st, ct), axis=-1)


def direction_to_pixel(d: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) indices of the pixels holding world directions ``d`` (N, 3)."""
    d = np.asarray(d, dtype=np.float64)
    theta = np.arccos(np.clip(d[:, 2], -1.0, 1.0))
    phi = np.arctan2(d[:, 0], d[:, 1]) % (2.0 * math.pi)
    row = np.clip((theta / math.pi * height).astype(np.int64), 0, height - 1)
    col = np.clip((phi / (2.0 * math.pi) * width).astype(np.int64), 0, width - 1)
    return row, col


@dataclass(frozen=True, eq=False)
class Environment:
    """Linear RGB radiance ``(H, W, 3)`` in the map convention above, and ``rotation``: the
    3 x 3 rotation from the map's world frame into the frame the lights are used in."""

    radiance: np.ndarray
    rotation: np.ndarray
    name: str = "environment"

    def __post_init__(self) -> None:
        r = np.asarray(self.radiance, dtype=np.float32)
        if r.ndim != 3 or r.shape[2] != 3 or r.shape[0] < 2 or r.shape[1] < 2:
            raise ParameterError(f"environment map {self.name!r} must be an RGB image of at least 2 x 2 pixels")
        if not np.all(np.isfinite(r)) or np.any(r < 0.0):
            raise ParameterError(f"environment map {self.name!r} holds negative or non-finite radiance")
        object.__setattr__(self, "radiance", np.ascontiguousarray(r))
        object.__setattr__(self, "rotation", np.asarray(self.rotation, dtype=np.float64))
        if not self.power > 0.0:
            raise ParameterError(f"environment map {self.name!r} is black: it lights nothing")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> Environment:
        """Read an .exr / .hdr lat-long map (Mitsuba's convention, placed with +Z up)."""
        p = Path(path)
        if p.suffix.lower() not in ENVMAP_SUFFIXES:
            raise ParameterError(f"environment map {str(path)!r} must be an .exr or .hdr file")
        if not p.is_file():
            raise ParameterError(f"environment map {str(path)!r} does not exist")
        import mitsuba as mi

        try:
            bmp = mi.Bitmap(str(p)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
        except Exception as exc:  # Mitsuba raises RuntimeError with a long message
            raise ParameterError(f"cannot read environment map {str(path)!r}: {str(exc).splitlines()[0][:160]}") from None
        return cls(np.array(bmp, dtype=np.float32), np.eye(3), p.name)

    @classmethod
    def from_function(cls, radiance: Callable[[np.ndarray], np.ndarray], width: int, height: int, name: str) -> Environment:
        """Bake ``radiance(directions (N, 3), world frame) -> (N, 3) RGB`` onto a lat-long grid."""
        d = pixel_directions(width, height).reshape(-1, 3)
        rgb = np.asarray(radiance(d), dtype=np.float64).reshape(height, width, 3)
        return cls(rgb.astype(np.float32), np.eye(3), name)

    # ------------------------------------------------------------------ properties
    @property
    def height(self) -> int:
        return int(self.radiance.shape[0])

    @property
    def width(self) -> int:
        return int(self.radiance.shape[1])

    def solid_angles(self) -> np.ndarray:
        """(H,) solid angle of one pixel in each row, steradians."""
        h, w = self.height, self.width
        edges = np.cos(np.arange(h + 1) * (math.pi / h))
        return (edges[:-1] - edges[1:]) * (2.0 * math.pi / w)

    def luminance(self) -> np.ndarray:
        return self.radiance.astype(np.float64) @ LUMINANCE

    @property
    def power(self) -> float:
        """Σ Y dω over the sphere: the sum of the weights :meth:`sample` returns."""
        return float((self.luminance() * self.solid_angles()[:, None]).sum())

    # ------------------------------------------------------------------ use
    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``n`` importance samples (luminance x solid angle), deterministic: directions in the
        frame of use and irradiance weights (each sample carries power/n; samples landing on
        the same pixel are merged). Weights sum to :attr:`power`."""
        if not (isinstance(n, int | np.integer) and 1 <= int(n) <= 1_000_000):
            raise ParameterError(f"number of environment samples must be a whole number in [1, 1000000], got {n!r}")
        p = (self.luminance() * self.solid_angles()[:, None]).ravel()
        cdf = np.cumsum(p)
        total = float(cdf[-1])
        u = (np.arange(int(n)) + 0.5) / int(n) * total
        idx = np.minimum(np.searchsorted(cdf, u, side="right"), p.size - 1)
        pix, count = np.unique(idx, return_counts=True)
        d = pixel_directions(self.width, self.height).reshape(-1, 3)[pix]
        return d @ self.rotation.T, count * (total / int(n))

    def rotated(self, r: np.ndarray) -> Environment:
        """The same map used in a frame rotated by ``r`` (new = r @ old)."""
        return Environment(self.radiance, np.asarray(r) @ self.rotation, self.name)

    def scaled(self, s: float) -> Environment:
        return Environment(self.radiance * np.float32(s), self.rotation, self.name)

    def plus(self, other: Environment) -> Environment:
        """Sum of two maps used in the same frame (the second is looked up at this one's pixels)."""
        if not np.allclose(self.rotation, other.rotation, atol=1e-9):
            raise ParameterError("environment maps in different frames cannot be combined")
        d = pixel_directions(self.width, self.height).reshape(-1, 3)
        row, col = direction_to_pixel(d, other.width, other.height)
        extra = other.radiance[row, col].reshape(self.radiance.shape)
        return Environment(self.radiance + extra, self.rotation, f"{self.name}+{other.name}")

    def mitsuba_to_world(self) -> np.ndarray:
        """4 x 4 ``to_world`` of Mitsuba's envmap plugin for this map in its frame of use."""
        m = np.eye(4)
        m[:3, :3] = self.rotation @ MAP_TO_WORLD
        return m

    def emitter(self, scale: float = 1.0) -> dict[str, Any]:
        """Mitsuba ``envmap`` emitter dict (needs a variant set)."""
        import mitsuba as mi

        bitmap = mi.Bitmap(np.ascontiguousarray(self.radiance * np.float32(scale)))
        return {"type": "envmap", "bitmap": bitmap, "to_world": mi.ScalarTransform4f(self.mitsuba_to_world().tolist())}

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the radiance as an EXR (atomically), e.g. to light another tool the same way."""
        import mitsuba as mi

        from ..fileio import atomic_output

        with atomic_output(path, (".exr",)) as tmp:
            mi.Bitmap(np.ascontiguousarray(self.radiance)).write(str(tmp))
        return Path(path)


# ---------------------------------------------------------------------- procedural maps
def _soft_box(d: np.ndarray, centre: np.ndarray, half_w_deg: float, half_h_deg: float, edge_deg: float = 2.0) -> np.ndarray:
    """1 inside an angular rectangle around ``centre`` (its long side vertical), smooth edges."""
    f = frame_to(centre)
    # local x horizontal: build from world up so boxes stand upright
    up = np.array([0.0, 0.0, 1.0])
    z = f[:, 2]
    x = np.cross(up, z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-6 else f[:, 0]
    y = np.cross(z, x)
    lx, ly, lz = d @ x, d @ y, d @ z
    ax = np.degrees(np.arctan2(lx, np.maximum(lz, 1e-9)))
    ay = np.degrees(np.arctan2(ly, np.maximum(lz, 1e-9)))

    def ramp(a: np.ndarray, half: float) -> np.ndarray:
        return np.clip((half - np.abs(a)) / edge_deg + 0.5, 0.0, 1.0)

    return np.where(lz > 0.0, ramp(ax, half_w_deg) * ramp(ay, half_h_deg), 0.0)


def studio_radiance(d: np.ndarray) -> np.ndarray:
    """A photographer's light tent (world frame): a large key softbox above-front-left, a
    strip light front-right, a soft top light, a dim grey tent and a darker floor."""
    from .directions import direction

    z = d[:, 2]
    base = np.where(z > 0.0, 0.06 + 0.10 * z, 0.03)
    key = 7.0 * _soft_box(d, direction(40.0, 230.0), 22.0, 16.0)
    strip = 4.0 * _soft_box(d, direction(65.0, 320.0), 5.0, 20.0)
    top = 2.5 * _soft_box(d, direction(0.0, 0.0), 14.0, 14.0)
    grey = base + key + strip + top
    warm = np.array([1.0, 0.98, 0.95])
    return grey[:, None] * warm[None, :]


def ceiling_radiance(d: np.ndarray) -> np.ndarray:
    """Office ceiling: radiance ∝ cos θ over the upper hemisphere (a bright, even ceiling)."""
    return np.repeat(np.clip(d[:, 2], 0.0, None)[:, None], 3, axis=1)


def sky_radiance(d: np.ndarray) -> np.ndarray:
    """Overcast sky: uniform radiance over the upper hemisphere, nothing from below."""
    return np.repeat((d[:, 2] > 0.0).astype(np.float64)[:, None], 3, axis=1)


def studio_environment() -> Environment:
    """The procedural studio map (256 x 128), built in code: no download."""
    return Environment.from_function(studio_radiance, 256, 128, "studio")
