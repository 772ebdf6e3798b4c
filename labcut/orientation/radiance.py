"""The schiller radiance of one (point, light, view) triple, and the two references flash is measured by.

``L_s`` of a triple (the BSDF's lobe, one implementation in :mod:`labcut.physics.schiller`)::

    L_s(x, v; m) = Σ_l E_l T_i T_o R_Y(|a·h|) (n·l) / (4 |a·h| max(a·n, b·n) η²) · q(h·m)

``a``, ``b`` are the internal directions refracted from ``l`` and ``v`` and ``h = normalize(a + b)``
the lamella orientation that mirrors the light into the eye (DESIGN.md §4).

The references (docs/orientation.md, "What counts as flash"):

* ``L_ref``, the **unit** of every flash value: the schiller of a flat polished face with the lamellae
  parallel to it, lit and viewed along its normal by one light carrying the scene's total irradiance.
* the **scene's peak** ``P`` (in units of ``L_ref``, at most 1): the brightest schiller the scene's own
  lights can give that face, turned towards whatever direction makes it brightest and seen along its
  normal. One point light gives ``P = 1``; a lamp of finite size a little less (its light is spread over
  the lamella lobe); an even ceiling or an overcast sky a small fraction (no direction gathers more than
  a lobe's worth of it).

A point of the stone **flashes** where ``L_s ≥ τ P L_ref``: the threshold is relative to the scene, so
under diffuse light the schiller that stands out from what that light can give at best counts as flash,
where against a face-on lamp of the same irradiance nothing ever would.

Frames: any, as long as the face normals, lights and views share it; irradiances are the lights' weights.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..colour import luminance_table, material_key
from ..errors import ParameterError
from ..physics import schiller as lobe
from ..physics.material import Labradorite
from ..physics.ops import NUMPY
from ..scene import Lights
from ..scene.directions import direction, spherical_cap
from ..scene.envmap import direction_to_pixel, pixel_directions

#: face directions tried over the whole sphere before the best few are polished (besides every light's own)
PEAK_GRID = 512
#: the polished starts: the best face directions of the grid and of the lights
PEAK_STARTS = 3
#: the compass search's first step and the step it stops below (degrees; :func:`polish_peak`): the
#: grid's spacing is about 9°, a lamella lobe's width a few degrees
PEAK_STEP_DEG = 4.0
PEAK_TOL_DEG = 0.002
#: the cap (degrees around the face's normal) and directions over which :func:`sky_schiller` sums the lobe
SKY_CAP_DEG = 70.0
SKY_CAP_SAMPLES = 20000

_SKY: dict[str, float] = {}  # sky_schiller per material key
#: scene peaks by the lights' content and the material (:func:`scene_peak`): lights built anew with
#: the same directions (a scenario resolved again, a rough plan's candidates) find theirs here
_PEAKS: dict[str, float] = {}
_PEAKS_KEPT = 256
#: scene peaks kept in the user cache file (the newest; a scenario's variants and rough plans add a few each)
PEAKS_ON_DISK = 512


def fresnel_dielectric(cos_i: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance from outside (index 1) into index ``eta`` (numpy)."""
    return lobe.fresnel_reflectance(np.asarray(cos_i, dtype=np.float64), eta, NUMPY)


