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
    """A Mitsuba mesh of a stone (a :class:`~labcut.Stone` or ``trimesh.Trimesh``, mm),
    smooth-shaded except across sharp edges.

    Edges sharper than ``smooth_angle_deg`` (default: the stone's
    :attr:`~labcut.Stone.shading_angle_deg`, 30° or 0.5° for faceted designs) keep flat shading;
    curved domes get interpolated vertex normals.
    """
    split = Stone.of(mesh).smooth_split(smooth_angle_deg)
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
