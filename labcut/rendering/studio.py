"""The studio look: a stone photographed on a table, under its scenario's lamps, in a light tent.

Everything here is built in code (no download) and set up in the mesh frame's axes (+Z face-up),
its positions in the stone's render frame (:class:`~labcut.rendering.scene.RenderFrame`: sizes in
stone radii):

* **Lamps as area lights.** A scenario's lamps reach the renderer as sampled directions
  (:class:`~labcut.scene.Lights`: a round lamp of angular radius r is n equal-solid-angle
  directions of equal weight). :func:`lamps_of` groups them back into lamps (equal weights,
  within 45° of each other) and recovers each lamp's centre and radius from the spiral
  (``1 - cos r = (1 - cos θ_max) n / (n - 1/2)``); :func:`studio_emitters` places each as an
  emitting disc :data:`Studio.lamp_distance` stone radii away, of the same angular radius
  and the same irradiance at the stone (radiance ``E / (π sin² r)``). The polished surface
  then mirrors the lamps: a bright highlight where its normal bisects lamp and camera. A
  point lamp (spot, sun) has no size to mirror: it is drawn :data:`Studio.point_lamp_deg`
  across. Each lamp has a bright core (:data:`Studio.lamp_core` of its irradiance from the
  central 0.3 of its radius, a bulb in a reflector), so the mirrored lamp shows a small
  near-white spot; the flash integrates over the whole lamp and does not change.
* **A light tent** (:func:`tent_radiance`, world frame, +Z up): white fabric brighter towards
  the top, two tall softboxes left and right and a top strip, for the long soft reflections a
  polished dome shows in a jeweller's photograph. Scaled so that its irradiance on a face-up
  card is :data:`Studio.tent_share` of the scenario's lights; added to the scenario's own
  environment map when it has one (it replaces the diagram look's dim constant room).
* **A table**: a neutral grey matte plane under the stone's base (:data:`Studio.backdrop_albedo`),
  lit by the same lights, so the stone casts a soft contact shadow (direct lighting; a convex
  stone's polish mirrors the lamps and the tent, and the table only with ``max_depth`` > 2).
* **The body** (:func:`body_grid`): the labradorite BSDF's grey body tinted dark grey-green
  (:data:`Studio.body_tint`) and modulated by a seeded 3D texture: dark inclusions (magnetite
  specks and short needles, which also block the flash where they sit at the surface), milky
  cloudiness, and a lighter body where the stone is thin (near its base plane: a presentation
  stand-in for light scattered through a translucent edge; no subsurface transport is
  simulated). The schiller lobe's physics is unchanged.
* **The camera**: a perspective camera (:data:`Studio.fov_deg`) framing the stone with a margin
  of table around it.

The flash metrics (:func:`~labcut.orientation.flash_check.flash_by_view`, the estimators) never use this
look: it is for pictures.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene.envmap import Environment, pixel_directions
from .scene import RENDER_IRRADIANCE, RenderFrame

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True)
class Studio:
    """Settings of the studio look (all dimensionless unless said).

    ``tent_share``: the tent's irradiance on a face-up card over the scenario lights' total.
    ``lamp_distance``: lamp discs' distance from the stone, in stone radii (bounding sphere).
    ``point_lamp_deg``: angular radius a point lamp is drawn with. ``lamp_core``: share of a
    lamp's irradiance from its bright core (a bulb in its reflector: a disc of 0.3 x the lamp's
    radius; 0 for an even disc). ``backdrop_albedo``: the table's grey under the stone (it darkens
    to 45 % of that about three stone radii away, like a backdrop lit by a spot). ``body_tint``: linear sRGB colour of the body (normalised to luminance 1; the
    material's ``body_albedo`` sets its brightness). ``inclusions``: share of the body volume
    taken by dark inclusions (0 for none). ``seed``: the inclusions' and cloudiness' noise seed.
    ``translucency``: how much lighter the body is where the stone is thin (0 for none).
    ``fov_deg`` and ``margin``: the camera's field of view and how much wider than the stone's
    bounding sphere it frames. ``max_depth``: path depth for a convex stone: 2 (direct lighting:
    the polish mirrors the lamps and the tent, the table is lit and shadowed) or more (the polish
    also mirrors the lit table, at the price of caustic fireflies on the table where it sees the
    lamps' cores in the polish)."""

    tent_share: float = 0.35
    lamp_distance: float = 30.0
    point_lamp_deg: float = 1.5
    lamp_core: float = 0.5
    backdrop_albedo: float = 0.5
    body_tint: tuple[float, float, float] = (0.80, 1.0, 0.86)
    inclusions: float = 0.02
    seed: int = 0
    translucency: float = 1.2
    fov_deg: float = 18.0
    margin: float = 1.5
    max_depth: int = 2
    lamps: tuple[dict[str, Any], ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        checks = {
            "tent_share": (0.0, 10.0), "lamp_distance": (3.0, 1e4), "point_lamp_deg": (0.05, 20.0), "lamp_core": (0.0, 0.95),
            "backdrop_albedo": (0.0, 0.95), "inclusions": (0.0, 0.5), "translucency": (0.0, 5.0),
            "fov_deg": (2.0, 90.0), "margin": (1.0, 10.0),
        }
        for key, (lo, hi) in checks.items():
            v = getattr(self, key)
            if isinstance(v, bool) or not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise ParameterError(f"studio {key} must be a number in [{lo:g}, {hi:g}], got {v!r}")
        tint = np.asarray(self.body_tint, dtype=np.float64)
        if tint.shape != (3,) or not np.all(np.isfinite(tint)) or np.any(tint < 0) or float(tint @ LUMINANCE) <= 0:
            raise ParameterError(f"studio body_tint must be three finite numbers >= 0 (linear sRGB), got {self.body_tint!r}")
        if not (isinstance(self.seed, int | np.integer) and not isinstance(self.seed, bool)):
            raise ParameterError(f"studio seed must be a whole number, got {self.seed!r}")
        if isinstance(self.max_depth, bool) or not (isinstance(self.max_depth, int) and 2 <= self.max_depth <= 16):
            raise ParameterError(f"studio max_depth must be a whole number in [2, 16], got {self.max_depth!r}")

    @property
    def tint(self) -> np.ndarray:
        """The body tint normalised to luminance 1."""
        t = np.asarray(self.body_tint, dtype=np.float64)
        return t / float(t @ LUMINANCE)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("lamps")
        d["body_tint"] = list(self.body_tint)
        return d


LOOKS = ("studio", "diagram")


def resolve_look(look: Any) -> Studio | None:
    """``"studio"`` or a :class:`Studio` -> the settings; ``"diagram"`` -> None."""
    if isinstance(look, Studio):
        return look
    key = str(look).strip().lower() if isinstance(look, str) else None
    if key == "studio":
        return Studio()
    if key == "diagram":
        return None
    raise ParameterError(f"look must be one of {', '.join(LOOKS)} or a labcut.rendering.studio.Studio, got {look!r}")


# ---------------------------------------------------------------------- lamps
@dataclass(frozen=True)
class Lamp:
    """A lamp in the mesh frame: unit ``direction`` towards it, angular ``radius_deg``, irradiance
    (the scenario's relative units) and whether it was a point lamp (drawn wider)."""

    direction: tuple[float, float, float]
    radius_deg: float
    irradiance: float
    point: bool


def lamps_of(lights: Any, point_lamp_deg: float = 1.5, link_deg: float = 45.0) -> list[Lamp]:
    """Group a :class:`~labcut.scene.Lights`' lamp directions back into round lamps (see module doc)."""
    d = np.asarray(lights.lamp_directions, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(lights.lamp_weights, dtype=np.float64).reshape(-1)
    n = len(w)
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    cos_link = math.cos(math.radians(link_deg))
    for i in range(n):
        for j in range(i + 1, n):
            if abs(w[i] - w[j]) <= 1e-9 * max(w[i], w[j]) and float(d[i] @ d[j]) >= cos_link:
                parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    lamps = []
    for idx in groups.values():
        dirs, weights = d[idx], w[idx]
        e = float(weights.sum())
        if e <= 0.0:
            continue
        if len(idx) == 1:
            lamps.append(Lamp(tuple(float(x) for x in dirs[0]), float(point_lamp_deg), e, True))
            continue
        c = dirs.mean(axis=0)
        c /= np.linalg.norm(c)
        one_minus = float(np.max(1.0 - np.clip(dirs @ c, -1.0, 1.0))) * len(idx) / (len(idx) - 0.5)
        radius = math.degrees(math.acos(max(-1.0, 1.0 - one_minus)))
        lamps.append(Lamp(tuple(float(x) for x in c), max(radius, float(point_lamp_deg)), e, False))
    return lamps


# ---------------------------------------------------------------------- tent
def _box(d: np.ndarray, centre: np.ndarray, half_w: float, half_h: float, soft: float) -> np.ndarray:
    """Soft-edged angular rectangle around ``centre`` (its long side vertical), world frame."""
    z = centre / np.linalg.norm(centre)
    up = np.array([0.0, 0.0, 1.0])
    x = np.cross(up, z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-6 else np.array([1.0, 0.0, 0.0])
    y = np.cross(z, x)
    lz = d @ z
    ax = np.degrees(np.arctan2(d @ x, np.maximum(lz, 1e-9)))
    ay = np.degrees(np.arctan2(d @ y, np.maximum(lz, 1e-9)))

    def ramp(a: np.ndarray, half: float) -> np.ndarray:
        return np.clip((half - np.abs(a)) / soft + 0.5, 0.0, 1.0)

    return np.where(lz > 0.0, ramp(ax, half_w) * ramp(ay, half_h), 0.0)


def tent_radiance(d: np.ndarray) -> np.ndarray:
    """Radiance of the light tent towards world directions ``d`` (N, 3), +Z up, the front at -Y:
    fabric 0.35-1.0 from the horizon to the top, two tall softboxes 55° from the vertical on the
    left and right (30x), a strip along the top towards the back (20x), a grey floor below."""
    from ..scene.directions import direction

    z = d[:, 2]
    fabric = np.where(z > 0.0, 0.35 + 0.65 * np.clip(z, 0.0, 1.0) ** 0.7, 0.12)
    left = _box(d, direction(55.0, 180.0), 12.0, 24.0, 3.0)
    right = _box(d, direction(55.0, 0.0), 12.0, 24.0, 3.0)
    strip = _box(d, direction(25.0, 90.0), 30.0, 5.0, 2.0)
    value = fabric + 30.0 * (left + right) + 20.0 * strip
    return value[:, None] * np.array([1.0, 0.985, 0.96])[None, :]  # a touch warm, like daylight lamps


@functools.lru_cache(maxsize=4)
def _tent_map(width: int, height: int) -> np.ndarray:
    return Environment.from_function(tent_radiance, width, height, "tent").radiance


def irradiance_towards(env: Environment, normal: np.ndarray) -> float:
    """Luminance irradiance of ``env`` on a card facing ``normal`` (frame of use)."""
    d = pixel_directions(env.width, env.height).reshape(-1, 3) @ env.rotation.T
    cos = np.clip(d @ np.asarray(normal, dtype=np.float64), 0.0, None)
    sa = np.repeat(env.solid_angles()[:, None], env.width, axis=1).ravel()
    return float((env.luminance().ravel() * cos * sa).sum())


def studio_environment(setting: Any, studio: Studio, scale: float) -> Environment | None:
    """The environment a studio render is lit by (frame of use = mesh frame): the scenario's map
    (if any) plus the tent, both times ``scale`` (the render's irradiance scale); None where
    there is neither (lamps without a map, ``tent_share`` 0: a dark room around the lamps)."""
    lights = setting.lights
    if lights.environment is None and studio.tent_share == 0.0:
        return None
    pose = np.eye(3) if setting.pose is None else np.asarray(setting.pose, dtype=np.float64)
    env = lights.environment
    if env is None:
        grid_rot = pose.T  # map world (scenario world) -> mesh
        base = np.zeros((64, 128, 3), dtype=np.float32)
        width, height = 128, 64
    else:
        grid_rot = env.rotation
        base = env.radiance
        height, width = base.shape[:2]
    # the tent is defined in the scenario's world: map pixel d_m -> world = pose @ grid_rot @ d_m
    d = pixel_directions(width, height).reshape(-1, 3) @ (pose @ grid_rot).T
    tent = tent_radiance(d).reshape(height, width, 3)
    tent_env = Environment(tent.astype(np.float32), grid_rot, "tent")
    up = pose.T @ np.array([0.0, 0.0, 1.0])  # world up in the mesh frame
    e_tent = irradiance_towards(tent_env, up)
    k = studio.tent_share * float(np.sum(lights.weights)) / max(e_tent, 1e-12)
    radiance = base.astype(np.float64) + k * tent
    if env is None:
        name = "tent"
    else:
        name = f"{env.name}+tent" if studio.tent_share > 0.0 else env.name
    return Environment((radiance * scale).astype(np.float32), grid_rot, name)


# ---------------------------------------------------------------------- scene pieces
def studio_emitters(mesh: Any, setting: Any, studio: Studio,
                    total_irradiance: float = RENDER_IRRADIANCE) -> tuple[dict[str, Any], list[Lamp], Environment | None]:
    """Mitsuba emitters (lamp discs and the environment) and the table of a studio render.

    Returns (scene entries, the lamps, the environment used or None: :func:`studio_environment`):
    directions in the mesh frame, positions in the stone's render frame (:class:`~labcut.rendering.
    scene.RenderFrame`, where its bounding sphere is the unit sphere)."""
    import mitsuba as mi

    lights = setting.lights
    scale = total_irradiance / float(np.sum(lights.weights))
    frame = RenderFrame.of(mesh)
    centre, radius = np.zeros(3), 1.0  # the stone's bounding sphere in its render frame
    lamps = lamps_of(lights, studio.point_lamp_deg)
    out: dict[str, Any] = {}
    dist = studio.lamp_distance * radius
    for i, lamp in enumerate(lamps):
        d = np.asarray(lamp.direction)
        up = [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [0.0, 1.0, 0.0]
        e = lamp.irradiance * scale
        for part, (alpha, radiance, gap) in lamp_discs(lamp, e, studio.lamp_core).items():
            a = dist * math.tan(alpha)
            pos = centre + d * (dist - gap * radius)  # the core sits just in front of the disc
            out[f"lamp_{i}_{part}"] = {
                "type": "disk",
                "to_world": mi.ScalarTransform4f().look_at(origin=pos.tolist(), target=centre.tolist(), up=up)
                @ mi.ScalarTransform4f().scale([a, a, 1.0]),
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [radiance] * 3},
                            "sampling_weight": radiance * math.pi * math.sin(alpha) ** 2},
            }
    env = studio_environment(setting, studio, scale)
    if env is not None:
        out["environment"] = env.emitter(1.0)
        out["environment"]["sampling_weight"] = irradiance_towards(env, np.array([0.0, 0.0, 1.0]))
    zmin = float(frame.points(mesh.bounds[0])[2])
    half = TABLE_HALF_RADII * radius
    out["table"] = {
        "type": "rectangle",
        "to_world": mi.ScalarTransform4f().translate([float(centre[0]), float(centre[1]), zmin - 2e-3 * radius])
        @ mi.ScalarTransform4f().scale([half, half, 1.0]),
        "bsdf": {"type": "diffuse", "reflectance": {"type": "bitmap", "bitmap": mi.Bitmap(table_albedo(studio.backdrop_albedo)),  # float: linear
                                                     "filter_type": "bilinear", "wrap_mode": "clamp"}},
    }
    return out, lamps, env


TABLE_HALF_RADII = 40.0  # the table's half width, in stone radii
CORE_RADIUS = 0.3  # a lamp's core, as a share of its angular radius


def table_albedo(albedo: float, size: int = 512) -> np.ndarray:
    """(size, size, 3) reflectance of the table: ``albedo`` under the stone, falling smoothly to
    45 % of it four stone radii away (a backdrop lit by a spot), then flat."""
    u = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    r = np.hypot(u[None, :], u[:, None]) * TABLE_HALF_RADII  # stone radii from the centre
    fall = 0.45 + 0.55 * np.exp(-((r / 2.2) ** 2))
    return np.repeat((albedo * fall)[..., None], 3, axis=2).astype(np.float32)


def lamp_discs(lamp: Lamp, irradiance: float, core: float) -> dict[str, tuple[float, float, float]]:
    """The discs drawing one lamp: name -> (angular radius in radians, radiance, how far in front
    of the lamp's plane, in stone radii). The whole disc and its core together give the lamp's
    irradiance at the stone: ``π L_disc (sin² α - sin² α_c) + π L_core sin² α_c = E``, the core
    contributing ``core`` of it."""
    alpha = math.radians(lamp.radius_deg)
    s2 = math.sin(alpha) ** 2
    if core <= 0.0:
        return {"disc": (alpha, irradiance / (math.pi * s2), 0.0)}
    alpha_c = CORE_RADIUS * alpha
    c2 = math.sin(alpha_c) ** 2
    return {
        "disc": (alpha, (1.0 - core) * irradiance / (math.pi * (s2 - c2)), 0.0),
        "core": (alpha_c, core * irradiance / (math.pi * c2), 0.01),
    }


def irradiance_at_camera(lamps: list[Lamp], env: Environment | None, camera_direction: Any, scale: float) -> float:
    """Irradiance (render units) on a card at the stone facing the camera: the lamps (``scale``
    times their relative irradiance) and the environment (already scaled; None for none),
    ignoring the table."""
    v = np.asarray(camera_direction, dtype=np.float64)
    v = v / np.linalg.norm(v)
    e = sum(lamp.irradiance * scale * max(0.0, float(np.asarray(lamp.direction) @ v)) for lamp in lamps)
    if env is None:
        return float(e)
    # the table hides what lies below the base plane (mesh -Z): leave that half of the map out
    d = pixel_directions(env.width, env.height).reshape(-1, 3) @ env.rotation.T
    cos = np.clip(d @ v, 0.0, None) * (d[:, 2] > 0.0)
    sa = np.repeat(env.solid_angles()[:, None], env.width, axis=1).ravel()
    return float(e + (env.luminance().ravel() * cos * sa).sum())


# ---------------------------------------------------------------------- body texture
GRID_CELLS = 72  # along the longest side of the stone's box


@functools.lru_cache(maxsize=8)
def _body_grid_cached(lo: tuple[float, ...], hi: tuple[float, ...], inclusions: float, seed: int,
                      translucency: float) -> tuple[np.ndarray, np.ndarray]:
    from .noise import equalise, fbm

    lo_a, hi_a = np.asarray(lo), np.asarray(hi)
    ext = hi_a - lo_a
    step = float(ext.max()) / GRID_CELLS
    shape = tuple(int(max(4, math.ceil(e / step) + 1)) for e in ext)  # nx, ny, nz
    axes = [np.linspace(lo_a[k], hi_a[k], shape[k]) for k in range(3)]
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    p = np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)
    size = float(ext.max())
    # milky cloudiness: low-frequency, +-25 %
    cloud = equalise(fbm(p, size * 0.45, 3, seed))
    body = 0.75 + 0.5 * cloud
    # thin edges: lighter near the base plane (translucent look)
    height = (p[:, 2] - lo_a[2]) / max(ext[2], 1e-9)
    body *= 1.0 + translucency * np.exp(-height / 0.18)
    # dark inclusions: specks (mid frequency) and stretched needles (anisotropic noise)
    mask = np.ones(len(p))
    if inclusions > 0.0:
        specks = equalise(fbm(p, size * 0.035, 2, seed + 101))
        needles = equalise(fbm(p * np.array([1.0, 5.0, 5.0]), size * 0.08, 2, seed + 202))
        t = 1.0 - inclusions
        dark = np.clip((np.maximum(specks, needles * 0.995) - t) / max(0.35 * inclusions, 1e-6), 0.0, 1.0)
        mask = 1.0 - 0.85 * dark
    nx, ny, nz = shape
    grid = np.stack([body * mask, mask], axis=1).reshape(nz, ny, nx, 2).astype(np.float32)
    return grid, np.array([lo_a, hi_a])


def body_grid(mesh: Any, studio: Studio) -> dict[str, Any]:
    """BSDF properties of the studio body: tint, and a baked (nz, ny, nx, 2) grid over the mesh's
    box of (body multiplier, flash mask) (baked in the mesh frame, mm, deterministic for
    ``studio.seed``; its box given in the stone's render frame, where its renders place it)."""
    import mitsuba as mi

    lo = tuple(float(x) for x in mesh.bounds[0])
    hi = tuple(float(x) for x in mesh.bounds[1])
    grid, box = _body_grid_cached(lo, hi, float(studio.inclusions), int(studio.seed), float(studio.translucency))
    pad = 1e-3 * float(np.max(box[1] - box[0]))
    body_lo, body_hi = RenderFrame.of(mesh).box([float(x) - pad for x in box[0]], [float(x) + pad for x in box[1]])
    return {
        "body_tint": [float(x) for x in studio.tint],
        "body_grid": mi.TensorXf(grid),
        "body_lo": body_lo,
        "body_hi": body_hi,
    }
