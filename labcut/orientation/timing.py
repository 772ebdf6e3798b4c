"""Predicted wall time of the sample estimator, calibrated on this machine.

The effect planner (:mod:`labcut.planner`) shows the predicted time of each choice (docs/planner.md).
The render estimator has its own calibration (:func:`labcut.orientation.render_estimator.render_timing`);
this module is the sample estimator's:

``seconds = fixed + per_term x terms + per_ray x rays`` (occlusion only)

with ``terms`` = surface points x the sum over poses of lights x views (the candidate
(point, light, view) triples before culling) and ``rays`` = surface points x the sum over poses
of lights + views (the shadow rays of a non-convex stone). The three constants come from three
timed recommendations of a bundled-size oval cabochon (draft and standard quality, and draft
with occlusion forced on), measured once per machine (a few seconds) and kept in the user
cache folder; they are measured again when the CPU count, labcut's or numpy's version differ.
"""

from __future__ import annotations

import os
import contextlib
import contextvars
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import ParameterError
from ..geometry.stone import Stone

#: the user-cache file of the calibration (:func:`sample_timing`)
TIMING_FILE = "sample-estimator-timing.json"
#: whether this thread of work is timing calls for a calibration: the planner predicts nothing for
#: the calls it times (a prediction would ask for the calibration being made). A context variable,
#: not a module flag: each thread and task sees its own, and :func:`calibration_run` restores it
_CALIBRATING: contextvars.ContextVar[bool] = contextvars.ContextVar("labcut_calibrating", default=False)


@dataclass(frozen=True)
class SampleTiming:
    """Seconds of a sample-estimator recommendation: a fixed part, per candidate term, per shadow ray."""

    fixed: float
    per_term: float
    per_ray: float
    key: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def calibrating() -> bool:
    """True inside :func:`calibration_run` (the planner then predicts nothing)."""
    return _CALIBRATING.get()


@contextlib.contextmanager
def calibration_run() -> Iterator[None]:
    """The calls made inside are timed for a calibration (:func:`calibrating` is True there)."""
    token = _CALIBRATING.set(True)
    try:
        yield
    finally:
        _CALIBRATING.reset(token)


def work(settings: Sequence[Any], surface_points: int) -> tuple[float, float]:
    """``(terms, rays)`` of a problem: surface points x Σ_poses lights x views, and x Σ (lights + views)."""
    terms = sum(len(st.lights) * len(st.views) for st in settings) * surface_points
    rays = sum(len(st.lights) + len(st.views) for st in settings) * surface_points
    return float(terms), float(rays)


def _key() -> str:
    import numpy as np

    from .. import __version__

    return f"labcut {__version__} numpy {np.__version__} cpus {os.cpu_count()} v4 (the occluded call warmed too)"


def time_three(call: Any, repeats: int = 1) -> tuple[float, float, float]:
    """Fit ``seconds = fixed + per_term x terms + per_ray x rays`` to three timed calls of
    ``call(mesh, quality)`` on a 16 x 12 mm oval cabochon under the bench scenario: draft and
    standard (the per-term cost), and draft with occlusion forced on (the per-ray cost); each the
    best of ``repeats``, after a warm-up of each stone (the occluded one's first call loads a
    Mitsuba variant and builds its ray scene, once per process: timing it would inflate the
    per-ray cost). Returns ``(fixed, per_term, per_ray)``."""

    from ..geometry.cabochon import cabochon
    from ..scene import resolve_scene

    mesh = cabochon(outline="oval", length=16.0, width=12.0, dome="medium")
    hidden = Stone.of(mesh).replace(convex=False).mesh  # the same stone, with the occluded path's rays
    rows = []
    with calibration_run():
        call(mesh, "draft")  # warm: imports and kernels
        call(hidden, "draft")  # and the occluded path's: a Mitsuba variant, the ray scene, their kernels
        for m, quality, occl in ((mesh, "draft", False), (mesh, "standard", False), (hidden, "draft", True)):
            scene = resolve_scene("bench", quality=quality)
            terms, rays = work(scene.settings(), scene.quality.surface_points)
            best = float("inf")
            for _ in range(repeats):
                t = time.perf_counter()
                call(m, quality)
                best = min(best, time.perf_counter() - t)
            rows.append((terms, rays if occl else 0.0, best))
    (t0, _, s0), (t1, _, s1), (t2, r2, s2) = rows
    per_term = max((s1 - s0) / (t1 - t0), 0.0) if t1 != t0 else 0.0
    fixed = max(s0 - per_term * t0, 0.0)
    per_ray = max((s2 - s0) / r2, 0.0) if r2 > 0 else 0.0
    return fixed, per_term, per_ray


def measure_sample_timing(run: Callable[[Any, str], Any]) -> SampleTiming:
    """Time three recommendations of a 16 x 12 mm oval cabochon under the bench scenario
    (:func:`time_three`), each made by ``run(mesh, quality)``: the calibration is handed what it
    times (the planner hands it a recommendation's own steps, :func:`labcut.planner.recommend_run`)."""
    return SampleTiming(*time_three(run), _key())


def sample_timing(run: Callable[[Any, str], Any] | None = None, refresh: bool = False) -> SampleTiming:
    """The calibration of the sample estimator's predicted seconds
    (:func:`labcut.planner.predict_sample_seconds`): measured once on this machine by
    :func:`measure_sample_timing` with ``run`` and kept in the user cache
    (:func:`labcut.fileio.calibration`, :data:`TIMING_FILE`); without ``run`` only a kept one is read
    (a :class:`~labcut.errors.ParameterError` when there is none)."""
    from ..fileio import calibration

    key = _key()
    names = ("fixed", "per_term", "per_ray")

    def measure() -> dict[str, float]:
        if run is None:
            raise ParameterError("the sample estimator is not calibrated on this machine yet: "
                                 "labcut.planner.sample_timing() measures it")
        t = measure_sample_timing(run)
        return {k: getattr(t, k) for k in names}

    value = calibration(TIMING_FILE, key, measure, refresh=refresh, timed=True, check=lambda v: [float(v[k]) for k in names])
    return SampleTiming(*(float(value[k]) for k in names), key)


def seconds_of(t: SampleTiming, settings: Sequence[Any], surface_points: int, occlusion: bool) -> float:
    """Wall seconds a calibration ``t`` predicts for a problem of these settings and points."""
    terms, rays = work(settings, surface_points)
    return float(t.fixed + t.per_term * terms + (t.per_ray * rays if occlusion else 0.0))
