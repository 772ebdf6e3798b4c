"""The score map as a picture: the hemisphere of lamella normals seen from above, one PNG.

The explorer shows the objective over every allowed lamella normal as a disc, the projection
being azimuthal equidistant about +Z: a normal at tilt ``t`` (degrees from +Z) and azimuth ``a``
(degrees from +X toward +Y) lies at radius ``t / 90`` of the disc's radius, at angle ``a``
counter-clockwise from the disc's right-hand side. +X is right and +Y up in the picture, so the
front of the stone (-Y, where the bench viewer sits) is at the bottom. The page's click handler and
its markers (``static/app.js``) use the same projection.

Each pixel takes the score of the nearest map normal (the maps are regular grids on the
hemisphere a few degrees apart; :func:`labcut.orientation.optimize.hemisphere_grid`). Which map
normal each pixel shows is worked out once per grid (:class:`DiscRaster`); a new map of the same
grid costs a gather, a colour lookup and a PNG encoding, a few milliseconds.
"""

from __future__ import annotations

import base64
import io

import numpy as np

#: the picture's size in pixels (square)
MAP_PIXELS = 200


def disc_normals(pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """``(normals, inside)``: the unit normal each pixel centre of a ``pixels`` x ``pixels`` disc
    picture shows (rows top to bottom, columns left to right; (P, 3), undefined outside the disc)
    and whether the pixel lies within the disc (tilt <= 90°)."""
    c = (np.arange(pixels) + 0.5) / pixels * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)  # +Y up
    r = np.hypot(x, y)
    tilt = np.radians(np.minimum(r, 1.0) * 90.0)
    az = np.arctan2(y, x)
    normals = np.stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)], axis=-1).reshape(-1, 3)
    return normals, (r <= 1.0).ravel()


def pixel_of(tilt_deg: float, azimuth_deg: float, pixels: int = MAP_PIXELS) -> tuple[float, float]:
    """``(column, row)`` (pixels, fractional, from the top-left corner) where the normal at
    ``tilt_deg`` / ``azimuth_deg`` lies on the disc picture: the inverse of :func:`disc_normals`."""
    r = tilt_deg / 90.0
    a = np.radians(azimuth_deg)
    x, y = r * np.cos(a), r * np.sin(a)
    return float((x + 1.0) / 2.0 * pixels), float((1.0 - y) / 2.0 * pixels)


class DiscRaster:
    """Which of a grid's normals each pixel of the disc picture shows (the nearest, axially)."""

    def __init__(self, grid_normals: np.ndarray, pixels: int = MAP_PIXELS) -> None:
        grid = np.asarray(grid_normals, dtype=np.float64)
        if grid.ndim != 2 or grid.shape[1] != 3 or len(grid) == 0:
            raise ValueError(f"grid normals must be an (N, 3) array with N >= 1, got shape {grid.shape}")
        self.pixels = int(pixels)
        normals, self.inside = disc_normals(self.pixels)
        self.index = np.empty(len(normals), dtype=np.int64)
        for s in range(0, len(normals), 4096):  # nearest by the largest |cos| (lamella normals are axial)
            self.index[s:s + 4096] = np.argmax(np.abs(normals[s:s + 4096] @ grid.T), axis=1)
        self.count = len(grid)

    def rgba(self, scores: np.ndarray) -> np.ndarray:
        """The picture of ``scores`` (one per grid normal): (pixels, pixels, 4) uint8, viridis from
        0 to the map's highest score, transparent outside the disc."""
        from matplotlib import colormaps

        s = np.asarray(scores, dtype=np.float64)
        if s.shape != (self.count,):
            raise ValueError(f"expected {self.count} scores, got shape {s.shape}")
        top = float(np.nanmax(s)) if np.isfinite(s).any() else 0.0
        level = np.nan_to_num(s / top if top > 0 else np.zeros_like(s), nan=0.0)
        lut = (colormaps["viridis"](np.linspace(0.0, 1.0, 256)) * 255).astype(np.uint8)
        colours = lut[np.clip((level * 255).round().astype(np.int64), 0, 255)][self.index]
        colours[~self.inside, 3] = 0
        return colours.reshape(self.pixels, self.pixels, 4)

    def png(self, scores: np.ndarray) -> bytes:
        """:meth:`rgba` encoded as PNG."""
        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(self.rgba(scores), "RGBA").save(buf, format="PNG", compress_level=1)
        return buf.getvalue()


def data_url(png: bytes) -> str:
    """A PNG as a ``data:`` URL (the page shows it without another request)."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")
