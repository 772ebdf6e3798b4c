"""Render a stone with the labradorite BSDF, simulating only what the request needs.

:func:`labcut.render` (:mod:`labcut.commands.render`) chooses the samples per pixel and records
the effect plan, then runs :func:`render_image` here.

The render plan (variant, integrator, depth, lobes) is chosen from the request
and the mesh, logged, and returned on the result:

* colour: ``rgb`` unless ``mode="spectral"`` / ``"mono"`` is asked for; polarized
  transport only when a polarizer angle is given.
* light transport: a convex stone lit by anything is rendered with direct
  lighting only (the BSDF is a surface model: no path can leave a convex stone
  and come back); a non-convex carving gets a path tracer with a few bounces
  so light reflected between its parts is included.
* lobes: ``("surface", "schiller", "body")`` by default; a schiller-only render
  (flash maps) switches the others off inside the plugin.
* look: ``"diagram"`` (default for the API; what the estimators and comparisons use): the
  scenario's lamps as distant lights in a dim constant room, an orthographic camera, the
  hue-preserving tone curve and an exposure from the image. ``"studio"``
  (:mod:`labcut.rendering.studio`; the default of ``labcut render``): the lamps as area lights
  the polish mirrors, a light tent, a grey table with a contact shadow, a dark grey-green body
  with inclusions, a perspective camera, path tracing to depth 3, OIDN denoising
  (:mod:`labcut.rendering.denoise`), the AgX-like tone curve and an incident-light exposure
  (:mod:`labcut.rendering.tonemap`).
"""

from __future__ import annotations

import dataclasses

import contextlib
import logging
import math
import signal
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..geometry.stone import Stone
from ..physics.material import Labradorite
from .exposure import Exposed, choose_exposure
from .images import save_image
from ..scene import Setting, resolve_scene
from ..scene.directions import normalize_normal
from .passes import render_pass
from .plan import LOBES, RenderPlan, plan_render
from .scene import RENDER_IRRADIANCE, CameraView, RenderFrame, camera, camera_views, emitters, stone_entries, to_mitsuba_mesh

log = logging.getLogger("labcut.render")

