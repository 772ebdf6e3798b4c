"""Denoising renders with Intel Open Image Denoise (``pyoidn``), guided by a noise-free shading estimate.

A denoised studio render traces its colour with the real integrator through a box pixel filter
(OIDN wants each pixel's noise independent of its neighbours'), then the auxiliary images in
passes of their own over the same camera, shapes and lights (:func:`trace_aux`):

* **the guide** (:data:`GUIDE_SPP` samples per pixel, low-discrepancy, whatever the colour's
  count): a cheap, noise-free estimate of the colour itself, traced by the ``labcut_guide``
  integrator (:func:`register_guide`): at the first hit, the BSDF evaluated towards a few fixed
  points of every lamp (:data:`LAMP_NODES` a lamp: a fixed quadrature instead of random light
  samples, no shadow rays), the environment's light on the diffuse components at
  :data:`ENV_NODES` fixed directions, and the polished surface's mirror image traced exactly
  (one reflected ray: the lamps' highlight, the tent's reflections, the dark rim where the polish
  mirrors the unlit table); emitters and the environment seen directly. It shows what the
  converged render shows on the stone (the view-dependent flash, the highlight, the rim), which
  the material's albedo does not;
* **the normal** (:data:`AUX_SPP` samples per pixel): the first hit's shading normal (mesh frame,
  the world frame of the scene; unit length, pixel-averaged across the silhouette).

:func:`denoise` then *demodulates*: it divides the colour by the guide, has OIDN's ``RT`` filter
(HDR, high quality, ``cleanAux``) denoise that ratio, which is smooth where the guide is right,
with the normal and a flat albedo as auxiliaries, and multiplies the guide back. What the guide
leaves out (shadows, the environment's light in the schiller) stays in the ratio and comes
through. The measured alternative, OIDN guided by the material's albedo AOV (body colour plus
face-on flash colour) and the normal, is kept (``albedo=``) for the benchmark's comparison.
``benchmarks/render_denoise.py`` measures what it buys (docs/render-performance.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import BackendError

AOVS = "albedo:albedo,nn:sh_normal"
#: the normal pass's AOV alone (the guide replaces the albedo)
NORMAL_AOV = "nn:sh_normal"
#: samples per pixel of the normal pass (first hits only, low-discrepancy; a power of 4)
AUX_SPP = 64
#: samples per pixel of the guide pass up to 256² (a power of 4: the low-discrepancy sampler's
#: counts; :func:`guide_samples` lowers it for larger images)
GUIDE_SPP = 64
#: the fewest samples per pixel of the guide pass, however large the image
GUIDE_SPP_MIN = 16
#: fixed points per lamp (area emitter) in the guide's quadrature
LAMP_NODES = 2
#: fixed directions of the environment in the guide (diffuse components only)
ENV_NODES = 4
#: the guide's floor in the demodulation, as a share of its mean (keeps dark pixels finite)
GUIDE_FLOOR = 0.01
#: the flat albedo OIDN is given with the demodulated colour
FLAT_ALBEDO = 0.5


def available() -> bool:
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        return False
    return True


def _nodes(n: int) -> np.ndarray:
    """``n`` fixed points of the unit square (a Fibonacci lattice), shape (n, 2)."""
    i = np.arange(int(n))
    return np.stack([(i + 0.5) / n, (i * 0.6180339887498949) % 1.0], axis=-1)


_GUIDES: dict[str, type] = {}


def register_guide() -> None:
    """Register the ``labcut_guide`` integrator for the current (JIT) variant (idempotent)."""
    import mitsuba as mi

    variant = mi.variant()
    if variant in _GUIDES:
        return
    _GUIDES[variant] = _define_guide()
    cls = _GUIDES[variant]
    mi.register_integrator("labcut_guide", lambda props: cls(props))


def _define_guide() -> type:
    import drjit as dr
    import mitsuba as mi

    class GuideIntegrator(mi.SamplingIntegrator):
        """A noise-free estimate of direct lighting at the first hit (module docstring):
        properties ``lamp_nodes`` and ``env_nodes``."""

        def __init__(self, props: Any) -> None:
            mi.SamplingIntegrator.__init__(self, props)
            self.lamp_nodes = int(props.get("lamp_nodes", LAMP_NODES))
            self.env_nodes = int(props.get("env_nodes", ENV_NODES))

        def aov_names(self) -> list[str]:
            return []

        def _quadrature(self, emitter: Any, n: int, si: Any, bsdf: Any, ctx: Any, active: Any) -> Any:
            uv = _nodes(n)
            us, vs = mi.Float(uv[:, 0]), mi.Float(uv[:, 1])
            width = dr.width(active)

            def body(k: Any, acc: Any) -> tuple[Any, Any]:
                sample = mi.Point2f(dr.gather(mi.Float, us, k), dr.gather(mi.Float, vs, k))
                ds, weight = emitter.sample_direction(si, sample, active)  # weight: radiance / pdf
                f = bsdf.eval(ctx, si, si.to_local(ds.d), active & (ds.pdf > 0.0))
                return k + 1, acc + dr.select(active & (ds.pdf > 0.0), f * weight, 0.0)

            k = dr.zeros(mi.UInt32, width)
            acc = dr.zeros(mi.Spectrum, width)
            k, acc = dr.while_loop((k, acc), lambda k, acc: k < n, body)
            return acc * (1.0 / n)

        def sample(self, scene: Any, sampler: Any, ray: Any, medium: Any = None, active: Any = True) -> tuple[Any, Any, list]:
            si = scene.ray_intersect(ray, active)
            valid = si.is_valid()
            result = dr.zeros(mi.Spectrum, dr.width(valid))
            # what the camera sees of the emitters (the environment where it misses)
            seen = si.emitter(scene, active)
            result += dr.select(seen != None, seen.eval(si, active & (seen != None)), 0.0)  # noqa: E711
            bsdf = si.bsdf(ray)
            glossy = mi.BSDFContext()
            diffuse = mi.BSDFContext()
            diffuse.type_mask = +mi.BSDFFlags.Diffuse
            for emitter in scene.emitters():
                if mi.has_flag(emitter.flags(), mi.EmitterFlags.Delta):  # directional or point: one direction
                    result += self._quadrature(emitter, 1, si, bsdf, glossy, valid)
                elif mi.has_flag(emitter.flags(), mi.EmitterFlags.Infinite):
                    if self.env_nodes > 0:
                        result += self._quadrature(emitter, self.env_nodes, si, bsdf, diffuse, valid)
                else:
                    result += self._quadrature(emitter, self.lamp_nodes, si, bsdf, glossy, valid)
            # the polish's mirror image, traced exactly
            mirror = mi.BSDFContext()
            mirror.type_mask = +mi.BSDFFlags.DeltaReflection
            bs, weight = bsdf.sample(mirror, si, 0.5, mi.Point2f(0.5, 0.5), valid)
            delta = valid & mi.has_flag(bs.sampled_type, mi.BSDFFlags.DeltaReflection) & (dr.max(mi.unpolarized_spectrum(weight)) > 0.0)
            si2 = scene.ray_intersect(si.spawn_ray(si.to_world(bs.wo)), delta)
            emitter = si2.emitter(scene, delta)
            hit = delta & (emitter != None)  # noqa: E711
            result += dr.select(hit, weight * emitter.eval(si2, hit), 0.0)
            return result, valid | (seen != None), []  # noqa: E711

    return GuideIntegrator


def _camera(sensor: Any, sampler: dict[str, Any]) -> Any:
    """A copy of a perspective ``sensor`` (pose, field of view, clip planes, film size; box filter)
    with its own ``sampler``; another kind of sensor as it is."""
    import mitsuba as mi

    params = mi.traverse(sensor)
    if "x_fov" not in params:
        return sensor
    width, height = (int(x) for x in sensor.film().crop_size())
    matrix = np.asarray(sensor.world_transform().matrix, dtype=np.float32).reshape(4, 4)
    return mi.load_dict({
        "type": "perspective", "fov": float(params["x_fov"][0]), "fov_axis": "x",
        "near_clip": float(sensor.near_clip()), "far_clip": float(sensor.far_clip()),
        "to_world": mi.ScalarTransform4f(np.ascontiguousarray(matrix)),
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                 "pixel_format": "luminance" if mi.is_monochromatic else "rgb"},
        "sampler": sampler,
    })


def aux_scene(scene: Any, integrator: dict[str, Any] | None = None, sensor: Any = None) -> Any:
    """``scene``'s shapes (with their lamps) and other emitters seen through its first sensor (or
    ``sensor``), traced by ``integrator`` (default: Mitsuba's ``aov`` integrator, :data:`AOVS`)."""
    import mitsuba as mi

    d: dict[str, Any] = {"type": "scene", "sensor": sensor if sensor is not None else scene.sensors()[0],
                         "integrator": integrator or {"type": "aov", "aovs": AOVS}}
    for i, shape in enumerate(scene.shapes()):
        d[f"shape_{i}"] = shape  # with its area lights
    for i, emitter in enumerate(scene.emitters()):
        if not mi.has_flag(emitter.flags(), mi.EmitterFlags.Surface):  # the environment, directional lamps
            d[f"emitter_{i}"] = emitter
    return mi.load_dict(d)


def _passes(scene: Any, spp: int, per: int, seed: int) -> np.ndarray:
    from .passes import render_pass

    passes = max(1, -(-int(spp) // per))
    acc = None
    for k in range(passes):
        img = np.array(render_pass(scene, per, seed + k), dtype=np.float64)
        acc = img if acc is None else acc + img
    return acc / passes


def _per_pass(spp: int) -> int:
    """Samples per pass: a power of 4 (the low-discrepancy sampler's counts), at most 64."""
    per = 1
    while per < min(int(spp), 64):
        per *= 4
    return per


def guide_samples(pixels: int) -> int:
    """Samples per pixel of the guide for an image of ``pixels``: :data:`GUIDE_SPP` up to 256², then
    as many samples in all as 256² x :data:`GUIDE_SPP` (smaller pixels need fewer each), at least
    :data:`GUIDE_SPP_MIN`; a power of 4."""
    want = GUIDE_SPP * (256 * 256) / max(int(pixels), 1)
    spp = GUIDE_SPP_MIN
    while spp * 4 <= min(want, GUIDE_SPP):
        spp *= 4
    return spp


def _trace_aovs(scene: Any, aovs: str, spp: int, seed: int) -> np.ndarray:
    """The ``aovs`` (Mitsuba's ``aov`` integrator list) of ``scene``'s camera at ``spp`` samples per
    pixel (rounded up to a power of 4; low-discrepancy samples for a perspective camera), box-averaged."""
    per = _per_pass(spp)
    aux = aux_scene(scene, {"type": "aov", "aovs": aovs},
                    sensor=_camera(scene.sensors()[0], {"type": "ldsampler", "sample_count": per}))
    return _passes(aux, max(int(spp), per), per, seed * 7919 + 1_000_003).astype(np.float32)


def trace_albedo_normal(scene: Any, spp: int = AUX_SPP, seed: int = 0) -> np.ndarray:
    """(H, W, 6) float32: the first hit's albedo AOV (``eval_diffuse_reflectance``; in [0, 1])
    and shading normal of ``scene``'s camera at ``spp`` samples per pixel (:func:`_trace_aovs`)."""
    return _trace_aovs(scene, AOVS, spp, seed)[..., :6]


def trace_guide(scene: Any, spp: int = GUIDE_SPP, seed: int = 0, *, lamp_nodes: int = LAMP_NODES,
                env_nodes: int = ENV_NODES) -> np.ndarray:
    """(H, W, 3) float32: the guide (module docstring; linear radiance, >= 0) of ``scene``'s first
    camera, ``spp`` rounded up to a power of 4, low-discrepancy samples (a perspective camera's)."""
    register_guide()
    per = _per_pass(spp)
    sensor = _camera(scene.sensors()[0], {"type": "ldsampler", "sample_count": per})
    guide = aux_scene(scene, {"type": "labcut_guide", "lamp_nodes": int(lamp_nodes), "env_nodes": int(env_nodes)}, sensor)
    img = _passes(guide, max(int(spp), per), per, seed * 7919 + 2_000_003)
    if img.shape[-1] == 1:
        img = np.repeat(img, 3, axis=-1)
    return np.clip(np.nan_to_num(img[..., :3]), 0.0, None).astype(np.float32)


def trace_aux(scene: Any, spp: int = AUX_SPP, seed: int = 0, *, guide_spp: int | None = None) -> np.ndarray:
    """(H, W, 6) float32: the guide (:func:`trace_guide`, ``guide_spp`` samples; None: as
    :func:`guide_samples` chooses for the image's size) and the shading normal (``spp`` samples) of
    ``scene``'s camera, what :func:`denoise` takes as ``guide`` and ``normal``."""
    normal = _trace_aovs(scene, NORMAL_AOV, spp, seed)[..., :3]  # the normal alone: no BSDF evaluated
    g_spp = guide_samples(_pixels(scene)) if guide_spp is None else int(guide_spp)
    return np.concatenate([trace_guide(scene, g_spp, seed), normal], axis=-1)


def _pixels(scene: Any) -> int:
    """Pixels of ``scene``'s first camera's film."""
    w, h = scene.sensors()[0].film().crop_size()
    return int(w) * int(h)


def _unit(normal: np.ndarray) -> np.ndarray:
    n = np.nan_to_num(np.asarray(normal, dtype=np.float64))
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    return np.ascontiguousarray(np.where(length > 1e-6, n / np.maximum(length, 1e-6), 0.0), dtype=np.float32)


def denoise(colour: np.ndarray, guide: np.ndarray | None = None, normal: np.ndarray | None = None,
            *, albedo: np.ndarray | None = None, clean_aux: bool = True) -> np.ndarray:
    """Denoise a linear HDR image (H, W, 3).

    ``guide`` (:func:`trace_guide`, linear radiance >= 0): the colour is divided by it (floored at
    :data:`GUIDE_FLOOR` of its mean), denoised with the ``normal`` (in [-1, 1]) and a flat albedo,
    and multiplied by it again. Without a guide, OIDN denoises the colour itself, with ``albedo``
    (in [0, 1]) and ``normal`` when given (OIDN takes a normal only with an albedo).
    ``clean_aux``: the auxiliaries are noise-free (traced at many samples), so OIDN uses them as
    they are; False makes it prefilter them first. Returns float32 (H, W, 3), >= 0. Raises
    :class:`~labcut.errors.BackendError` when pyoidn is missing or OIDN fails."""
    try:
        import pyoidn
    except ImportError:
        raise BackendError("denoising needs the pyoidn package (pip install pyoidn), or render with denoise off") from None
    c = np.clip(np.nan_to_num(np.asarray(colour, dtype=np.float64)), 0.0, None)
    n = None if normal is None else _unit(normal)
    scale = None
    if guide is not None:
        g = np.clip(np.nan_to_num(np.asarray(guide, dtype=np.float64)), 0.0, None)
        mean = float(g.mean())
        if mean > 0.0:
            scale = g + GUIDE_FLOOR * mean
            c = c / scale
            albedo = np.full(c.shape, FLAT_ALBEDO)
    a = None if albedo is None else np.ascontiguousarray(np.clip(np.nan_to_num(albedo), 0.0, 1.0), dtype=np.float32)
    if n is not None and a is None:
        n = None  # OIDN takes a normal only together with an albedo
    try:
        out = pyoidn.denoise(np.ascontiguousarray(c, dtype=np.float32), a, n, hdr=True,
                             clean_aux=bool(clean_aux) and a is not None, quality="high")
    except (RuntimeError, ValueError, TypeError) as exc:
        raise BackendError(f"denoising failed: {str(exc).splitlines()[0][:160]}") from None
    out = np.asarray(out, dtype=np.float64)
    if scale is not None:
        out = out * scale
    return np.clip(out, 0.0, None).astype(np.float32)
