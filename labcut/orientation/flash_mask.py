"""The flash mask of a render: which pixels of the stone flash, by the metrics' own threshold.

A presentation render is tonemapped for the eye; whether a pixel *flashes* is the metrics'
question (DESIGN.md §4): is its schiller radiance ``L_s`` at least ``τ P L_ref``, ``P`` the
brightest schiller the scene's lights can give a flat polished face, in units of ``L_ref``
(:mod:`labcut.orientation.radiance`)? :func:`flash_mask` answers it per pixel from the
render's own cameras: the schiller lobe alone (the BSDF plugin, luminance: the mono variant),
summed exactly over the scenario's lights as the metrics model them (every direction with its
weight, at unit total irradiance, no room light; a shadow ray each), at the pixels a ray from the
render's camera meets the stone, each judged from the main view's direction (the metrics' distant
viewer; a perspective camera's own rays differ by a few degrees across the stone). Exact, not sampled: a Monte Carlo render picks one light per
sample, and under an environment map's many lights its noise alone pushed faint pixels over the
threshold (6 % of a pendant's pixels at 16 spp, 3 % at 64, where none flash). The coverage-weighted
share of the stone's pixels in the mask is the view's flash area as the picture shows it: the
surface-sample estimator's within a few points (tests/test_flash_mask.py).

Frames and units: the mesh frame (mm, +Z face-up; the scene traced is in the stone's render
frame, :class:`~labcut.rendering.scene.RenderFrame`, which moves no direction); ``ratio`` is
``L_s / L_ref``; the cameras
are the render's (:class:`~labcut.rendering.scene.CameraView`), tiled 4 across like a render's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..physics.material import Labradorite
from ..rendering.api import bsdf_dict, tile_views
from ..rendering.scene import CameraView, camera, stone_entries, to_mitsuba_mesh
from ..scene import Setting
from ..scene.directions import normalize_normal
from .radiance import flash_threshold, reference_radiance

#: coverage below which a pixel does not see the stone
COVERED = 1e-3
#: the largest side a flash mask is computed at (px); a larger picture gets it scaled up
MASK_RESOLUTION = 256
#: the colour flashing pixels are drawn in on an overlay (sRGB, 0-255), and the dimming of the rest
OVERLAY_COLOUR = (255, 214, 0)
OVERLAY_DIM = 0.35


def schiller_ratio(scene: Any, directions: np.ndarray, irradiances: np.ndarray, resolution: int, l_ref: float,
                   subsamples: int = 1, view_direction: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """``(ratio, coverage)`` of a scene holding the stone (its BSDF the schiller lobe alone) and a
    sensor of ``resolution`` px square: per pixel ``L_s / l_ref``, the schiller radiance summed
    exactly over the lights (``directions`` towards them, mesh frame; ``irradiances`` each, unit
    total) with a shadow ray each, averaged over the pixel's ``subsamples``² stratified rays that
    hit the stone; and the share of those rays that hit it. Both H x W float64.

    Exact, not sampled: a Monte Carlo render picks one light per sample, and under many lights
    (an environment map's samples) the noise alone pushes faint pixels over the threshold."""
    import drjit as dr
    import mitsuba as mi

    res, sub = int(resolution), int(subsamples)
    per_pixel = sub * sub

    def rays(idx: Any) -> Any:
        p, k = idx // per_pixel, idx % per_pixel
        x = (mi.Float(p % res) + (mi.Float(k % sub) + 0.5) / sub) / res
        y = (mi.Float(p // res) + (mi.Float(k // sub) + 0.5) / sub) / res
        ray, _ = scene.sensors()[0].sample_ray(0.0, 0.5, mi.Point2f(x, y), mi.Point2f(0.5, 0.5))
        return ray

    every = dr.arange(mi.UInt32, res * res * per_pixel)
    hits = dr.compress(scene.ray_test(rays(every)))  # only rays that meet the stone are shaded
    hit_idx = np.array(hits, dtype=np.int64)
    total = np.zeros(res * res * per_pixel)
    if len(hit_idx):
        si = scene.ray_intersect(rays(hits))
        if view_direction is not None:
            v = np.asarray(view_direction, dtype=np.float64)
            si.wi = si.to_local(mi.Vector3f(*(float(c) for c in v / np.linalg.norm(v))))
        bsdf, ctx, valid = si.bsdf(), mi.BSDFContext(), si.is_valid()
        radiance = dr.zeros(mi.Float, dr.width(hits))
        for d, e in zip(np.asarray(directions, dtype=np.float64), np.asarray(irradiances, dtype=np.float64)):
            if e <= 0.0:
                continue
            # opaque: one compiled kernel serves every light
            toward = mi.Vector3f(*(dr.opaque(mi.Float, float(c)) for c in d))
            value = bsdf.eval(ctx, si, si.to_local(toward), valid)
            lit = valid & ~scene.ray_test(si.spawn_ray(toward))
            radiance += dr.select(lit, dr.opaque(mi.Float, float(e)) * value[0], 0.0)
            dr.eval(radiance)
        total[hit_idx] = np.array(radiance, dtype=np.float64)
    hit = np.zeros(res * res * per_pixel, dtype=bool)
    hit[hit_idx] = True
    hit = hit.reshape(res, res, per_pixel)
    count = hit.sum(axis=-1)
    ratio = total.reshape(res, res, per_pixel).sum(axis=-1) / np.maximum(count, 1) / float(l_ref)
    return ratio, count / float(per_pixel)


@dataclass(frozen=True)
class FlashMask:
    """Per pixel of a render (H x W): ``ratio`` = ``L_s / L_ref`` (schiller radiance over the
    reference flash) and ``coverage`` (the share of the pixel the stone covers); ``threshold`` the flash
    threshold ``τ P`` in units of ``L_ref`` (``P`` the scene's peak, :mod:`labcut.orientation.radiance`);
    ``views`` the camera names, tiled 4 across as the render's are; ``tau`` the threshold's factor τ."""

    ratio: np.ndarray
    coverage: np.ndarray
    threshold: float
    views: tuple[str, ...]
    shares: tuple[float, ...]
    tau: float = 0.1

    @property
    def mask(self) -> np.ndarray:
        """The flashing pixels (bool, H x W): on the stone and at or above the threshold."""
        return (self.coverage > COVERED) & (self.ratio >= self.threshold)

    @property
    def share(self) -> float:
        """The coverage-weighted share of the stone's pixels that flash (all views together; one
        view: its flash area as the render sees it)."""
        return _share(self.ratio, self.coverage, self.threshold)

    def ratio_at(self, height: int, width: int) -> np.ndarray:
        """``ratio`` on a picture of ``height`` x ``width`` px framed like the mask (each picture
        pixel takes its nearest mask pixel's value)."""
        return self.ratio[self._nearest(height, width)]

    def _nearest(self, height: int, width: int) -> Any:
        """The mask pixel nearest each pixel of a picture of ``height`` x ``width`` px framed like
        the mask (an index for ``array[...]``); a picture framed otherwise is a ParameterError."""
        mh, mw = self.ratio.shape
        if height * mw != width * mh or height < mh:
            raise ParameterError(f"a picture of {width}x{height} px does not frame like the mask ({mw}x{mh} px)")
        return np.ix_(np.arange(height) * mh // height, np.arange(width) * mw // width)

    def overlay(self, picture: np.ndarray) -> np.ndarray:
        """A display picture (H x W x 3 uint8, the render's PNG) with the flash mask drawn on it:
        flashing pixels in :data:`OVERLAY_COLOUR` mixed by their coverage, the rest dimmed, so the
        flash the numbers count is what the eye sees marked."""
        pic = np.asarray(picture, dtype=np.float64)
        flash = (self.mask * self.coverage)[self._nearest(*pic.shape[:2])][..., None]
        out = pic * OVERLAY_DIM * (1.0 - flash) + flash * (0.5 * pic + 0.5 * np.asarray(OVERLAY_COLOUR, dtype=np.float64))
        return np.clip(np.round(out), 0, 255).astype(np.uint8)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: the threshold, the share, and each view's share."""
        return {"tau": self.tau, "threshold": self.threshold, "share": self.share,
                "by_view": [{"view": v, "share": s} for v, s in zip(self.views, self.shares)]}


def _share(ratio: np.ndarray, coverage: np.ndarray, threshold: float) -> float:
    on = coverage > COVERED
    total = float(coverage[on].sum())
    return float((coverage[on] * (ratio[on] >= threshold)).sum()) / total if total > 0 else 0.0


def flash_mask(mesh: Any, material: Labradorite, lamella_normal: Any, setting: Setting, cameras: Sequence[CameraView],
               resolution: int, *, perspective: bool = False, fov_deg: float = 25.0, margin: float = 1.0,
               far_radii: float = 2.0, tau: float = 0.1, subsamples: int = 1) -> FlashMask:
    """The :class:`FlashMask` of a render of ``mesh`` at ``lamella_normal`` under ``setting`` (its
    lights, mesh frame, as the metrics model them: every direction of ``setting.lights`` with its
    weight, at unit total irradiance, no room light) from ``cameras``, framed as the render
    frames them (``perspective``, ``fov_deg``, ``margin``, ``far_radii``:
    :func:`~labcut.rendering.scene.camera`'s), at ``resolution`` px up to
    :data:`MASK_RESOLUTION` (:meth:`FlashMask.overlay` scales it to the picture);
    ``subsamples``² rays per pixel; ``tau`` the flash threshold's factor (a pixel flashes at
    ``L_s ≥ τ P L_ref``, DESIGN.md §4). Through a
    perspective camera each point the camera sees is judged from the camera's direction, as the
    metrics' distant viewer sees it, so the mask marks what the numbers count."""
    import mitsuba as mi

    from ..backend import set_variant
    from ..rendering import bsdf as _bsdf  # noqa: F401  (registers the plugin)

    m = normalize_normal(lamella_normal)
    set_variant("mono")
    l_ref = reference_radiance(material, 1.0)
    threshold = flash_threshold(material, setting.lights, tau)
    res = min(int(resolution), MASK_RESOLUTION)
    stone = to_mitsuba_mesh(mesh, mi.load_dict(bsdf_dict(material, m, ("schiller",))))
    weights = np.asarray(setting.lights.weights, dtype=np.float64)
    irradiances = weights / float(weights.sum())
    ratios, covers, shares = [], [], []
    for cam in cameras:
        sensor = camera(cam, res, perspective, fov_deg, margin=margin, far_radii=far_radii, rfilter="box")
        scene = mi.load_dict({"type": "scene", "sensor": sensor, **stone_entries(stone)})
        ratio, cover = schiller_ratio(scene, setting.lights.directions, irradiances, res, l_ref, subsamples,
                                      cam.direction if perspective else None)
        ratios.append(ratio)
        covers.append(cover)
        shares.append(_share(ratio, cover, threshold))
    return FlashMask(tile_views(ratios), tile_views(covers), threshold, tuple(c.name for c in cameras), tuple(shares), float(tau))