@dataclass
class RenderResult(Exposed):
    """A rendered image (linear RGB, float32, H x W x 3) and how it was made.

    ``exposure``: the multiplier a PNG of it is tonemapped with, one for the whole image (the
    tiles of an orbit share it; :mod:`labcut.rendering.exposure`): by default the look's
    reference (``exposure_mode`` ``"reference"``: the bench's, the same for every scene, so a
    dimmer scene looks dimmer), or brightened to the scene (``"auto"``), or ``"given"``;
    ``exposure_reference``: the look's reference exposure (:attr:`exposure_vs_reference_ev` the
    stops over it). ``flash``: per view, its name, the flash
    area the estimator finds there (share of the visible stone at or above the flash threshold;
    None where the view sees the stone edge-on) and whether there is any. ``notes``: what a
    viewer of the image should know (e.g. "no flash from this view"). ``mesh``: the mesh's
    provenance (:meth:`labcut.Stone.provenance_dict`). ``look``: ``diagram`` or ``studio``;
    ``tonemap``: the PNG's tone curve (``hue`` or ``agx``); ``exposure_metering``: how the
    exposure was found (``reference``: the bench's metered from its lamps; ``image``: from the
    image's bright pixels; ``incident``: from this scene's lights, as an incident-light meter
    would, so a dull stone stays dull; ``given``); ``studio``: the studio settings and lamps used."""

    image: np.ndarray
    plan: RenderPlan
    spp: int
    seconds: float
    views: list[str] = field(default_factory=list)
    scenario: dict[str, Any] = field(default_factory=dict)
    exposure: float = 1.0
    exposure_mode: str = "reference"
    flash: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    mesh: dict[str, Any] = field(default_factory=dict)
    look: str = "diagram"
    tonemap: str = "hue"
    exposure_metering: str = "reference"
    studio: dict[str, Any] = field(default_factory=dict)
    #: ``time_budget=``'s choice (:class:`labcut.commands.render_budget.SppChoice` as a dict), or empty
    budget: dict[str, Any] = field(default_factory=dict)
    exposure_reference: float = 1.0
    #: which pixels flash by the metrics' threshold (:class:`labcut.orientation.flash_mask.FlashMask`),
    #: when asked for (``labcut.render(..., flash_mask=True)``), else None
    flash_mask: Any = None

    @property
    def samples_per_second(self) -> float:
        h, w = self.image.shape[:2]
        return h * w * self.spp / max(self.seconds, 1e-9)

    def __repr__(self) -> str:
        h, w = self.image.shape[:2]
        return (f"RenderResult({w}x{h} px, {self.spp} spp, {self.look} look, {self.plan.integrator} on {self.plan.variant}, "
                f"{self.seconds:.1f} s, exposure {self.exposure:.3g})")

    def _repr_png_(self) -> bytes:
        """The image as a notebook shows it: the PNG :meth:`save` writes (same exposure and tone curve)."""
        import io

        from PIL import Image

        from .images import to_uint8

        buf = io.BytesIO()
        Image.fromarray(to_uint8(np.nan_to_num(self.image), self.exposure, self.tonemap), "RGB").save(buf, format="PNG")
        return buf.getvalue()

    def save(self, path: str | Path, exposure: float | None = None) -> Path:
        """PNG (tonemapped, sRGB) or EXR (linear HDR) by suffix; written atomically.

        ``exposure`` replaces the result's (and is recorded as given); a PNG records the
        exposure it used in its ``labcut:exposure`` text field."""
        if exposure is not None:
            from .images import tonemap

            tonemap(np.zeros((1, 1, 3)), exposure)  # validates
            self.exposure, self.exposure_mode, self.exposure_metering = float(exposure), "given", "given"
        meta = {"views": self.views, "flash": self.flash, "plan": "; ".join(self.plan.reasons), "look": self.look,
                "exposure_metering": self.exposure_metering, "exposure_reference": self.exposure_reference,
                "exposure_vs_reference_ev": round(self.exposure_vs_reference_ev, 3),
                "exposure_caption": self.exposure_caption}
        return save_image(self.image, path, self.exposure, metadata=meta, exposure_mode=self.exposure_mode, curve=self.tonemap)


    def save_flash_mask(self, path: str | Path) -> Path:
        """Write the flash mask over the render's PNG picture (same exposure and tone curve) as a
        PNG, atomically: the flashing pixels marked, the rest dimmed; its text records the share
        of the stone's pixels that flash and the threshold."""
        from .images import save_picture, to_uint8

        if self.flash_mask is None:
            raise ParameterError("this render has no flash mask: render with flash_mask=True")
        picture = to_uint8(np.nan_to_num(self.image), self.exposure, self.tonemap)
        meta = {"flash_mask": self.flash_mask.to_dict(), "views": self.views, "flash": self.flash,
                "exposure": repr(float(self.exposure)), "exposure_caption": self.exposure_caption}
        return save_picture(self.flash_mask.overlay(picture), path, meta)


def plan_for(mesh: Any, ask: Any) -> RenderPlan:
    """The render plan (variant, integrator, depth, lobes, look) of the request ``ask`` for ``mesh``:
    what :func:`render_image` will run (a time budget prices it)."""
    return plan_render(mesh, ask.scenario.main_setting().lights, ask.mode, ask.polarizer_deg, ask.lobes, ask.max_depth,
                       look=ask.look_spec, denoise=ask.denoise, zoning=ask.zoning)


def bsdf_dict(material: Labradorite, normal: np.ndarray, lobes: Sequence[str] = LOBES, *, zoning: Any = None) -> dict[str, Any]:
    """Plugin dictionary of the labradorite BSDF for ``material`` and a lamella normal.

    ``zoning``: an optional :class:`~labcut.rendering.zoning.BakedZoning` (needs a JIT variant set).
    """
    d: dict[str, Any] = {"type": "labradorite", "normal": [float(x) for x in normal]}
    for key, value in material.to_dict().items():
        if key != "name":
            d[key] = value
    for lobe in LOBES:
        d[lobe] = lobe in lobes
    if zoning is not None:
        d.update(zoning.props())
    return d


