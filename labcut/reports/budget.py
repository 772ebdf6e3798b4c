"""``compare_cuts(..., time_budget=SECONDS)``: the most accurate quality predicted to fit.

A comparison runs, for every cut under every scenario, a recommendation, the energy scorer of
its curves, a tilt-performance curve and the renders (the main render, the rocking strip and the
schiller-only render). Each part is predicted from this machine's calibrations, all measured
once and kept in the user cache:

* the recommendation: :func:`labcut.planner.predict_sample_seconds` for the scenario's
  own poses, lights and viewers at the rung, with occlusion where the planner turns it on;
* the scorer and the tilt curve: :func:`labcut.planner.predict_evaluate_seconds` (a problem
  build and an evaluation) for the same settings and for the tilt curve's poses
  (:func:`labcut.reports.analysis.tilt_settings`) at the rung's ``tilt_points``;
* the renders and the flash-colour map: :func:`compare_render_timing`, this machine's calibration
  of :func:`labcut.reports.renders.render_cut` (the main render, the rocking strip, the
  schiller-only render and the mask) and :func:`~labcut.reports.flashcolour.flash_colour_map`,
  at the rung's render size and samples (or the ``resolution`` / ``spp`` asked): direct lighting
  for a convex stone, a path tracer for a carving; the first renders of each kind in a process
  also pay for loading their kernels.

The sum, times an adaptive correction learnt from past budgeted comparisons (the actual over the
predicted seconds, a geometric running mean kept with the recommendation's corrections,
:func:`labcut.commands.budget.record` under the name ``"compare"``; one below 1 only within its
reach, :func:`labcut.commands.budget.factor_at`), is each rung's prediction; the most accurate
rung of :func:`labcut.commands.budget.ladder` predicted to fit runs. A budget below the cheapest rung's prediction runs the cheapest with a one-line note; a
budget that is not a positive number of seconds is a :class:`~labcut.errors.ParameterError`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..geometry.stone import Stone
from ..commands.budget import BudgetChoice, ladder, learnt, pick_corrected
from ..validation import check_budget
from ..scene.quality import Quality
from ..scene.scenario import scenarios_from

#: the correction's name in the user cache (:func:`labcut.commands.budget.record`)
KIND = "compare"
#: the two (resolution px, spp, strip angles) :func:`compare_render_timing` times
_CAL = ((48, 4, (0.0, 10.0)), (128, 16, (-10.0, 0.0, 10.0)))


def render_samples(resolution: int, spp: int, strip_angles: Sequence[float]) -> int:
    """Samples a cut's renders trace: the main and schiller-only renders at ``spp``, every
    rocking-strip frame but the rest pose at half of it, each ``resolution²`` pixels."""
    strips = sum(1 for a in strip_angles if abs(a) > 1e-9)
    return int(resolution) ** 2 * (2 * int(spp) + strips * max(1, int(spp) // 2))


#: the integrators whose comparison renders have run in this process (their kernels are loaded)
_WARM: set[str] = set()


def mark_warm(integrator: str) -> None:
    """Note that a comparison's renders with ``integrator`` ran in this process (:data:`_WARM`)."""
    _WARM.add(integrator)


