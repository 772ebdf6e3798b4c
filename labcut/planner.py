"""The effect planner: simulate only what a scene calls for (docs/planner.md).

Every command (``render``, ``recommend``, ``evaluate``, ``compare``) asks :func:`plan_effects`
which effects to simulate for its scene, and gets an :class:`EffectPlan`: each effect on or off,
how it is simulated and why, which flash estimator answers (``samples``: the surface-sample
triples of :mod:`labcut.orientation.problem`; ``render``: Mitsuba renders differentiated with
Dr.Jit, :mod:`labcut.orientation.render_estimator`) and the predicted time of each choice. The
plan travels with the result (``plan`` in every JSON) and ``--plan`` prints it.

Effects (all directions in the mesh frame, mm, +Z face-up):

``occlusion``
    parts of the stone hiding lights or viewers from other parts. A ray leaving a convex surface
    never meets the surface again, so a convex stone needs none (exact); a carving does.
``inter_reflection``
    light reaching a point by way of another part of the stone. Zero for a convex stone (exact).
    For a carving the planner bounds it: ``f x rho``, where ``f`` is the cosine-weighted share of
    the sky above the surface that is the stone itself (:func:`labcut.rendering.rays.self_view_fraction`)
    and ``rho`` the most the stone can send back (hemispherical Fresnel reflectance of its polish
    + body albedo + the brightest schiller reflectance). It is simulated (a path tracer; for a
    recommendation the render estimator) when the bound exceeds :data:`INTERREFLECTION_TOLERANCE`.
``depth``
    light mirrored below the surface by the stack (:attr:`labcut.Labradorite.flash_depth_mm` deep
    on average) leaving the stone elsewhere, or not at all where a part is thinner than the stack.
    Weighed by :func:`labcut.orientation.volume.depth_exposure` (the share of the surface over less
    stone than the stack's depth, the normal's turn across the flash depth): on (the ``volume``
    estimator) where that share reaches :data:`DEPTH_THIN_SHARE`.
``environment``
    an environment map among the lights (``ceiling``, ``sky``, an .exr/.hdr file): sampled into
    directions by the sample estimator, an ``envmap`` emitter in renders.
``polarisation``
    the flash metrics are for unpolarised light and an unpolarised eye. The sample estimator
    multiplies s/p-averaged transmissions and stack reflectance; the planner computes what that
    costs for the scene's light and view pairs (``(T_s R_s T_s + T_p R_p T_p)/2`` against
    ``T R T`` of the averages) and reports it. Renders are polarised only through a polariser.
``colour``
    flash metrics are luminance ratios, from a table that integrates the spectrum exactly at every
    angle (mono); renders are RGB unless spectral or mono is asked for, spectral with a polariser.
``zoning``
    colour zones (docs/zoning.md), when asked for (``--zoning``): in renders, and for
    ``recommend``/``evaluate`` through the render estimator (each point flashes with its own
    lamella stack, which the surface samples cannot carry).

The estimator (``recommend``, ``evaluate``; ``compare`` always ranks with the samples and says
what that leaves out): ``render`` where the scene needs what the surface samples cannot carry
(inter-reflection on, a zoned stone), ``volume`` where the stack's depth matters, ``samples``
otherwise. An environment map seen past the parts of a non-convex stone is drawn through more
directions than the quality's (:func:`env_samples_enough`): the samples see the map through
directions shared by every surface point, each blocked or not, and a few of them miss the light a
carving's parts let through from the rest of the map.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .errors import ParameterError
from .geometry.stone import Stone, mesh_of
from .scene.effects import ESTIMATORS, check_effects

__all__ = ["COMMANDS", "COMPARE_REFUSES", "PILOT_BUDGET_SHARE", "Decision", "EffectPlan", "check_compare_estimator", "measured_interreflection", "pilot_scene", "plan_effects", "plan_question"]

COMMANDS = ("render", "recommend", "evaluate", "compare")
#: the stated tolerance of the planner's "off" decisions: an effect whose measured or bounded
#: change of the flash energy stays below this share of it is left off. A fixed number, not yet
#: the answer's own error bar; tests/test_planner_off.py checks every "off" of the bundled stones
#: and scenarios against it, and docs/planner.md ("The tolerance") gives the seed-to-seed
#: spread of a recommendation's score it is set against (benchmarks/planner.py measures it)
INTERREFLECTION_TOLERANCE = 0.02
#: a map seen past a carving's parts is seen by the surface samples through at least this many of its
#: directions in the stone's own frame (the map's sampled directions x the poses: each pose turns
#: them; a still stone gets more drawn, :func:`env_samples_enough`): docs/planner.md measures the
#: biplane under the moving scenarios (224 and more) and the still ones (256) against the renders;
#: still under the ceiling through the quality's 32 and 64 directions the two were 9° and 2.7° apart
ENV_DIRECTIONS_ENOUGH = 96
#: where a map seen past a carving's parts has fewer (a still stone), the sample estimator draws at least
#: this many directions from it (:func:`env_samples_enough`): the biplane under the still office ceiling
#: (``ring-diffuse``, the whole light a map) at draft lands 4.6° from the renders' answer through 128
#: and 0.55° through 256 (docs/planner.md measures every still map-lit scenario)
ENV_SAMPLES_PAST_PARTS = 256
#: the light is carried through the stone's volume (the ``volume`` estimator) where at least this
#: share of the surface lies over less stone than the material's stack is deep
#: (:func:`labcut.orientation.volume.depth_exposure`): there the surface model lets thin parts mirror
#: a whole stack's flash. docs/planner.md ("Depth") measures the bundled stones: the carving
#: (66 %) loses a quarter of its flash energy through the volume; below, the low dome's rim (10 %)
#: and every other bundled cut move their answer by at most 0.5° and their energy by at most 4 %
DEPTH_THIN_SHARE = 0.2
#: seconds per path of the volume estimator on top of the sample estimator's time (four ray casts
#: and the path's terms, its error bars' quarter-budget problems included; measured on the 2-core
#: machine of docs/accuracy.md, "The volume estimator's cost": +1.1-1.9 s for 0.44-0.83 M paths at standard)
VOLUME_PATH_SECONDS = 2.5e-6


@dataclass(frozen=True)
class Decision:
    """One effect: simulated or not, how, why, and whether the user forced it."""

    effect: str
    on: bool
    how: str
    why: str
    forced: bool = False
    #: the predicted relative change of the flash energy if this effect were switched the other
    #: way (None where the planner has no estimate; 0.0 where it is exact)
    bound: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "on": self.on, "how": self.how, "why": self.why,
                "forced": self.forced, "bound": self.bound}


@dataclass(frozen=True)
class EffectPlan:
    """What a command simulates, how and why, and the predicted time of each choice (seconds)."""

    command: str
    decisions: tuple[Decision, ...]
    estimator: str | None
    estimator_why: str
    predicted_seconds: dict[str, float] = field(default_factory=dict)
    convex: bool = True
    facts: dict[str, Any] = field(default_factory=dict)
    #: wall seconds this plan spent on pilot renders (0 when they were cached: a stone's first plan
    #: pays them); not part of the plan's answer (nor of :meth:`to_dict`), for time budgets
    pilot_seconds: float = field(default=0.0, compare=False)
    #: the directions the sample (or volume) estimator draws from the scene's environment map, where
    #: the planner asks for more than the quality's (a map seen past a carving's parts,
    #: :func:`env_samples_enough`); None: the scene's own
    env_samples: int | None = None

    def __getitem__(self, effect: str) -> Decision:
        for d in self.decisions:
            if d.effect == effect:
                return d
        raise KeyError(effect)

    def on(self, effect: str) -> bool:
        return self[effect].on

    def to_dict(self) -> dict[str, Any]:
        return {
            "command": self.command,
            "estimator": self.estimator,
            "estimator_why": self.estimator_why,
            "predicted_seconds": {k: round(v, 3) for k, v in self.predicted_seconds.items()},
            "env_samples": self.env_samples,
            "convex": self.convex,
            "facts": self.facts,
            "effects": {d.effect: d.to_dict() for d in self.decisions},
        }

    def lines(self) -> list[str]:
        """The plan as text, one line per effect, then the estimator and its predicted time."""
        out = [f"{d.effect.replace('_', '-'):17} {'ON ' if d.on else 'off'}  {d.how if d.on else ''}"
               f"{' — ' if d.on else ''}{d.why}{' (forced)' if d.forced else ''}" for d in self.decisions]
        if self.estimator is not None:
            t = self.predicted_seconds.get(self.estimator)
            costs = ", ".join(f"{k} ~{v:.1f} s" for k, v in self.predicted_seconds.items())
            out.append(f"{'estimator':17} {self.estimator}  — {self.estimator_why}"
                       + (f" (predicted {t:.1f} s; {costs})" if t is not None else ""))
        elif self.predicted_seconds:
            where = self.facts.get("predicted_for")
            out.append(f"{'predicted':17} " + ", ".join(f"{k} ~{v:.1f} s" for k, v in self.predicted_seconds.items())
                       + (f" ({where})" if where else ""))
        return out

    def __repr__(self) -> str:
        on = [d.effect for d in self.decisions if d.on]
        est = f", estimator={self.estimator!r}" if self.estimator else ""
        return f"EffectPlan({self.command}: on={on}{est})"

    def _repr_html_(self) -> str:
        from html import escape

        rows = "".join(f"<tr><td>{escape(d.effect)}</td><td>{'on' if d.on else 'off'}</td><td>{escape(d.why)}</td></tr>"
                       for d in self.decisions)
        if self.estimator:
            rows += f"<tr><td>estimator</td><td>{escape(self.estimator)}</td><td>{escape(self.estimator_why)}</td></tr>"
        return f"<table><thead><tr><th>effect</th><th></th><th>why</th></tr></thead><tbody>{rows}</tbody></table>"


# ---------------------------------------------------------------------- facts of a scene
def occlusion_on(convex: bool, forced: Mapping[str, bool]) -> bool:
    """The planner's occlusion rule: on for a stone that is not convex, unless ``forced``
    (checked overrides, :func:`check_effects`) says otherwise."""
    return bool(forced.get("occlusion", not convex))


def occlusion_decision(convex: bool, forced: Mapping[str, bool]) -> Decision:
    """The flash estimators' occlusion decision (:func:`occlusion_on`) and why: none for a convex
    stone (exact), shadow rays for one that is not, unless switched off (approximate). Occlusion
    forced on for a convex stone is refused (a plan's first check)."""
    if forced.get("occlusion") and convex:
        raise ParameterError("occlusion cannot be switched on for a convex stone: no part of it can hide another")
    on = occlusion_on(convex, forced)
    if convex:
        return Decision("occlusion", False, "", "convex stone: a ray leaving the surface never meets it again (exact)",
                        False, 0.0)
    why = ("non-convex stone: parts of it hide lights and viewers from other parts" if on
           else "switched off: lights and viewers treated as seen from every surface point (approximate)")
    return Decision("occlusion", on, "shadow rays from every surface sample to every light and view direction", why,
                    "occlusion" in forced)


def map_directions_past_parts(scene: Any, occluded: bool, convex: bool) -> int | None:
    """How many directions the surface samples draw from the scene's environment map where it is
    seen past the parts of a stone that is not convex (:func:`env_samples_enough`, more than the
    quality's), or None where the quality's own serve: no map, a convex stone, occlusion off, or
    directions enough over the scene's poses already (docs/planner.md measures the rule)."""
    if convex or not occluded or not any(st.lights.environment is not None for st in scene.settings()):
        return None
    n_map = len(scene.lights) - scene.lights.n_lamps
    enough = env_samples_enough(n_map, len(scene.poses()))
    return enough if enough > n_map else None


def plan_surface_samples(mesh: Any, setup: Any) -> EffectPlan:
    """The plan of a live view's answer (:attr:`labcut.Study.surface_scorer`, the explorer's map and
    metrics): the surface samples, under :func:`plan_effects`'s occlusion rule and with its
    directions of an environment map seen past a carving's parts (:func:`map_directions_past_parts`),
    and none of the decisions that choose a recommendation's estimator from the material and the
    lights (inter-reflection and its pilot renders, the stack's depth, the polarisation bias: tenths
    of a second for a new material, which a lamp or material moved on the page need not wait for).
    ``setup``: a :class:`~labcut.orientation.question.FlashQuestion`."""
    from .scene import resolve_scene

    convex = Stone.of(mesh).convex
    forced = check_effects(setup.effect_overrides)
    occlusion = occlusion_decision(convex, forced)
    scene = resolve_scene(setup.scenario, None, None, setup.quality)
    dense = map_directions_past_parts(scene, occlusion.on, convex)
    return EffectPlan("recommend", (occlusion,), "samples", "a live view answers from the surface samples", {}, convex,
                      {"convex": convex}, env_samples=dense)


def hemispherical_fresnel(eta: float, samples: int = 512) -> float:
    """Cosine-weighted mean of the unpolarised Fresnel reflectance from air into index ``eta``."""
    from .physics import schiller

    c = (np.arange(samples) + 0.5) / samples  # midpoint rule over cos θ
    return float(2.0 * np.mean(schiller.fresnel_reflectance(c, eta) * c))


def return_albedo(material: Any) -> float:
    """The most light a stone can send back towards itself: hemispherical Fresnel reflectance of
    its polish + its body albedo + its brightest schiller (luminance) reflectance."""
    from .colour import luminance_table

    _, r = luminance_table(material)
    return hemispherical_fresnel(material.n_surface) + float(material.body_albedo) + float(np.max(r))


def _fresnel_sp(cos_i: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Power transmissions (T_s, T_p) from air into index ``eta`` at external cosines ``cos_i``."""
    from .physics.lamella import interface_amplitudes

    c = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    q_t = np.sqrt(np.maximum(eta * eta - (1.0 - c * c), 0.0))
    r_s, r_p = interface_amplitudes(c, q_t, 1.0, eta)
    return 1.0 - r_s * r_s, 1.0 - r_p * r_p


#: polarisation biases kept in the user cache file (the latest this many material and direction sets)
POLARISATION_KEEP = 256


def polarisation_bias(material: Any, lights: Any, views: Any) -> float:
    """Relative error of the unpolarised (s/p-averaged) schiller for a scene's light/view pairs.

    For every pair (mesh frame; the stone's face +Z, the lamella normal at the pair's internal
    half vector, where the flash is), the exact unpolarised product ``(T_s R_s T_s + T_p R_p
    T_p)/2`` against ``T R T`` of the s/p averages; weighted by light x view weight. Pairs that
    do not both lie above the face carry no schiller and are skipped.

    The spectra of the s and p stacks are the cost, and a CLI call plans a preset scenario's poses
    every time: the value is kept, in this process and in the user cache file
    ``planner-polarisation.json`` (:func:`labcut.fileio.calibration`), keyed by every material
    parameter, a hash of the directions and weights, labcut's, numpy's and Mitsuba's versions and
    a hash of the code that computes it (this module, the colour and physics modules)."""
    return polarisation_biases(material, [(lights, views)])[0]


def polarisation_biases(material: Any, pairs: Sequence[tuple[Any, Any]]) -> list[float]:
    """:func:`polarisation_bias` of each ``(lights, views)`` of ``pairs`` (a scene's poses): those
    not kept computed together (one s and one p spectrum of the stack for all of them) and kept
    with one write of the cache file."""
    import hashlib

    from .colour import material_key
    from .fileio import calibrations

    arrays, keys = [], []
    for lights, views in pairs:
        L = np.asarray(lights.directions, dtype=np.float64)
        V = np.asarray(views.directions, dtype=np.float64)
        wl, wv = np.asarray(lights.weights, dtype=np.float64), np.asarray(views.weights, dtype=np.float64)
        digest = hashlib.blake2b(digest_size=16)
        for x in (L, wl, V, wv):
            digest.update(str(x.shape).encode())
            digest.update(np.ascontiguousarray(x).tobytes())
        arrays.append((L, wl, V, wv))
        keys.append(f"planner {_planner_code()} directions {digest.hexdigest()} {material_key(material)}")
    by_key = dict(zip(keys, arrays))

    def measure(missing: list[str]) -> list[dict[str, float]]:
        return [{"bias": b} for b in _polarisation_bias(material, [by_key[k] for k in missing])]

    values = calibrations("planner-polarisation.json", keys, measure, check=lambda v: float(v["bias"]),
                          keep=POLARISATION_KEEP)
    return [float(v["bias"]) for v in values]


@functools.lru_cache(maxsize=1)
def _planner_code() -> str:
    """A hash of this module's code (part of the polarisation biases' cache key)."""
    from pathlib import Path

    from .fileio import code_hash

    return code_hash(Path(__file__))


def _polarisation_bias(material: Any, sets: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]) -> list[float]:
    """:func:`polarisation_bias` of each ``(L, wl, V, wv)`` of ``sets``: light directions ``L``
    (n, 3) with weights ``wl`` and view directions ``V`` (m, 3) with weights ``wv``, computed; the
    stack's s and p luminance reflectances of every set's half-vector cosines read from the material's
    table (:func:`labcut.colour.luminance_sp_table`)."""
    from .colour import luminance_sp_table

    eta = float(material.n_surface)

    def internal(d: np.ndarray) -> np.ndarray:  # refracted into the stone, pointing out of it
        c = np.clip(d[:, 2], 1e-6, 1.0)
        t = d.copy()
        t[:, :2] /= eta
        t[:, 2] = np.sqrt(np.maximum(1.0 - (1.0 - c * c) / (eta * eta), 0.0))
        return t / np.linalg.norm(t, axis=1, keepdims=True)

    parts = []
    for L, wl, V, wv in sets:
        cl, cv = L[:, 2][:, None], V[:, 2][None, :]
        a, b = internal(L), internal(V)
        h = a[:, None, :] + b[None, :, :]
        cos_half = np.clip(np.einsum("ijk,ijk->ij", a[:, None, :].repeat(len(V), 1), h) / np.maximum(np.linalg.norm(h, axis=2), 1e-12), 0.0, 1.0)
        parts.append((cl, cv, wl, wv, cos_half))
    flat = np.concatenate([p[4].ravel() for p in parts]) if parts else np.zeros(0)
    grid, ys, yp = luminance_sp_table(material)
    rs_all, rp_all = np.interp(flat, grid, ys), np.interp(flat, grid, yp)
    out, start = [], 0
    for cl, cv, wl, wv, cos_half in parts:
        n = cos_half.size
        rs, rp = rs_all[start:start + n].reshape(cos_half.shape), rp_all[start:start + n].reshape(cos_half.shape)
        start += n
        ok = (cl > 1e-3) & (cv > 1e-3)
        if not np.any(ok):
            out.append(0.0)
            continue
        ts_l, tp_l = _fresnel_sp(np.clip(cl, 0, 1), eta)
        ts_v, tp_v = _fresnel_sp(np.clip(cv, 0, 1), eta)
        exact = 0.5 * (ts_l * rs * ts_v + tp_l * rp * tp_v)
        approx = (0.5 * (ts_l + tp_l)) * (0.5 * (rs + rp)) * (0.5 * (ts_v + tp_v))
        w = np.where(ok, wl[:, None] * wv[None, :], 0.0)
        # the bias of the flash energy: weighted by the flash each pair carries
        total = float(np.sum(w * exact))
        out.append(float(abs(np.sum(w * (approx - exact))) / total) if total > 0 else 0.0)
    return out


# ---------------------------------------------------------------------- the planner
#: pilot renders that measure inter-reflection (:func:`measured_interreflection`)
PILOT_RESOLUTION = 64
PILOT_SPP = 16
PILOT_POSES = 5
#: stones of more triangles are piloted on a clustered copy (:func:`labcut.geometry.proxy.clustered_proxy`)
#: of cells :data:`PILOT_CELLS` to the bounding diagonal (a pilot pixel is about 1/64 of it: four
#: cells to a pixel); at or below it, on the mesh itself
PILOT_FACES = 200_000
#: the quality whose lamp, map and viewing-cone directions and rocking poses the pilot renders
#: sample (:func:`plan_effects`' ``pilot_scene``): one measurement per stone and scene, whatever the
#: plan's quality, so a plan decides the same at every quality and a time budget's plan (made at
#: the asked quality) has measured what the chosen rung's plan needs
PILOT_QUALITY = "standard"
PILOT_CELLS = 256
_PILOT_CACHE: dict[str, float] = {}
#: seconds per pose of a stone's pilot renders, predicted before this machine has made any (the
#: bundled biplane's first pilots took 0.32-0.44 s a pose on 2 cores); after, the running mean of
#: its own (:func:`pilot_seconds_predicted`), kept in the pilot cache under :data:`PILOT_TIMING_KEY`
PILOT_SECONDS_PER_POSE = 0.4
#: the share of a time budget a never-seen stone's pilot renders may take (``pilot_seconds_max``):
#: predicted to take longer, they are skipped and the plan says so (the budget's rungs need the rest)
PILOT_BUDGET_SHARE = 0.25
PILOT_TIMING_KEY = "seconds per pose"


def pilot_seconds_predicted(poses: int) -> float:
    """Seconds this machine's pilot renders of ``poses`` poses (at most :data:`PILOT_POSES`) are
    predicted to take: its running mean seconds per pose (:data:`PILOT_SECONDS_PER_POSE` before any)."""
    from .fileio import read_cache

    try:
        per_pose = float((read_cache(_pilot_cache_path()) or {}).get(PILOT_TIMING_KEY, PILOT_SECONDS_PER_POSE))
    except (TypeError, ValueError):
        per_pose = PILOT_SECONDS_PER_POSE
    return min(int(poses), PILOT_POSES) * per_pose


def measured_interreflection(mesh: Any, material: Any, scene: Any, timing: dict[str, float] | None = None,
                             max_seconds: float | None = None) -> float | None:
    """The share of the best flash energy that light between the parts of ``mesh`` adds under
    ``scene`` (:func:`labcut.orientation.render_objective.interreflection_share` with pilot renders
    of :data:`PILOT_RESOLUTION`² px at :data:`PILOT_SPP` spp, seed 0, at most :data:`PILOT_POSES`
    of the scene's poses, evenly spaced). Cached for the process and
    on disk (the user cache folder, keyed by the mesh's vertices and faces, the material, the
    scene's lights, views and poses, labcut's version and what renders:
    :func:`labcut.fileio.compute_platform`), so a second plan of the same stone costs nothing. A stone of
    more than :data:`PILOT_FACES` triangles (a scan) is rendered as its clustered copy
    (:func:`pilot_mesh`): a 64-pixel pilot sees the same shape, at a fraction of the cost.
    ``timing``: a dict that gets ``"pilot_seconds"``, the seconds the renders took (0 when cached).
    ``max_seconds``: the most the renders may take (a time budget's share): when they are not
    cached and :func:`pilot_seconds_predicted` exceeds it, nothing is rendered, the answer is
    None (not measured) and ``timing`` gets ``"pilot_seconds_skipped"``, the prediction."""
    import hashlib
    import json

    from .orientation.render_objective import interreflection_share

    settings = scene.settings()
    if len(settings) > PILOT_POSES:  # a rocking hand: every k-th pose is enough for a share
        settings = settings[:: -(-len(settings) // PILOT_POSES)]
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    h.update(json.dumps(material.to_dict(), sort_keys=True, default=str).encode())
    for st in settings:
        for a in (st.lights.directions, st.lights.weights, st.views.directions, st.views.weights, st.pose):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        h.update(str(float(st.weight)).encode())
    # what is rendered: the mesh itself (the key as before the copies), or its copy of PILOT_CELLS cells
    on_copy = f" copy {PILOT_CELLS} v2" if pilots_on_copy(mesh) else " v1"
    on_copy += " emitters hidden"  # since the renders stopped counting the lights seen behind the stone
    on_copy += " render frame"  # since renders place the stone in its render frame (last bits moved)
    h.update(f"pilot {PILOT_RESOLUTION} {PILOT_SPP} {PILOT_POSES}{on_copy}".encode())
    from . import __version__
    from .fileio import compute_platform

    h.update(f"labcut {__version__}".encode())  # a new release may render (or decide) otherwise
    h.update(compute_platform().encode())  # another backend or libLLVM renders other noise
    key = h.hexdigest()[:32]
    if key in _PILOT_CACHE:
        return _PILOT_CACHE[key]
    from .fileio import cache_problem, read_cache, write_cache

    path = _pilot_cache_path()
    try:
        stored = {str(k): float(v) for k, v in (read_cache(path) or {}).items()}
    except (TypeError, ValueError):
        cache_problem(path, "a value is not a number")
        stored = {}
    if key in stored:
        _PILOT_CACHE[key] = stored[key]
        return stored[key]
    if max_seconds is not None:
        predicted = pilot_seconds_predicted(len(settings))
        if predicted > max_seconds:
            if timing is not None:
                timing["pilot_seconds_skipped"] = predicted
            return None
    t0 = time.perf_counter()
    value = interreflection_share(pilot_mesh(mesh), material, settings, resolution=PILOT_RESOLUTION, spp=PILOT_SPP)
    took = time.perf_counter() - t0
    if timing is not None:
        timing["pilot_seconds"] = took
    _PILOT_CACHE[key] = value
    per_pose = took / len(settings)
    seen = stored.pop(PILOT_TIMING_KEY, None)
    stored[key] = value
    stored = dict(list(stored.items())[-512:])  # the latest 512 stones and scenes
    stored[PILOT_TIMING_KEY] = per_pose if seen is None else 0.5 * (seen + per_pose)
    write_cache(path, stored)
    return value


def pilots_on_copy(mesh: Any) -> bool:
    """Whether the pilot renders of ``mesh`` render its clustered copy (:func:`pilot_mesh`): more
    than :data:`PILOT_FACES` triangles."""
    return len(mesh.faces) > PILOT_FACES


def pilot_mesh(mesh: Any) -> Any:
    """What the pilot renders render: ``mesh`` itself up to :data:`PILOT_FACES` triangles, else its
    clustered copy with :data:`PILOT_CELLS` cells along the bounding diagonal (a 4.9 M-triangle
    subdivision of the bundled biplane: about 87 k triangles, ``benchmarks/speed_ratio.py --big``;
    ``tests/test_pilot_proxy.py`` compares the pilots' share of inter-reflection on a copy with the
    full mesh's). The copy, made once per mesh, is certified as the checked ``mesh``'s stand-in
    (:func:`labcut.geometry.meshio.mark_valid`): the renderer's closed-mesh check would refuse the
    few non-manifold edges clustering can leave; it is made for these pilots, not as a solid."""
    if not pilots_on_copy(mesh):
        return mesh
    from .geometry.meshio import mark_valid
    from .geometry.proxy import clustered_proxy

    stone = Stone.of(mesh)
    mesh = stone.mesh

    def stand_in() -> Any:
        diagonal = float(np.linalg.norm(np.ptp(np.asarray(mesh.bounds, dtype=np.float64), axis=0)))
        copy = clustered_proxy(mesh, diagonal / PILOT_CELLS)
        mark_valid(copy)
        return copy

    return stone.cached(f"pilot_proxy_{PILOT_CELLS}", stand_in)


def _pilot_cache_path() -> Any:
    from .fileio import cache_path

    return cache_path("planner-pilot.json")


def plan_question(mesh: Any, setup: Any, command: str = "recommend", *, predict: bool = True,
                  pilot_seconds_max: float | None = None) -> EffectPlan:
    """The effect plan of a flash question (a :class:`~labcut.orientation.question.FlashQuestion`) about
    ``mesh``: :func:`plan_effects` given every part of it (material, scene, quality, estimator,
    effect overrides, zoning) and the pilots' scene (:func:`pilot_scene`). ``predict``: also
    predict each estimator's seconds (on by default, as ``plan_effects``); ``pilot_seconds_max``:
    as ``plan_effects``."""
    return plan_effects(mesh, setup.material, command=command, scenario=setup.scenario, quality=setup.quality,
                        estimator=setup.estimator, effects=setup.effect_overrides, zoning=setup.zoning,
                        predict=predict, pilot_scene=pilot_scene(setup), pilot_seconds_max=pilot_seconds_max)


def pilot_scene(setup: Any) -> Any:
    """The scene of a flash question drawn at :data:`PILOT_QUALITY`: what its pilot renders
    measure under, whatever the question's quality (``plan_effects(..., pilot_scene=)``)."""
    from .scene.quality import Quality

    pilot = Quality.coerce(PILOT_QUALITY)
    return setup.scenario if setup.quality == pilot else setup.at_quality(pilot).scenario


def plan_effects(
    mesh: Any,
    material: Any = None,
    *,
    command: str = "recommend",
    scenario: Any = None,
    lighting: Any = None,
    viewing: Any = None,
    quality: str = "standard",
    estimator: str = "auto",
    mode: str | None = None,
    polarizer_deg: float | None = None,
    zoning: Any = None,
    max_depth: int | None = None,
    effects: Mapping[str, Any] | None = None,
    predict: bool = True,
    resolution: int | None = None,
    spp: int | None = None,
    views: int = 1,
    look: str = "diagram",
    pilot_scene: Any = None,
    pilot_seconds_max: float | None = None,
) -> EffectPlan:
    """Decide which effects ``command`` simulates for a stone in a scene (module docstring).

    ``estimator`` (``recommend``/``evaluate``/``compare``): ``auto`` lets the planner choose,
    ``samples``/``render`` force one. ``mode``/``polarizer_deg``/``zoning``/``max_depth``: a
    render's request. ``effects``: ``{"occlusion": bool, "inter_reflection": bool}`` overrides.
    ``predict``: the predicted seconds of each choice on this machine (calibrated once, a few
    seconds, then cached: :mod:`labcut.orientation.timing`, :func:`evaluate_timing`,
    :func:`render_command_timing`): for ``recommend`` and ``evaluate`` each estimator's, for
    ``compare`` the sample estimator's recommendation of the cut (its curves and renders come on
    top), for ``render`` the render at ``resolution``² px (default 512), ``spp`` samples per pixel
    (default 64), ``views`` views (default 1) and ``look`` (``diagram`` or ``studio``), as
    ``facts["predicted_for"]`` says. ``pilot_scene``: the scene the pilot renders of inter-reflection
    measure under (:func:`measured_interreflection`); default: ``scenario``, ``lighting`` and
    ``viewing`` drawn at :data:`PILOT_QUALITY` (a scene given as a :class:`~labcut.Scenario` object
    keeps its own directions: pass :func:`pilot_scene` of the question to pilot the question's scene at
    that quality). ``pilot_seconds_max``: the most those pilot renders may take (a time budget's
    share): predicted to take longer (and not cached), they are not rendered, inter-reflection stays
    off and its decision says why (None: no limit).

    Raises :class:`~labcut.errors.ParameterError` for combinations the scene cannot have (a
    polariser with mono colour, inter-reflection in a convex stone, an unknown effect ...).

    Examples
    --------
    >>> import labcut
    >>> cab = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
    >>> plan = labcut.plan_effects(cab, "blue", command="recommend", scenario="bench", predict=False)
    >>> plan.estimator, plan.on("occlusion"), plan["occlusion"].why
    ('samples', False, 'convex stone: a ray leaving the surface never meets it again (exact)')
    >>> labcut.plan_effects(cab, "blue", command="render", polarizer_deg=30.0)["colour"].how
    'spectral'
    >>> labcut.plan_effects(cab, "blue", command="render", polarizer_deg=30.0, mode="mono")
    Traceback (most recent call last):
    ...
    labcut.errors.ParameterError: a polariser view needs colour (the polarised schiller changes hue): use --mode spectral or leave --mode out, not mono
    """
    mesh = mesh_of(mesh)  # a Stone or a trimesh
    from .physics.material import Labradorite
    from .scene import resolve_scene

    if command not in COMMANDS:
        raise ParameterError(f"command must be one of {', '.join(COMMANDS)}, got {command!r}")
    if estimator not in ESTIMATORS:
        raise ParameterError(f"estimator must be one of {', '.join(ESTIMATORS)}, got {estimator!r}")
    forced = check_effects(effects)
    pilot_seconds = 0.0
    from .scene import Scenario

    if pilot_scene is not None and not isinstance(pilot_scene, Scenario):
        raise ParameterError(f"pilot_scene must be a labcut.Scenario (planner.pilot_scene(setup)), got {type(pilot_scene).__name__}")
    from .validation import check_number

    resolution = None if resolution is None else check_number(resolution, "resolution", 8, 8192, integer=True)
    spp = None if spp is None else check_number(spp, "spp (samples per pixel)", 1, 1 << 30, integer=True)  # as labcut.render: no practical limit
    views = check_number(views, "views", 1, 10_000, integer=True)
    if look not in ("diagram", "studio"):
        raise ParameterError(f"look must be diagram or studio, got {look!r}")
    material = Labradorite.coerce(material)
    scene = resolve_scene(scenario, lighting, viewing, quality)
    rendering = command == "render"
    if not rendering and (polarizer_deg is not None or mode is not None):
        raise ParameterError(f"{command} scores luminance flash: colour mode and polariser apply to renders only")
    if zoning is not None and command == "compare":
        raise ParameterError("compare scores uniform materials with the sample estimator: zoning applies to "
                             "render, recommend-orientation and evaluate-orientation")
    if zoning is not None and estimator == "samples":
        raise ParameterError("the sample estimator scores a uniform material: a zoned stone needs --estimator render "
                             "(or auto, which picks it)")
    if rendering and estimator != "auto":
        raise ParameterError("estimator applies to recommend, evaluate and compare, not to render")
    if polarizer_deg is not None and mode == "mono":
        raise ParameterError("a polariser view needs colour (the polarised schiller changes hue): "
                             "use --mode spectral or leave --mode out, not mono")
    convex = Stone.of(mesh).convex
    facts: dict[str, Any] = {"convex": convex, "scenario": scene.name, "lighting": scene.lights.name,
                             "viewing": scene.views.name, "poses": len(scene.poses())}
    decisions: list[Decision] = []

    # occlusion ---------------------------------------------------------------
    occlusion = occlusion_decision(convex, forced)
    if rendering:
        occ_on = True
        decisions.append(Decision("occlusion", True, "ray tracing", "a renderer traces every ray; it costs nothing extra",
                                  "occlusion" in forced, None if not convex else 0.0))
    else:
        occ_on = occlusion.on
        decisions.append(occlusion)

    # inter-reflection ----------------------------------------------------------
    if "inter_reflection" in forced and forced["inter_reflection"] and convex:
        raise ParameterError("inter-reflection cannot be switched on for a convex stone: no light path leaves it and comes back")
    if convex:
        bound = 0.0
        ir_on = False
        why = "convex stone: no light path leaves it and comes back (exact)"
    else:
        from .rendering.rays import self_view_fraction

        f = self_view_fraction(mesh)
        rho = return_albedo(material)
        bound = f * rho
        facts.update(self_view_fraction=round(f, 4), return_albedo=round(rho, 4), interreflection_bound=round(bound, 4))
        share = f"{f:.0%} of the sky above the surface is the stone itself, which sends back at most {rho:.0%}"
        measured = None
        if bound > INTERREFLECTION_TOLERANCE and "inter_reflection" not in forced and command in ("recommend", "evaluate"):
            # the bound is loose (the returning light is mostly the lamps' mirror images, which
            # rarely meet the lamellae's flash direction): measure it with pilot renders
            timing: dict[str, float] = {}
            if pilot_scene is None:  # drawn here, where pilots are needed: a plan without them never resolves it
                pilot_scene = resolve_scene(scenario, lighting, viewing, PILOT_QUALITY)
            measured = measured_interreflection(mesh, material, pilot_scene, timing=timing, max_seconds=pilot_seconds_max)
            pilot_seconds = timing.get("pilot_seconds", 0.0)
            if measured is None:  # the time budget has no room for the pilots: not measured, left off
                facts["interreflection_pilots_skipped_seconds"] = round(timing["pilot_seconds_skipped"], 3)
            else:
                facts["interreflection_measured"] = round(measured, 5)
        size = bound if measured is None else measured
        ir_on = forced.get("inter_reflection", size > INTERREFLECTION_TOLERANCE)
        skipped = facts.get("interreflection_pilots_skipped_seconds")
        if measured is None:
            evidence = f"{share}: at most {bound:.1%} of the flash energy"
        else:
            # (the copy is named, not built: a cached measurement needs no copy)
            on_copy = "" if not pilots_on_copy(mesh) else f", of a copy clustered to {PILOT_CELLS} cells along its diagonal"
            evidence = (f"pilot renders with and without light between its parts ({PILOT_RESOLUTION}² px, {PILOT_SPP} spp, "
                        f"5 normals{on_copy}) differ by {measured:.1%} of the best flash ({share}: a bound of {bound:.1%})")
        if "inter_reflection" in forced:
            why = f"switched {'on' if ir_on else 'off'} ({evidence})"
        elif skipped is not None:  # the time budget has no room to measure it: the surface samples answer
            ir_on = False
            why = (f"not measured: the time budget leaves {pilot_seconds_max:.2g} s for pilot renders predicted to take "
                   f"{skipped:.2g} s, so the surface samples answer ({evidence}; a larger budget, or none, measures it)")
        elif ir_on:
            why = f"{evidence}, above the {INTERREFLECTION_TOLERANCE:.0%} the answer can miss"
        else:
            why = f"{evidence}, below the {INTERREFLECTION_TOLERANCE:.0%} the answer can miss"
        bound = size
    if rendering and max_depth is not None:
        ir_on = int(max_depth) > 2
        how = f"path tracing to depth {int(max_depth)} (as asked)"
    elif rendering:
        ir_on = not convex  # a renderer traces the extra bounces at little cost: no need to measure
        how = "path tracing, 3 bounces"
    else:
        how = "the render estimator's path tracer (the surface samples cannot carry it)"
    decisions.append(Decision("inter_reflection", ir_on, how, why, "inter_reflection" in forced, bound))

    # depth -----------------------------------------------------------------------
    from .orientation.volume import depth_exposure

    exposure = depth_exposure(mesh, material)
    facts.update(thin_share=exposure["thin_share"], normal_turn_deg=exposure["turn_deg"],
                 flash_depth_mm=exposure["flash_depth_mm"], stack_depth_mm=exposure["stack_depth_mm"])
    thin_text = (f"{exposure['thin_share']:.0%} of the surface lies over less stone than the stack's "
                 f"{exposure['stack_depth_mm']:.2f} mm and the normal turns {exposure['turn_deg']:.1f}° across twice "
                 f"the flash depth ({exposure['flash_depth_mm']:.2f} mm)")
    depth_on = forced.get("depth", exposure["thin_share"] >= DEPTH_THIN_SHARE)
    if rendering:
        depth_on = False
        depth_why = "renders mirror the schiller where the light meets the surface (the BSDF); recommend --estimator volume carries the depth"
    elif "depth" in forced:
        depth_why = f"switched {'on' if depth_on else 'off'} ({thin_text})"
    elif depth_on:
        depth_why = (f"{thin_text}: at or above {DEPTH_THIN_SHARE:.0%}, thin parts would mirror a whole stack's flash "
                     "in the surface model")
    else:
        depth_why = (f"{thin_text}: below {DEPTH_THIN_SHARE:.0%}; on the bundled cuts this leaves the energy within 4 % "
                     "and the answer within 0.6° (1.3° along a worn ring's flat top; docs/planner.md)")
    decisions.append(Decision("depth", depth_on, "the volume estimator: light refracted in, mirrored at a depth drawn "
                              "from the stack's depth law, traced to where it leaves", depth_why, "depth" in forced))

    # environment ---------------------------------------------------------------
    envs = {st.lights.environment.name for st in scene.settings() if st.lights.environment is not None}
    if envs:
        env_how = ("an envmap emitter" if rendering else
                   f"{len(scene.lights) - scene.lights.n_lamps} directions importance-sampled from the map")
        decisions.append(Decision("environment", True, env_how, f"the lights include the map {', '.join(sorted(envs))!r}"))
    else:
        decisions.append(Decision("environment", False, "", "the lights are lamps only"
                                  + (" (a dim constant room shows the body in renders)" if rendering else ""), False, 0.0))

    # polarisation --------------------------------------------------------------
    if rendering:
        if polarizer_deg is not None:
            decisions.append(Decision("polarisation", True, "Stokes vectors through Mueller matrices (polarised variant)",
                                      f"a polariser at {polarizer_deg:g}° is in front of the camera"))
        else:
            decisions.append(Decision("polarisation", False, "", "no polariser: the eye and the camera see unpolarised light"))
    else:
        bias = max(polarisation_biases(material, [(st.lights, st.views) for st in scene.settings()]))
        facts["polarisation_bias"] = round(bias, 5)
        over = (f", above the {INTERREFLECTION_TOLERANCE:.0%} the answer can miss: the flash estimators carry "
                "unpolarised terms only (grazing light on the face; a render with --polarizer shows the polarised "
                "flash)") if bias > INTERREFLECTION_TOLERANCE else ""
        decisions.append(Decision(
            "polarisation", False, "",
            f"unpolarised light and eye: s/p-averaged Fresnel and stack terms, {bias:.2%} off the exact "
            f"unpolarised product for this scene's light and view pairs{over}", False, bias))

    # colour --------------------------------------------------------------------
    if rendering:
        m = mode or "rgb"
        if polarizer_deg is not None and m == "rgb":
            m = "spectral"
            why = "a polariser: Mitsuba has no polarised RGB, so spectral"
        elif mode is None:
            why = "RGB: the BSDF's colour table integrates the spectrum at every angle"
        else:
            why = f"{m} as asked"
        decisions.append(Decision("colour", True, m, why))
        facts["mode"] = m
    else:
        decisions.append(Decision("colour", False, "luminance",
                                  "flash metrics are luminance ratios: a luminance table integrates the spectrum "
                                  "exactly at every angle (no colour channels needed)", False, 0.0))

    # zoning --------------------------------------------------------------------
    if zoning is not None:
        label = zoning if isinstance(zoning, str) else (getattr(zoning, "name", None) or "custom")
        decisions.append(Decision("zoning", True, "lamella parameters blended by a baked noise field" +
                                  ("" if rendering else ": the render estimator weighs each zone's flash as the viewers see it"),
                                  "a studio picture shows a real stone's zones by default (natural; --zoning none "
                                  "for the clean model)" if label == "natural" and rendering and look == "studio"
                                  else f"colour zones asked for ({label})"))
    else:
        decisions.append(Decision("zoning", False, "", "a uniform material" + ("" if command == "compare" else
                                  " (--zoning asks for colour zones)")))

    # estimator -----------------------------------------------------------------
    chosen: str | None = None
    est_why = ""
    n_map = len(scene.lights) - scene.lights.n_lamps
    # an environment map seen past the parts of a carving: the samples see the map through n_map
    # directions shared by every surface point, each blocked or not (docs/planner.md measures it)
    env_seen = n_map * len(scene.poses())  # the map's directions in the stone's frame, over the motion
    past_parts = bool(envs) and occ_on and not convex
    dense = map_directions_past_parts(scene, occ_on, convex)
    if past_parts:
        facts["map_directions"] = n_map
        facts["map_directions_over_poses"] = env_seen
    seen_through = (f"the environment map is seen past the stone's parts through {dense} sampled directions instead "
                    f"of the quality's {n_map} (fewer miss the light the parts let through from the rest of the map, "
                    "docs/planner.md)") if dense else ""
    if not rendering:
        if estimator == "render":
            chosen, est_why = "render", "asked for"
            if depth_on:
                est_why += "; renders mirror the light where it enters (the stack's depth is left out)"
        elif estimator == "volume":
            chosen, est_why = "volume", "asked for"
            if ir_on:
                est_why += f"; it cannot carry inter-reflection (up to {bound:.1%} of the energy is left out)"
            if dense:
                est_why += f"; {seen_through}"
        elif estimator == "samples":
            chosen, est_why = "samples", "asked for"
            if depth_on:
                est_why += "; it mirrors the light where it enters (the stack's depth is left out)"
            if ir_on:
                est_why += f"; it cannot carry inter-reflection (up to {bound:.1%} of the energy is left out)"
            if dense:
                est_why += f"; {seen_through}"
        elif zoning is not None:
            chosen, est_why = "render", "a zoned stone: each point flashes with its own lamella stack, which only renders carry"
        elif ir_on:
            chosen, est_why = "render", "inter-reflection is on and only renders carry it"
        elif depth_on or past_parts:
            chosen = "volume" if depth_on else "samples"
            parts = (["the stack's depth matters here and the volume estimator carries it"] if depth_on else []) + (
                [seen_through] if dense else
                [f"an environment map seen past the parts of a non-convex stone, but the moving stone sees {n_map} map "
                 f"directions in each of {len(scene.poses())} poses, {env_seen} in its own frame (at least "
                 f"{ENV_DIRECTIONS_ENOUGH}): the samples follow the map as the renders do (docs/planner.md)"]
                if past_parts else [])
            est_why = "; ".join(parts)
        else:
            chosen, est_why = "samples", "every effect on is one the surface samples carry"
        if chosen == "render" and depth_on and estimator == "auto":
            est_why += "; renders mirror the light where it enters (the stack's depth is left out)"
        if command == "compare" and chosen in COMPARE_REFUSES:
            check_compare_estimator(estimator)
            chosen = "samples"
            missing = ([f"inter-reflection (up to {bound:.1%} of the flash energy)"] if ir_on else []) + (
                ["the stack's depth (thin parts mirroring less)"] if depth_on else [])
            how = " or ".join((["--estimator render"] if ir_on else []) + (["--estimator volume"] if depth_on else []))
            est_why = (f"compare ranks many cuts with the sample estimator; {' and '.join(missing)} "
                       f"{'are' if len(missing) > 1 else 'is'} left out: "
                       f"recommend-orientation {how} per cut carries it") + (f"; {seen_through}" if dense else "")
            decisions = [Decision(d.effect, False, "", f"left out: compare ranks with the sample estimator ({d.why})",
                                  d.forced, d.bound) if d.effect in ("inter_reflection", "depth") and d.on else d
                         for d in decisions]
    predicted: dict[str, float] = {}
    if predict:
        if rendering:
            size = (512 if resolution is None else resolution, 64 if spp is None else spp, views)
            facts["predicted_for"] = f"{size[0]}² px, {size[1]} spp, {size[2]} view{'s' if size[2] != 1 else ''}, {look} look"
            integrator = "path" if ir_on or max_depth is not None else "direct"
            predicted = _predicted_render_seconds(facts["mode"], polarizer_deg is not None, integrator, *size, look)
        else:
            predicted = estimator_seconds(scene, command, occ_on, ir_on, convex, zoning is not None, env_samples=dense)
    if dense and chosen in ("samples", "volume"):
        facts["map_directions_sampled"] = dense
        decisions = [replace(d, how=f"{dense} directions importance-sampled from the map (the quality's {n_map}, "
                                    "more where the map is seen past the stone's parts)") if d.effect == "environment" else d
                     for d in decisions]
    return EffectPlan(command, tuple(decisions), chosen, est_why, predicted, convex, facts, pilot_seconds,
                      env_samples=dense if chosen in ("samples", "volume") else None)


def env_samples_enough(n_map: int, poses: int) -> int:
    """How many directions the sample estimator draws from an environment map seen past a stone's parts:
    the scene's ``n_map`` where the stone moves through ``poses`` (more than one) that turn them to at
    least :data:`ENV_DIRECTIONS_ENOUGH` in its own frame; otherwise ``n_map`` doubled until it reaches
    :data:`ENV_SAMPLES_PAST_PARTS` (a still stone at any bundled quality: 256)."""
    n = max(int(n_map), 1)
    if int(poses) > 1 and n * int(poses) >= ENV_DIRECTIONS_ENOUGH:
        return n
    while n < ENV_SAMPLES_PAST_PARTS:
        n *= 2
    return n


#: the estimators compare does not run (it ranks many cuts with the surface samples)
COMPARE_REFUSES = ("render", "volume")


def check_compare_estimator(estimator: str) -> None:
    """Refuse, with a one-line :class:`~labcut.errors.ParameterError`, an estimator compare does not
    run (:data:`COMPARE_REFUSES`): the planner's and the CLI's one check."""
    if estimator in COMPARE_REFUSES:
        raise ParameterError("compare runs the sample estimator (many cuts and curves); "
                             f"use --estimator samples, or recommend-orientation --estimator {estimator} per cut")


def estimator_seconds(scene: Any, command: str, occlusion: bool, inter_reflection: bool, convex: bool,
                      zoned: bool = False, *, env_samples: int | None = None) -> dict[str, float]:
    """Predicted seconds of each estimator on this machine (calibrated:
    :func:`predict_sample_seconds`, :func:`evaluate_timing`,
    :func:`labcut.orientation.render_estimator.predict_render_seconds`).

    ``recommend``: the render estimator starts from the sample estimator's answer, so its time
    includes the samples'; a zoned stone's starts from a coarse map of renders over the whole
    hemisphere (:attr:`~labcut.orientation.render_estimator.RenderQuality.coarse_deg` apart),
    counted here. ``evaluate``: building the sample problem and scoring one normal; the render
    estimator builds the same problem, then renders every view once. ``compare``: the sample
    estimator's recommendation of the cut under the scenario (the curves and renders come on top)."""
    from .orientation.timing import calibrating

    if calibrating():
        return {}
    from .orientation.optimize import Constraint, hemisphere_grid
    from .orientation.render_estimator import RenderQuality, predict_render_seconds

    settings = scene.with_env_samples(env_samples).settings()  # the samples' scene (the renders see the map itself)
    q = scene.quality
    rq = RenderQuality.of(q)
    n_views = sum(len(st.views) for st in settings)
    depth = 4 if inter_reflection else 2
    if command == "evaluate":
        samples = predict_evaluate_seconds(settings, q.surface_points, occlusion)
        one = predict_render_seconds(n_views, rq.resolution, rq.spp, convex, 1, 0, depth)
        two = predict_render_seconds(n_views, rq.resolution, rq.spp, convex, 2, 0, depth)
        volume = samples + volume_path_seconds(settings, q.surface_points)
        return {"samples": samples, "volume": volume,
                "render": samples + max(one - (two - one), 0.0)}  # no L-BFGS step: one primal per view
    samples = predict_sample_seconds(settings, q.surface_points, occlusion)
    if command == "compare":
        return {"samples": samples}
    volume = samples + volume_path_seconds(settings, q.surface_points)
    coarse = len(hemisphere_grid(rq.coarse_deg, Constraint(90.0))) if zoned else 0
    render = samples + predict_render_seconds(n_views, rq.resolution, rq.spp, convex, rq.iterations, coarse, depth)
    return {"samples": samples, "volume": volume, "render": render}


# ---------------------------------------------------------------------- calibrations of the other commands


def _evaluate_key() -> str:
    import os

    from . import __version__

    return f"labcut {__version__} numpy {np.__version__} cpus {os.cpu_count()} evaluate v1"


def recommend_run(mesh: Any, quality: str) -> Any:
    """A sample-estimator recommendation of ``mesh`` at ``quality`` (default question, bench), made
    by :func:`labcut.recommend_orientation`'s own steps (plan, flash problem, answer) without its
    checks and budget: what the calibration of :func:`predict_sample_seconds` times."""
    from .backend import serial_blas
    from .orientation.recommend import answer_recommendation, build_scorer, question

    ask = question(None, quality=quality)
    plan = plan_question(mesh, ask, "recommend")
    with serial_blas():
        return answer_recommendation(mesh, ask, build_scorer(mesh, ask, plan), plan)


def evaluate_run(mesh: Any, quality: str) -> Any:
    """A sample-estimator evaluation of one lamella normal, by :func:`labcut.evaluate_orientation`'s
    own steps: what :func:`evaluate_timing` times."""
    from .backend import serial_blas
    from .orientation.recommend import build_scorer, evaluation_metrics, question
    from .scene.directions import normalize_normal

    ask = question(None, quality=quality)
    plan = plan_question(mesh, ask, "evaluate", predict=False)
    with serial_blas():
        return evaluation_metrics(mesh, ask, build_scorer(mesh, ask, plan), plan, normalize_normal((0.05, 0.02, 1.0)))


def sample_timing(refresh: bool = False) -> Any:
    """The sample estimator's calibration on this machine (:func:`labcut.orientation.timing.sample_timing`,
    handed :func:`recommend_run` to time)."""
    from .orientation.timing import sample_timing as calibrated

    return calibrated(recommend_run, refresh=refresh)


def volume_path_seconds(settings: Sequence[Any], surface_points: int) -> float:
    """Predicted seconds the volume estimator adds to the sample estimator's for a problem of
    ``settings`` and ``surface_points``: its paths (:func:`labcut.orientation.volume.volume_paths`)
    at :data:`VOLUME_PATH_SECONDS` each."""
    from .orientation.volume import volume_paths

    return VOLUME_PATH_SECONDS * volume_paths(settings, surface_points)


def predict_sample_seconds(settings: Sequence[Any], surface_points: int, occlusion: bool) -> float:
    """Predicted wall seconds of a sample-estimator recommendation on this machine (warm process)."""
    from .orientation.timing import seconds_of

    return seconds_of(sample_timing(), settings, surface_points, occlusion)


def evaluate_timing(refresh: bool = False) -> dict[str, float]:
    """The sample estimator's evaluation (build the problem, score one normal) on this machine:
    ``{"fixed", "per_term", "per_ray"}`` seconds, fitted as
    :func:`labcut.orientation.timing.measure_sample_timing` fits a recommendation's, from three
    timed evaluations of a 16 x 12 mm oval cabochon under the bench scenario (draft, standard,
    draft with occlusion forced on); measured once (about a second) and kept in the user cache
    (:func:`labcut.fileio.calibration`, ``planner-evaluate-timing.json``), again when labcut's or
    numpy's version or the CPU count differ."""
    from .fileio import calibration

    def measure() -> dict[str, float]:
        from .orientation.timing import time_three

        fixed, per_term, per_ray = time_three(evaluate_run, repeats=2)  # a calibration run (timing.calibration_run) itself
        return {"fixed": fixed, "per_term": per_term, "per_ray": per_ray}

    value = calibration("planner-evaluate-timing.json", _evaluate_key(), measure, refresh=refresh, timed=True,
                        check=lambda v: [float(v[k]) for k in ("fixed", "per_term", "per_ray")])
    return {k: float(value[k]) for k in ("fixed", "per_term", "per_ray")}


def predict_evaluate_seconds(settings: Sequence[Any], surface_points: int, occlusion: bool) -> float:
    """Predicted wall seconds of a sample-estimator evaluation on this machine (:func:`evaluate_timing`)."""
    from .orientation.timing import work

    t = evaluate_timing()
    terms, rays = work(settings, surface_points)
    return float(t["fixed"] + t["per_term"] * terms + (t["per_ray"] * rays if occlusion else 0.0))


#: the image sizes (px, spp) a render's calibration times: two image sizes (the per-pixel cost, the
#: studio look's denoiser most of it, against the fixed) and two sample counts at the larger (the
#: per-sample cost). Small, so that the first render of a look on a machine waits about 1.5-2 s
#: for it (studio) instead of 7.5-8 s at (96, 4), (256, 4), (256, 32), with predictions as close
#: (docs/performance.md, "The render command's calibration")
_RENDER_CAL = ((64, 4), (128, 4), (128, 16))


def render_command_timing(mode: str, polarised: bool, integrator: str, look: str = "diagram",
                          refresh: bool = False) -> tuple[float, float, float]:
    """``(fixed, per_sample, per_pixel)`` seconds of :func:`labcut.render` on this machine for one
    colour ``mode``, with or without a polariser, with the ``direct`` or the ``path`` integrator:
    three timed renders of a 10 mm sphere (the scenario ``bench``, the ``look``, :data:`_RENDER_CAL`
    sizes; the ``path`` integrator to depth 4, the carvings' default), each after one warm-up. The
    per-pixel term is what does not grow with the samples: the studio look's denoiser (its guide
    and normal passes, OIDN) and the image's own handling.
    Measured once per key (a second or two, with the kernels compiled) and kept in the user cache
    (``planner-render-timing.json``), again when Mitsuba's or labcut's version, the CPU count or
    the calibration's sizes differ."""
    import os
    import time

    import mitsuba as mi

    from . import __version__
    from .fileio import calibration

    key = f"{mode} {'polarised' if polarised else 'plain'} {integrator} {look} | mitsuba {mi.__version__} labcut {__version__} cpus {os.cpu_count()} v4"

    def measure() -> dict[str, float]:
        import trimesh

        from .orientation.timing import calibration_run

        from .physics.material import Labradorite
        from .scene.directions import normalize_normal

        sphere = Stone(trimesh.creation.icosphere(subdivisions=3, radius=5.0), convex=True).mesh
        kw = dict(scenario="bench", mode=mode, polarizer_deg=30.0 if polarised else None,
                  max_depth=4 if integrator == "path" else None, look=look)
        mat = Labradorite()
        normal = normalize_normal((0.05, 0.02, 1.0))
        rows = []
        with calibration_run():
            for res, n in _RENDER_CAL:
                # labcut.render's own steps for a given spp: the request, then the render
                render_once(sphere, mat, normal, res, n, kw)  # warm: kernels
                t = time.perf_counter()
                render_once(sphere, mat, normal, res, n, kw)
                rows.append((res * res, n, time.perf_counter() - t))
        return pixel_sample_fit(rows)

    value = calibration("planner-render-timing.json", key, measure, refresh=refresh, timed=True,
                        check=lambda v: (float(v["fixed"]), float(v["per_sample"]), float(v["per_pixel"])))
    return float(value["fixed"]), float(value["per_sample"]), float(value["per_pixel"])


def render_once(mesh: Any, material: Any, normal: Any, resolution: int, spp: int, request: dict[str, Any]) -> Any:
    """A render at ``spp`` samples per pixel by :func:`labcut.render`'s own steps (the request, the
    render, the check of each camera's flash): what :func:`render_command_timing` times."""
    from .orientation.flash_check import flash_by_view
    from .rendering.api import render_image, render_question

    ask = render_question(material=material, resolution=resolution, spp=spp, **request)
    result = render_image(mesh, ask, normal, spp)
    result.flash, result.notes = flash_by_view(mesh, ask.material, normal, ask.scenario.main_setting(), ask.cameras)
    return result


def linear_fit(rows: Sequence[tuple[float, float]]) -> dict[str, float]:
    """``{"fixed", "per_sample"}`` seconds through two timed runs ``(samples, seconds)`` (the
    slope and intercept of the line through them, neither below zero)."""
    (n0, s0), (n1, s1) = rows[0], rows[-1]
    per_sample = max((s1 - s0) / (n1 - n0), 0.0) if n1 != n0 else 0.0
    return {"fixed": max(s0 - per_sample * n0, 0.0), "per_sample": per_sample}


def pixel_sample_fit(rows: Sequence[tuple[float, float, float]]) -> dict[str, float]:
    """``{"fixed", "per_sample", "per_pixel"}`` seconds through three timed runs ``(pixels, spp,
    seconds)``: the first two at one spp and two sizes, the last at the second size and more spp
    (none below zero): ``seconds = fixed + per_pixel x pixels + per_sample x pixels x spp``."""
    (p0, n0, s0), (p1, n1, s1), (p2, n2, s2) = rows
    per_sample = max((s2 - s1) / (p1 * (n2 - n1)), 0.0) if n2 != n1 else 0.0
    per_pixel = max((s1 - s0 - per_sample * (p1 * n1 - p0 * n0)) / (p1 - p0), 0.0) if p1 != p0 else 0.0
    fixed = max(s0 - per_sample * p0 * n0 - per_pixel * p0, 0.0)
    return {"fixed": fixed, "per_sample": per_sample, "per_pixel": per_pixel}


def _predicted_render_seconds(mode: str, polarised: bool, integrator: str, resolution: int, spp: int,
                              views: int, look: str = "diagram") -> dict[str, float]:
    """Predicted seconds of a render (:func:`render_seconds`)."""
    from .orientation.timing import calibrating

    if calibrating():
        return {}
    return {"render": render_seconds(mode, polarised, integrator, resolution, spp, views, look)}


def render_seconds(mode: str, polarised: bool, integrator: str, resolution: int, spp: int, views: int,
                   look: str = "diagram") -> float:
    """Predicted wall seconds of :func:`labcut.render` on this machine: ``views`` x (fixed + per
    pixel x resolution² + per sample x resolution² x spp), from :func:`render_command_timing`."""
    fixed, per_sample, per_pixel = render_command_timing(mode, polarised, integrator, look)
    pixels = resolution * resolution
    return float(views * (fixed + per_pixel * pixels + per_sample * pixels * spp))
