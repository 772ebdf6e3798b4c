"""``labcut recommend-orientation`` and ``labcut evaluate-orientation``.

The answer comes first: the recommendation is printed and its JSON and score map written
before an optional render starts, so a failing or interrupted render leaves the answer in place.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated, Any, Optional

import numpy as np
import typer
from rich.table import Table

from . import materials as m
from . import meshes as mo
from . import plan_options as po
from . import look_options as lo
from . import scene_options as so
from . import answers
from .preflight import Yes, check_cost
from .root import all_or_nothing, app, check_outputs, console, figure_after_answer, interruptibly, normal_or_angles, notes_after, parse_vector, print_note, write_json

Quality = Annotated[str, typer.Option(help="draft, standard or high.")]


def _metrics_table(title: str, metrics) -> Table:
    """Flash metrics whose labels say what the numbers are, and whose numbers add up."""
    from labcut.orientation import energy_parts

    in_flash, _ = energy_parts(metrics)
    energy = round(metrics.flash_energy, 4)
    shown_in = round(in_flash, 4)
    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_column("meaning (each a mean over the viewing directions)")
    rows = [
        ("flash area", f"{metrics.flash_area:.1%}", "share of the visible stone that flashes (reaches the threshold)"
         + ("" if metrics.flash_area_mm2 is None else
            f": {metrics.flash_area_mm2:.1f} mm² of the {metrics.visible_area_mm2:.0f} mm² seen")),
        ("flash intensity", f"{metrics.flash_intensity:.3f}", "mean brightness of the flashing part / a face-on flat flash"),
        ("flash energy", f"{energy:.4f}",
         f"mean brightness over all the visible stone = {shown_in:.4f} in the flashes (area x intensity, view by view) "
         f"+ {energy - shown_in:.4f} fainter schiller below the threshold"),
        ("coverage", f"{metrics.coverage:.1%}", "share of viewing directions that see a flash (> 5 % area)"),
    ]
    for r in rows:
        table.add_row(*r)
    return table


#: the misses (degrees) the recommendation's table shows the flash kept at
MISSES_SHOWN = (1.0, 2.0, 5.0, 10.0)


def _misorientation_table(rec) -> Table | None:
    """Flash energy kept when the cut misses the recommended normal by 1-10°: on average, at worst
    and leaning further towards each side (named as the scenario wears the stone)."""
    from labcut.orientation import UPRIGHT_NAMES

    curve = rec.misorientation
    if curve is None:
        return None
    upright = bool(getattr(rec.scenario, "worn_upright", False))
    sides = [s for s in ("front", "back", "left", "right") if s in curve.by_side]
    table = Table(title="If the cut misses: flash energy kept", caption="each column: the lamella normal off the recommended "
                  "one by the degrees on the left, in any direction (mean, worst) or leaning further towards that side")
    table.add_column("off by", justify="right")
    for col in ("mean", "worst", *[(UPRIGHT_NAMES[s] if upright else s) for s in sides]):
        table.add_column(col, justify="right")
    for miss in MISSES_SHOWN:
        if miss > curve.miss_deg[-1]:
            break
        worst = float(np.interp(miss, curve.miss_deg, curve.worst))
        table.add_row(f"{miss:g}°", f"{curve.kept_at(miss):.0%}", f"{worst:.0%}", *(f"{curve.kept_at(miss, s):.0%}" for s in sides))
    return table


#: seconds of a time budget kept for writing the answer (JSON, tables) after the recommendation
ANSWER_SECONDS = 0.1
#: the least a time budget leaves the recommendation, however long the loading took (its cheapest
#: rung then runs, with a note)
MIN_BUDGET_SECONDS = 0.05


def _scene_label(scene) -> str:
    """``scenario 'ring' (ceiling, above)``: what a result was computed under."""
    return f"scenario {scene.name!r}: {scene.lights.name} light, {scene.views.name} viewers"


def _answer_table(rec, name: str, scene) -> Table:
    """The recommendation: in words, as a cutter sets it up, as numbers, and how precise it must be."""
    table = Table(show_header=False)
    table.add_column("what", style="bold")
    table.add_column("value")
    ax = rec.tolerance_by_axis
    shop = rec.workshop
    table.add_row("orientation", rec.description)
    table.add_row("when sawing or dopping", shop["text"])
    bar = rec.uncertainty
    tilt = f"{rec.tilt_deg:.1f}°" + ("" if bar is None else f" ± {bar.angle_deg:.1f}°")
    upright = bool(getattr(rec.scenario, "worn_upright", False))
    sides = "0° right, 90° top (+Y, the bail end, as worn), 180° left, 270° bottom" if upright else \
        "0° right, 90° back, 180° left, 270° front"
    table.add_row("tilt, azimuth", f"{tilt} from the face-up axis (+Z); azimuth {rec.azimuth_deg:.0f}° (from +X: {sides})")
    if rec.parallel_within_deg is not None and rec.tilt_deg >= 0.5:
        table.add_row("how these fit", f"the optimum leans {rec.tilt_deg:.1f}°, but lamellae parallel to the base keep at "
                                       f"least 90 % of its {rec.objective} score, and so does any tilt within "
                                       f"±{rec.parallel_within_deg:.1f}° of parallel: cut it parallel, the easier cut")
    if bar is not None:
        table.add_row("error bars", f"the converged normal lies within {bar.angle_deg:.1f}° of this one and the "
                                    f"{rec.objective} score within ±{bar.score_rel:.0%} (about 95 %; sampling "
                                    f"±{bar.sampling_angle_deg:.1f}°, directions ±{bar.discretisation_angle_deg:.1f}°)")
    along = "top-to-bottom" if upright else "front-to-back"
    table.add_row("tolerance", f"±{rec.tolerance_deg:.1f}° in any direction around the optimum keeps 90 % of its "
                               f"{rec.objective} score (±{ax['front_back_deg']:.1f}° {along}, "
                               f"±{ax['left_right_deg']:.1f}° side-to-side)")
    table.add_row("lamella normal", f"{rec.normal[0]:+.3f}, {rec.normal[1]:+.3f}, {rec.normal[2]:+.3f} (mesh frame)")
    return table


#: what a library parameter is called on this command line, for its one-line errors
_OPTION_NAMES = {"objective": "--objective", "quality": "--quality", "max_tilt": "--max-tilt",
                 "tilt axis": "--tilt-axis", "seed": "--seed"}


def _question(material: Any, scenario: str | None, lighting: str | None, viewing: str | None, quality: str,
              estimator: str, effect: list[str] | None, zoning: str | None, **rest: Any) -> Any:
    """The command's :class:`~labcut.orientation.question.FlashQuestion`, built (and so checked) once
    from its options, before the mesh is read; errors name the options."""
    from labcut.errors import ParameterError
    from labcut.orientation import FlashQuestion

    effects = po.check(estimator, effect)
    zone = m.build_zoning(zoning, material)
    try:
        return FlashQuestion.build(material, scenario, lighting, viewing, quality=quality, estimator=estimator,
                                effects=effects, zoning=zone, **rest)
    except ParameterError as exc:
        raise exc.renamed(_OPTION_NAMES) from None


def render_summary(result: Any, path: Path | str) -> dict[str, Any]:
    """The JSON block of a render: where it went, its plan, its exposure, and whether it shows a flash."""
    return {
        "path": str(path), "plan": result.plan.to_dict(), "scenario": result.scenario, "views": result.views,
        "spp": result.spp, **lo.exposure_json(result),
        "flash_by_view": result.flash, "notes": result.notes,
    }


def print_render_notes(result: Any) -> None:
    for note in result.notes:
        console.print(f"note: {note}", highlight=False)


def _print_answer(rec: Any, data: dict[str, Any], provenance: dict[str, Any], name: str, scene: Any,
                  json_path: str | None, objective: str, remembered: dict[str, Any] | None = None) -> None:
    """The answer of ``recommend-orientation``: its JSON (``json_path``, ``-`` for stdout alone) and
    the tables, with the mesh's provenance (``Stone.metadata()``); ``remembered``: the store's entry
    when the answer is an earlier call's (:mod:`labcut_cli.answers`), said under the tables."""
    if json_path is not None:
        write_json(json_path, data)
    if json_path == "-":
        return
    mo.print_provenance_facts(provenance, name)
    console.print(f"[bold]Recommendation for {name}[/] ({_scene_label(scene)}): {rec.description}.")
    console.print(_answer_table(rec, name, scene))
    console.print(_metrics_table("Flash at the recommended orientation", rec.metrics))
    misses = _misorientation_table(rec)
    if misses is not None:
        console.print(misses)
    if rec.metrics.flash_area == 0.0:
        console.print(
            f"No part of the stone reaches the flash threshold ({rec.settings['tau']:g} x the brightest schiller this "
            "scenario's light can give a flat polished face) at this orientation. The energy score still ranks orientations."
        )
    if rec.robustness is not None:
        r = rec.robustness
        style = "bold yellow" if r.verdict == "swings" else ""
        console.print((f"[{style}]" if style else "") + r.sentence()[0].upper() + r.sentence()[1:] + "."
                      + (f"[/{style}]" if style else ""), highlight=False)
    if rec.runners_up:
        table = Table(title="Other good orientations (distinct optima)")
        for col in ("#", "orientation", f"{objective} vs best"):
            table.add_column(col)
        for i, r in enumerate(rec.runners_up, start=2):
            table.add_row(str(i), r["description"], f"{r['relative_score']:.0%}")
        console.print(table)
    console.print(f"{rec.optimizer}: {rec.evaluations} evaluations, {rec.seconds:.2f} s; "
                  f"{rec.settings['triples']} (point, light, view) triples")
    if rec.settings.get("time_budget"):
        b = rec.settings["time_budget"]
        console.print(f"time budget {b['call_budget_seconds']:g} s for the call ({b['before_seconds']:.2f} s loading, "
                      f"{b['budget_seconds']:.2f} s left for the recommendation): quality {b['quality']} "
                      f"(predicted {b['predicted_seconds']:.2f} s, took {rec.seconds:.2f} s; its error bars "
                      f"±{rec.uncertainty.angle_deg:.1f}°, ±{rec.uncertainty.score_rel:.0%}, about 95 %)", highlight=False)
    volume = rec.settings.get("volume")
    if volume:  # the volume estimator: say what the light did inside the stone
        paths = max(1, volume["paths"])
        console.print(f"volume estimator: {volume['paths']} paths through the stone ({volume['depths']} depth per "
                      f"point, view and light, flash depth {volume['flash_depth_mm']:.2f} mm); "
                      f"{volume['thin'] / paths:.0%} found too little stone below, {volume['unlit'] / paths:.0%} an "
                      f"entry the light does not reach", highlight=False)
    if rec.estimator == "render":
        r = rec.render
        console.print(f"render estimator ({r['integrator']}, depth {r['max_depth']}, {r['resolution']}² px, {r['spp']} spp): "
                      f"{r['evaluations']} evaluations, {r['renders']} renders, {r['seconds']:.1f} s; "
                      f"{r['angle_to_samples_deg']:.2f}° from the sample estimator's answer")
    if json_path is not None:
        console.print(f"JSON written to {json_path}")
    if remembered is not None:
        console.print(f"remembered answer of an identical call on {remembered['computed']} "
                      f"({remembered['seconds']:.2f} s then); --recompute computes it again", highlight=False)