def light_terms(n: np.ndarray, l: np.ndarray, irradiance: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Per (point, light): the internal direction ``a`` and ``E T(n·l) (n·l)``."""
    cos_nl = NUMPY.dot(l, n)
    return lobe.internal_direction(l, n, eta, NUMPY), irradiance * lobe.transmission(cos_nl, eta) * cos_nl


def view_terms(n: np.ndarray, v: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Per (point, view): the internal direction ``b`` and ``T(n·v)``."""
    return lobe.internal_direction(v, n, eta, NUMPY), lobe.transmission(NUMPY.dot(v, n), eta)


def triple_terms(a: np.ndarray, e_t_l: np.ndarray, b: np.ndarray, t_v: np.ndarray, n: np.ndarray, eta: float,
                 table: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per triple: the lamella orientation ``h`` (unit, not folded) and the factor ``w`` in front of
    the lobe, ``L_s = w · q(h·m)``: the BSDF's ``f_s`` (:mod:`labcut.physics.schiller`) times E (n·l)."""
    h, cos_l, max_ab = lobe.mirror_terms(a, b, n, NUMPY)
    r_y = np.interp(np.clip(cos_l, 0.0, 1.0), table[0], table[1])
    return h, lobe.schiller_factor(e_t_l, t_v, cos_l, max_ab, eta, NUMPY) * r_y


def schiller_weights(n: np.ndarray, l: np.ndarray, v: np.ndarray, irradiance: np.ndarray, eta: float,
                     table: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`triple_terms` straight from (T, 3) shading normals, light and view directions."""
    a, e_t_l = light_terms(n, l, irradiance, eta)
    b, t_v = view_terms(n, v, eta)
    return triple_terms(a, e_t_l, b, t_v, n, eta, table)


def reference_radiance(material: Labradorite, total_irradiance: float) -> float:
    """L_ref (DESIGN.md §4): flat polished face, lamellae parallel, lit and viewed along its
    normal by one light of irradiance ``total_irradiance``: ``E T(0)² R_Y(1) q(1) / (4 η²)``."""
    eta = material.n_surface
    t0 = 1.0 - float(fresnel_dielectric(np.array(1.0), eta))
    return total_irradiance * t0 * t0 * float(luminance_table(material)[1][-1]) * material.lobe_norm / (4.0 * eta * eta)


def flat_face_schiller(material: Labradorite, lights: Lights, faces: np.ndarray) -> np.ndarray:
    """Per face direction (rows of ``faces``, unit): the schiller of a flat polished face turned that way,
    lamellae parallel to it, seen along its normal, under ``lights`` scaled to total irradiance 1; in
    units of ``L_ref``. Lights behind the face give nothing.

    The lamps count as the points they are; a lighting's environment map (``lights.environment``)
    counts as the continuous map its samples stand for: the lobe gathers the map's radiance around the
    face's own direction, ``K Y(n)`` with ``K`` the schiller of a sky of unit radiance (:func:`sky_schiller`),
    so the answer does not depend on how many directions sampled the map."""
    faces = np.asarray(faces, dtype=np.float64).reshape(-1, 3)
    total = float(lights.weights.sum())
    k = lights.n_lamps if lights.environment is not None else len(lights.weights)
    out = _point_schiller(material, lights.directions[:k], lights.weights[:k], faces)
    env = lights.environment
    if env is not None:
        row, col = direction_to_pixel(faces @ env.rotation, env.width, env.height)  # frame of use -> the map's
        out = out + sky_schiller(material) * env.luminance()[row, col]
    return out / total


def sky_schiller(material: Labradorite) -> float:
    """``K``: the schiller (units of ``L_ref`` per unit irradiance) a flat polished face, lamellae parallel,
    shows along its normal under a sky of unit radiance, found by summing the lobe over a fine cap of
    directions around the normal (the lobe is a few degrees wide; the cap holds it whole); once per material."""
    key = material_key(material)
    if key not in _SKY:
        _SKY[key] = _sky_schiller(material)
    return _SKY[key]


def _sky_schiller(material: Labradorite) -> float:
    cap = spherical_cap([0.0, 0.0, 1.0], SKY_CAP_DEG, SKY_CAP_SAMPLES)
    solid_angle = 2.0 * math.pi * (1.0 - math.cos(math.radians(SKY_CAP_DEG)))
    weights = np.full(len(cap), solid_angle / len(cap))
    return float(_point_schiller(material, cap, weights, np.array([[0.0, 0.0, 1.0]]))[0])


def _point_schiller(material: Labradorite, directions: np.ndarray, irradiances: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per face direction: the schiller (units of ``L_ref`` per unit irradiance) of point lights of these
    irradiances on the flat face turned that way, seen along its normal."""
    n_f, n_l = len(faces), len(irradiances)
    if n_l == 0:
        return np.zeros(n_f)
    n = np.repeat(faces, n_l, axis=0)
    l = np.tile(np.asarray(directions, dtype=np.float64), (n_f, 1))
    e = np.tile(np.asarray(irradiances, dtype=np.float64), n_f)
    lit = np.einsum("ij,ij->i", n, l) > 1e-9
    out = np.zeros(n_f * n_l)
    if lit.any():
        table = luminance_table(material)
        h, w = schiller_weights(n[lit], l[lit], n[lit], e[lit], material.n_surface, table)
        cos_hm = np.abs(np.einsum("ij,ij->i", h, n[lit]))
        out[lit] = w * material.lobe_norm * np.exp(material.lobe_kappa * (cos_hm - 1.0))
    return out.reshape(n_f, n_l).sum(axis=1) / reference_radiance(material, 1.0)


def scene_peak(material: Labradorite, lights: Lights) -> float:
    """The scene's peak ``P`` (module docstring): the largest :func:`flat_face_schiller` over every face
    direction, in units of ``L_ref`` (0 < P ≤ 1 for lights above some face). Found on a grid of the whole
    sphere, every lamp's own direction and the map's brightest pixels, the best few polished by a simplex
    search; kept with the lights (and their turned copies), per material."""
    key = f"scene peak {material_key(material)}"
    kept = lights.invariants  # shared with the lights' turned copies: P does not depend on the frame
    if key not in kept:
        content = _content_key(lights, key)
        if content not in _PEAKS:
            if len(_PEAKS) >= _PEAKS_KEPT:
                _PEAKS.pop(next(iter(_PEAKS)))
            _PEAKS[content] = _kept_peak(material, lights, content)
        kept[key] = _PEAKS[content]
    return kept[key]


def _kept_peak(material: Labradorite, lights: Lights, content: str) -> float:
    """:func:`_scene_peak`, kept in labcut's user cache (``scene-peaks.json``, :func:`labcut.fileio.calibrations`)
    under the lights' and material's content, labcut's, numpy's and SciPy's versions and a hash of this
    module's code: a new process asks the same lights (every CLI call) and reads the peak back, the
    same float, instead of searching again."""
    import scipy

    from .. import __version__
    from ..fileio import calibrations, code_hash

    key = f"scene peak | labcut {__version__} numpy {np.__version__} scipy {scipy.__version__} | code {code_hash(__file__)} | {content}"
    value = calibrations("scene-peaks.json", [key], lambda missing: [{"peak": _scene_peak(material, lights)}],
                         check=_check_peak, keep=PEAKS_ON_DISK)[0]
    return float(value["peak"])


def _check_peak(value: dict[str, Any]) -> None:
    """Refuse a kept peak that is not a number in (0, 1] (a damaged or foreign file is searched again)."""
    peak = value["peak"]
    if isinstance(peak, bool) or not isinstance(peak, float) or not 0.0 < peak <= 1.0:
        raise ValueError(f"not a scene peak: {peak!r}")


def _content_key(lights: Lights, material: str) -> str:
    """A digest of what :func:`_scene_peak` reads of ``lights`` (directions, weights, how many are
    lamps, the environment map's luminance and rotation) and the material's key."""
    import hashlib

    h = hashlib.sha256(material.encode())
    for a in (lights.directions, lights.weights):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    h.update(str(lights.n_lamps).encode())
    env = lights.environment
    if env is not None:
        h.update(np.ascontiguousarray(env.luminance(), dtype=np.float64).tobytes())
        h.update(np.ascontiguousarray(env.rotation, dtype=np.float64).tobytes())
    return h.hexdigest()


def flash_threshold(material: Labradorite, lights: Lights, tau: float) -> float:
    """The flash threshold in units of ``L_ref``: ``τ P`` (a point flashes where ``L_s ≥ τ P L_ref``)."""
    return float(tau) * scene_peak(material, lights)


def _scene_peak(material: Labradorite, lights: Lights) -> float:
    parts = [spherical_cap([0.0, 0.0, 1.0], 180.0, PEAK_GRID), lights.lamp_directions if lights.environment is not None
             else lights.directions]
    env = lights.environment
    if env is not None:  # the map's brightest pixels, in the frame of use
        brightest = np.argsort(env.luminance().ravel())[::-1][:PEAK_STARTS]
        parts.append(pixel_directions(env.width, env.height).reshape(-1, 3)[brightest] @ env.rotation.T)
    faces = np.vstack(parts)
    values = flat_face_schiller(material, lights, faces)
    best = float(values.max(initial=0.0))
    if not best > 0.0:
        raise ParameterError(f"the lights {lights.name!r} give no schiller to any face: no flash threshold can be set")

    starts = np.argsort(values)[::-1][:PEAK_STARTS]
    best = max(best, polish_peak(lambda d: flat_face_schiller(material, lights, d), faces[starts], values[starts]))
    return min(best, 1.0)


def polish_peak(f: Any, starts: np.ndarray, values: np.ndarray, step_deg: float = PEAK_STEP_DEG,
                tol_deg: float = PEAK_TOL_DEG) -> float:
    """The largest ``f`` (a function of unit directions, (n, 3) -> (n,)) found by a compass search
    from each of ``starts`` (unit, (k, 3); ``values``: ``f`` there): each start tries the eight
    directions ``step`` away in its tangent plane (along two orthogonal axes and their diagonals),
    moves to the best of them where it is brighter, halves its step where none is, and stops
    below ``tol_deg``. All starts go together, one call of ``f`` per round; no chart of the sphere
    (no pole where steps shrink)."""
    d = np.array(starts, dtype=np.float64, copy=True)
    best = np.array(values, dtype=np.float64, copy=True)
    step = np.full(len(d), math.radians(step_deg))
    pattern = np.array([(a, b) for a in (-1.0, 0.0, 1.0) for b in (-1.0, 0.0, 1.0) if (a, b) != (0.0, 0.0)])
    tol = math.radians(tol_deg)
    active = step > tol
    while active.any():
        dk = d[active]
        helper = np.where(np.abs(dk[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        u = np.cross(dk, helper)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        v = np.cross(dk, u)
        offsets = pattern[None, :, 0:1] * u[:, None, :] + pattern[None, :, 1:2] * v[:, None, :]  # (k, 8, 3)
        cand = dk[:, None, :] + step[active][:, None, None] * offsets
        cand /= np.linalg.norm(cand, axis=2, keepdims=True)
        vals = np.asarray(f(cand.reshape(-1, 3)), dtype=np.float64).reshape(len(dk), len(pattern))
        j = np.argmax(vals, axis=1)
        top = vals[np.arange(len(dk)), j]
        idx = np.flatnonzero(active)
        up = top > best[idx]
        d[idx[up]] = cand[np.flatnonzero(up), j[up]]
        best[idx[up]] = top[up]
        step[idx[~up]] *= 0.5
        active = step > tol
    return float(best.max(initial=0.0))
