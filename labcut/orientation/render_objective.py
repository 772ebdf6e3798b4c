"""The flash objective of a lamella normal from Mitsuba renders, differentiable by Dr.Jit AD.

:class:`RenderObjective` renders every view of a scenario's poses (orthographic, mono, the
schiller lobe alone) and scores the images as :func:`labcut.orientation.render_estimator.render_metrics`
does; :func:`view_terms` and :func:`combine_views` turn images into the flash terms and the
objective, and the objective's derivative into the per-pixel adjoint images the integrator's
reverse pass takes. :mod:`labcut.orientation.render_estimator` optimises it.

Frames and units: normals and directions in the mesh frame (mm, +Z face-up); radiance as
``L/L_ref`` (:func:`labcut.orientation.problem.reference_radiance`, lights at unit total
irradiance); times in seconds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..geometry.stone import Stone
from ..physics.material import Labradorite
from ..scene.directions import normalize_normal
from ..scene import Setting
from .radiance import flash_threshold, reference_radiance
from .scoring import FlashMetrics

#: width of the logistic step that stands in for the flash threshold in the gradients of the
#: ``area``/``intensity``/``balanced`` objectives, in units of tau (a rendered pixel is noisier than
#: a surface sample, so the step is wider than the sample estimator's 0.02 tau)
SMOOTH_WIDTH = 0.05
#: path depth: 2 is direct lighting (exact for a convex stone), 4 carries light reflected
#: between the parts of a carving up to twice (as ``labcut.render`` plans a non-convex stone)
DIRECT_DEPTH = 2
CARVING_DEPTH = 4
#: samples (pixels x spp) of one view rendered and differentiated in one go; larger images
#: are rendered in passes of at most this many samples, each with its own seed
PASS_SAMPLES = 1 << 20
#: a pixel counts when its alpha (box-filter coverage) exceeds this, as in :func:`render_metrics`
COVER_ALPHA = 1e-3


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * x))  # overflow-free logistic


@dataclass
class ViewTerms:
    """Flash terms of one rendered view (hard threshold) and, when smoothed, their derivatives
    with respect to the view's pixel values (luminance, the film's first channel)."""

    area: float
    intensity: float
    energy: float
    d_area: np.ndarray | None = None
    d_intensity: np.ndarray | None = None
    d_energy: np.ndarray | None = None


def view_terms(value: np.ndarray, alpha: np.ndarray, tau: float, l_ref: float, width: float | None = None) -> ViewTerms:
    """Flash area, intensity and energy of one view from its image (as :func:`render_metrics`).

    ``value``: rendered luminance per pixel (alpha-premultiplied, the film's output), ``alpha``:
    coverage of the stone per pixel (box filter: the share of the pixel's area it covers), so a
    pixel's weight is the projected area it sees and ``L/L_ref = value / alpha / l_ref``. Pixels
    with alpha <= :data:`COVER_ALPHA` are left out. With ``width`` (in units of ``tau``) the hard
    threshold of area and intensity is replaced by a logistic step ``σ((L/L_ref - τ) / (width τ))``
    and the derivatives of the three terms with respect to ``value`` (same shape) are returned
    too; the energy has no threshold and is the same either way."""
    value = np.asarray(value, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    cover = alpha > COVER_ALPHA
    w = alpha[cover]
    y = value[cover]
    total = float(w.sum())
    if total <= 0.0:
        zero = np.zeros_like(value) if width is not None else None
        return ViewTerms(0.0, 0.0, 0.0, zero, zero, zero)
    r = y / w / l_ref
    energy = float(y.sum()) / l_ref / total
    if width is None:
        flash = r >= tau
        area = float((w * flash).sum()) / total
        inflash = float((w * flash).sum())
        intensity = float((w * r * flash).sum()) / inflash if area > 0 else 0.0
        return ViewTerms(area, intensity, energy)
    scale = width * tau
    s = _sigmoid((r - tau) / scale)
    ds = s * (1.0 - s) / scale  # d s / d r
    area_w = float((w * s).sum())  # D
    inflash = float((w * s * r).sum())  # N
    area = area_w / total
    intensity = inflash / area_w if area_w > 1e-300 else 0.0
    # dr_p/dy_p = 1 / (w_p l_ref): dD/dy = ds / l_ref, dN/dy = (ds r + s) / l_ref
    d_d = ds / l_ref
    d_n = (ds * r + s) / l_ref
    out = [np.zeros_like(value) for _ in range(3)]
    out[0][cover] = d_d / total
    out[1][cover] = (d_n - intensity * d_d) / area_w if area_w > 1e-300 else 0.0
    out[2][cover] = 1.0 / (l_ref * total)
    return ViewTerms(area, intensity, energy, *out)


def combine_views(terms: Sequence[ViewTerms], weights: np.ndarray, objective: str) -> tuple[float, list[np.ndarray] | None]:
    """The objective of per-view terms with view weights (summing to 1), and (when the terms carry
    derivatives) its derivative with respect to each view's pixel values. ``balanced`` =
    sqrt(area x intensity), floored at 1e-20 under the root where it is smoothed (a finite gradient
    where nothing flashes), as :class:`~labcut.orientation.scoring.Scorer` does."""
    w = np.asarray(weights, dtype=np.float64)
    area = float(sum(wv * t.area for wv, t in zip(w, terms)))
    intensity = float(sum(wv * t.intensity for wv, t in zip(w, terms)))
    energy = float(sum(wv * t.energy for wv, t in zip(w, terms)))
    smooth = all(t.d_energy is not None for t in terms)
    if objective == "energy":
        return energy, [wv * t.d_energy for wv, t in zip(w, terms)] if smooth else None
    if objective == "area":
        return area, [wv * t.d_area for wv, t in zip(w, terms)] if smooth else None
    if objective == "intensity":
        return intensity, [wv * t.d_intensity for wv, t in zip(w, terms)] if smooth else None
    value = math.sqrt(max(area * intensity, 1e-20 if smooth else 0.0))
    if not smooth:
        return value, None
    return value, [wv * (intensity * t.d_area + area * t.d_intensity) / (2.0 * value) for wv, t in zip(w, terms)]


class RenderObjective:
    """The flash objective of a lamella normal from Mitsuba renders, with its gradient by Dr.Jit AD.

    For every pose of ``settings`` (:meth:`labcut.Scenario.settings`: lights and views in the mesh
    frame, mm, +Z face-up) a scene is built when first rendered, holding that pose's lights (lamps as distant
    lights at unit total irradiance, an environment map as an ``envmap`` emitter, no ambient room)
    and one orthographic sensor per view; all scenes share one stone mesh and one ``labradorite``
    BSDF with only its schiller lobe on for direct lighting (the delta ``surface`` lobe does not
    depend on the normal; the body is not flash); with deeper paths every lobe is on and the
    flash is the image less the same scene's image without the schiller (:meth:`images`). Poses
    whose lamps differ only in direction (a rocking hand under lamps: :func:`poses_share_a_scene`)
    share one scene instead, with every pose's sensors, and each pose's lamps are set through
    ``mi.traverse`` before its views render: one tree for the stone instead of one per pose, the
    same images bit for bit. A new normal is written into the BSDF
    through ``mi.traverse`` as an opaque Dr.Jit value, so every evaluation reuses the compiled
    kernels. The images are mono (luminance), as the sample estimator scores luminance.

    Light transport: ``max_depth`` 2 (default for a convex stone, where no light path leaves the
    stone and comes back, so direct lighting is exact) renders with Mitsuba's ``direct``
    integrator and differentiates it in reverse mode through its traced kernel (Dr.Jit AD; it
    gives the same images and gradients as ``prb`` at depth 2, faster); a larger depth (default 4
    for a non-convex carving: light reflected between its parts by their polish, body or schiller,
    up to twice) uses ``prb``, whose adjoint pass re-traces the paths (detached sampling). Only the
    smooth schiller lobe depends on the normal, so the delta polish, which ``prb`` does not
    differentiate, only carries light along a path and needs no derivative.

    Common random numbers: every evaluation renders every view with the same ``seed``, so the
    objective is a deterministic function of the normal and finite differences of it are
    meaningful; the gradient is that of the same estimator (with ``direct``: exactly, the adjoint
    pass replays the primal's samples; with ``prb`` the BSDF-sampled directions are held fixed).

    Objective (DESIGN.md §4): the view-weighted (pose weight x view weight) mean over views of
    the flash terms of :func:`view_terms`; ``energy`` is linear in the images, the thresholded
    objectives are smoothed by a logistic step of width ``smooth_width`` x tau for
    :meth:`value_and_grad` and exact (hard threshold) in :meth:`value` and :meth:`metrics`.
    """

    def __init__(self, mesh: Any, material: Any, settings: Sequence[Setting], tau: float = 0.1,
                 resolution: int = 64, spp: int = 8, seed: int = 0, objective: str = "energy",
                 max_depth: int | None = None, smooth_width: float = SMOOTH_WIDTH, zoning: Any = None) -> None:
        import mitsuba as mi

        from ..backend import set_variant
        from ..geometry.meshio import validate_mesh
        from ..rendering import bsdf as _bsdf  # noqa: F401  (registers the plugin)
        from ..rendering.api import bsdf_dict
        from ..rendering.scene import CameraView, RenderFrame, camera, emitters, stone_entries, to_mitsuba_mesh
        from ..validation import check_number
        from .scoring import OBJECTIVES

        if objective not in OBJECTIVES:
            raise ParameterError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}", parameter="objective")
        self.tau = check_number(tau, "flash threshold tau", 0.0, 10.0, low_open=True)
        self.resolution = check_number(resolution, "resolution", 8, 4096, integer=True)
        self.spp = check_number(spp, "spp (samples per pixel)", 1, 1 << 16, integer=True)
        self.seed = check_number(seed, "seed", 0, (1 << 32) - 1, integer=True)
        self.smooth_width = check_number(smooth_width, "smooth_width", 0.0, 10.0, low_open=True)
        settings = list(settings) if settings is not None else []
        if not settings or not all(isinstance(st, Setting) for st in settings):
            raise ParameterError("the render estimator needs at least one labcut.scene.Setting (a scenario's settings())")
        validate_mesh(mesh)
        self.material = Labradorite.coerce(material)
        self.objective = objective
        self.convex = Stone.of(mesh).convex
        self.max_depth = (DIRECT_DEPTH if self.convex else CARVING_DEPTH) if max_depth is None else check_number(max_depth, "max_depth", 2, 16, integer=True)
        self.integrator = "direct" if self.max_depth == DIRECT_DEPTH else "prb"
        self.l_ref = reference_radiance(self.material, 1.0)
        if not self.l_ref > 0:
            raise ParameterError("the material reflects nothing at normal incidence: no flash can be scored")
        self.threshold = flash_threshold(self.material, settings[0].lights, self.tau)  # τ P, in units of L_ref
        self.variant = set_variant("mono")
        from ..rendering.zoning import resolve as resolve_zoning

        self.zoning = resolve_zoning(zoning, self.material)  # colour zones: each point's own lamella stack
        baked = None if self.zoning is None else self.zoning.bake(mesh.bounds).in_frame(RenderFrame.of(mesh))
        integ = flash_integrator(self.max_depth)
        # direct lighting: the schiller lobe alone is the flash. Deeper paths: every lobe, so light
        # the polish (or the body) of one part sends to another reaches its schiller; the flash is
        # then the image less the same scene's image without the schiller (rendered once: it does
        # not depend on the normal), see :meth:`images`
        from ..rendering.api import LOBES

        self.indirect = self.integrator == "prb"
        lobes = tuple(LOBES) if self.indirect else ("schiller",)
        self._bsdf = mi.load_dict(bsdf_dict(self.material, np.array([0.0, 0.0, 1.0]), lobes, zoning=baked))
        shape = to_mitsuba_mesh(mesh, self._bsdf)
        base_shape = None
        if self.indirect:
            base_lobes = tuple(x for x in LOBES if x != "schiller")
            base_shape = to_mitsuba_mesh(mesh, mi.load_dict(bsdf_dict(self.material, np.array([0.0, 0.0, 1.0]), base_lobes,
                                                                      zoning=baked)))
        pose_total = sum(float(st.weight) for st in settings)
        # (group, sensor index in the group's scene, pose) per view, in the order of the weights
        self._views: list[tuple[int, int, int]] = []
        weights = []
        lamp_sets = [emitters(st.lights, total_irradiance=1.0, ambient=0.0) for st in settings]
        # poses that differ only in where their lamps stand share one scene (one tree, the sensors
        # of every pose): a pose's lamps are set through mi.traverse before its views render
        shared = poses_share_a_scene(lamp_sets)
        self._pose_lamps = [_lamp_params(lamps) for lamps in lamp_sets] if shared else None
        # the poses of each scene: all in one, or one scene per pose
        groups = [range(len(settings))] if shared else [range(p, p + 1) for p in range(len(settings))]
        self._groups: list[dict[str, Any]] = []  # each scene's entries: lamps and sensors
        for g, poses in enumerate(groups):
            sensors: dict[str, Any] = {}
            view_poses = []  # the pose of each sensor, in the scene's order
            for p in poses:
                st = settings[p]
                for k, (d, wv) in enumerate(zip(st.views.directions, st.views.weights)):
                    sensor = camera(CameraView(f"view {k}", tuple(d), tuple(st.up())), self.resolution)
                    sensor["film"]["pixel_format"] = "luminance_alpha"
                    sensor["film"]["rfilter"] = {"type": "box"}
                    # scene.sensors() keeps the dictionary's (sorted) order of the keys: pose, then view
                    sensors[f"sensor_{p:03d}_{k:03d}"] = sensor
                    weights.append(float(st.weight) / pose_total * float(wv))
                    view_poses.append(p)
            self._groups.append({**lamp_sets[poses[0]], **sensors})
            self._views += [(g, i, p) for i, p in enumerate(view_poses)]
        self._integ = integ
        self._shape, self._base_shape = shape, base_shape
        # the scenes, built when first rendered: (group, False) the flash scene, (group, True) the
        # no-schiller scene of deeper paths (rendered once per view, then let go)
        self._built: dict[tuple[int, bool], Any] = {}
        wv = np.asarray(weights, dtype=np.float64)
        self.view_weight = wv / wv.sum()
        self._base: list[np.ndarray | None] = [None] * len(self._views)  # no-schiller luminance per view (indirect)
        self._params = mi.traverse(self._bsdf)  # the BSDF every scene shares
        self._scene_params: dict[tuple[int, bool], Any] = {}
        self._shown: dict[tuple[int, bool], int] = {}  # scene -> the pose whose lamps it holds
        self._key = "normal"
        self.evaluations = 0  # objective evaluations (value, or value and gradient)
        self.renders = 0  # images rendered: one per view for a value, plus one adjoint pass per view for a gradient
        self.render_seconds = 0.0

    def _scene(self, group: int, base: bool = False) -> Any:
        """The Mitsuba scene of ``group`` (its poses' lamps and sensors, the stone), built on first
        use; ``base``: the same without the schiller (deeper paths)."""
        if (group, base) not in self._built:
            import mitsuba as mi

            from ..rendering.scene import stone_entries

            # a flash scene and the no-schiller scene its views still need are built together, in
            # that order: Dr.Jit writes the registry number of a scene's environment into the render
            # kernels, so each new objective numbers its scenes as the last did and reuses its kernels
            wanted = [base]
            if not base and self._base_shape is not None and (group, True) not in self._built and any(
                    self._base[k] is None for k, (g, _, _) in enumerate(self._views) if g == group):
                wanted.append(True)
            for b in wanted:
                shape = self._base_shape if b else self._shape
                self._built[(group, b)] = mi.load_dict({"type": "scene", "integrator": self._integ,
                                                        **stone_entries(shape), **self._groups[group]})
        return self._built[(group, base)]

    def _let_go(self, group: int, base: bool) -> None:
        """Forget the scene of ``group`` (and its traversal, its lamps' pose): built again if needed."""
        for store in (self._built, self._scene_params, self._shown):
            store.pop((group, base), None)

    @property
    def n_views(self) -> int:
        return len(self._views)

    def _passes(self) -> list[tuple[int, int]]:
        """(seed, spp) of each pass: one pass (the objective's seed) while a view's samples fit
        :data:`PASS_SAMPLES`, else passes with seeds derived from it."""
        per = max(1, min(self.spp, PASS_SAMPLES // (self.resolution * self.resolution)))
        if per >= self.spp:
            return [(self.seed, self.spp)]
        out, left, k = [], self.spp, 0
        while left > 0:
            n = min(per, left)
            out.append(((self.seed * 1_000_003 + k) % (1 << 32), n))
            left -= n
            k += 1
        return out

    def _set_normal(self, m: np.ndarray, grad: bool) -> Any:
        import drjit as dr
        import mitsuba as mi

        from ..backend import set_variant

        set_variant("mono")  # another part of labcut may have switched the variant since
        value = mi.Vector3f(*(dr.opaque(mi.Float, float(x)) for x in m))  # opaque: no recompilation
        if grad:
            dr.enable_grad(value)
        self._params[self._key] = value
        self._params.update()
        return self._params[self._key]

    def images(self, normal: Any) -> list[np.ndarray]:
        """The flash images (H, W, 2) float64 (schiller luminance, alpha) of every view for ``normal``.

        Direct lighting renders the schiller lobe alone. With deeper paths (:attr:`indirect`) the
        scene has every lobe, and the flash is its luminance less that of the same scene without
        the schiller (same seeds; rendered once, as it does not depend on the normal): the light
        that reaches the lamellae of one part by way of another part's polish or body is in it."""
        m = normalize_normal(normal)
        self._set_normal(m, grad=False)
        return self._flash([self._render(g, i, p) for g, i, p in self._views])

    def values(self, normals: Sequence[Any]) -> list[float]:
        """:meth:`value` (hard threshold) at each of ``normals``, rendered a scene at a time: each
        scene not built yet is built, renders its views for every normal and is let go before the
        next is built. The same images, so the same values as ``[value(n) for n in normals]``.
        Faster where a scenario has several scenes (a pose each): Dr.Jit traces every live BSDF,
        shape and emitter into each render's calls, so the fewer scenes alive, the cheaper each
        render (the effect planner's pilot renders, :func:`interreflection_share`)."""
        import gc

        ms = [normalize_normal(n) for n in normals]
        images: list[list[Any]] = [[None] * len(self._views) for _ in ms]
        for g in range(len(self._groups)):
            kept = (g, False) in self._built  # built before (this objective's own use): kept
            views = [(k, i, p) for k, (gg, i, p) in enumerate(self._views) if gg == g]
            for pose in sorted({p for _, _, p in views}):  # a pose's lamps set once for every normal
                for j, m in enumerate(ms):
                    self._set_normal(m, grad=False)
                    for k, i, p in views:
                        if p == pose:
                            images[j][k] = self._render(g, i, p)
            if self.indirect:
                for k, i, p in views:
                    self._base_image(k)
                self._let_go(g, True)
            if not kept:
                self._let_go(g, False)
                gc.collect()  # the scene's Python BSDF is a reference cycle: free it before the next
        self.evaluations += len(ms)
        return [self._metrics(self._flash(imgs)).score(self.objective) for imgs in images]

    def _base_image(self, k: int) -> np.ndarray:
        """The no-schiller luminance of view ``k`` (deeper paths), rendered once; when every view's
        is, the no-schiller shape and its BSDF are let go (each live BSDF slows every later render)."""
        base = self._base[k]
        if base is None:
            g, i, p = self._views[k]
            base = self._base[k] = self._render(g, i, p, base=True)[..., 0]
            if all(b is not None for b in self._base):
                import gc

                for group in range(len(self._groups)):
                    self._let_go(group, True)
                self._base_shape = None
                gc.collect()  # the Python BSDF is a reference cycle
        return base

    def _flash(self, images: list[np.ndarray]) -> list[np.ndarray]:
        if not self.indirect:
            return images
        out = []
        for k, img in enumerate(images):
            img = img.copy()
            img[..., 0] -= self._base_image(k)
            out.append(img)
        for g in range(len(self._groups)):  # rendered: free their memory
            self._let_go(g, True)
        return out

    def _show_pose(self, group: int, base: bool, pose: int) -> Any:
        """The scene of ``group`` (``base``: without the schiller), its lamps set to ``pose``'s where
        the poses share it (nothing to set for a scene of one pose)."""
        scene = self._scene(group, base)
        if self._pose_lamps is None or self._shown.get((group, base)) == pose:
            return scene
        import mitsuba as mi

        params = self._scene_params.get((group, base))
        if params is None:
            params = self._scene_params[(group, base)] = mi.traverse(scene)
        for key, value in self._pose_lamps[pose].items():
            params[key] = value
        params.update()
        self._shown[(group, base)] = pose
        return scene

    def _render(self, group: int, sensor: int, pose: int, base: bool = False) -> np.ndarray:
        import drjit as dr

        scene = self._show_pose(group, base, pose)
        start = time.perf_counter()
        passes = self._passes()
        acc = None
        integ = scene.integrator()
        for seed, spp in passes:
            with dr.suspend_grad():
                img = np.array(integ.render(scene, sensor, seed=seed, spp=spp), dtype=np.float64) * spp
            acc = img if acc is None else acc + img
            self.renders += 1
        self.render_seconds += time.perf_counter() - start
        return acc / float(self.spp)

    def _terms(self, images: Sequence[np.ndarray], width: float | None) -> list[ViewTerms]:
        return [view_terms(img[..., 0], img[..., 1], self.threshold, self.l_ref, width) for img in images]

    def metrics(self, normal: Any) -> FlashMetrics:
        """All flash metrics (hard threshold) of ``normal`` from its renders (:func:`render_metrics`'s
        numbers, here with the objective's integrator and depth)."""
        self.evaluations += 1
        return self._metrics(self.images(normal))

    def _metrics(self, images: Sequence[np.ndarray]) -> FlashMetrics:
        t = self._terms(images, None)
        return FlashMetrics.from_views([x.area for x in t], [x.intensity for x in t], [x.energy for x in t], self.view_weight)

    def value(self, normal: Any, smooth: bool = False) -> float:
        """The objective at a lamella normal (mesh frame, axial): with the hard threshold, or
        ``smooth`` as :meth:`value_and_grad` optimises it (the same for ``energy``)."""
        if not smooth:
            return self.metrics(normal).score(self.objective)
        self.evaluations += 1
        return combine_views(self._terms(self.images(normal), self.smooth_width), self.view_weight, self.objective)[0]

    def value_and_grad(self, normal: Any) -> tuple[float, np.ndarray]:
        """The objective at ``normal`` and its gradient with respect to the normal (a 3-vector,
        mesh frame, orthogonal to the unit normal: the BSDF normalises what it is given).

        ``energy`` is exact; the thresholded objectives are smoothed (class docstring). The
        gradient: one adjoint render per view seeded with the image-space derivative of the
        objective (:func:`combine_views`), by Dr.Jit AD through the integrator."""
        import drjit as dr
        import mitsuba as mi

        m = normalize_normal(normal)
        self.evaluations += 1
        self._set_normal(m, grad=False)
        images = self._flash([self._render(g, i, p) for g, i, p in self._views])
        value, d_images = combine_views(self._terms(images, self.smooth_width), self.view_weight, self.objective)
        assert d_images is not None
        start = time.perf_counter()
        var = self._set_normal(m, grad=True)
        passes = self._passes()
        for (g, i, p), d_value in zip(self._views, d_images):
            if not np.any(d_value):
                continue
            scene = self._show_pose(g, False, p)
            grad_in = np.zeros((self.resolution, self.resolution, 2), dtype=np.float32)
            grad_in[..., 0] = d_value
            integ = scene.integrator()
            for seed, spp in passes:
                # image = Σ_k spp_k image_k / spp: each pass's adjoint gets its share of the derivative
                integ.render_backward(scene, self._params, mi.TensorXf(grad_in * (spp / self.spp)), i, seed=seed, spp=spp)
                self.renders += 1
        g = dr.grad(var)
        grad = np.array([float(np.array(c).ravel()[0]) for c in (g.x, g.y, g.z)], dtype=np.float64)
        dr.disable_grad(var)
        self._set_normal(m, grad=False)
        self.render_seconds += time.perf_counter() - start
        return float(value), grad


def flash_integrator(max_depth: int = DIRECT_DEPTH) -> dict[str, Any]:
    """The Mitsuba integrator of images measured as flash (this objective, :func:`~labcut.orientation.
    render_estimator.render_metrics`): direct lighting at :data:`DIRECT_DEPTH`, else ``prb`` to
    ``max_depth``. Emitters hidden from the cameras: a pixel the stone covers only in part must not
    add the lights seen behind it (an environment map behind a stone seen from the side, a pendant's
    or a brooch's ceiling: its radiance at the silhouette read as 11 % of the best flash under
    direct lighting, which the deeper paths' image less its no-schiller image cancelled)."""
    if max_depth == DIRECT_DEPTH:
        return {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1, "hide_emitters": True}
    return {"type": "prb", "max_depth": int(max_depth), "hide_emitters": True}


def poses_share_a_scene(lamp_sets: Sequence[dict[str, Any]]) -> bool:
    """Whether the poses whose Mitsuba emitters are ``lamp_sets`` (:func:`labcut.rendering.scene.
    emitters` of each pose's lights) can share one scene: two or more poses, the same directional
    lamps in each (names, irradiance and sampling weight) and the same environment map (its
    radiance, bit for bit, and sampling weight), only their directions (a lamp's direction, the
    map's ``to_world``) differ. The scene's tree is then built once, and its images are those of one
    scene per pose, bit for bit (``tests/test_render_estimator.py``). (One scene matters beyond its
    build: Dr.Jit traces every live emitter and shape at each render's calls, so a scene per pose
    makes every render trace all poses' instances.)"""
    if len(lamp_sets) < 2:
        return False
    first = lamp_sets[0]
    if not first or any(d.get("type") not in ("directional", "envmap") for d in first.values()):
        return False
    for lamps in lamp_sets[1:]:
        if lamps.keys() != first.keys():
            return False
        for key, d in lamps.items():
            f = first[key]
            if d.get("type") != f.get("type") or d.get("sampling_weight") != f.get("sampling_weight"):
                return False
            if d["type"] == "directional" and d.get("irradiance") != f.get("irradiance"):
                return False
            if d["type"] == "envmap" and not _same_map(d, f):
                return False
    return True


def _same_map(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Two ``envmap`` emitter dictionaries hold the same radiance (their ``bitmap``), bit for bit."""
    if "bitmap" not in a or "bitmap" not in b or set(a) != set(b) or a.get("scale", 1.0) != b.get("scale", 1.0):
        return False
    return bool(np.array_equal(np.asarray(a["bitmap"]), np.asarray(b["bitmap"])))


def _lamp_params(lamps: dict[str, Any]) -> dict[str, Any]:
    """The traversable parameters (``light_i.to_world``, ...) of a pose's emitters, as Mitsuba
    builds them from their dictionaries (so a shared scene holds exactly a pose's own lamps); of an
    environment map its ``to_world`` alone (its radiance is the same in every pose)."""
    import mitsuba as mi

    out: dict[str, Any] = {}
    for key, d in lamps.items():
        params = mi.traverse(mi.load_dict(d))
        for name in params.keys():
            if d.get("type") == "envmap" and name != "to_world":
                continue
            out[f"{key}.{name}"] = params[name]
    return out


def interreflection_share(mesh: Any, material: Any, settings: Sequence[Setting], normals: Any = None,
                          resolution: int = 48, spp: int = 8, max_depth: int = CARVING_DEPTH, seed: int = 0) -> float:
    """Measured share of the flash energy that light reflected between the parts of a stone adds:
    the largest over ``normals`` (default: face-up and four normals tilted 30°) of
    ``|E_depth - E_direct|``, divided by the largest ``E_direct`` (the share of the best flash
    among them), ``E`` the rendered ``energy`` objective with paths of
    ``max_depth`` (every lobe carries light between parts) and with direct lighting alone, from
    the same seeds (pilot renders of ``resolution``², ``spp`` samples per pixel). Used by the
    effect planner (:func:`labcut.planner.plan_effects`) where its cheap geometric bound is not
    small enough to leave inter-reflection off. Noise: the two renders share their first
    vertices, so the difference is far less noisy than either image."""
    if normals is None:
        t = math.radians(30.0)
        normals = [(0.0, 0.0, 1.0)] + [(math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t))
                                       for a in np.radians([0.0, 90.0, 180.0, 270.0])]
    import gc

    # one objective and one of its scenes alive at a time (RenderObjective.values): each render
    # traces every live BSDF, shape and emitter, so the other's would slow every one of them
    direct = RenderObjective(mesh, material, settings, resolution=resolution, spp=spp, seed=seed, max_depth=DIRECT_DEPTH)
    e_direct = np.array(direct.values(normals))
    del direct
    gc.collect()
    deep = RenderObjective(mesh, material, settings, resolution=resolution, spp=spp, seed=seed, max_depth=max_depth)
    e_deep = np.array(deep.values(normals))
    del deep
    gc.collect()
    best = float(e_direct.max())
    if not best > 0.0:
        return 0.0
    return float(np.max(np.abs(e_deep - e_direct)) / best)