def build_scene(
    mesh: Any,
    material: Labradorite,
    lamella_normal: Any,
    setting: Setting | None = None,
    view: Any = "main",
    resolution: int = 512,
    mode: str = "rgb",
    *,
    integrator: str | None = None,
    **request: Any,
) -> tuple[Any, RenderPlan]:
    """The Mitsuba scene for one camera (selects the plan's variant). Returns (scene, plan).

    ``request``: the other arguments of the render request, as
    :meth:`RenderRequest.build <labcut.rendering.request.RenderRequest.build>` takes them
    (``polarizer_deg``, ``lobes``, ``max_depth``, ``perspective``, ``zoning``, ``look``,
    ``denoise``); the lights and camera come from ``setting`` and ``view``.

    ``setting``: the lights and main view in the mesh frame (a scenario's
    :meth:`~labcut.Scenario.main_setting`; default: the ``bench`` scenario's rest pose).
    ``view``: a :class:`~labcut.rendering.scene.CameraView` or what :func:`camera_views` takes
    (a single camera). ``integrator`` overrides the plan's (e.g. ``"prb"`` for gradients). For
    gradients leave the delta ``surface`` lobe out (``lobes=("schiller", "body")``):
    it does not depend on the lamella normal, and prb's ``relative_grad`` of the
    re-evaluated BSDF would credit radiance reached through the delta lobe to
    the glossy lobe evaluated in that direction, biasing the gradient.

    ``zoning``: ``None``, ``"smooth"``, ``"sharp"`` or a :class:`~labcut.rendering.zoning.Zoning`
    (docs/zoning.md); its noise is baked over the mesh's bounding box.

    ``look``: ``"diagram"`` (default) or ``"studio"`` / a :class:`~labcut.rendering.studio.Studio`
    (module docstring). ``denoise``: as :func:`plan_render`; when on, the film uses a box pixel
    filter (the colour only; :func:`labcut.rendering.denoise.trace_aux` traces the shading guide
    and normal the denoiser wants from this scene in passes of their own).
    """
    from .request import RenderRequest

    if setting is None:
        setting = resolve_scene().main_setting()
    cams = camera_views(view, setting)
    if len(cams) != 1:
        raise ParameterError("build_scene takes a single view; render() handles 'orbit'")
    bad = sorted(set(request) - {"polarizer_deg", "lobes", "max_depth", "perspective", "zoning", "look", "denoise"})
    if bad:
        raise ParameterError(f"build_scene takes no {', '.join(bad)} (the camera and lights come from setting and view)")
    ask = RenderRequest.build(material, resolution=resolution, mode=mode, **request)
    return _scene(mesh, ask, normalize_normal(lamella_normal), setting, cams[0], integrator)


@dataclass(frozen=True)
class _SceneParts:
    """What every camera of one render shares: the plan, the BSDF's plugin dictionary (zoning baked
    and the studio body grid in it), the integrator's and the lights' dictionaries; in the studio
    look also its lamps and environment (what the exposure meter and the render's record read)."""

    plan: RenderPlan
    bsdf: dict[str, Any]
    integrator: dict[str, Any]
    lights: dict[str, Any]
    lamps: list[Any] = field(default_factory=list)
    environment: Any = None


def _scene_parts(mesh: Any, ask: Any, normal: np.ndarray, setting: Setting, integrator: str | None = None) -> _SceneParts:
    """The camera-independent parts of a render's scenes (:class:`_SceneParts`), built once per
    render: the zoning's noise and the studio body grid are baked here, not per camera."""
    import mitsuba as mi

    from . import bsdf as _bsdf  # noqa: F401  (registers the plugin)

    studio = ask.studio
    plan = plan_render(mesh, setting.lights, ask.mode, ask.polarizer_deg, ask.lobes, ask.max_depth, look=ask.look_spec,
                       denoise=ask.denoise, zoning=ask.zoning)
    mi.set_variant(plan.variant)
    baked = ask.zoning.bake(mesh.bounds).in_frame(RenderFrame.of(mesh)) if ask.zoning is not None else None
    d = bsdf_dict(ask.material, normal, plan.lobes, zoning=baked)
    if studio is not None and plan.polarizer_deg is None:
        from .studio import body_grid

        d.update(body_grid(mesh, studio))
    name = integrator or plan.integrator
    integ: dict[str, Any] = {"type": name, "max_depth": plan.max_depth} if name != "direct" else {"type": "direct"}
    if name == "direct":
        integ.update({"emitter_samples": 1, "bsdf_samples": 1})
    if plan.polarizer_deg is not None:
        integ = {"type": "stokes", "nested": integ}
    if studio is None:
        return _SceneParts(plan, d, integ, emitters(setting.lights))
    from .studio import studio_emitters

    lights, lamps, env = studio_emitters(mesh, setting, studio)
    return _SceneParts(plan, d, integ, lights, lamps, env)


