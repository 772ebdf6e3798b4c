"""Mitsuba pieces for rendering a stone: mesh conversion, emitters of a scene's lights, cameras.

Frames and units: renders are set up in the mesh frame (mm, +Z face-up, DESIGN.md
§3); a :class:`~labcut.Scenario` has already turned its world-frame lights and
viewers into that frame (:mod:`labcut.scene`). The *front* of the stone is -Y.
Azimuths are measured from +X toward +Y, tilts from +Z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene.directions import FRONT_AZIMUTH_DEG, direction

RENDER_IRRADIANCE = 3.0  # total irradiance of a render's lights (linear units; exposure maps it)
ROOM_AMBIENT = 0.02  # a dim room around lamps, so the body of the stone shows


@dataclass(frozen=True)
class CameraView:
    """A camera direction (towards the camera) and the image's up vector, both in the mesh frame."""

    name: str
    direction: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)


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


SMOOTH_ANGLE_DEG = 30.0  # edges sharper than this keep flat shading
FACETED_ANGLE_DEG = 0.5  # a faceted design (GemCad) is flat-shaded at every facet junction


def shading_angle_deg(mesh: Any) -> float:
    """The smooth-shading angle of a mesh: 30° (curved domes smooth, step-cut junctions crisp),
    or 0.5° for a faceted design, whose facets meet at angles as gentle as a few degrees
    (a brilliant's pavilion mains: 7.6°) and must stay flat. The renderer and the flash
    estimator both shade with it."""
    info = (getattr(mesh, "metadata", None) or {}).get("labcut", {})
    return FACETED_ANGLE_DEG if info.get("faceted") else SMOOTH_ANGLE_DEG


def mesh_cached(mesh: Any, key: str, build: Any) -> Any:
    """``build()``, kept under ``key`` in the mesh's own trimesh cache (trimesh drops it when the
    vertices or faces change), so work derived from one mesh is done once per mesh."""
    cache = getattr(mesh, "_cache", None)
    try:
        hit = cache[key] if cache is not None else None  # trimesh's Cache: None when missing or stale
    except Exception:  # noqa: BLE001 - a cache that cannot be read: build again
        hit = None
    if hit is not None:
        return hit
    value = build()
    try:
        if cache is not None:
            cache[key] = value
    except Exception:  # noqa: BLE001 - not cached: the next caller builds again
        pass
    return value


def smooth_split(mesh: Any, angle_deg: float) -> Any:
    """``trimesh.graph.smooth_shade`` of ``mesh`` at ``angle_deg`` (split along edges sharper than
    it), once per mesh (:func:`mesh_cached`): the renderer, the flash problem (three per
    recommendation with its error bars) and the planner's pilot renders all shade the same mesh."""
    import trimesh

    return mesh_cached(mesh, f"labcut_smooth_split_{float(angle_deg):.6g}",
                       lambda: trimesh.graph.smooth_shade(mesh, angle=math.radians(angle_deg)))


def to_mitsuba_mesh(mesh: Any, bsdf: Any, smooth_angle_deg: float | None = None) -> Any:
    """A Mitsuba mesh of a ``trimesh.Trimesh`` (mm), smooth-shaded except across sharp edges.

    Edges sharper than ``smooth_angle_deg`` (default :func:`shading_angle_deg`: 30°, or
    0.5° for faceted designs) keep flat shading; curved domes get interpolated vertex normals.
    """
    angle = shading_angle_deg(mesh) if smooth_angle_deg is None else float(smooth_angle_deg)
    split = smooth_split(mesh, angle)
    m = _mitsuba_mesh(split.vertices, split.faces, split.vertex_normals)
    m.set_bsdf(bsdf)
    return m


def _mitsuba_mesh(vertices: Any, faces: Any, normals: Any = None) -> Any:
    """A Mitsuba mesh of vertex positions (mm), triangles and optional vertex normals (float32 arrays)."""
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


def ray_scene(mesh: Any) -> Any:
    """A Mitsuba scene of the mesh's bare triangles for ray queries (shadow and view rays): no
    shading normals, no BSDF to speak of. Built once per mesh and Mitsuba variant
    (:func:`mesh_cached`): a flash problem asks it two queries per pose, and a recommendation
    with error bars builds three problems."""
    import mitsuba as mi

    def build() -> Any:
        m = _mitsuba_mesh(mesh.vertices, mesh.faces)
        m.set_bsdf(mi.load_dict({"type": "diffuse"}))
        return mi.load_dict({"type": "scene", "stone": m})

    return mesh_cached(mesh, f"labcut_ray_scene_{mi.variant()}", build)


def camera(mesh: Any, view: CameraView, resolution: int, perspective: bool = False, fov_deg: float = 25.0,
           *, margin: float = 1.0, far_radii: float = 2.0, rfilter: str = "gaussian") -> dict[str, Any]:
    """A sensor dict looking at the mesh's bounding sphere from ``view.direction`` (mesh frame),
    the image's top towards ``view.up``; clip planes from the bounds, so any size renders.
    ``margin`` (perspective): frame a sphere that many times wider than the stone's (room for a
    table around it); ``far_radii``: the far clip plane, in bounding radii beyond the centre.
    ``rfilter``: the film's reconstruction filter (``box`` keeps pixel noise independent, as a
    denoiser expects; the gaussian spreads each sample over neighbouring pixels)."""
    import mitsuba as mi

    lo, hi = np.asarray(mesh.bounds[0]), np.asarray(mesh.bounds[1])
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-6)
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
