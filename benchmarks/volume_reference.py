"""A volumetric reference for the flash: lamellae as reflecting planes through the stone (issue 38).

    .venv/bin/python benchmarks/volume_reference.py slab           # the reference checked on a slab
    .venv/bin/python benchmarks/volume_reference.py compare        # labcut's answers against it
    .venv/bin/python benchmarks/volume_reference.py answers        # labcut's side of it again (seconds)
    .venv/bin/python benchmarks/volume_reference.py model-scans    # labcut's flash along the same scans
    .venv/bin/python benchmarks/volume_reference.py factor         # the ovals' answers with the planes' a·n
    .venv/bin/python benchmarks/volume_reference.py fit-check      # the fit at the reference's noise
    .venv/bin/python benchmarks/volume_reference.py surface-limit --paths 4000000  # the model's physics by Monte Carlo
    .venv/bin/python benchmarks/volume_reference.py converge       # labcut's answer with more surface points
    .venv/bin/python benchmarks/volume_reference.py planner        # surface against volume, every bundled cut
    .venv/bin/python benchmarks/volume_reference.py report         # the tables into the docs

An independent Monte Carlo light transport through the stone, written apart from labcut's flash
estimators (it uses labcut only for the mesh, the material's stack reflectance, the lamp and view
directions and Mitsuba's ray casts against the smooth-shaded mesh):

* **Camera paths** start at the viewer (an orthographic view of each of the scenario's view
  directions, uniform over the stone's outline), refract into the polished surface (Fresnel
  transmission as weight, Snell with the smooth shading normal) and travel straight through the
  stone.
* **The lamellae are planes**, :data:`PLANES` of them over the stack's depth ``D = N (d_a + d_b)``,
  counted from the surface point the path last came in through (traced from the viewer: the point
  that is seen; after a reflection inside, where it was reflected). Their normal is the domain's: drawn
  from the material's mosaic (an axial von Mises-Fisher distribution of spread ``spread_deg`` around
  the mean lamella normal) where the light comes in, shared by every plane the path meets there (light
  mirrored back and forth between them keeps one mirror direction). A path crossing plane ``k`` is
  mirrored with probability ``rho_k(lambda, cos)`` or passes. The ``rho_k`` are derived from the model's own saturation law: with ``R_k`` the stack
  reflectance of the first ``N k / PLANES`` pairs (:meth:`labcut.Labradorite.reflectance` of the cut
  stack), a pile of plates adding plane ``k`` under the first ``k - 1`` reflects ``R_k`` when
  ``rho_k = (R_k - R_{k-1}) / ((1 - R_{k-1})^2 + R_{k-1} (R_k - R_{k-1}))`` (lossless plates, light
  bouncing between them in every order). So a stack at least ``D`` thick reflects exactly the
  model's ``R(lambda, theta)``, built up over the depth as the model's localisation law builds it,
  with every multiple reflection between the planes carried; ``slab`` checks both.
* **At the surface** a path is reflected inside (Fresnel, total internal reflection) or leaves;
  leaving after at least one lamella reflection, it scores the lamp's radiance if its direction falls
  in the lamp's disc. A wavelength per path is drawn from D65 x ybar, so the mean is the luminance
  ratio the flash metrics use.

Nothing here is the volume estimator's: no fixed point, no depth law sampled, no single reflection,
no factor ``max(a.n, b.n)``; multiple lamella reflections, internal Fresnel reflections and the
beam's focusing by the curved surface are all in.

``compare`` runs labcut's default recommendation (estimator ``auto``, quality standard) of the
low, medium and high oval and the biplane carving under a lamp 35 deg in front (a 4 deg disc, so that
paths can find it) and the overhead lamp, face-up viewers, and scans the reference's flash energy
along two great circles through labcut's answer (front-back and left-right, the lamp's plane first),
over 1.6 times the answer's tolerance either side; the reference optimum is the top of a
least-squares cubic through each scan (:data:`FIT_DEGREE`), its 90 % tolerance the nearer point where
the cubic falls to 90 % of its top (the smaller of the two axes'), each with its standard deviation
from the fit (:func:`scan_fit`). ``answers`` records labcut's side again (its tolerances along the
two scans too) without tracing the reference. Results: ``benchmarks/data/volume_reference.json`` (``planner``'s in
``benchmarks/data/volume_planner.json``); ``report`` writes the tables between the ``VOLUME-REFERENCE``
markers of docs/physics-accuracy.md, ``DEPTH-OFF`` of docs/planner.md and ``VOLUME-COST`` of docs/accuracy.md.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import labcut  # noqa: E402
from labcut.colour import tables  # noqa: E402
from labcut.orientation.volume import VolumeRays  # noqa: E402
from labcut.rendering.rays import surface_offset  # noqa: E402
from labcut.scene.directions import direction  # noqa: E402
from labcut.scene.presets import FRONT_AZIMUTH_DEG  # noqa: E402

#: lamella planes over the stack's depth
PLANES = 48
#: wavelengths of the reflectance tables (nm)
WAVELENGTHS = np.arange(380.0, 781.0, 5.0)
#: internal cosines of the reflectance tables
COSINES = np.linspace(0.0, 1.0, 257)
#: the most surface events of a path (a path still inside after them is dropped: < 1e-4 of the flux)
MAX_SURFACE_EVENTS = 12
#: the lamp 35 deg in front, as a disc of this radius (deg) in the comparison (paths must find it)
SPOT_RADIUS_DEG = 4.0
DATA = ROOT / "benchmarks" / "data" / "volume_reference.json"
PLANNER_DATA = ROOT / "benchmarks" / "data" / "volume_planner.json"
DOC = ROOT / "docs" / "physics-accuracy.md"
BEGIN, END = "<!-- VOLUME-REFERENCE:BEGIN -->", "<!-- VOLUME-REFERENCE:END -->"
STONES = {"low oval": "meshes/oval-16x12-low.ply", "medium oval": "meshes/oval-16x12-medium.ply",
          "high oval": "meshes/oval-16x12-high.ply", "biplane": "meshes/carving-biplane.ply"}


# ---------------------------------------------------------------------- the stack as planes
class Planes:
    """Per-plane reflectances ``rho[k, lambda, cos]`` of :data:`PLANES` planes (module docstring)."""

    def __init__(self, material: labcut.Labradorite, planes: int = PLANES) -> None:
        self.material = material
        self.planes = planes
        self.depth_mm = material.stack_depth_mm
        self.spacing = self.depth_mm / planes
        pairs = material.pairs * np.arange(0, planes + 1) / planes
        r = np.zeros((planes + 1, len(WAVELENGTHS), len(COSINES)))
        for k in range(1, planes + 1):
            stack = material.stack._replace(pairs=float(pairs[k]))
            r[k] = np.asarray(stack.reflectance(WAVELENGTHS[:, None], COSINES[None, :]), dtype=np.float64)
        self.cumulative = r  # R_k: the first k planes together
        d = np.diff(r, axis=0)
        prev = r[:-1]
        self.rho = np.clip(d / np.maximum((1.0 - prev) ** 2 + prev * d, 1e-300), 0.0, 1.0)  # (planes, L, C)
        log_pass = np.log1p(-np.minimum(self.rho, 1.0 - 1e-12))  # (planes, L, C)
        self.log_pass = np.concatenate([np.zeros((len(WAVELENGTHS), len(COSINES), 1)),
                                        np.cumsum(np.moveaxis(log_pass, 0, -1), axis=-1)], axis=-1)  # (L, C, planes + 1)
        t = tables()
        weight = np.interp(WAVELENGTHS, t.wavelengths, t.d65 * t.xyz_bar[:, 1])
        self.lambda_cdf = np.cumsum(weight) / weight.sum()

    def draw_lambda(self, u: np.ndarray) -> np.ndarray:
        """Wavelength indices drawn from D65 x ybar (the luminance's weights) by the uniforms ``u``."""
        return np.minimum(np.searchsorted(self.lambda_cdf, u), len(WAVELENGTHS) - 1)

    def next_mirror(self, u: np.ndarray, depth: np.ndarray, rate: np.ndarray, lam: np.ndarray,
                    cos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(k, t)``: the plane (1-based) that mirrors each path next and the distance to it (inf:
        none before the path leaves the stack), for paths at ``depth`` (mm below their entry) moving
        at ``rate`` (mm of depth per mm of path) with wavelength index ``lam`` and cosine ``cos`` to the
        planes: the planes the path meets in turn pass it with probability ``1 - rho_k`` each, so the
        first that does not is found from one uniform number against the running product
        (the cumulative sums of ``log(1 - rho)``, by bisection), not plane by plane."""
        n = len(depth)
        x = np.clip(cos, 0.0, 1.0) * (len(COSINES) - 1)
        c = np.minimum(x.astype(np.int64), len(COSINES) - 2)
        f = (x - c)[:, None]
        # (n, planes + 1): C[0] = 0, C[k] = sum_{i<=k} log(1 - rho_i), linear in the cosine (the
        # stack's luminance moves by per cent per nanometre of Bragg shift: no nearest row)
        logs = self.log_pass[lam, c] * (1.0 - f) + self.log_pass[lam, c + 1] * f
        target = np.log(np.maximum(u, 1e-300))
        going_down = rate > 0
        first = np.where(going_down, np.floor(depth / self.spacing + 1e-9) + 1.0,
                         np.ceil(depth / self.spacing - 1e-9) - 1.0).astype(np.int64)
        rows = np.arange(n)
        k = np.full(n, -1, dtype=np.int64)
        # down: the smallest j >= first with C[j] - C[first - 1] < target
        d = np.flatnonzero(going_down & (first >= 1) & (first <= self.planes))
        if d.size:
            base = logs[rows[d], first[d] - 1] + target[d]
            found = logs[rows[d], self.planes] < base
            lo, hi = first[d].copy(), np.full(d.size, self.planes)
            for _ in range(int(math.ceil(math.log2(self.planes + 1))) + 1):
                mid = (lo + hi) // 2
                below = logs[rows[d], mid] < base
                hi = np.where(below, mid, hi)
                lo = np.where(below, lo, mid + 1)
            k[d] = np.where(found, hi, -1)
        # up: the largest j <= first with C[first] - C[j - 1] < target
        u = np.flatnonzero(~going_down & (rate < 0) & (first >= 1))
        if u.size:
            top = np.minimum(first[u], self.planes)
            base = logs[rows[u], top] - target[u]
            found = logs[rows[u], 0] > base
            lo, hi = np.ones(u.size, dtype=np.int64), top.copy()
            for _ in range(int(math.ceil(math.log2(self.planes + 1))) + 1):
                mid = (lo + hi + 1) // 2
                above = logs[rows[u], mid - 1] > base
                lo = np.where(above, mid, lo)
                hi = np.where(above, hi, mid - 1)
            k[u] = np.where(found, lo, -1)
        t = np.full(n, np.inf)
        ok = k >= 1
        t[ok] = (k[ok] * self.spacing - depth[ok]) / rate[ok]
        t[ok & (t < 0)] = np.inf
        return k, t

    def reflectance(self, k: np.ndarray, lam: np.ndarray, cos: np.ndarray) -> np.ndarray:
        """``rho`` of plane ``k`` (1-based) at wavelength index ``lam`` and internal cosine ``cos``."""
        x = np.clip(cos, 0.0, 1.0) * (len(COSINES) - 1)
        i = np.minimum(x.astype(np.int64), len(COSINES) - 2)
        f = x - i
        row = self.rho[k - 1, lam]
        return row[np.arange(len(k)), i] * (1 - f) + row[np.arange(len(k)), i + 1] * f


def luminance_reflectance(material: labcut.Labradorite, cos: float) -> float:
    """The model's luminance-weighted reflectance ``R_Y(cos)`` on :data:`WAVELENGTHS` (D65 x ybar)."""
    t = tables()
    weight = np.interp(WAVELENGTHS, t.wavelengths, t.d65 * t.xyz_bar[:, 1])
    return float(np.sum(weight * np.asarray(material.reflectance(WAVELENGTHS, cos))) / weight.sum())


# ---------------------------------------------------------------------- optics
def fresnel(cos_i: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance from inside (index ``eta``) to outside (1) at cosine ``cos_i``
    (1 beyond the critical angle), or from outside in for ``eta < 1``."""
    cos_i = np.clip(np.abs(cos_i), 0.0, 1.0)
    sin_t2 = eta * eta * (1.0 - cos_i * cos_i)
    tir = sin_t2 >= 1.0
    cos_t = np.sqrt(np.clip(1.0 - sin_t2, 0.0, 1.0))
    rs = (eta * cos_i - cos_t) / np.maximum(eta * cos_i + cos_t, 1e-300)
    rp = (cos_i - eta * cos_t) / np.maximum(cos_i + eta * cos_t, 1e-300)
    return np.where(tir, 1.0, 0.5 * (rs * rs + rp * rp))


def refract(w: np.ndarray, n: np.ndarray, eta: float) -> np.ndarray:
    """Direction ``w`` (travelling towards the surface of normal ``n``, w.n < 0 relative to the
    side it comes from) refracted with relative index ``eta`` (n_from / n_to); NaN rows at TIR."""
    cos_i = -np.einsum("ij,ij->i", w, n)
    sin_t2 = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = np.sqrt(np.where(sin_t2 < 1.0, 1.0 - sin_t2, np.nan))
    return eta * w + (eta * cos_i - cos_t)[:, None] * n


def reflect(w: np.ndarray, n: np.ndarray) -> np.ndarray:
    return w - 2.0 * np.einsum("ij,ij->i", w, n)[:, None] * n


def frame(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to ``m`` and to each other."""
    a = np.array([1.0, 0.0, 0.0]) if abs(m[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(m, a)
    t /= np.linalg.norm(t)
    return t, np.cross(m, t)


def draw_mosaic(m: np.ndarray, kappa: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Lamella normals from the axial vMF of concentration ``kappa`` around ``m`` (Wood 1994), one
    per pair of uniforms ``u``, ``v``."""
    cos = 1.0 + np.log(u + (1.0 - u) * np.exp(-2.0 * kappa)) / kappa
    sin = np.sqrt(np.clip(1.0 - cos * cos, 0.0, 1.0))
    phi = 2.0 * np.pi * v
    t, b = frame(m)
    return cos[:, None] * m + sin[:, None] * (np.cos(phi)[:, None] * t + np.sin(phi)[:, None] * b)


class Streams:
    """Counter-based uniform numbers: path ``i``'s number ``k`` of stream ``s`` is a hash (splitmix64)
    of ``(seed, i, k, s)`` alone. So a path draws the same numbers whatever the other paths do, and a
    scan over lamella normals is traced with the same numbers at every normal (common random
    numbers: its differences are smooth, not the lottery of which paths find the lamp)."""

    def __init__(self, seed: int) -> None:
        self.seed = np.uint64(seed)

    def uniform(self, ids: np.ndarray, counter: np.ndarray | int, stream: int) -> np.ndarray:
        with np.errstate(over="ignore"):
            x = (np.asarray(ids, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)
                 + np.asarray(counter, dtype=np.uint64) * np.uint64(0xD1B54A32D192ED03)
                 + np.uint64(stream) * np.uint64(0x8CB92BA72F3D8DD7) + self.seed * np.uint64(0xDB4F0B9175AE2165))
            x ^= x >> np.uint64(30)
            x *= np.uint64(0xBF58476D1CE4E5B9)
            x ^= x >> np.uint64(27)
            x *= np.uint64(0x94D049BB133111EB)
            x ^= x >> np.uint64(31)
        return ((x >> np.uint64(11)).astype(np.float64) + 0.5) * 2.0 ** -53


# ---------------------------------------------------------------------- the tracer
def outline_box(mesh: object) -> tuple[np.ndarray, float]:
    """``(centre, radius)``: the centre of the stone's bounding box and a radius 1 % beyond its half
    diagonal, the square every view's camera paths start from (uniform over it)."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    return 0.5 * (v.min(axis=0) + v.max(axis=0)), 0.5 * float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) * 1.01


class Reference:
    """The volumetric reference of one stone and material (module docstring)."""

    def __init__(self, mesh: object, material: labcut.Labradorite, planes: int = PLANES,
                 surface_events: int = MAX_SURFACE_EVENTS) -> None:
        self.mesh = mesh
        self.material = material
        self.planes = Planes(material, planes)
        #: the surface events a path may have (1: no reflection inside, the first meeting with the
        #: surface from inside is the last: what the estimators carry)
        self.surface_events = int(surface_events)
        self.rays = VolumeRays(mesh)
        self.eps = surface_offset(mesh)
        self.eta = float(material.n_surface)
        self.kappa = float(material.lobe_kappa)
        self.centre, self.radius = outline_box(mesh)

    def radiance(self, normal: np.ndarray, view: np.ndarray, lamp: np.ndarray, lamp_radius_deg: float, paths: int,
                 seed: int, half_width: float | None = None) -> tuple[float, float, int]:
        """``(mean schiller radiance over the stone's visible outline, its standard error, hits)`` seen
        from the unit direction ``view`` (orthographic, towards the stone), lamellae of mean normal
        ``normal``, lit by a disc lamp of irradiance 1 (normal to its centre ``lamp``). ``half_width``:
        look at a square of that half width (mm) around the stone's centre only (a slab's middle)."""
        rng = Streams(seed)
        ids = np.arange(paths)
        m = np.asarray(normal, dtype=np.float64) / np.linalg.norm(normal)
        v = np.asarray(view, dtype=np.float64) / np.linalg.norm(view)
        t, b = frame(v)
        xy = (np.stack([rng.uniform(ids, 0, 0), rng.uniform(ids, 0, 1)], axis=1) * 2.0 - 1.0) * (
            self.radius if half_width is None else half_width)
        origin = self.centre + 2.0 * self.radius * v + xy[:, :1] * t + xy[:, 1:] * b
        w = np.tile(-v, (paths, 1))
        hit = self.rays.cast(origin, w)
        seen = np.isfinite(hit.t)
        n_seen = int(seen.sum())
        if n_seen == 0:
            return 0.0, 0.0, 0
        x = origin[seen] + hit.t[seen, None] * w[seen]
        n = hit.n_sh[seen]
        w = w[seen]
        cos_in = -np.einsum("ij,ij->i", w, n)
        ok = cos_in > 0
        weight = np.where(ok, 1.0 - fresnel(cos_in, 1.0 / self.eta), 0.0)
        w = refract(w, np.where(ok[:, None], n, -n), 1.0 / self.eta)
        lost = ~np.all(np.isfinite(w), axis=1)
        weight[lost] = 0.0
        w[lost] = -v
        x = x - self.eps * hit.n_geo[seen]
        ids = ids[seen]
        lam = self.planes.draw_lambda(rng.uniform(ids, 0, 2))
        score = self._trace(rng, ids, m, x, w, weight, lam, lamp / np.linalg.norm(lamp), lamp_radius_deg)
        # over the whole outline: the paths that hit, weighted alike
        return float(score.mean()), float(score.std(ddof=1) / math.sqrt(n_seen)), int(np.count_nonzero(score))

    def _trace(self, rng: Streams, ids: np.ndarray, m: np.ndarray, x: np.ndarray, w: np.ndarray, weight: np.ndarray,
               lam: np.ndarray, lamp: np.ndarray, lamp_radius_deg: float) -> np.ndarray:
        """The radiance each path brings back from the lamp (its schiller part)."""
        pl = self.planes
        n = len(x)
        score = np.zeros(n)
        idx = np.arange(n)
        # each path's lamellae: one domain of the mosaic, drawn where the light comes in (every plane
        # the path meets there shares its normal, so light mirrored back and forth between them
        # keeps one mirror direction: the model's whole reflectance in one lobe)
        dom = draw_mosaic(m, self.kappa, rng.uniform(ids, 0, 3), rng.uniform(ids, 0, 4))
        step = np.zeros(n, dtype=np.int64)  # each path's count of steps: the counter of its numbers
        entry = np.einsum("ij,ij->i", x, dom)  # the plane coordinate of the point the light came in through
        down = np.sign(np.einsum("ij,ij->i", w, dom))  # the way into the stack from there
        down[down == 0] = 1.0
        mirrored = np.zeros(n, dtype=bool)
        events = np.zeros(n, dtype=np.int64)
        bound = self.rays.cast(x, w).t
        cos_lamp = math.cos(math.radians(lamp_radius_deg))
        lamp_radiance = 1.0 / (math.pi * math.sin(math.radians(lamp_radius_deg)) ** 2)
        alive = np.isfinite(bound) & (weight > 0)
        x, w, weight, lam, entry, down, mirrored, events, bound, idx, dom, step = (
            a[alive] for a in (x, w, weight, lam, entry, down, mirrored, events, bound, idx, dom, step))
        while len(idx):
            step += 1
            pid = ids[idx]
            wm = np.einsum("ij,ij->i", w, dom)
            depth = (np.einsum("ij,ij->i", x, dom) - entry) * down  # below the entry, along the way in
            rate = wm * down
            k, t_plane = pl.next_mirror(rng.uniform(pid, step, 5), depth, rate, lam, np.abs(wm))
            at_plane = t_plane < bound
            # --- the plane that mirrors the path (the ones before it passed)
            r_idx = np.flatnonzero(at_plane)
            if r_idx.size:
                x[r_idx] += w[r_idx] * t_plane[r_idx, None]
                w[r_idx] = reflect(w[r_idx], dom[r_idx])
                w[r_idx] /= np.linalg.norm(w[r_idx], axis=1, keepdims=True)
                mirrored[r_idx] = True
                bound[r_idx] = self.rays.cast(x[r_idx], w[r_idx]).t
            # --- the surface: reflected inside, or out
            s_idx = np.flatnonzero(~at_plane)
            done = np.zeros(len(idx), dtype=bool)
            if s_idx.size:
                hit_ok = np.isfinite(bound[s_idx])
                done[s_idx[~hit_ok]] = True
                s_idx = s_idx[hit_ok]
            if s_idx.size:
                xs = x[s_idx] + w[s_idx] * bound[s_idx, None]
                probe = self.rays.cast(x[s_idx], w[s_idx])  # the normals at the hit
                n_sh = probe.n_sh
                flip = np.einsum("ij,ij->i", w[s_idx], n_sh) <= 0
                n_sh[flip] = probe.n_geo[flip]
                cos_i = np.einsum("ij,ij->i", w[s_idx], n_sh)
                f = fresnel(cos_i, self.eta)
                inside = rng.uniform(pid[s_idx], step[s_idx], 6) < f
                events[s_idx] += 1
                out = s_idx[~inside]
                if out.size:
                    o = refract(w[out], -n_sh[~inside], self.eta)
                    good = np.all(np.isfinite(o), axis=1)
                    o[good] /= np.linalg.norm(o[good], axis=1, keepdims=True)
                    in_lamp = good & (np.nan_to_num(o @ lamp) >= cos_lamp) & mirrored[out]
                    score[idx[out[in_lamp]]] += weight[out[in_lamp]] * lamp_radiance
                    done[out] = True
                back = s_idx[inside]
                if back.size:
                    w[back] = reflect(w[back], n_sh[inside])
                    x[back] = xs[inside] - self.eps * probe.n_geo[inside]
                    dom[back] = draw_mosaic(m, self.kappa, rng.uniform(pid[back], step[back], 7),
                                            rng.uniform(pid[back], step[back], 8))  # another place: another domain
                    entry[back] = np.einsum("ij,ij->i", x[back], dom[back])
                    d = np.sign(np.einsum("ij,ij->i", w[back], dom[back]))
                    down[back] = np.where(d == 0, 1.0, d)
                    bound[back] = self.rays.cast(x[back], w[back]).t
                    done[back[events[back] >= self.surface_events]] = True
            keep = ~done
            x, w, weight, lam, entry, down, mirrored, events, bound, idx, dom, step = (
                a[keep] for a in (x, w, weight, lam, entry, down, mirrored, events, bound, idx, dom, step))
        return score


# ---------------------------------------------------------------------- the slab check
def slab_check(paths: int = 400_000) -> dict:
    """The reference on a flat slab 3 mm thick (thicker than the stack): (1) the planes alone, a
    pile walked plane by plane in one dimension, reflect the model's luminance reflectance at every
    angle; (2) the flash radiance of the slab (lamellae parallel to the face, and tilted to mirror a
    lamp 20 deg from the vertical into a viewer straight above) against labcut's flash model, which is
    exact for a flat face but for its factor ``max(a.n, b.n)`` (the reference's is ``a.n``: 2.5 % here)."""
    from labcut.orientation.radiance import reference_radiance

    mat = labcut.Labradorite()
    planes = Planes(mat)
    rng = np.random.default_rng(1)
    rows = []
    for cos in (1.0, 0.9, 0.75, 0.6):
        lam = planes.draw_lambda(rng.random(paths))
        cos_arr = np.full(paths, cos)
        depth = np.zeros(paths)
        rate = np.full(paths, cos)
        returned = np.zeros(paths, dtype=bool)
        active = np.arange(paths)
        for _ in range(200):  # down and up until each walker leaves the stack
            if not active.size:
                break
            k, t = planes.next_mirror(rng.random(active.size), depth[active], rate[active], lam[active], cos_arr[active])
            mirrored = np.isfinite(t)
            out = active[~mirrored]
            returned[out] = rate[out] < 0  # left through the top
            hit = active[mirrored]
            depth[hit] = k[mirrored] * planes.spacing
            rate[hit] = -rate[hit]
            active = hit
        want = luminance_reflectance(mat, cos)
        got = float(returned.mean())
        rows.append({"cos": cos, "model_R_Y": want, "planes_R_Y": got, "error": float(math.sqrt(got * (1 - got) / paths))})
    slab = labcut.load_mesh(str(ROOT / "meshes" / "slab-20x20x3.ply"))
    ref = Reference(slab, mat)
    lref = reference_radiance(mat, 1.0)
    z = np.array([0.0, 0.0, 1.0])
    lamp = direction(20.0, FRONT_AZIMUTH_DEG)
    a_int = math.degrees(math.asin(math.sin(math.radians(20.0)) / mat.n_surface))
    radiance = []
    for tilt in (0.0, 0.5 * a_int - 2.0, 0.5 * a_int, 0.5 * a_int + 2.0):
        m = direction(tilt, FRONT_AZIMUTH_DEG)
        value, error, _hits = ref.radiance(m, z, lamp, SPOT_RADIUS_DEG, 4 * paths, 7, half_width=5.0)
        model = labcut.evaluate_orientation(slab, m, lighting=labcut.Lights.lamp(lamp, SPOT_RADIUS_DEG, 1.0, 1000),
                                            viewing=labcut.Views([z]), quality="high").flash_energy
        radiance.append({"tilt_deg": tilt, "reference": value / lref, "error": error / lref, "model": float(model)})
    return {"stack": rows, "radiance": radiance}


# ---------------------------------------------------------------------- the comparison
def rotate(v: np.ndarray, axis: np.ndarray, deg: float) -> np.ndarray:
    """``v`` turned by ``deg`` about the unit ``axis`` (Rodrigues)."""
    a = math.radians(deg)
    return v * math.cos(a) + np.cross(axis, v) * math.sin(a) + axis * float(axis @ v) * (1.0 - math.cos(a))


def scan_axes(normal: np.ndarray) -> dict[str, np.ndarray]:
    """The rotation axes of the two scans through ``normal``: ``tilt`` (in the plane of the normal
    and +Z: front-back for an answer tilted to the front; the X axis for an answer near the pole)
    and ``side`` (perpendicular)."""
    z = np.array([0.0, 0.0, 1.0])
    c = np.cross(z, normal)
    first = c / np.linalg.norm(c) if np.linalg.norm(c) > math.sin(math.radians(0.5)) else np.array([1.0, 0.0, 0.0])
    second = np.cross(normal, first)
    return {"tilt": first, "side": second / np.linalg.norm(second)}


def energy(ref: Reference, normal: np.ndarray, views: labcut.Views, lamp: np.ndarray, radius: float, paths: int,
           lref: float) -> tuple[float, float]:
    """The reference's flash energy (units of L_ref) of a lamella normal: the view-weighted mean of
    each view's mean schiller radiance over the stone's outline, and its standard error. Each view
    keeps its seed for every normal (common random numbers: a scan is smooth)."""
    w = np.asarray(views.weights, dtype=np.float64)
    w = w / w.sum()
    total, var = 0.0, 0.0
    for k, v in enumerate(views.directions):
        value, error, _hits = ref.radiance(normal, v, lamp, radius, paths, 1000 + k)
        total += w[k] * value
        var += (w[k] * error) ** 2
    return total / lref, math.sqrt(var) / lref


#: the degree of the polynomial fitted through a scan: a parabola (2) is symmetric, and on a flash that falls
#: off faster on one side (a high dome under the overhead lamp) its vertex lies up to a degree from the
#: top (labcut's own noise-free flash along the same scans: 0.97° off its optimum); a cubic finds the top
#: within 0.2° there and within 0.05° on every other case (``model-scans``), with one coefficient more
#: for the noise to move (each fit's standard deviations say how much)
FIT_DEGREE = 3
#: the other polynomial degrees whose tops give the reference tilt's fit spread (:func:`reference_optimum`)
FIT_SPREAD_DEGREES = (2, 4)


def _fit_top(coef: np.ndarray, lo: float, hi: float) -> tuple[float, float, float]:
    """``(x, top, tolerance)`` of the polynomial ``coef`` (numpy order) on ``[lo, hi]``: its local
    maximum there (the highest, where a cubic could have one more; nan where it has none), the value
    there and the 90 % tolerance, the distance from ``x`` to the nearer point either side where the
    polynomial falls to 90 % of ``top`` (inf where it does not within reach)."""
    coef = np.asarray(coef, dtype=np.float64)
    d1, d2 = np.polyder(coef), np.polyder(coef, 2)
    roots = np.roots(d1) if len(d1) > 1 else np.array([])
    cands = [float(r.real) for r in roots if abs(r.imag) < 1e-12 and lo - 1e-9 <= r.real <= hi + 1e-9
             and np.polyval(d2, r.real) < 0]
    if not cands:
        return math.nan, math.nan, math.inf
    x = max(cands, key=lambda r: np.polyval(coef, r))
    top = float(np.polyval(coef, x))
    if not top > 0:
        return x, top, math.inf
    shifted = coef.copy()
    shifted[-1] -= 0.9 * top
    cross = [float(r.real) for r in np.roots(shifted) if abs(r.imag) < 1e-9]
    below = [x - r for r in cross if r < x]
    above = [r - x for r in cross if r > x]
    return x, top, min(min(below, default=math.inf), min(above, default=math.inf))


def scan_fit(offsets: np.ndarray, values: np.ndarray, errors: np.ndarray, degree: int = FIT_DEGREE) -> dict[str, float]:
    """The optimum and 90 % tolerance of one scan with their precision: a least-squares polynomial of
    ``degree`` through every point (weighted by their standard errors; the scan spans about 1.6 times
    the answer's tolerance either side), its top within the scan the optimum (``peak``, an offset in
    degrees) and the nearer 90 % point either side the tolerance (:func:`_fit_top`). The standard
    deviations ``peak_sd`` and ``tolerance_sd`` are propagated from the fit's covariance (the delta
    method, central differences); the covariance is the one the points' standard errors give, scaled
    up by ``chi2 / dof`` where the scan scatters more than they say (never down: common random numbers
    make neighbouring points' errors alike, so a smaller scatter is not a smaller error)."""
    x = np.asarray(offsets, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    sig = np.maximum(np.asarray(errors, dtype=np.float64), 1e-12)
    coef, cov = np.polyfit(x, y, degree, w=1.0 / sig, cov="unscaled")
    chi2 = float(np.sum(((np.polyval(coef, x) - y) / sig) ** 2) / max(1, len(x) - degree - 1))
    cov = cov * max(1.0, chi2)
    lo, hi = float(x.min()), float(x.max())

    def derived(c: np.ndarray) -> np.ndarray:
        peak, _top, tol = _fit_top(c, lo, hi)
        return np.array([peak, tol])

    value = derived(coef)
    top = _fit_top(coef, lo, hi)[1]
    if not np.all(np.isfinite(value)):
        return {"peak": float(value[0]), "peak_sd": math.inf, "top": top, "tolerance": float(value[1]),
                "tolerance_sd": math.inf, "chi2": chi2}
    jac = np.empty((2, len(coef)))
    for i in range(len(coef)):
        h = 1e-6 * max(1.0, abs(coef[i]))
        up, down = coef.copy(), coef.copy()
        up[i] += h
        down[i] -= h
        jac[:, i] = (derived(up) - derived(down)) / (2.0 * h)
    rows = np.all(np.isfinite(jac), axis=1)  # a 90 % point that leaves reach under a small step: no precision
    sd = np.full(2, math.inf)
    sd[rows] = np.sqrt(np.maximum(np.diag(jac[rows] @ cov @ jac[rows].T), 0.0))
    return {"peak": float(value[0]), "peak_sd": float(sd[0]), "top": top, "tolerance": float(value[1]),
            "tolerance_sd": float(sd[1]), "chi2": chi2}


def reference_optimum(case: dict) -> dict[str, object]:
    """One case's reference answer from its scans (:func:`scan_fit` of each): the optimum normal (the
    scans' centre, :func:`scan_centre`, turned by the tilt scan's peak about its axis, then by the side scan's), its tilt, the 90 %
    tolerance (the smaller scan's) and their standard deviations, the tilt's carried through the two
    rotations (central differences of the tilt in each scan's offset: near the pole either scan moves it)."""
    n0 = scan_centre(case)
    scans = case["scans"]
    fits = {name: scan_fit(s["offsets_deg"], s["energy"], s["error"]) for name, s in scans.items()}
    axes = {name: np.asarray(s["axis"], dtype=np.float64) for name, s in scans.items()}

    def normal(p_tilt: float, p_side: float) -> np.ndarray:
        return rotate(rotate(n0, axes["tilt"], p_tilt), axes["side"], p_side)

    def tilt(p_tilt: float, p_side: float) -> float:
        return math.degrees(math.acos(min(1.0, abs(float(normal(p_tilt, p_side)[2])))))

    pt, ps = fits["tilt"]["peak"], fits["side"]["peak"]
    smaller = min(fits.values(), key=lambda f: f["tolerance"])
    out: dict[str, object] = {"fits": fits, "tolerance_deg": smaller["tolerance"], "tolerance_sd": smaller["tolerance_sd"],
                              "chi2": max(f["chi2"] for f in fits.values())}
    if not (math.isfinite(pt) and math.isfinite(ps)):
        return {**out, "normal": [math.nan] * 3, "tilt_deg": math.nan, "tilt_sd": math.inf}
    h = 0.05
    gt = (tilt(pt + h, ps) - tilt(pt - h, ps)) / (2 * h)
    gs = (tilt(pt, ps + h) - tilt(pt, ps - h)) / (2 * h)
    # how much the shape assumed moves the answer: the tilt by a parabola and by a quartic beside the
    # cubic's (half their range; where a scan is bumpy, each fit's own deviation understates this)
    others = []
    for degree in FIT_SPREAD_DEGREES:
        peaks = [scan_fit(scans[n]["offsets_deg"], scans[n]["energy"], scans[n]["error"], degree)["peak"]
                 for n in ("tilt", "side")]
        if all(math.isfinite(x) for x in peaks):
            others.append(tilt(*peaks))
    tilts = [tilt(pt, ps), *others]
    return {**out, "normal": [float(v) for v in normal(pt, ps)], "tilt_deg": tilt(pt, ps),
            "tilt_sd": math.hypot(gt * fits["tilt"]["peak_sd"], gs * fits["side"]["peak_sd"]),
            "tilt_fit_spread": 0.5 * (max(tilts) - min(tilts)), "tilt_by_degree": tilts}


def lamp_discs() -> dict[str, tuple[np.ndarray, float]]:
    """The comparison's two lamps as the reference traces them: (centre direction, disc radius in
    degrees), by the names its cases carry (:func:`case_lights` gives labcut's side of the same)."""
    return {"lamp 35° in front": (direction(35.0, FRONT_AZIMUTH_DEG), SPOT_RADIUS_DEG),
            "overhead lamp": (np.array([0.0, 0.0, 1.0]), 8.0)}


def case_lights() -> dict[str, labcut.Lights]:
    """The comparison's two lamps by the names its cases carry: a 4° disc 35° above the horizon in
    front (:data:`SPOT_RADIUS_DEG`) and the overhead preset, each at standard quality's sampling."""
    from labcut.scene.presets import overhead

    q = labcut.Quality.coerce("standard")
    front = direction(35.0, FRONT_AZIMUTH_DEG)
    return {"lamp 35° in front": labcut.Lights.lamp(front, SPOT_RADIUS_DEG, 1.0, q.lamp_samples, "front lamp"),
            "overhead lamp": overhead("standard")}


def compare(paths: int, points: int, fresh: bool, *, stones: list[str] | None = None, surface_events: int = MAX_SURFACE_EVENTS,
            key: str = "cases", lamps: list[str] | None = None) -> dict:
    """labcut's default recommendations against the reference (module docstring); one case at a
    time, kept in :data:`DATA` (under ``key``) as it finishes; a case already run with another
    ``paths`` runs again and its last run moves to ``{key}_by_paths``. ``stones``: only these of
    :data:`STONES`; ``surface_events``: the reference's (1: no light reflected inside the stone)."""
    from labcut.orientation.radiance import reference_radiance
    from labcut.scene.presets import face_up

    data = json.loads(DATA.read_text()) if DATA.exists() else {}
    if fresh:
        data.pop(key, None)
    cases = data.setdefault(key, {})
    earlier = data.setdefault(f"{key}_by_paths", {})  # a case run again with another path count keeps its last run here
    mat = labcut.Labradorite()
    lref = reference_radiance(mat, 1.0)
    views = face_up("standard")
    lit = case_lights()
    lamp_cases = {name: (lit[name], *disc) for name, disc in lamp_discs().items()}
    for stone, path in STONES.items():
        if stones and stone not in stones:
            continue
        mesh = labcut.load_mesh(str(ROOT / path))
        ref = None
        for lamp_name, (lights, centre, radius) in lamp_cases.items():
            key = f"{stone} | {lamp_name}"
            if lamps and not any(lamp_name.startswith(x) for x in lamps):
                continue
            if key in cases:
                ran = cases[key]["reference"]["paths_per_view"]
                if ran == paths:
                    continue
                earlier.setdefault(str(ran), {})[key] = cases.pop(key)
            t0 = time.perf_counter()
            rec = labcut.recommend_orientation(mesh, material=mat, lighting=lights, viewing="face-up", quality="standard")
            answer_seconds = time.perf_counter() - t0
            forced = forced_answers(mesh, mat, lights, rec)
            ref = ref or Reference(mesh, mat, surface_events=surface_events)
            n0 = np.asarray(rec.normal, dtype=np.float64)
            half = float(np.clip(1.6 * rec.tolerance_deg, 3.0, 12.0))
            offsets = np.linspace(-half, half, points)
            scans = {}
            t1 = time.perf_counter()
            for axis_name, axis in scan_axes(n0).items():
                values, errors = [], []
                for off in offsets:
                    e, se = energy(ref, rotate(n0, axis, off), views, centre, radius, paths, lref)
                    values.append(e)
                    errors.append(se)
                fit = scan_fit(offsets, np.array(values), np.array(errors))
                scans[axis_name] = {"axis": [float(x) for x in axis], "offsets_deg": [float(x) for x in offsets],
                                    "energy": values, "error": errors}
                print(f"  {key} {axis_name}: peak {fit['peak']:+.2f}° ± {fit['peak_sd']:.2f}°, tolerance "
                      f"{fit['tolerance']:.2f}° ± {fit['tolerance_sd']:.2f}°", flush=True)
            found = reference_optimum({"scan_centre": n0, "scans": scans})
            opt, ref_tilt, ref_tol = found["normal"], found["tilt_deg"], found["tolerance_deg"]
            cases[key] = {
                "stone": stone, "lamp": lamp_name, "estimator": rec.estimator,
                "answer": answer_record(rec, answer_seconds),
                "estimators": forced,
                "reference": {"normal": [float(x) for x in opt], "tilt_deg": ref_tilt, "tolerance_deg": ref_tol,
                              "seconds": time.perf_counter() - t1, "paths_per_view": paths},
                "scans": scans,
            }
            DATA.parent.mkdir(parents=True, exist_ok=True)
            DATA.write_text(json.dumps(data, indent=1))
            print(f"{key}: labcut {rec.estimator} tilt {rec.tilt_deg:.2f}° tol {rec.tolerance_deg:.2f}°  "
                  f"reference tilt {ref_tilt:.2f}° tol {ref_tol:.2f}°", flush=True)
    data["machine"] = f"{platform.machine()}, Python {platform.python_version()}"
    DATA.write_text(json.dumps(data, indent=1))
    return data


def forced_answers(mesh: object, material: labcut.Labradorite, lights: labcut.Lights, rec: object) -> dict:
    """Each estimator's answer, forced (``samples`` and ``volume``; ``rec``, the default
    recommendation, stands for the one it used): its normal, tilt, tolerance and seconds."""
    out = {}
    for est in ("samples", "volume"):
        other = rec if rec.estimator == est else labcut.recommend_orientation(
            mesh, material=material, lighting=lights, viewing="face-up", quality="standard", estimator=est)
        out[est] = {"normal": [float(x) for x in other.normal], "tilt_deg": other.tilt_deg,
                    "tolerance_deg": other.tolerance_deg, "seconds": other.seconds}
    return out


def answer_record(rec: object, seconds: float) -> dict:
    """What a case keeps of labcut's recommendation: its normal, tilt, tolerances (in any direction
    and along the front-back and left-right great circles, the two the reference scans when the
    answer leans to the front or lies near the pole), error bar and time."""
    return {"normal": [float(x) for x in rec.normal], "tilt_deg": rec.tilt_deg, "tolerance_deg": rec.tolerance_deg,
            "tolerance_by_axis": {k: float(v) for k, v in rec.tolerance_by_axis.items()},
            "bar_deg": rec.uncertainty.angle_deg if rec.uncertainty is not None else None, "seconds": seconds}


def scan_centre(case: dict) -> np.ndarray:
    """The normal a case's scans pass through: labcut's answer when they were traced (kept as
    ``scan_centre`` once a later labcut answers elsewhere, :func:`refresh_answers`)."""
    return np.asarray(case["scan_centre"] if "scan_centre" in case else case["answer"]["normal"], dtype=np.float64)


def refresh_answers() -> dict:
    """labcut's answers of every finished case recomputed (seconds each, no reference paths), the
    forced estimators' too, and kept beside the reference's scans. The reference's optimum is found
    from its scans wherever labcut's answer lies, so an answer that moved since the scans were traced
    keeps them: their centre stays as ``scan_centre`` and the move is printed (an answer beyond half
    a scan's reach would want ``compare --fresh``)."""
    data = json.loads(DATA.read_text())
    mat = labcut.Labradorite()
    lights = case_lights()
    for key, c in data.get("cases", {}).items():
        mesh = labcut.load_mesh(str(ROOT / STONES[c["stone"]]))
        t0 = time.perf_counter()
        rec = labcut.recommend_orientation(mesh, material=mat, lighting=lights[c["lamp"]], viewing="face-up",
                                           quality="standard")
        seconds = time.perf_counter() - t0
        centre = scan_centre(c)
        moved = math.degrees(math.acos(min(1.0, abs(float(np.dot(rec.normal, centre))))))
        reach = 0.5 * max(max(abs(x) for x in scan["offsets_deg"]) for scan in c["scans"].values())
        if moved > 1e-3:
            c["scan_centre"] = [float(x) for x in centre]
            print(f"{key}: labcut's answer lies {moved:.2f}° from the scans' centre"
                  + (f", beyond half their reach ({reach:.2f}°): trace them again (compare --fresh)" if moved > reach else ""),
                  flush=True)
        c["answer"] = answer_record(rec, seconds)
        c["estimators"] = forced_answers(mesh, mat, lights[c["lamp"]], rec)
        c["estimator"] = rec.estimator
        print(key, f"tilt {rec.tilt_deg:.2f}°", c["answer"]["tolerance_by_axis"], flush=True)
    DATA.write_text(json.dumps(data, indent=1))
    return data


def factor_experiment() -> dict:
    """labcut's answers on the ovals (the sample estimator) with the lobe's ``max(a·n, b·n)`` replaced
    by the planes' ``a·n`` (``labcut.physics.schiller.mirror_terms`` swapped in this process only: the
    device triple kernel, on by default, takes its factor from there): how much of the gap to the
    reference the model's radiometric factor makes. ``{case: {"tilt_deg", "tolerance_deg",
    "tolerance_by_axis"}}``."""
    from labcut.orientation.kernels import DEFAULT_KERNELS
    from labcut.physics import schiller as lobe

    if not DEFAULT_KERNELS.triples:
        raise SystemExit("the experiment swaps the device triple kernel's factor: needs KernelOptions.triples on")
    mat = labcut.Labradorite()
    lights = case_lights()
    paper = lobe.mirror_terms

    def planes_factor(a: object, b: object, n: object, ops: object) -> tuple:
        h, cos_l, _max = paper(a, b, n, ops)
        return h, cos_l, ops.dot(a, n)

    out = {}
    lobe.mirror_terms = planes_factor
    try:
        for stone in ("low oval", "medium oval", "high oval"):
            mesh = labcut.load_mesh(str(ROOT / STONES[stone]))
            for lamp, lit in lights.items():
                rec = labcut.recommend_orientation(mesh, material=mat, lighting=lit, viewing="face-up",
                                                   quality="standard", estimator="samples")
                out[f"{stone} | {lamp}"] = {"tilt_deg": rec.tilt_deg, "tolerance_deg": rec.tolerance_deg,
                                            "tolerance_by_axis": dict(rec.tolerance_by_axis)}
                print(stone, lamp, f"a·n: tilt {rec.tilt_deg:.2f}°, tolerance {rec.tolerance_deg:.2f}°", flush=True)
    finally:
        lobe.mirror_terms = paper
    return out


def fit_check(draws: int = 400, seed: int = 5) -> list[dict]:
    """How :func:`scan_fit` behaves at the reference's own noise: labcut's noise-free flash along each
    case's scans (``model-scans``) plus Gaussian noise of that case's mean relative error per point,
    ``draws`` times. Per scan: the top's mean offset from the noise-free fit's (bias), its scatter
    against the median standard deviation the fit reports, and the 90 % tolerance's mean against the
    noise-free one. Printed as a markdown table; the rows are returned."""
    data = json.loads(DATA.read_text())
    rng = np.random.default_rng(seed)
    rows = []
    print("| case | scan | noise | top: bias | scatter | reported | tolerance: noisy / noise-free |")
    print("|---|---|---|---|---|---|---|")
    for key, c in data.get("cases", {}).items():
        for name, scan in c["scans"].items():
            model = c.get("model_scans", {}).get(name)
            if not model:
                continue
            x, m = np.asarray(scan["offsets_deg"]), np.asarray(model["energy"])
            rel = float(np.mean(np.asarray(scan["error"]) / np.max(scan["energy"])))
            err = np.full(x.size, rel * m.max())
            clean = scan_fit(x, m, err)
            fits = [scan_fit(x, m + rng.normal(0.0, err), err) for _ in range(draws)]
            peaks = np.array([f["peak"] for f in fits])
            tols = np.array([f["tolerance"] for f in fits])
            reported = np.array([f["peak_sd"] for f in fits])
            ok = np.isfinite(peaks) & np.isfinite(reported)
            row = {"case": key, "scan": name, "noise": rel, "bias": float(np.mean(peaks[ok]) - clean["peak"]),
                   "scatter": float(np.std(peaks[ok])), "reported": float(np.median(reported[ok])),
                   "tolerance_ratio": float(np.mean(tols[np.isfinite(tols)]) / clean["tolerance"])}
            rows.append(row)
            print(f"| {key.replace(' | ', ', ')} | {name} | {rel:.1%} | {row['bias']:+.2f}° | {row['scatter']:.2f}° | {row['reported']:.2f}° | "
                  f"{row['tolerance_ratio']:.3f} |", flush=True)
    return rows


def model_scans() -> dict:
    """labcut's own flash energy (the estimator its answer used, quality standard) along each finished
    case's scans, fitted as the reference's are: the same method on both sides, so that the table
    separates what the physics moves from what the fit does."""
    from labcut.orientation.question import FlashQuestion

    data = json.loads(DATA.read_text())
    mat = labcut.Labradorite()
    lights = case_lights()
    for key, c in data.get("cases", {}).items():
        mesh = labcut.load_mesh(str(ROOT / STONES[c["stone"]]))
        ask = FlashQuestion.build(mat, None, lights[c["lamp"]], "face-up", quality="standard")
        scorer = ask.scorer(mesh, occlusion=not labcut.Stone.of(mesh).convex, volume=c["estimator"] == "volume")
        n0 = scan_centre(c)
        out = {}
        for name, scan in c["scans"].items():
            offsets = np.asarray(scan["offsets_deg"])
            normals = np.array([rotate(n0, np.asarray(scan["axis"]), o) for o in offsets])
            values = scorer.scores(normals)
            fit = scan_fit(offsets, values, np.full(len(values), 1e-3))
            out[name] = {"energy": [float(v) for v in values], "peak_offset_deg": fit["peak"], "peak_energy": fit["top"],
                         "tolerance_deg": fit["tolerance"]}
        c["model_scans"] = out
        print(key, {k: (round(v["peak_offset_deg"], 3), round(v["tolerance_deg"], 3)) for k, v in out.items()}, flush=True)
    DATA.write_text(json.dumps(data, indent=1))
    return data


def timing() -> dict:
    """Seconds of a recommendation at standard quality by each estimator, forced, warm (the better
    of two runs after one to warm): the comparison's stones and lamps, and the carving under the
    worn ring and pendant (a room's many directions over 13 poses: each pair's lights drawn)."""
    from labcut.scene.presets import overhead

    q = labcut.Quality.coerce("standard")
    front = direction(35.0, FRONT_AZIMUTH_DEG)
    cases = [(stone, lamp, dict(lighting=lights, viewing="face-up"))
             for stone in STONES for lamp, lights in (
                 ("lamp 35° in front", labcut.Lights.lamp(front, SPOT_RADIUS_DEG, 1.0, q.lamp_samples, "front lamp")),
                 ("overhead lamp", overhead("standard")))]
    cases += [("biplane", f"worn: {sc}", dict(scenario=sc)) for sc in ("ring", "pendant")]
    rows = []
    for stone, lamp, scene in cases:
        mesh = labcut.load_mesh(str(ROOT / STONES[stone]))
        row = {"stone": stone, "lamp": lamp}
        for est in ("samples", "volume"):
            labcut.recommend_orientation(mesh, quality="draft", estimator=est, **scene)
            best = math.inf
            for _ in range(2):
                t0 = time.perf_counter()
                rec = labcut.recommend_orientation(mesh, quality="standard", estimator=est, **scene)
                best = min(best, time.perf_counter() - t0)
            row[est] = best
            row[f"{est}_tilt_deg"] = rec.tilt_deg
            if est == "volume":
                row["paths"] = rec.settings["volume"]["paths"]
                row["lights_drawn"] = rec.settings["volume"]["lights_drawn"]
        rows.append(row)
        print(row, flush=True)
    return {"rows": rows}


def choices() -> dict:
    """What the volume estimator's settings move (docs/accuracy.md, "The volume estimator's cost"):
    the depths per (pair, light) (1 against 4) and the fixed-point steps (3, 4 against 8) on the
    ovals and the carving under the 4° front lamp at standard (draft for the steps, as the test), and
    the path budget on the carving under the worn ring and pendant (every light, 1 M, 0.5 M): each a
    search of the volume problem's map and optimiser (its tilt and energy)."""
    from labcut.orientation.optimize import search_best
    from labcut.orientation.question import FlashQuestion
    from labcut.orientation.scoring import Scorer
    from labcut.orientation.volume import build_volume_problem

    mat = labcut.Labradorite()
    rows = []

    def run(stone: str, scene: str, ask: FlashQuestion, **options: int) -> None:
        mesh = labcut.load_mesh(str(ROOT / STONES[stone]))
        t0 = time.perf_counter()
        problem = build_volume_problem(mesh, mat, ask.quality, settings=ask.scenario.settings(),
                                       occlusion=not labcut.Stone.of(mesh).convex, **options)
        seconds = time.perf_counter() - t0
        best = search_best(Scorer(problem, "energy"), ask.constraint, ask.quality, "nlopt")
        rows.append({"stone": stone, "scene": scene, "quality": ask.quality.name, **options,
                     "tilt_deg": math.degrees(math.acos(min(1.0, abs(float(best.normal[2]))))),
                     "normal": [float(x) for x in best.normal], "energy": float(best.score), "seconds": seconds,
                     "paths": problem.info["volume"]["paths"]})
        print(rows[-1], flush=True)

    front = labcut.Lights.lamp(direction(35.0, FRONT_AZIMUTH_DEG), SPOT_RADIUS_DEG, 1.0,
                               labcut.Quality.coerce("standard").lamp_samples, "front lamp")
    lamp = FlashQuestion.build(mat, None, front, "face-up", quality="standard")
    for stone in STONES:
        for depths in (1, 4):
            run(stone, "lamp 35° in front", lamp, depths=depths)
    spot = FlashQuestion.build(mat, None, "spot", "face-up", quality="draft")
    for iterations in (3, 4, 8):
        run("high oval", "spot", spot, iterations=iterations)
    for scene in ("ring", "pendant"):
        worn = FlashQuestion.build(mat, scene, quality="standard")
        for budget in (100_000_000, 1_000_000, 500_000):
            run("biplane", scene, worn, path_budget=budget)
    return {"rows": rows}


PLANNER_SCENES = ("spot", "overhead", "pendant", "ring")


def planner_table() -> dict:
    """Every bundled cut under four scenes at draft: the planner's depth facts and decision, and the
    surface sample estimator's answer against the volume estimator's (the angle between their
    normals, the volume's energy over the surface's)."""
    from labcut.orientation.optimize import search_best
    from labcut.orientation.question import FlashQuestion
    from labcut.orientation.volume import depth_exposure

    rows = []
    mat = labcut.Labradorite()
    for path in sorted((ROOT / "meshes").glob("*.ply")):
        mesh = labcut.load_mesh(str(path))
        facts = depth_exposure(mesh, mat)
        plan = labcut.plan_effects(mesh, mat, scenario="bench", quality="draft", predict=False)
        for scene in PLANNER_SCENES:
            q = (FlashQuestion.build(mat, None, scene, "face-up", quality="draft") if scene in ("spot", "overhead")
                 else FlashQuestion.build(mat, scene, quality="draft"))
            found = []
            for volume in (False, True):
                scorer = q.scorer(mesh, occlusion=not plan.convex, volume=volume)
                best = search_best(scorer, q.constraint, q.quality, "nlopt")
                found.append((best.normal, best.score))
            moved = math.degrees(math.acos(min(1.0, abs(float(found[0][0] @ found[1][0])))))
            rows.append({"stone": path.name, "scene": scene, "thin_share": facts["thin_share"], "turn_deg": facts["turn_deg"],
                         "depth_on": plan.on("depth"), "moved_deg": moved, "energy_ratio": found[1][1] / found[0][1]})
            print(f"{path.name:32} {scene:9} thin {facts['thin_share']:.3f} moved {moved:.2f}° energy x{found[1][1] / found[0][1]:.3f}",
                  flush=True)
    return {"rows": rows}


PLANNER_DOC = ROOT / "docs" / "planner.md"
COST_DOC = ROOT / "docs" / "accuracy.md"
PLANNER_BEGIN, PLANNER_END = "<!-- DEPTH-OFF:BEGIN -->", "<!-- DEPTH-OFF:END -->"
COST_BEGIN, COST_END = "<!-- VOLUME-COST:BEGIN -->", "<!-- VOLUME-COST:END -->"
#: what must hold (issue 38): the default answer's tilt within this of the reference's, its 90 %
#: tolerance within this share of the reference's
TILT_TARGET_DEG, TOLERANCE_TARGET = 0.5, 0.10


def splice(path: Path, begin: str, end: str, body: str) -> None:
    """Put ``body`` between the markers of ``path`` (added at the end when missing)."""
    text = path.read_text()
    block = f"{begin}\n{body.rstrip()}\n{end}"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    path.write_text(text)


def report() -> None:
    """The tables of :data:`DATA` into the docs (each between its markers)."""
    data = json.loads(DATA.read_text())
    machine = data.get("machine", "")
    out = [f"Measured with `.venv/bin/python benchmarks/volume_reference.py slab`, `... compare` (the ovals with "
           "`--paths 800000`, the biplane at the default 200,000), `... answers`, `... model-scans`, `... factor` and "
           f"`... report` ({machine}, 2 cores, Mitsuba LLVM variants for the ray casts; the reference is numpy).", ""]
    slab = data.get("slab")
    if slab:
        out += ["**The planes alone** (a pile of 48 planes walked in one dimension, 400,000 walkers per angle): the share "
                "of the light they send back against the model's luminance reflectance `R_Y` of the whole stack.", "",
                "| internal cos | model R_Y | planes | difference |", "|---|---|---|---|"]
        for r in slab["stack"]:
            out.append(f"| {r['cos']:.2f} | {r['model_R_Y']:.4f} | {r['planes_R_Y']:.4f} ± {r['error']:.4f} | "
                       f"{(r['planes_R_Y'] / r['model_R_Y'] - 1):+.1%} |")
        out += ["", "**A slab 3 mm thick** (lamellae tilted in the plane of a 4° lamp 20° from the vertical, a viewer straight "
                "above; the slab's middle 10 x 10 mm; 1.6 M camera paths each): the reference's flash against labcut's "
                "flash model (surface samples, high quality), in units of L_ref. On a flat face the model is exact but for "
                "its factor `max(a·n, b·n)` where the planes give `a·n` (2.5 % here) and for light mirrored more than once.",
                "", "| lamella tilt | reference | model | reference / model |", "|---|---|---|---|"]
        for r in slab["radiance"]:
            out.append(f"| {r['tilt_deg']:.2f}° | {r['reference']:.4f} ± {r['error']:.4f} | {r['model']:.4f} | "
                       f"{r['reference'] / r['model']:.3f} |")
    order = {name: i for i, name in enumerate(STONES)}
    cases = dict(sorted(data.get("cases", {}).items(),
                        key=lambda kv: (order.get(kv[1]["stone"], len(order)), kv[1]["lamp"] != "lamp 35° in front")))
    if cases:
        paths = sorted({c["reference"]["paths_per_view"] for c in cases.values()})
        out += ["", "**Default recommendations against the reference** (quality standard, face-up viewers; the reference "
                f"scanned along two great circles through labcut's answer, {' or '.join(f'{n:,}' for n in paths)} camera "
                "paths per view and normal (column *paths*), common random numbers along a scan; its optimum the top of a "
                "least-squares cubic through each scan, its 90 % tolerance the nearer point where that cubic falls to 90 %, "
                "the smaller of the two scans'; after ± the reference's own standard deviation, from the cubic's covariance: "
                "`scan_fit`; *fits*: half the range of the tilts a parabola, the cubic and a quartic give, the part of the "
                "uncertainty that is the shape assumed). *labcut* is the planner's estimator's answer and its stated tolerance (a ring search); "
                "*fitted* is labcut's own flash along the same scans fitted as the reference's (`model-scans`), which "
                "separates what the physics moves from what the two ways of measuring do; *along the scans* is labcut's "
                "stated tolerance along the same two great circles (`Recommendation.tolerance_by_axis`, front-back and "
                "left-right, the smaller), the quantity the reference measures. *samples* and *volume*: the tilt "
                "of each estimator, forced.",
                "", "| stone | lamp | estimator | paths | labcut tilt | reference tilt | apart | fitted optimum | "
                "samples / volume tilt | tolerance: labcut | along the scans | fitted | reference | labcut / ref | "
                "along / ref | fitted / ref |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        tilt_ok = tol_ok = fit_ok = tilt_within = tol_within = axes_ok = axes_within = 0
        for key, c in cases.items():
            a = c["answer"]
            r = reference_optimum(c)
            prec = {"tilt_sd": r["tilt_sd"], "tolerance_sd": r["tolerance_sd"]}
            cos_apart = abs(float(np.dot(a["normal"], r["normal"])))
            apart = math.degrees(math.acos(min(1.0, cos_apart))) if math.isfinite(cos_apart) else math.nan
            ratio = a["tolerance_deg"] / r["tolerance_deg"] if math.isfinite(r["tolerance_deg"]) else float("nan")
            ms = c.get("model_scans")
            if ms:
                own_scans = {name: {**c["scans"][name], "energy": v["energy"], "error": [1e-3] * len(v["energy"])}
                             for name, v in ms.items()}
                own = reference_optimum({"scan_centre": scan_centre(c), "scans": own_scans})
                fit_tol = own["tolerance_deg"]
                fit_opt = math.degrees(math.acos(min(1.0, abs(float(np.dot(own["normal"], a["normal"]))))))
                fit_ratio = fit_tol / r["tolerance_deg"]
                fit_ok += abs(fit_ratio - 1.0) <= TOLERANCE_TARGET
                fitted = (f"{fit_opt:.2f}° off", f"±{fit_tol:.2f}°", f"{fit_ratio:.2f}")
            else:
                fitted = ("", "", "")
            gap = abs(a["tilt_deg"] - r["tilt_deg"])
            tilt_ok += gap <= TILT_TARGET_DEG
            tilt_within += gap <= TILT_TARGET_DEG + 2.0 * math.hypot(prec["tilt_sd"], r.get("tilt_fit_spread", 0.0))
            tol_ok += abs(ratio - 1.0) <= TOLERANCE_TARGET
            tol_within += abs(ratio - 1.0) <= TOLERANCE_TARGET + 2.0 * prec["tolerance_sd"] / r["tolerance_deg"]
            by_axis = a.get("tolerance_by_axis")
            if by_axis:
                along = min(by_axis.values())
                along_ratio = along / r["tolerance_deg"]
                axes_ok += abs(along_ratio - 1.0) <= TOLERANCE_TARGET
                axes_within += abs(along_ratio - 1.0) <= TOLERANCE_TARGET + 2.0 * prec["tolerance_sd"] / r["tolerance_deg"]
                axes = (f"±{along:.2f}°", f"{along_ratio:.2f}")
            else:
                axes = ("", "")
            est = c["estimators"]
            out.append(f"| {c['stone']} | {c['lamp']} | {c['estimator']} | {c['reference']['paths_per_view'] // 1000:,}k | "
                       f"{a['tilt_deg']:.2f}° | {r['tilt_deg']:.2f}° ± {prec['tilt_sd']:.2f}° (fits ±{r['tilt_fit_spread']:.2f}°) | "
                       f"{apart:.2f}° | {fitted[0]} | {est['samples']['tilt_deg']:.2f}° / {est['volume']['tilt_deg']:.2f}° | "
                       f"±{a['tolerance_deg']:.2f}° | {axes[0]} | {fitted[1]} | "
                       f"±{r['tolerance_deg']:.2f}° ± {prec['tolerance_sd']:.2f}° | {ratio:.2f} | {axes[1]} | {fitted[2]} |")
        out += ["", f"Tilt within {TILT_TARGET_DEG}° of the reference in {tilt_ok} of {len(cases)} cases, and within "
                f"{TILT_TARGET_DEG}° plus twice the reference's own uncertainty (its standard deviation and the fits' spread "
                f"together) in {tilt_within}; the stated 90 % "
                f"tolerance within {TOLERANCE_TARGET:.0%} of the reference's in {tol_ok} of {len(cases)} (with twice the "
                f"reference's standard deviation added: {tol_within}); labcut's tolerance along the scans within "
                f"{TOLERANCE_TARGET:.0%} in {axes_ok} of {len(cases)} (with twice the reference's standard deviation: "
                f"{axes_within}), the fitted one in {fit_ok} of {len(cases)}."]
    swapped = data.get("factor_an", {})
    if swapped and cases:
        out += ["", "**The model's factor** (`factor`: labcut's answer on the ovals, sample estimator, with the lobe's "
                "`max(a·n, b·n)` replaced by the planes' `a·n`; the rest of the model unchanged):", "",
                "| stone | lamp | labcut tilt: max(a·n, b·n) | a·n | reference tilt | tolerance: max(a·n, b·n) | a·n | "
                "reference |", "|---|---|---|---|---|---|---|---|"]
        for key, f in swapped.items():
            c = cases.get(key)
            if not c:
                continue
            r = reference_optimum(c)
            out.append(f"| {c['stone']} | {c['lamp']} | {c['estimators']['samples']['tilt_deg']:.2f}° | {f['tilt_deg']:.2f}° | "
                       f"{r['tilt_deg']:.2f}° ± {r['tilt_sd']:.2f}° | ±{c['estimators']['samples']['tolerance_deg']:.2f}° | "
                       f"±{f['tolerance_deg']:.2f}° | ±{r['tolerance_deg']:.2f}° ± {r['tolerance_sd']:.2f}° |")
    limit, conv = data.get("surface_limit", {}), data.get("converge", {})
    if limit and cases:
        out += ["", "**Where the gap comes from** (`surface-limit --paths 4000000` and `converge`): *standard* is the "
                "default answer (8,000 surface points); *converged* labcut's answer with 50,000, 200,000 and 1,000,000 "
                "points (the model's own optimum, where the sampling no longer moves it; its spread says how flat the top "
                "is); *surface limit* the model's physics by Monte Carlo (camera paths mirrored where they come in by "
                "domain normals drawn from the mosaic, scored when they leave into the lamp: no lobe, no lamp or surface "
                "samples; 4 M paths per view, fitted as the reference), with the model's factor `max(a·n, b·n)` and with "
                "the planes' `a·n`; *reference* the volumetric one. Read left to right, each step is one cause: labcut's "
                "sampling, its estimate of its own physics, the factor, and the rest (depth, light mirrored more than "
                "once or reflected inside, the reference's noise).", "",
                "| stone | lamp | standard | converged | surface limit: max(a·n, b·n) | a·n | reference |",
                "|---|---|---|---|---|---|---|"]
        for key, row in limit.items():
            c = cases.get(key)
            if not c:
                continue
            r = reference_optimum(c)
            more = [x["tilt_deg"] for x in conv.get(key, []) if x["points"] > 8_000]
            converged = (f"{np.mean(more):.2f}° ({min(more):.2f}-{max(more):.2f}°)" if more else "")
            out.append(f"| {c['stone']} | {c['lamp']} | {c['estimators']['samples']['tilt_deg']:.2f}° | {converged} | "
                       f"{row['model']['tilt_deg']:.2f}° ± {row['model']['tilt_sd']:.2f}° | "
                       f"{row['planes']['tilt_deg']:.2f}° ± {row['planes']['tilt_sd']:.2f}° | "
                       f"{r['tilt_deg']:.2f}° ± {r['tilt_sd']:.2f}° |")
    bare = data.get("no_internal", {})
    if bare:
        out += ["", "**Without light reflected inside** (`compare --no-internal --stones \"medium oval,high oval\"`: a path "
                "ends at its first meeting with the surface from inside, as in the estimators; against the reference with "
                "all light traced with the same paths, kept from that run):", "",
                "| stone | lamp | paths | labcut tilt | reference tilt: all light | without | tolerance: labcut | reference: all | "
                "without |",
                "|---|---|---|---|---|---|---|---|---|"]
        for key, c in bare.items():
            # the all-light case traced with the same paths (the same camera paths up to their first meeting
            # with the surface from inside: the difference is the light reflected there, not noise)
            same = str(c["reference"]["paths_per_view"])
            full = data.get("cases_by_paths", {}).get(same, {}).get(key) or cases.get(key)
            if not full or full["reference"]["paths_per_view"] != c["reference"]["paths_per_view"]:
                continue
            if max(abs(float(np.dot(scan_centre(c), scan_centre(full)))), 0.0) < math.cos(math.radians(1e-3)):
                continue  # scanned around another answer than the full case's: not comparable
            r_all, r_bare = reference_optimum(full), reference_optimum(c)
            now = cases.get(key, c)["answer"]  # labcut's answer as it is now
            out.append(f"| {c['stone']} | {c['lamp']} | {c['reference']['paths_per_view'] // 1000:,}k | "
                       f"{now['tilt_deg']:.2f}° | {r_all['tilt_deg']:.2f}° ± {r_all['tilt_sd']:.2f}° | "
                       f"{r_bare['tilt_deg']:.2f}° ± {r_bare['tilt_sd']:.2f}° | ±{now['tolerance_deg']:.2f}° | "
                       f"±{r_all['tolerance_deg']:.2f}° ± {r_all['tolerance_sd']:.2f}° | "
                       f"±{r_bare['tolerance_deg']:.2f}° ± {r_bare['tolerance_sd']:.2f}° |")
    splice(DOC, BEGIN, END, "\n".join(out))
    rows = json.loads(PLANNER_DATA.read_text()).get("rows", []) if PLANNER_DATA.exists() else []
    if rows:
        text = ["Measured with `.venv/bin/python benchmarks/volume_reference.py planner` "
                f"({machine}): every bundled cut at draft quality, the surface samples' answer against the volume "
                f"estimator's under {', '.join(PLANNER_SCENES)} (the first two with face-up viewers).", "",
                "| cut | thin share | normal turn | depth | largest move | volume energy / surface |", "|---|---|---|---|---|---|"]
        for stone in dict.fromkeys(r["stone"] for r in rows):
            mine = [r for r in rows if r["stone"] == stone]
            e = [r["energy_ratio"] for r in mine]
            text.append(f"| {stone} | {mine[0]['thin_share']:.1%} | {mine[0]['turn_deg']:.1f}° | "
                        f"{'on' if mine[0]['depth_on'] else 'off'} | {max(r['moved_deg'] for r in mine):.2f}° | "
                        f"{min(e):.3f}-{max(e):.3f} |")
        splice(PLANNER_DOC, PLANNER_BEGIN, PLANNER_END, "\n".join(text))
    timed = json.loads(PLANNER_DATA.read_text()).get("timing", {}).get("rows", []) if PLANNER_DATA.exists() else []
    if timed:
        text = ["Measured with `.venv/bin/python benchmarks/volume_reference.py timing` "
                f"({machine}, 2 cores): a recommendation at standard quality by each estimator, forced, warm (the better "
                "of two runs), with its error bars (the volume's finer problems are volumetric too, on a quarter of the "
                "path budget). *paths*: the answer's problem's; *drawn*: over the budget of 1,000,000 paths each pair's "
                "lights are drawn in proportion to their irradiance.", "",
                "| stone | scene | samples | volume | volume / samples | paths | drawn | tilt: samples / volume |",
                "|---|---|---|---|---|---|---|---|"]
        for r in timed:
            text.append(f"| {r['stone']} | {r['lamp']} | {r['samples']:.2f} s | {r['volume']:.2f} s | "
                        f"{r['volume'] / r['samples']:.1f}x | {r['paths']:,} | {'yes' if r['lights_drawn'] else 'no'} | "
                        f"{r['samples_tilt_deg']:.2f}° / {r['volume_tilt_deg']:.2f}° |")
        splice(COST_DOC, COST_BEGIN, COST_END, "\n".join(text))


def _store(key: str, value: dict) -> None:
    data = json.loads(DATA.read_text()) if DATA.exists() else {}
    data[key] = value
    data["machine"] = f"{platform.machine()}, Python {platform.python_version()}"
    DATA.parent.mkdir(parents=True, exist_ok=True)
    DATA.write_text(json.dumps(data, indent=1))


#: the converged answer's surface points (:func:`converge`): standard quality's 8,000 and more
CONVERGE_POINTS = (8_000, 50_000, 200_000, 1_000_000)


def converge(points: tuple[int, ...] = CONVERGE_POINTS, keys: list[str] | None = None) -> dict:
    """labcut's answer (sample estimator, standard quality otherwise) with more surface points, per
    finished case: how far standard quality's 8,000 points put the default answer from the one the
    model itself converges to. ``{case: [{"points", "tilt_deg", "tolerance_deg"}, ...]}``."""
    data = json.loads(DATA.read_text())
    mat = labcut.Labradorite()
    lights = case_lights()
    out = {}
    for key, c in data.get("cases", {}).items():
        if keys and key not in keys or c["estimator"] != "samples":
            continue
        mesh = labcut.load_mesh(str(ROOT / STONES[c["stone"]]))
        rows = []
        for n in points:
            q = labcut.Quality.coerce("standard").replace(surface_points=int(n))
            rec = labcut.recommend_orientation(mesh, material=mat, lighting=lights[c["lamp"]], viewing="face-up",
                                               quality=q, estimator="samples")
            rows.append({"points": int(n), "tilt_deg": rec.tilt_deg, "tolerance_deg": rec.tolerance_deg})
            print(key, rows[-1], flush=True)
        out[key] = rows
    return out


class SurfaceLimit:
    """The flash with the lamellae at the surface, by Monte Carlo: the reference's camera paths
    (orthographic, uniform over the outline, Fresnel in, Snell with the shading normal) mirrored where
    they come in by a domain normal drawn from the mosaic (:func:`draw_mosaic`'s law), leaving there
    (Fresnel out) and scoring the lamp's radiance times the stack's luminance reflectance
    ``R_Y(|w·m|)`` when they leave into its disc. No depth, one mirroring, no light reflected inside:
    the model's own physics, sampled rather than integrated (no lobe, no Jacobian, no lamp samples,
    no surface samples), so that it checks labcut's estimate of that physics; ``factor="model"``
    puts the model's ``max(a·n, b·n)`` in place of the ``a·n`` the paths give. Each view's hits and
    uniforms are drawn once and kept for every normal (common random numbers along a scan)."""

    def __init__(self, mesh: object, material: labcut.Labradorite, views: labcut.Views, paths: int, seed: int = 3) -> None:
        from labcut.colour import luminance_table

        self.eta = float(material.n_surface)
        self.kappa = float(material.lobe_kappa)
        self.table = luminance_table(material)
        w = np.asarray(views.weights, dtype=np.float64)
        self.weights = w / w.sum()
        rays = VolumeRays(mesh)
        centre, radius = outline_box(mesh)
        rng = np.random.default_rng(seed)
        self.views = []
        for v in np.asarray(views.directions, dtype=np.float64):
            v = v / np.linalg.norm(v)
            t, b = frame(v)
            xy = (rng.random((paths, 2)) * 2.0 - 1.0) * radius
            hit = rays.cast(centre + 2.0 * radius * v + xy[:, :1] * t + xy[:, 1:] * b, np.tile(-v, (paths, 1)))
            seen = np.isfinite(hit.t)
            n = hit.n_sh[seen]
            cos_in = n @ v
            lit = cos_in > 0
            u1, u2 = rng.random(int(lit.sum())), rng.random(int(lit.sum()))
            cos = 1.0 + np.log(u1 + (1.0 - u1) * np.exp(-2.0 * self.kappa)) / self.kappa
            self.views.append({"n": n[lit], "w": refract(np.tile(-v, (int(lit.sum()), 1)), n[lit], 1.0 / self.eta),
                               "t_in": 1.0 - fresnel(cos_in[lit], 1.0 / self.eta), "cos": cos,
                               "sin": np.sqrt(np.clip(1.0 - cos * cos, 0.0, 1.0)), "phi": 2.0 * np.pi * u2,
                               "seen": int(seen.sum())})

    def energy(self, normal: np.ndarray, lamp: np.ndarray, radius_deg: float, lref: float,
               factor: str = "planes") -> tuple[float, float]:
        """The view-weighted mean schiller radiance over the outline (units of ``lref``) and its
        standard error, lamellae of mean normal ``normal``, a disc lamp of irradiance 1."""
        m = np.asarray(normal, dtype=np.float64) / np.linalg.norm(normal)
        t, b = frame(m)
        lamp = np.asarray(lamp, dtype=np.float64) / np.linalg.norm(lamp)
        cos_lamp = math.cos(math.radians(radius_deg))
        radiance = 1.0 / (math.pi * math.sin(math.radians(radius_deg)) ** 2)
        total, var = 0.0, 0.0
        for weight, p in zip(self.weights, self.views):
            dom = p["cos"][:, None] * m + p["sin"][:, None] * (np.cos(p["phi"])[:, None] * t + np.sin(p["phi"])[:, None] * b)
            wm = np.einsum("ij,ij->i", p["w"], dom)
            out = p["w"] - 2.0 * wm[:, None] * dom
            cos_out = np.einsum("ij,ij->i", out, p["n"])
            up = np.flatnonzero(cos_out > 0)  # mirrored back towards the surface it came in through
            o = refract(out[up], -p["n"][up], self.eta)
            good = np.all(np.isfinite(o), axis=1)
            o[good] /= np.linalg.norm(o[good], axis=1, keepdims=True)
            idx = up[good & (np.nan_to_num(o @ lamp) >= cos_lamp)]
            score = np.zeros(p["seen"])
            value = (p["t_in"][idx] * np.interp(np.abs(wm[idx]), *self.table) * (1.0 - fresnel(cos_out[idx], self.eta))
                     * radiance)
            if factor == "model":  # the planes' a·n (a: the lamp's side) -> the model's max(a·n, b·n)
                value *= cos_out[idx] / np.maximum(cos_out[idx], -np.einsum("ij,ij->i", p["w"][idx], p["n"][idx]))
            score[idx] = value
            total += weight * score.mean()
            var += (weight * score.std(ddof=1) / math.sqrt(len(score))) ** 2
        return total / lref, math.sqrt(var) / lref


def surface_limit(paths: int, keys: list[str] | None = None) -> dict:
    """:class:`SurfaceLimit` along each finished case's two scans, with the planes' factor and with
    the model's, fitted as the reference is (:func:`reference_optimum`). ``{case: {factor: {"tilt_deg",
    "tilt_sd", "tolerance_deg", "tolerance_sd", "scans"}}}``."""
    from labcut.orientation.radiance import reference_radiance
    from labcut.scene.presets import face_up

    data = json.loads(DATA.read_text())
    mat = labcut.Labradorite()
    lref = reference_radiance(mat, 1.0)
    lamps = lamp_discs()
    out = {}
    for key, c in data.get("cases", {}).items():
        if keys and key not in keys:
            continue
        t0 = time.perf_counter()
        mc = SurfaceLimit(labcut.load_mesh(str(ROOT / STONES[c["stone"]])), mat, face_up("standard"), paths)
        lamp, radius = lamps[c["lamp"]]
        n0 = scan_centre(c)
        row = {}
        for factor in ("planes", "model"):
            scans = {}
            for name, scan in c["scans"].items():
                axis = np.asarray(scan["axis"], dtype=np.float64)
                pairs = [mc.energy(rotate(n0, axis, o), lamp, radius, lref, factor) for o in scan["offsets_deg"]]
                scans[name] = {"axis": scan["axis"], "offsets_deg": scan["offsets_deg"],
                               "energy": [e for e, _ in pairs], "error": [se for _, se in pairs]}
            found = reference_optimum({"scan_centre": n0, "scans": scans})
            row[factor] = {"tilt_deg": found["tilt_deg"], "tilt_sd": found["tilt_sd"],
                           "tolerance_deg": found["tolerance_deg"], "tolerance_sd": found["tolerance_sd"], "scans": scans}
            print(f"{key} [{factor}]: tilt {found['tilt_deg']:.2f}° ± {found['tilt_sd']:.2f}°, tolerance "
                  f"{found['tolerance_deg']:.2f}°", flush=True)
        row["paths_per_view"] = paths
        row["seconds"] = time.perf_counter() - t0
        out[key] = row
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", choices=("slab", "compare", "answers", "model-scans", "factor", "fit-check", "planner",
                                         "timing", "choices", "surface-limit", "converge", "report"))
    parser.add_argument("--paths", type=int, default=200_000, help="camera paths per view and normal (compare)")
    parser.add_argument("--points", type=int, default=13, help="normals per scan (compare)")
    parser.add_argument("--fresh", action="store_true", help="start the comparison over")
    parser.add_argument("--stones", default=None, help="compare: only these stones (comma-separated names)")
    parser.add_argument("--lamps", default=None, help="compare: only these lamps (comma-separated: lamp, overhead)")
    parser.add_argument("--cases", default=None, help="surface-limit, converge: only these cases ('stone | lamp', ';'-separated)")
    parser.add_argument("--no-internal", action="store_true",
                        help="compare: no light reflected inside the stone (kept apart, as no_internal)")
    args = parser.parse_args()
    if args.what == "slab":
        result = slab_check()
        _store("slab", result)
        print(json.dumps(result, indent=1))
    elif args.what == "model-scans":
        model_scans()
    elif args.what == "answers":
        refresh_answers()
    elif args.what == "factor":
        _store("factor_an", factor_experiment())
    elif args.what == "fit-check":
        fit_check()
    elif args.what in ("surface-limit", "converge"):
        keys = [k.strip() for k in args.cases.split(";")] if args.cases else None
        store_key = args.what.replace("-", "_")
        data = json.loads(DATA.read_text())
        kept = data.get(store_key, {})
        kept.update(surface_limit(args.paths, keys) if args.what == "surface-limit" else converge(keys=keys))
        _store(store_key, kept)
    elif args.what == "choices":
        data = json.loads(PLANNER_DATA.read_text()) if PLANNER_DATA.exists() else {}
        data["choices"] = choices()
        PLANNER_DATA.write_text(json.dumps(data, indent=1))
    elif args.what == "timing":
        data = json.loads(PLANNER_DATA.read_text()) if PLANNER_DATA.exists() else {}
        data["timing"] = timing()
        PLANNER_DATA.write_text(json.dumps(data, indent=1))
    elif args.what == "planner":
        PLANNER_DATA.parent.mkdir(parents=True, exist_ok=True)
        data = json.loads(PLANNER_DATA.read_text()) if PLANNER_DATA.exists() else {}
        data.update(planner_table(), machine=f"{platform.machine()}, Python {platform.python_version()}")
        PLANNER_DATA.write_text(json.dumps(data, indent=1))
    elif args.what == "compare":
        stones = args.stones.split(",") if args.stones else None
        lamps = args.lamps.split(",") if args.lamps else None
        if args.no_internal:
            compare(args.paths, args.points, args.fresh, stones=stones, surface_events=1, key="no_internal", lamps=lamps)
        else:
            compare(args.paths, args.points, args.fresh, stones=stones, lamps=lamps)
    else:
        report()


if __name__ == "__main__":
    main()
