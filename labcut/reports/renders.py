"""Renders of a comparison: the stone at its recommended orientation from the scenario's main
view, a rocking strip (the stone tilted in the hand), and a schiller-only render from which the
flash-colour map is made.

One Mitsuba scene is built per (cut, scenario, lobes) with
:func:`labcut.rendering.api.build_scene` (the scenario's rest pose: its lights and main viewer in
the mesh frame, world up at the top of the image); the frames of a rocking strip turn the stone
inside that scene (vertices, shading normals and lamella normal rotated about the stone's
centre) instead of building a scene per frame. Turning the stone by the world rotation ``R``
under lights and a viewer fixed in the world is turning it by ``Q = Pᵀ R P`` in the rest pose's
mesh frame (``P``: the rest pose, mesh to world).

Images are linear RGB (float32, H x W x 3), in the renderer's units (lights of total
irradiance :data:`~labcut.rendering.scene.RENDER_IRRADIANCE`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..orientation.flash_mask import flash_mask
from ..rendering.api import build_scene
from ..rendering.scene import camera_views
from ..scene.directions import normalize_normal
from ..scene import Scenario
from ..scene.directions import rotation

# render size, samples per pixel and strip angles by quality: Quality.render_resolution,
# render_spp and strip_angles_deg (labcut.scene.quality)


@dataclass
class StoneRenders:
    """The images of one cut under one scenario (linear RGB, float32).

    ``main``: full render (surface, schiller, body) at the recommended orientation from the main
    view. ``strip``: the same with the stone tilted front-to-back by each of ``strip_angles_deg``
    (:func:`labcut.reports.analysis.tilt_axes`). ``schiller``: the schiller lobe alone, for the
    flash-colour map. ``mask``: pixels whose centre sees the stone."""

    main: np.ndarray
    strip: list[np.ndarray]
    strip_angles_deg: tuple[float, ...]
    schiller: np.ndarray
    mask: np.ndarray
    resolution: int
    spp: int
    view: str
    plan: dict[str, Any]
    flash: Any = None


class StoneScene:
    """A Mitsuba scene of one cut at one lamella orientation under a scenario's rest pose, whose
    stone can be turned between renders."""

    def __init__(self, mesh: Any, material: Any, normal: Any, scenario: Scenario, resolution: int,
                 lobes: Sequence[str] = ("surface", "schiller", "body")) -> None:
        import drjit as dr
        import mitsuba as mi

        self.normal = normalize_normal(normal)
        self.pose = np.asarray(scenario.pose, dtype=np.float64)
        setting = scenario.main_setting()
        self.scene, self.plan = build_scene(mesh, material, self.normal, setting, "main", int(resolution), lobes=lobes)
        self.view_name = f"{setting.views.name} (main view)"
        self.params = mi.traverse(self.scene)
        # the camera and every emitter, as built for the rest pose
        self._rest = {k: type(self.params[k])(self.params[k]) for k in self.params.keys() if k.endswith("to_world")}  # noqa: SIM118 (iterating SceneParameters gives items)
        self.resolution = int(resolution)
        self._dr, self._mi = dr, mi
        self._turn = np.eye(3)

    def turn(self, q: np.ndarray) -> None:
        """Turn the stone by the rotation ``q`` (mesh frame of the rest pose) about its centre, the
        lamella normal with it; ``np.eye(3)`` restores the rest pose.

        Done by turning the camera and every emitter by ``qᵀ`` about the stone's centre (the
        origin of its render frame, :class:`~labcut.rendering.scene.RenderFrame`): the same
        picture (only relative directions matter to distant lights and an orthographic camera),
        while the scene's bounds, which Mitsuba bakes into its kernels, stay the same, so no
        frame compiles a kernel of its own."""
        mi = self._mi
        q = np.asarray(q, dtype=np.float64)
        if np.allclose(q, self._turn):
            return
        rest_pose = np.allclose(q, np.eye(3), atol=0.0)
        m = np.eye(4)
        m[:3, :3] = q.T
        about = mi.Transform4f(m)
        for key, rest in self._rest.items():
            self.params[key] = type(rest)(rest) if rest_pose else about @ rest
        self.params.update()
        self._turn = q

    def tilt(self, world_axis: np.ndarray, angle_deg: float) -> None:
        """Tilt the stone by ``angle_deg`` about a world-frame axis, the lights and viewer staying put."""
        r = rotation(world_axis, angle_deg)
        self.turn(self.pose.T @ r @ self.pose)

    def render(self, spp: int, seed: int = 0) -> np.ndarray:
        """Linear RGB image (float32, H x W x 3)."""
        img = np.array(self._mi.render(self.scene, spp=int(spp), seed=int(seed)), dtype=np.float32)
        self._dr.flush_malloc_cache()
        return np.ascontiguousarray(img[..., :3])

    def mask(self) -> np.ndarray:
        """Pixels (H x W, bool) whose centre ray hits the stone, for the current turn."""
        dr, mi = self._dr, self._mi
        w = h = self.resolution
        idx = dr.arange(mi.UInt32, w * h)
        x, y = idx % w, idx // w
        pos = mi.Point2f((mi.Float(x) + 0.5) / w, (mi.Float(y) + 0.5) / h)
        ray, _ = self.scene.sensors()[0].sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
        hit = self.scene.ray_test(ray)
        return np.array(hit, dtype=bool).reshape(h, w)


def render_cut(mesh: Any, material: Any, normal: Any, scenario: Scenario, tilt_axis: np.ndarray,
               resolution: int, spp: int, strip_angles: Sequence[float], seed: int = 0,
               strip_spp: int | None = None, tau: float = 0.1) -> StoneRenders:
    """:class:`StoneRenders` of a cut at lamella ``normal`` (mesh frame) under ``scenario``: the
    main render (``spp`` samples per pixel), the rocking strip about the world ``tilt_axis``
    (``strip_spp``, default ``spp``; its 0° frame is the main render), the schiller-only render,
    the stone's mask and the flash mask at threshold ``tau`` (all at rest)."""
    full = StoneScene(mesh, material, normal, scenario, resolution)
    main = full.render(spp, seed)
    strip = []
    for a in strip_angles:
        if abs(a) < 1e-9:
            strip.append(main)
            continue
        full.tilt(tilt_axis, float(a))
        strip.append(full.render(spp if strip_spp is None else strip_spp, seed))
    full.turn(np.eye(3))
    flash = StoneScene(mesh, material, normal, scenario, resolution, lobes=("schiller",))
    schiller = flash.render(spp, seed)
    mask = flash.mask()
    setting = scenario.main_setting()
    which = flash_mask(mesh, material, normal, setting, camera_views("main", setting), int(resolution), tau=tau)
    return StoneRenders(main, strip, tuple(float(a) for a in strip_angles), schiller, mask, int(resolution), int(spp),
                        full.view_name, full.plan.to_dict(), which)
