"""Scene pieces for rendering a stone: mesh conversion, lighting presets, cameras.

Frames and units: the mesh frame is the world frame (mm, +Z face-up, DESIGN.md
§3). The *front* of the stone is -Y: a viewer at the front looks along +Y.
Azimuths are measured from +X toward +Y, tilts from +Z.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError

LIGHTING_PRESETS = ("overhead", "sky", "studio")
VIEW_PRESETS = ("face-up", "tilted", "side", "orbit")
FRONT_AZIMUTH_DEG = 270.0  # the front of the stone faces -Y


def direction(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    """Unit vector at ``tilt_deg`` from +Z and ``azimuth_deg`` from +X toward +Y."""
    t, a = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


@dataclass(frozen=True)
class Lighting:
    """A lighting set-up: distant lights (direction towards the light, irradiance) and/or an environment.

    ``ambient`` is a constant environment radiance (a diffuse sky of that value);
    ``envmap`` an equirectangular EXR/HDR file. ``distant_only`` tells the
    planner that direct lighting is exact for a convex stone.
    """

    name: str
    directions: tuple[tuple[float, float, float], ...] = ()
    irradiance: tuple[float, ...] = ()
    ambient: float = 0.0
    envmap: str | None = None
    envmap_scale: float = 1.0

    @property
    def distant_only(self) -> bool:
        return self.envmap is None and self.ambient == 0.0

    def emitters(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for i, (d, e) in enumerate(zip(self.directions, self.irradiance)):
            out[f"light_{i}"] = {
                "type": "directional",
                "direction": [-float(x) for x in d],  # Mitsuba: direction of travel
                "irradiance": {"type": "rgb", "value": [float(e)] * 3},
            }
        if self.envmap is not None:
            out["environment"] = {"type": "envmap", "filename": self.envmap, "scale": self.envmap_scale}
        elif self.ambient > 0.0:
            out["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": [self.ambient] * 3}}
        return out


def lighting_from_lights(lights: Any, total_irradiance: float = 3.0, ambient: float = 0.02) -> Lighting:
    """Render lighting of an orientation :class:`~labcut.Lights` model: one directional
    light per direction, irradiances scaled to ``total_irradiance``, plus a dim room."""
    w = np.asarray(lights.weights, dtype=np.float64)
    keep = w > 0
    scale = total_irradiance / float(w[keep].sum())
    return Lighting(
        str(lights.name),
        tuple(tuple(float(x) for x in d) for d in np.asarray(lights.directions)[keep]),
        tuple(float(x) * scale for x in w[keep]),
        ambient=ambient,
    )


def lighting_preset(spec: Any) -> Lighting:
    """``overhead`` | ``sky`` | ``studio`` | an EXR/HDR environment map | a :class:`~labcut.Lights` model.

    ``overhead`` is the same bench lamp as the orientation model's (a disc of 8° straight
    above the stone) in a dim room, so renders show what recommendations optimise.
    """
    if isinstance(spec, Lighting):
        return spec
    if type(spec).__name__ == "Lights":
        return lighting_from_lights(spec)
    key = str(spec).strip()
    if key == "overhead":
        from ..orientation.models import Lights

        return lighting_from_lights(Lights.preset("overhead", "draft"), 3.0, 0.02)
    if key == "sky":
        return Lighting("sky", ambient=0.6)
    if key == "studio":
        key_light = direction(25.0, FRONT_AZIMUTH_DEG + 30.0)
        fill = direction(50.0, FRONT_AZIMUTH_DEG - 60.0)
        rim = direction(60.0, 90.0)
        return Lighting("studio", (tuple(key_light), tuple(fill), tuple(rim)), (2.5, 0.8, 1.2), ambient=0.02)
    path = Path(key)
    if path.suffix.lower() in (".exr", ".hdr"):
        if not path.is_file():
            raise ParameterError(f"environment map {key!r} does not exist")
        return Lighting(f"envmap:{path.name}", envmap=str(path.resolve()))
    raise ParameterError(f"unknown lighting {key!r}; choose one of {', '.join(LIGHTING_PRESETS)} or an .exr/.hdr file")


@dataclass(frozen=True)
class View:
    """A camera direction (towards the viewer) by tilt from +Z and azimuth; orthographic or perspective."""

    name: str
    tilt_deg: float
    azimuth_deg: float = FRONT_AZIMUTH_DEG

    @property
    def direction(self) -> np.ndarray:
        return direction(self.tilt_deg, self.azimuth_deg)


def view_presets(spec: str | View | tuple[float, float]) -> list[View]:
    """``face-up`` | ``tilted`` (30° toward the front) | ``side`` | ``orbit`` (8 views) | (tilt, azimuth)."""
    if isinstance(spec, View):
        return [spec]
    if isinstance(spec, tuple | list) and len(spec) == 2:
        tilt, az = (float(x) for x in spec)
        if not (math.isfinite(tilt) and math.isfinite(az)) or not 0.0 <= tilt <= 90.0:
            raise ParameterError(f"view tilt must lie in [0, 90] degrees, got {tilt}")
        return [View(f"tilt {tilt:g}° az {az:g}°", tilt, az)]
    key = str(spec).strip()
    if key == "face-up":
        return [View("face-up", 0.0)]
    if key == "tilted":
        return [View("tilted", 30.0)]
    if key == "side":
        return [View("side", 80.0)]
    if key == "orbit":
        return [View(f"orbit {az:.0f}°", 35.0, FRONT_AZIMUTH_DEG + az) for az in np.arange(0.0, 360.0, 45.0)]
    raise ParameterError(f"unknown view {key!r}; choose one of {', '.join(VIEW_PRESETS)} or 'TILT,AZIMUTH'")


def to_mitsuba_mesh(mesh: Any, bsdf: Any, smooth_angle_deg: float = 30.0) -> Any:
    """A Mitsuba mesh of a ``trimesh.Trimesh`` (mm), smooth-shaded except across sharp edges.

    Edges sharper than ``smooth_angle_deg`` (facet junctions of a step cut) keep
    flat shading; curved domes get interpolated vertex normals.
    """
    import drjit as dr
    import mitsuba as mi
    import trimesh

    split = trimesh.graph.smooth_shade(mesh, angle=math.radians(smooth_angle_deg))
    v = np.ascontiguousarray(split.vertices, dtype=np.float32)
    f = np.ascontiguousarray(split.faces, dtype=np.uint32)
    n = np.ascontiguousarray(split.vertex_normals, dtype=np.float32)
    m = mi.Mesh("stone", vertex_count=len(v), face_count=len(f), has_vertex_normals=True, props=mi.Properties())
    params = mi.traverse(m)
    params["vertex_positions"] = dr.ravel(mi.Point3f(v[:, 0], v[:, 1], v[:, 2]))
    params["faces"] = dr.ravel(mi.Vector3u(f[:, 0], f[:, 1], f[:, 2]))
    params["vertex_normals"] = dr.ravel(mi.Vector3f(n[:, 0], n[:, 1], n[:, 2]))
    params.update()
    m.set_bsdf(bsdf)
    return m


def camera(mesh: Any, view: View, resolution: int, perspective: bool = False, fov_deg: float = 25.0) -> dict[str, Any]:
    """A sensor dict looking at the mesh's bounding sphere from ``view.direction``."""
    import mitsuba as mi

    lo, hi = np.asarray(mesh.bounds[0]), np.asarray(mesh.bounds[1])
    centre = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    d = view.direction
    up = np.array([0.0, 1.0, 0.0]) if abs(d[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
    film = {
        "type": "hdrfilm",
        "width": int(resolution),
        "height": int(resolution),
        "rfilter": {"type": "gaussian"},
        "pixel_format": "luminance" if mi.is_monochromatic else "rgb",
    }
    if perspective:
        distance = radius / math.sin(math.radians(fov_deg) / 2.0) * 1.05
        origin = centre + d * distance
        return {
            "type": "perspective",
            "fov": fov_deg,
            "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=centre.tolist(), up=up.tolist()),
            "film": film,
        }
    origin = centre + d * (radius * 4.0)
    scale = radius * 1.08
    return {
        "type": "orthographic",
        "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=centre.tolist(), up=up.tolist())
        @ mi.ScalarTransform4f().scale([scale, scale, 1.0]),
        "film": film,
    }


def check_envmap(path: str | os.PathLike[str]) -> None:
    """Refuse an environment map Mitsuba cannot read, with a one-line message."""
    import mitsuba as mi

    try:
        mi.Bitmap(str(path))
    except Exception as exc:  # Mitsuba raises RuntimeError with a long message
        raise ParameterError(f"cannot read environment map {str(path)!r}: {str(exc).splitlines()[0][:160]}") from None