def _remembered(entry: dict[str, Any], setup: Any, mesh_path: Path, where: Path) -> tuple[dict[str, Any], Any] | None:
    """A remembered answer's JSON document (with this call's mesh path) and its recommendation, or
    None with one note naming the entry's file ``where`` when its answer cannot be read back (then
    it is computed again)."""
    import copy
    import dataclasses

    from labcut.errors import LabcutError
    from labcut.fileio import cache_problem
    from labcut.orientation import Recommendation

    data = copy.deepcopy(entry["answer"])
    try:
        rec = dataclasses.replace(Recommendation.from_dict(data, source="remembered answer"), scenario=setup.scenario)
        mesh = data["mesh"]
        if not isinstance(mesh, dict):
            raise TypeError("its mesh is not an object")
    except (LabcutError, KeyError, TypeError, ValueError) as exc:
        cache_problem(where, f"not a remembered answer: {exc}")
        return None
    mesh["path"] = str(mesh_path)
    if "source" in mesh:  # the same bytes read from where this call found them
        mesh["source"] = str(mesh_path)
    return data, rec


def _answer_again(entry: dict[str, Any], data: dict[str, Any], rec: Any, scene: Any, mesh_path: Path,
                  json_path: str | None, objective: str) -> None:
    """Print a remembered answer (:mod:`labcut_cli.answers`, read back by :func:`_remembered`) as
    its call printed it: its warning and note lines, its JSON and its tables, the mesh not loaded."""
    for kind, text in entry["messages"]:
        (mo.print_warning if kind == "warning" else print_note)(text)
    _print_answer(rec, data, entry["provenance"], mesh_path.name, scene, json_path, objective, remembered=entry)


