"""Mitsuba pieces for rendering a stone: mesh conversion, emitters of a scene's lights, cameras.

Frames and units: renders are set up in the mesh frame's axes (+Z face-up, DESIGN.md
§3); a :class:`~labcut.Scenario` has already turned its world-frame lights and
viewers into that frame (:mod:`labcut.scene`). The *front* of the stone is -Y.
Azimuths are measured from +X toward +Y, tilts from +Z. Positions in a Mitsuba scene are in the
stone's :class:`RenderFrame` (the mesh frame moved and scaled so that the stone's bounding sphere
is the unit sphere), not in mm: directions are the same in both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..geometry.stone import Stone
from ..scene.directions import FRONT_AZIMUTH_DEG, direction

RENDER_IRRADIANCE = 3.0  # total irradiance of a render's lights (linear units; exposure maps it)
ROOM_AMBIENT = 0.02  # a dim room around lamps, so the body of the stone shows


@dataclass(frozen=True)
class CameraView:
    """A camera direction (towards the camera) and the image's up vector, both in the mesh frame."""

    name: str
    direction: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)


#: half the side of the cube that every render's scene spans (render frame, stone radii): the
#: stone lies inside the unit sphere, and :func:`bounds_marker` holds the cube's corners
SCENE_HALF_SIDE = 4.0


@dataclass(frozen=True)
class RenderFrame:
    """The frame a stone is rendered in: the mesh frame moved so that the centre of the stone's
    bounding box is the origin and scaled so that the stone's bounding radius (half the box's
    diagonal) is 1; axes unchanged, so directions (lamps, viewers, lamella normals) are the mesh
    frame's and no light or shading changes.

    Why: Mitsuba writes the scene's sizes into its kernels as constants (an orthographic camera's
    clip planes; the bounding sphere from which a directional lamp or an environment takes its
    shadow rays' length). In this frame, with :func:`bounds_marker` fixing the scene's bounds,
    they are the same for every stone, so a stone of a new size or place renders with the kernels
    already compiled (``benchmarks/kernel_compiles.py``)."""

    centre: tuple[float, float, float]  #: the bounding box's centre, mesh frame, mm
    radius: float  #: the bounding radius, mm

    @classmethod
    def of(cls, mesh: Any) -> RenderFrame:
        """The render frame of a stone (a :class:`~labcut.Stone` or ``trimesh.Trimesh``, mm)."""
        lo, hi = (np.asarray(b, dtype=np.float64) for b in Stone.of(mesh).mesh.bounds)
        return cls(tuple(float(x) for x in 0.5 * (lo + hi)), max(0.5 * float(np.linalg.norm(hi - lo)), 1e-6))

    def points(self, p: Any) -> np.ndarray:
        """Points (..., 3) of the mesh frame (mm) in this frame (float64)."""
        return (np.asarray(p, dtype=np.float64) - np.asarray(self.centre)) / self.radius

    def box(self, lo: Any, hi: Any) -> tuple[list[float], list[float]]:
        """An axis-aligned box of the mesh frame (its corners, mm) in this frame."""
        return self.points(lo).tolist(), self.points(hi).tolist()


def bounds_marker() -> Any:
    """A Mitsuba mesh that only widens the scene's bounds to the cube of half side
    :data:`SCENE_HALF_SIDE` about the origin: two triangles, each shrunk to one corner of that
    cube, which no ray can hit (zero area). Every render's scene holds one beside its stone
    (:class:`RenderFrame` says why; a studio scene's table reaches further, the same for every
    stone); ``tests/test_render_frame.py`` checks that it changes no pixel."""
    import drjit as dr
    import mitsuba as mi

    h = float(SCENE_HALF_SIDE)
    m = mi.Mesh("scene bounds", vertex_count=2, face_count=2, has_vertex_normals=False, props=mi.Properties())
    params = mi.traverse(m)
    params["vertex_positions"] = dr.ravel(mi.Point3f([-h, h], [-h, h], [-h, h]))
    params["faces"] = dr.ravel(mi.Vector3u([0, 1], [0, 1], [0, 1]))
    params.update()
    return m


def stone_entries(stone: Any) -> dict[str, Any]:
    """A render scene's shapes: its ``stone`` (:func:`to_mitsuba_mesh`) and the
    :func:`bounds_marker`, as scene dictionary entries."""
    return {"stone": stone, "scene_bounds": bounds_marker()}


def emitters(lights: Any, total_irradiance: float = RENDER_IRRADIANCE, ambient: float = ROOM_AMBIENT) -> dict[str, Any]:
    """Mitsuba emitters of a :class:`~labcut.Lights` in the mesh frame: its lamps as directional
    lights, its environment map (if any) as an ``envmap`` emitter with the same rotation, scaled
    together so that the lights' total irradiance is ``total_irradiance``. Without a map a dim
    constant ``ambient`` room is added. Emitters are sampled in proportion to their power."""
    w = np.asarray(lights.weights, dtype=np.float64)
    scale = total_irradiance / float(w.sum())
    out: dict[str, Any] = {}
    for i, (d, e) in enumerate(zip(lights.lamp_directions, lights.lamp_weights)):
        if e > 0:
            out[f"light_{i}"] = {
                "type": "directional",
                "direction": [-float(x) for x in d],  # Mitsuba: direction of travel
                "irradiance": {"type": "rgb", "value": [float(e) * scale] * 3},
                "sampling_weight": float(e) * scale,
            }
    env = lights.environment
    if env is not None:
        out["environment"] = env.emitter(scale)
        out["environment"]["sampling_weight"] = float(w[lights.n_lamps :].sum()) * scale
    elif ambient > 0.0:
        out["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": [ambient] * 3},
                              "sampling_weight": ambient * 2.0 * math.pi}
    return out


