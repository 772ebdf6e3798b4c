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


#: meshes with more triangles than this are shaded for the flash estimator by
#: :func:`smooth_corner_normals` at the sampled faces (a few million triangles' split copy costs
#: seconds to build and gigabytes to hold); smaller ones by the split copy the renderer uses
FAST_SMOOTH_FACES = 200_000


def face_areas(mesh: Any, chunk: int = 1 << 20) -> np.ndarray:
    """Area of every face, as trimesh's ``area_faces`` has it (the same formula, the same values),
    computed in chunks (no (F, 3, 3) copy of the corners kept) and once per mesh (:func:`mesh_cached`)."""
    def build() -> np.ndarray:
        from ..geometry.meshio import cross_rows

        v = np.asarray(mesh.vertices, dtype=np.float64)
        f = np.asarray(mesh.faces)
        out = np.empty(len(f))
        for s in range(0, len(f), chunk):
            ff = f[s : s + chunk]
            b = v[ff[:, 1]]
            crosses = cross_rows(b - v[ff[:, 0]], v[ff[:, 2]] - b)  # trimesh.triangles.cross's edges and values
            crosses **= 2
            out[s : s + len(ff)] = np.sqrt(crosses[:, 0] + crosses[:, 1] + crosses[:, 2]) / 2.0
        out.setflags(write=False)
        return out

    return mesh_cached(mesh, "labcut_face_areas", build)


def sample_surface(mesh: Any, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``trimesh.sample.sample_surface(mesh, count, seed=seed)`` (the same points and faces, from
    the same random stream) without its copies of every face's corners: the areas come from
    :func:`face_areas` and only the picked faces' corners are gathered. ``(points, face_index)``."""
    weight_cum = np.cumsum(face_areas(mesh))
    random = np.random.default_rng(seed).random
    face_index = np.searchsorted(weight_cum, random(count) * weight_cum[-1])
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)[face_index]
    origins = v[f[:, 0]]
    vectors = v[f[:, 1:]].copy()
    vectors -= np.tile(origins, (1, 2)).reshape((-1, 2, 3))
    lengths = random((len(vectors), 2, 1))
    lengths[lengths.sum(axis=1).reshape(-1) > 1.0] -= 1.0
    lengths = np.abs(lengths)
    return (vectors * lengths).sum(axis=1) + origins, face_index


def unit_normals(tri: np.ndarray) -> np.ndarray:
    """(N, 3) unit geometric normals of the triangles ``tri`` ((N, 3, 3) corners, outward by their
    winding; e.g. ``mesh.face_normals[idx]`` from only those faces' corners); a zero-area face
    gets a zero vector."""
    import trimesh

    unit, valid = trimesh.triangles.normals(tri)
    out = np.zeros((len(tri), 3))
    out[valid] = unit
    return out


def smooth_corner_normals(mesh: Any, angle_deg: float, face_idx: Any) -> np.ndarray:
    """(k, 3, 3) smooth shading normals at the three corners of the faces ``face_idx`` of ``mesh``
    (in its own face order), split along edges sharper than ``angle_deg``, without building a split
    copy of the whole mesh (:func:`smooth_split`), for a mesh of millions of triangles.

    At a corner (face f, vertex v) the normal is the corner-angle weighted mean of the normals of
    the faces around v that f reaches across edges at v whose faces' normals differ by less than
    ``angle_deg`` (trimesh's vertex normals of the split copy: the same weights and tests).
    trimesh's split goes by connected patches of the whole mesh instead, and keeps flat facets
    larger than a tenth of the surface apart: the two differ only at vertices where two or more
    sharp edges meet and the sectors they part around the vertex are one patch further away
    (trimesh then smooths across those edges there), and at the rims of such large facets. On
    the bundled cabochons they agree at every corner, on the carving at all but 0.03 % of its
    area (``tests/test_speed_big.py`` compares them)."""
    import trimesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(mesh.faces, dtype=np.int64)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    face_idx = np.asarray(face_idx, dtype=np.int64).ravel()
    nv = len(verts)
    need = np.zeros(nv, dtype=bool)
    need[faces[face_idx].ravel()] = True
    # every corner at a needed vertex: (face g, corner c), sorted by face then corner
    g, c = np.nonzero(need[faces])
    v = faces[g, c]
    w1, w2 = faces[g, (c + 1) % 3], faces[g, (c + 2) % 3]
    inc = np.unique(g)  # incident faces: their normals and corner angles
    tri = verts[faces[inc]]
    normals = unit_normals(tri)
    angles = trimesh.triangles.angles(tri)
    loc = np.searchsorted(inc, g)
    n_c = normals[loc]
    ang_c = angles[loc, c]
    ang_c = np.where(np.einsum("ij,ij->i", n_c, n_c) > 0.5, ang_c, 0.0)  # faces without a normal count for nothing
    # the fan around each vertex: corners whose faces share an edge (v, w) at it
    key = np.concatenate([v * nv + w1, v * nv + w2])
    corner = np.concatenate([np.arange(len(g)), np.arange(len(g))])
    order = np.argsort(key, kind="stable")
    ks, cs = key[order], corner[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    a, b = cs[same], cs[same + 1]
    keep = a != b
    a, b = a[keep], b[keep]
    dots = np.clip(np.einsum("ij,ij->i", n_c[a], n_c[b]), -1.0, 1.0)
    smooth = np.abs(np.arccos(dots)) < math.radians(angle_deg)
    a, b = a[smooth], b[smooth]
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(len(g), len(g)))
    _, comp = connected_components(graph, directed=False)
    summed = np.stack([np.bincount(comp, weights=ang_c * n_c[:, k]) for k in range(3)], axis=1)
    length = np.sqrt(np.einsum("ij,ij->i", summed, summed))
    unit = summed / np.where(length > 0, length, 1.0)[:, None]
    # the corners of the faces asked: their rows among the sorted (face, corner) pairs
    rows = np.searchsorted(g * 3 + c, (face_idx[:, None] * 3 + np.arange(3)[None, :]).ravel())
    return unit[comp[rows]].reshape(len(face_idx), 3, 3)


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