@app.command("recommend-orientation")
@mo.takes_mesh_options
@po.takes_plan_options
@m.takes_material
def recommend_orientation(
    ctx: typer.Context,
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh: STL, OBJ, PLY, OFF, GLB/GLTF, 3MF.")],
    mesh_options: Any = None,  # --units, --up-axis, --size (meshes.takes_mesh_options)
    material: Any = None,  # the material options (materials.takes_material)
    scenario: so.Scenario = None,
    lighting: so.Lighting = None,
    viewing: so.Viewing = None,
    objective: Annotated[str, typer.Option(help="energy, area, intensity or balanced.")] = "energy",
    quality: Annotated[Optional[str], typer.Option(help="draft, standard (the default) or high; not with --time-budget.")] = None,
    optimizer: Annotated[str, typer.Option(help="nlopt, gradient or grid.")] = "nlopt",
    max_tilt: Annotated[float, typer.Option("--max-tilt", help="Largest allowed tilt of the lamella normal, degrees.")] = 90.0,
    tilt_axis: Annotated[Optional[str], typer.Option("--tilt-axis", help="Only tilt about this horizontal axis X,Y,Z.")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the surface sampling.", min=0)] = 0,
    variants: Annotated[int, typer.Option(
        "--variants", metavar="N",
        help="Also answer under N plausible variants of the scenario (2-64: room layout, motion range, viewers; "
             "docs/scenarios.md) and say how far the best orientation moves across them, against its error bar and "
             "tolerance; 0 (the default) skips them.")] = 0,
    time_budget: Annotated[Optional[float], typer.Option(
        "--time-budget", metavar="SECONDS",
        help="Seconds the whole call may take (loading the mesh, planning, the recommendation, its error bars and its "
             "answer; --render comes after, on its own): the most accurate quality predicted to fit on this machine "
             "replaces --quality (docs/accuracy.md); below the cheapest setting's prediction that one runs, with a note.")] = None,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the result as JSON ('-' for stdout).")] = None,
    render_path: Annotated[Optional[Path], typer.Option("--render", help="Render the stone at the recommended orientation (.png/.exr), after the answer is written.")] = None,
    map_path: Annotated[Optional[Path], typer.Option("--map", help="Write a polar map of the score over the hemisphere (.png).")] = None,
    flash_mask_path: Annotated[Optional[Path], typer.Option(
        "--flash-mask", metavar="PNG",
        help="With --render: also write its picture with the pixels that flash marked (the metrics' threshold), "
             "their share of the stone reported beside the estimator's flash area of the view.")] = None,
    spp: Annotated[Optional[int], typer.Option(help="Samples per pixel of --render (default 16 denoised, as the studio look is; 64 otherwise).", min=1)] = None,
    resolution: Annotated[int, typer.Option(help="Width and height of --render in pixels.", min=8, max=8192)] = 512,
    exposure: lo.Exposure = "reference",
    yes: Annotated[bool, Yes] = False,
    look: lo.Look = "studio",
    denoise: lo.Denoise = None,
    plan_options: Any = None,  # --estimator, --effect, --plan, --plan-only (plan_options.takes_plan_options)
    zoning: m.ZoningOpt = None,
    recompute: Annotated[bool, typer.Option(
        "--recompute",
        help="Compute the answer even when labcut remembers it from an identical earlier call (same mesh file, "
             "options and labcut); the new answer is remembered in its place. Calls with --time-budget, "
             "--render, --map or --plan are always computed.")] = False,
) -> None:
    """Find the lamella orientation that makes MESH flash most, and how precisely it must be cut.

    Angles: tilt from the face-up axis (+Z); azimuth from +X (the stone's right) towards +Y
    (its back): 0° right, 90° back, 180° left, 270° front (-Y).
    """
    call_start = time.perf_counter()  # a time budget is the whole call's, from here
    estimator, effect, plan, plan_only = plan_options.estimator, plan_options.effect, plan_options.plan, plan_options.plan_only
    import labcut
    from labcut.errors import ParameterError
    from labcut.commands import quality_or_budget
    from labcut.orientation import OPTIMIZERS

    from .progress import progress_bar

    # validate everything before the work starts
    check_outputs({"--json": (json_path, (".json",)), "--render": (render_path, (".png", ".exr")),
                   "--map": (map_path, (".png",)), "--flash-mask": (flash_mask_path, (".png",))}, ctx)
    if flash_mask_path is not None and render_path is None:
        raise ParameterError("--flash-mask marks the flash on the --render picture: give --render too")
    if optimizer not in OPTIMIZERS:
        raise ParameterError(f"--optimizer must be one of {', '.join(OPTIMIZERS)}, got {optimizer!r}")
    exposure_value = lo.parse_exposure(exposure)
    from labcut.scene import Variation

    try:
        variation = Variation.coerce(variants)
    except ParameterError as exc:
        raise ParameterError(f"--{exc}") from None
    quality_or_budget(quality is not None, time_budget is not None, flags=True)
    quality = quality or "standard"
    # the whole question, checked once (FlashQuestion.build); the library takes it as it is
    setup = _question(material, scenario, lighting, viewing, quality, estimator, effect, zoning, objective=objective,
                      max_tilt=max_tilt, tilt_axis=parse_vector(tilt_axis, "--tilt-axis") if tilt_axis else None, seed=seed)
    scene, zone = setup.scenario, setup.zoning
    render_ask = None
    if render_path is not None:  # the render's request, checked once too, before the long work
        from labcut.rendering import RenderRequest

        render_ask = RenderRequest.build(setup.material, scene, spp=spp, resolution=resolution,
                                       zoning="auto" if zoning is None else zone,
                                       exposure=exposure_value, look=lo.spec(look), denoise=denoise)
    if time_budget is not None:
        from labcut.validation import check_budget

        check_budget(time_budget)
    from labcut.planner import PILOT_BUDGET_SHARE, plan_question

    # an identical earlier call's answer (answers.py): printed without loading the mesh
    stored = None
    if answers.enabled() and time_budget is None and render_path is None and map_path is None and not (plan or plan_only):
        stored = answers.key("recommend-orientation", mesh_path, mesh_options, setup, optimizer=optimizer, variants=variation)
        with notes_after():  # a damaged entry: one note, then computed again
            entry = None if stored is None or recompute else answers.read(stored)
            again = None if entry is None else _remembered(entry, setup, mesh_path, answers.entry_path(stored))
        if again is not None:
            _answer_again(entry, *again, setup.scenario, mesh_path, json_path, objective)
            return
    printed: list[tuple[str, str]] = []  # the warning and note lines, remembered with the answer
    state = answers.file_state(mesh_path)
    mesh = mesh_options.load(mesh_path, printed=printed)
    if stored is not None and answers.file_state(mesh_path) != state:  # rewritten while read: not its bytes' answer
        stored = None
    if render_ask is not None:  # what the render will cost, before the recommendation's work
        interruptibly(check_cost, mesh, render_ask, yes, quiet=json_path == "-", budget=False)
    the_plan = None
    pilots_max = None if time_budget is None else PILOT_BUDGET_SHARE * time_budget
    if plan or plan_only or setup.effects or estimator != "auto" or zone is not None:  # a bad combination fails before the work
        the_plan = plan_question(mesh, setup, "recommend", pilot_seconds_max=pilots_max)
    if plan or plan_only:
        po.show(the_plan, mesh_path.name, to_stderr=json_path == "-")
        if plan_only:
            po.finish_plan_only(the_plan, json_path)
            return

    before = time.perf_counter() - call_start  # loading and checking: spent of a time budget
    remaining = None if time_budget is None else max(time_budget - before - ANSWER_SECONDS, MIN_BUDGET_SECONDS)
    with notes_after(printed), progress_bar("recommending", "%") as update:
        rec = labcut.recommend_orientation(
            mesh, setup=setup, optimizer=optimizer, progress=lambda stage, fraction: update(int(round(100 * fraction)), 100),
            time_budget=remaining, plan=None if time_budget is not None else the_plan,  # planned once
            variants=variation,
        )
    if time_budget is not None:  # the call's budget, and what went before the recommendation's share of it
        rec.settings["time_budget"].update(call_budget_seconds=time_budget, before_seconds=before)
    data = rec.to_dict()
    data["mesh"]["path"] = str(mesh_path)
    if render_path is not None:
        data["render"] = {"path": str(render_path), "status": "pending: rendered after the answer was written"}

    # 1. the answer: JSON and table; the figures come after it, so a failing figure leaves the answer
    provenance = labcut.Stone.of(mesh).metadata()
    _print_answer(rec, data, provenance, mesh_path.name, scene, json_path, objective)
    quiet = json_path == "-"
    if stored is not None:
        with notes_after():  # a folder that cannot be written: one note
            answers.remember(stored, data, provenance, printed, time.perf_counter() - call_start)

    # 2. the optional figures, each after the answer: a failure or Ctrl-C leaves the answer above in place
    if map_path is not None:
        with figure_after_answer(json_path, map_path, "score map"):
            from labcut.plots import plot_score_map

            plot_score_map(rec, map_path, title=f"{mesh_path.name}: {objective}, {_scene_label(scene)}")
        if not quiet:
            console.print(f"score map written to {map_path}")
    if render_path is None:
        return
    with figure_after_answer(json_path, render_path, "render"):
        with progress_bar("rendering", "samples/pixel") as update:
            from labcut.commands import render_checked
            from labcut.scene import normalize_normal

            assert render_ask is not None
            result = interruptibly(render_checked, mesh, render_ask.replace(scenario=rec.scenario),
                                   normalize_normal(rec.normal), progress=update, flash_mask=flash_mask_path is not None)
        with all_or_nothing() as written:
            result.save(render_path)
            written.append(Path(render_path))
            if flash_mask_path is not None:
                result.save_flash_mask(flash_mask_path)
                written.append(Path(flash_mask_path))
            if json_path not in (None, "-"):
                data["render"] = render_summary(result, render_path)
                if flash_mask_path is not None:
                    data["render"]["flash_mask"] = {"path": str(flash_mask_path), **result.flash_mask.to_dict()}
                write_json(json_path, data)
    if not quiet:
        print_render_notes(result)
        console.print(f"render written to {render_path} ({lo.exposure_line(result)})")
        if flash_mask_path is not None:
            console.print(lo.flash_mask_line(result, flash_mask_path), highlight=False)


@app.command("evaluate-orientation")
@mo.takes_mesh_options
@po.takes_plan_options
@m.takes_material
def evaluate_orientation(
    ctx: typer.Context,
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh: STL, OBJ, PLY, OFF, GLB/GLTF, 3MF.")],
    normal: Annotated[Optional[str], typer.Option("--normal", "-n", help="Lamella normal X,Y,Z in the mesh frame (+Z face-up, -Y front); default 0,0,1.")] = None,
    tilt: Annotated[Optional[float], typer.Option("--tilt", help="Or the normal's tilt from the face-up axis, degrees (with --azimuth).")] = None,
    azimuth: Annotated[Optional[float], typer.Option("--azimuth", help="The normal's azimuth from +X (the stone's right) towards +Y, degrees (with --tilt).")] = None,
    mesh_options: Any = None,  # --units, --up-axis, --size (meshes.takes_mesh_options)
    material: Any = None,  # the material options (materials.takes_material)
    scenario: so.Scenario = None,
    lighting: so.Lighting = None,
    viewing: so.Viewing = None,
    quality: Quality = "standard",
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the metrics as JSON ('-' for stdout).")] = None,
    plan_options: Any = None,  # --estimator, --effect, --plan, --plan-only (plan_options.takes_plan_options)
    zoning: m.ZoningOpt = None,
) -> None:
    """Flash metrics of MESH cut with its lamella plane normal to --normal (or at --tilt and --azimuth)."""
    estimator, effect, plan, plan_only = plan_options.estimator, plan_options.effect, plan_options.plan, plan_options.plan_only
    import labcut
    from labcut.orientation import METRIC_DEFINITIONS, FRAME, metrics_dict

    check_outputs({"--json": (json_path, (".json",))}, ctx)
    m_vec = normal_or_angles(normal, tilt, azimuth, ("--normal", "--tilt", "--azimuth"), default="0,0,1")
    setup = _question(material, scenario, lighting, viewing, quality, estimator, effect, zoning)
    scene = setup.scenario
    from labcut.planner import plan_question

    mesh = mesh_options.load(mesh_path)
    the_plan = plan_question(mesh, setup, "evaluate")
    if plan or plan_only:
        po.show(the_plan, mesh_path.name, to_stderr=json_path == "-")
        if plan_only:
            po.finish_plan_only(the_plan, json_path)
            return
    metrics = labcut.evaluate_orientation(mesh, m_vec, setup=setup, plan=the_plan)  # planned once, above
    provenance = {**labcut.Stone.of(mesh).provenance_dict(), "path": str(mesh_path)}
    from labcut.scene import tilt_azimuth

    # the layout of recommend-orientation's JSON: the normal and its angles, then "metrics"
    tilt_deg, azimuth_deg = tilt_azimuth(m_vec)
    data = {"normal": m_vec.tolist(), "tilt_deg": tilt_deg, "azimuth_deg": azimuth_deg, "frame": FRAME,
            "scenario": scene.to_dict(), "material": material.to_dict(), "mesh": provenance,
            "metrics": metrics_dict(metrics), "metric_definitions": METRIC_DEFINITIONS,
            "estimator": the_plan.estimator, "plan": the_plan.to_dict()}
    if json_path == "-":
        typer.echo(json.dumps(data, indent=2, allow_nan=False))
        return
    if json_path is not None:
        write_json(json_path, data)
    mo.print_provenance(mesh, mesh_path.name)
    console.print(_metrics_table(f"Flash of {mesh_path.name} with lamella normal ({', '.join(f'{float(x):.3f}' for x in m_vec)}), "
                                 f"{_scene_label(scene)}", metrics))