def _scene(mesh: Any, ask: Any, normal: np.ndarray, setting: Setting, cam: CameraView,
           integrator: str | None = None, parts: _SceneParts | None = None) -> tuple[Any, RenderPlan]:
    """The Mitsuba scene of one camera for a validated :class:`~labcut.rendering.request.RenderRequest`
    ``ask`` and a unit lamella ``normal`` (checks nothing: :func:`build_scene` and :func:`render` did);
    ``parts``: the render's :func:`_scene_parts`, shared by its cameras (built here when None)."""
    import mitsuba as mi

    parts = parts or _scene_parts(mesh, ask, normal, setting, integrator)
    studio = ask.studio
    rfilter = "box" if studio is not None and parts.plan.denoise else "gaussian"
    sensor = camera(cam, ask.resolution, **camera_framing(ask), rfilter=rfilter)
    scene_dict: dict[str, Any] = {
        "type": "scene",
        "integrator": parts.integrator,
        "sensor": sensor,
        **stone_entries(to_mitsuba_mesh(mesh, mi.load_dict(parts.bsdf))),
        **parts.lights,
    }
    return mi.load_dict(scene_dict), parts.plan


def camera_framing(ask: Any) -> dict[str, Any]:
    """How a render request's cameras frame the stone (:func:`~labcut.rendering.scene.camera`'s
    ``perspective``, ``fov_deg``, ``margin``, ``far_radii``): the diagram look's orthographic (or
    asked-for perspective) view, or the studio look's perspective camera with room for the table."""
    studio = ask.studio
    if studio is None:
        return {"perspective": bool(ask.perspective)}
    return {"perspective": True, "fov_deg": studio.fov_deg, "margin": studio.margin, "far_radii": 200.0}


def _polarizer_intensity(image: np.ndarray, angle_deg: float) -> np.ndarray:
    """Intensity through an ideal linear polarizer from a Stokes image.

    Mitsuba's ``stokes`` integrator writes RGB, then S0, S1, S2, S3 (3 channels each).
    """
    s0, s1, s2 = image[..., 3:6], image[..., 6:9], image[..., 9:12]
    a = math.radians(2.0 * angle_deg)
    return 0.5 * (s0 + s1 * math.cos(a) + s2 * math.sin(a))


#: the request's arguments of :func:`render` and their defaults: with ``setup=`` they stay at these
_REQUEST_DEFAULTS: dict[str, Any] = {
    "material": None, "scenario": None, "lighting": None, "viewing": None, "view": "main", "spp": None,
    "resolution": 512, "mode": "rgb", "polarizer_deg": None, "lobes": LOBES, "max_depth": None, "perspective": False,
    "seed": 0, "zoning": "auto", "exposure": "reference", "look": "diagram", "denoise": None, "time_budget": None,
}


def render_question(setup: Any = None, **asked: Any) -> Any:
    """The :class:`~labcut.rendering.request.RenderRequest` of a call: ``setup`` itself, or one built
    (and so validated) from the loose arguments ``asked`` (names of :data:`_REQUEST_DEFAULTS`).
    Both at once is an error: the setup holds the request."""
    from ..validation import given_besides
    from .request import RenderRequest

    if setup is None:
        return RenderRequest.build(asked.pop("material", None), asked.pop("scenario", None), asked.pop("lighting", None),
                                 asked.pop("viewing", None), **asked)
    if not isinstance(setup, RenderRequest):
        raise ParameterError(f"setup must be a labcut RenderRequest (RenderRequest.build(...)), got {type(setup).__name__}")
    given_besides(asked, _REQUEST_DEFAULTS, "setup= already holds the render request")
    return setup