def camera_views(spec: Any, main: Any) -> list[CameraView]:
    """Cameras of a render request (mesh frame).

    ``spec``: ``main`` (the scenario's main viewer) | ``face-up`` (straight at the face) |
    ``orbit`` (8 views 35° off the face, every 45° from the front) | (tilt°, azimuth°) from the
    face (+Z) and +X toward +Y. ``main`` is a :class:`~labcut.scene.Setting` (its main view and up).
    """
    up = tuple(float(x) for x in main.up())
    if isinstance(spec, CameraView):
        return [spec]
    if isinstance(spec, tuple | list) and len(spec) == 2:
        tilt, az = (float(x) for x in spec)
        if not (math.isfinite(tilt) and math.isfinite(az)) or not 0.0 <= tilt <= 90.0:
            raise ParameterError(f"view tilt must lie in [0, 90] degrees, got {tilt}")
        return [CameraView(f"tilt {tilt:g}° az {az:g}°", tuple(direction(tilt, az)), up)]
    key = str(spec).strip().lower()
    if key == "main":
        return [CameraView(f"{main.views.name} (main view)", tuple(float(x) for x in main.views.main), up)]
    if key == "face-up":
        return [CameraView("face-up", (0.0, 0.0, 1.0), up)]
    if key == "orbit":
        return [CameraView(f"orbit {az:.0f}°", tuple(direction(35.0, FRONT_AZIMUTH_DEG + az)), up) for az in np.arange(0.0, 360.0, 45.0)]
    raise ParameterError(f"unknown view {spec!r}; choose one of {', '.join(VIEW_CHOICES)} or 'TILT,AZIMUTH'")


VIEW_CHOICES = ("main", "face-up", "orbit")


def to_mitsuba_mesh(mesh: Any, bsdf: Any, smooth_angle_deg: float | None = None) -> Any:
    """A Mitsuba mesh of a stone (a :class:`~labcut.Stone` or ``trimesh.Trimesh``, mm) in its
    :class:`RenderFrame`, smooth-shaded except across sharp edges.

    Edges sharper than ``smooth_angle_deg`` (default: the stone's
    :attr:`~labcut.Stone.shading_angle_deg`, 30° or 0.5° for faceted designs) keep flat shading;
    curved domes get interpolated vertex normals.
    """
    split = Stone.of(mesh).smooth_split(smooth_angle_deg)
    m = _mitsuba_mesh(RenderFrame.of(mesh).points(split.vertices), split.faces, split.vertex_normals)
    m.set_bsdf(bsdf)
    return m


def _mitsuba_mesh(vertices: Any, faces: Any, normals: Any = None) -> Any:
    """A Mitsuba mesh of vertex positions, triangles and optional vertex normals (float32 arrays)."""
    import drjit as dr
    import mitsuba as mi

    v = np.ascontiguousarray(vertices, dtype=np.float32)
    f = np.ascontiguousarray(faces, dtype=np.uint32)
    m = mi.Mesh("stone", vertex_count=len(v), face_count=len(f), has_vertex_normals=normals is not None,
                props=mi.Properties())
    params = mi.traverse(m)
    params["vertex_positions"] = dr.ravel(mi.Point3f(v[:, 0], v[:, 1], v[:, 2]))
    params["faces"] = dr.ravel(mi.Vector3u(f[:, 0], f[:, 1], f[:, 2]))
    if normals is not None:
        n = np.ascontiguousarray(normals, dtype=np.float32)
        params["vertex_normals"] = dr.ravel(mi.Vector3f(n[:, 0], n[:, 1], n[:, 2]))
    params.update()
    return m


def camera(view: CameraView, resolution: int, perspective: bool = False, fov_deg: float = 25.0,
           *, margin: float = 1.0, far_radii: float = 2.0, rfilter: str = "gaussian") -> dict[str, Any]:
    """A sensor dict looking at a stone's bounding sphere from ``view.direction`` (mesh frame),
    the image's top towards ``view.up``, in the stone's :class:`RenderFrame` (where that sphere
    is the unit sphere about the origin, so the camera is the same for every stone).
    ``margin`` (perspective): frame a sphere that many times wider than the stone's (room for a
    table around it); ``far_radii``: the far clip plane, in bounding radii beyond the centre.
    ``rfilter``: the film's reconstruction filter (``box`` keeps pixel noise independent, as a
    denoiser expects; the gaussian spreads each sample over neighbouring pixels)."""
    import mitsuba as mi

    centre, radius = np.zeros(3), 1.0  # the render frame's bounding sphere
    d = np.asarray(view.direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    up = np.asarray(view.up, dtype=np.float64)
    if abs(float(d @ up)) > 0.9 * float(np.linalg.norm(up)):  # looking along up: the back (+Y) is up
        up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    film = {
        "type": "hdrfilm",
        "width": int(resolution),
        "height": int(resolution),
        "rfilter": {"type": rfilter},
        "pixel_format": "luminance" if mi.is_monochromatic else "rgb",
    }
    if perspective:
        distance = radius * float(margin) / math.sin(math.radians(fov_deg) / 2.0) * 1.05
        origin = centre + d * distance
        return {
            "type": "perspective",
            "fov": fov_deg,
            "near_clip": max(distance - 2.0 * radius, distance * 1e-3),
            "far_clip": distance + float(far_radii) * radius,
            "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=centre.tolist(), up=up.tolist()),
            "film": film,
        }
    origin = centre + d * (radius * 4.0)
    scale = radius * 1.08
    return {
        "type": "orthographic",
        "near_clip": radius,
        "far_clip": radius * 8.0,
        "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=centre.tolist(), up=up.tolist())
        @ mi.ScalarTransform4f().scale([scale, scale, 1.0]),
        "film": film,
    }