def compare_render_timing(integrator: str, refresh: bool = False) -> tuple[float, float, float]:
    """``(fixed, per_sample, first)`` seconds of one cut's renders and flash-colour map in a comparison
    (:func:`render_samples`) with the ``direct`` or ``path`` integrator on this machine: two timed
    runs of a 16 x 12 mm oval cabochon (the default mesh resolution) under the bench scenario (:data:`_CAL`), each after a warm-up
    (``first``: what the first, cold run took beyond the warm one: loading the kernels and the
    plugin, paid once per process and integrator); measured
    once (about a second) and kept in the user cache (:func:`labcut.fileio.calibration`,
    ``compare-render-timing.json``), again when Mitsuba's or labcut's version or the CPU count differ."""
    import os
    import time

    import mitsuba as mi

    from .. import __version__
    from ..fileio import calibration
    from ..planner import linear_fit

    key = f"{integrator} | mitsuba {mi.__version__} labcut {__version__} cpus {os.cpu_count()} v3"

    def measure() -> dict[str, float]:
        from ..geometry.cabochon import cabochon
        from ..physics.material import Labradorite
        from ..scene import resolve_scene
        from .analysis import tilt_axes
        from .flashcolour import flash_colour_map
        from .renders import render_cut

        stone = Stone(cabochon("oval", 16.0, 12.0), convex=integrator == "direct").mesh
        scene = resolve_scene("bench")
        mat = Labradorite()
        axis = tilt_axes(scene)["front_back"]
        rows, first = [], 0.0
        for res, n, strip in _CAL:
            def once() -> None:
                r = render_cut(stone, mat, (0.05, 0.02, 1.0), scene, axis, res, n, strip, strip_spp=max(1, n // 2))
                flash_colour_map(r.schiller, r.mask, 1.0)

            t = time.perf_counter()
            once()  # warm: kernels
            cold = time.perf_counter() - t
            t = time.perf_counter()
            once()
            rows.append((render_samples(res, n, strip), time.perf_counter() - t))
            if len(rows) == 1:
                first = max(cold - rows[0][1], 0.0)
        mark_warm(integrator)
        return {**linear_fit(rows), "first": first}

    value = calibration("compare-render-timing.json", key, measure, refresh=refresh, timed=True,
                        check=lambda v: (float(v["fixed"]), float(v["per_sample"]), float(v["first"])))
    return float(value["fixed"]), float(value["per_sample"]), float(value["first"])


def predict_comparison(cuts: Sequence[Any], scenarios: Sequence[Any], quality: Quality, effects: Mapping[str, bool],
                       resolution: int | None = None, spp: int | None = None) -> float:
    """Predicted wall seconds of a comparison of ``cuts`` (resolved :class:`~labcut.reports.cuts.Cut`)
    under ``scenarios`` (as asked: names, files or Scenario objects) at ``quality``, before the
    adaptive correction."""
    from ..planner import occlusion_on, predict_evaluate_seconds, predict_sample_seconds
    from .analysis import tilt_settings

    scens = scenarios_from(scenarios, quality)
    res = quality.render_resolution if resolution is None else int(resolution)
    n_spp = quality.render_spp if spp is None else int(spp)
    samples = render_samples(res, n_spp, quality.strip_angles_deg)
    total = 0.0
    cold = set()
    for cut in cuts:
        convex = Stone.of(cut.mesh).convex
        occlusion = occlusion_on(convex, effects)
        integrator = "direct" if convex else "path"
        fixed, per_sample, first = compare_render_timing(integrator)
        renders = fixed + per_sample * samples
        if integrator not in _WARM and integrator not in cold:  # the first renders of their kind in this process
            cold.add(integrator)
            renders += first
        for sc in scens:
            settings = sc.settings()
            _, tilted, _ = tilt_settings(sc, quality)
            total += (predict_sample_seconds(settings, quality.surface_points, occlusion)
                      + predict_evaluate_seconds(settings, quality.surface_points, occlusion)
                      + predict_evaluate_seconds(tilted, quality.tilt_points, occlusion)
                      + renders)
    return float(total)


def choose_quality(budget: Any, cuts: Sequence[Any], scenarios: Sequence[Any], effects: Mapping[str, bool],
                   resolution: int | None = None, spp: int | None = None) -> BudgetChoice:
    """The most accurate rung of :func:`~labcut.commands.budget.ladder` whose predicted
    comparison (:func:`predict_comparison` x the ``compare`` correction at its size,
    :func:`~labcut.commands.budget.factor_at`) fits ``budget`` seconds."""
    seconds = check_budget(budget)
    raw = [(q, predict_comparison(cuts, scenarios, q, effects, resolution, spp)) for q in ladder()]
    return pick_corrected(raw, learnt(), KIND, seconds, "the cheapest comparison's",
                          f" ({len(cuts)} cut(s) x {len(scenarios)} scenario(s))")