def render_image(mesh: Any, ask: Any, normal: np.ndarray, spp: int, *,
                 progress: Callable[[int, int], None] | None = None,
                 effects: dict[str, Any] | None = None, budget: Any = None) -> RenderResult:
    """Render a checked mesh under the :class:`~labcut.rendering.request.RenderRequest` ``ask`` at the
    unit lamella ``normal`` with ``spp`` samples per pixel (checks nothing again; not saved):
    the render itself, as :func:`labcut.render` runs it once it has chosen ``spp`` (a time budget's
    choice, ``budget``) and recorded the effect plan (``effects``, its ``to_dict()``)."""
    import drjit as dr

    studio = ask.studio
    scenario_used = ask.scenario
    setting = scenario_used.main_setting()
    views = list(ask.cameras)
    parts = _scene_parts(mesh, ask, normal, setting)  # once for every camera
    effect_plan = dict(effects or {})
    total = int(spp) * len(views)
    per_pass = max(1, min(int(spp), 16))
    done = 0
    tiles = []
    plan = None
    start = time.perf_counter()
    with _interruptible() as interrupted:
        for v in views:
            scene, plan = _scene(mesh, ask, normal, setting, v, parts=parts)
            accum = None
            remaining = int(spp)
            k = 0
            while remaining > 0:
                n = min(per_pass, remaining)
                img = render_pass(scene, n, ask.seed * 100003 + k)
                if interrupted.is_set():
                    raise KeyboardInterrupt
                arr = np.array(img, dtype=np.float64) * n
                accum = arr if accum is None else accum + arr
                remaining -= n
                done += n
                k += 1
                if progress is not None:
                    progress(done, total)
            image = accum / float(spp)
            if plan.denoise:
                from .denoise import denoise as _denoise
                from .denoise import trace_aux

                aux = trace_aux(scene, seed=ask.seed)  # noise-free shading guide and normal (cleanAux)
                image = _denoise(image[..., :3], aux[..., :3], aux[..., 3:6])
            if plan.polarizer_deg is not None:
                image = _polarizer_intensity(image, plan.polarizer_deg)
            if image.shape[-1] == 1:  # mono film: luminance, shown grey
                image = np.repeat(image, 3, axis=-1)
            tiles.append(image[..., :3].astype(np.float32))
            dr.flush_malloc_cache()
    seconds = time.perf_counter() - start
    assert plan is not None
    image = tile_views(tiles)
    log.info("render plan: %s", "; ".join(plan.reasons))
    image = np.ascontiguousarray(image)
    studio_info: dict[str, Any] = {} if studio is None else studio_record(setting, studio, views, parts)
    chosen = choose_exposure(ask.exposure, studio, setting, views, image, studio_info.get("irradiance_at_camera"))
    plan = dataclasses.replace(plan, effects=effect_plan)
    result = RenderResult(
        image, plan, int(spp), seconds, [v.name for v in views], scenario_used.to_dict(),
        exposure=chosen.value,
        exposure_mode=chosen.mode,
        mesh=Stone.of(mesh).provenance_dict(),
        look=plan.look,
        tonemap="hue" if studio is None else "agx",
        exposure_metering=chosen.metering,
        studio=studio_info,
        budget={} if budget is None else budget.to_dict(),
        exposure_reference=chosen.reference,
    )
    return result


#: views side by side in a row of a multi-view render (an orbit's 8: 4 x 2)
VIEWS_PER_ROW = 4


def tile_views(images: Sequence[np.ndarray]) -> np.ndarray:
    """One image per camera, tiled as a multi-view render shows them: :data:`VIEWS_PER_ROW` to a row."""
    if len(images) == 1:
        return images[0]
    rows = [np.concatenate(images[i : i + VIEWS_PER_ROW], axis=1) for i in range(0, len(images), VIEWS_PER_ROW)]
    return np.concatenate(rows, axis=0)


def studio_record(setting: Setting, studio: Any, views: Sequence[CameraView], parts: _SceneParts) -> dict[str, Any]:
    """A record of a studio render's settings and lamps (mesh frame, as ``parts`` built them), with
    the irradiance on a card facing its first camera (render units)."""
    from .studio import irradiance_at_camera

    scale = RENDER_IRRADIANCE / float(np.sum(setting.lights.weights))
    return {
        **studio.to_dict(),
        "lamps": [{"direction": list(lamp.direction), "radius_deg": lamp.radius_deg, "point_lamp": lamp.point,
                   "irradiance": lamp.irradiance * scale} for lamp in parts.lamps],
        "environment": None if parts.environment is None else parts.environment.name,
        "irradiance_at_camera": irradiance_at_camera(parts.lamps, parts.environment, views[0].direction, scale),
    }


@contextlib.contextmanager
def _interruptible() -> Any:
    """Hold Ctrl-C for the next safe point of a render loop.

    A SIGINT that lands while Mitsuba calls back into the Python BSDF (loading or tracing a
    scene) can be swallowed on the way back through C++; while this context is active (and
    Python's own handler was in place) the signal only sets the returned event, which the
    loop checks between passes and turns into ``KeyboardInterrupt``.
    """
    event = threading.Event()
    previous = None
    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: event.set())
    try:
        yield event
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    if event.is_set():
        raise KeyboardInterrupt
