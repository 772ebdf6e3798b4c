"""``labcut compare``: compare cuts (mesh files or cabochon specs) for their schiller, under one or
more scenarios; a ranked table for people, an HTML report, JSON and CSV for programs.

Every cut, scenario, material option and output path is checked before the long work starts;
the outputs are written only when everything is computed, each atomically, all or none.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.table import Table

from labcut.scene import SCENARIOS

from . import materials as m
from . import meshes as mo
from . import plan_options as po
from .root import all_or_nothing, app, check_outputs, console, err_console, figure_after_answer, write_json

Cuts = Annotated[
    list[str],
    typer.Argument(
        metavar="CUT...",
        help="Cuts to compare: mesh files (STL, OBJ, PLY, OFF, GLB/GLTF, 3MF), GemCad designs (.asc, .gem; "
             "DESIGN@SIZE for its own girdle width in mm, e.g. SRB.asc@8 SRB.asc@12) or cabochon specs "
             "cab:OUTLINE,SIZE[,DOME][,key=value...], e.g. cab:oval,16x12,low or cab:round,12,high,profile=spherical.",
        show_default=False,
    ),
]
Scenarios = Annotated[
    Optional[list[str]],
    typer.Option("--scenario", "-s",
                 help=f"How the stones are lit, worn and seen, once per scenario to compare: {SCENARIOS.choices()} "
                      "or a scenario JSON file (default: bench)."),
]


def _reference(text: str, count: int) -> int | str:
    """``--reference``: a cut's position on the command line (1 = the first of ``count``) or its name."""
    from labcut.errors import ParameterError

    key = text.strip()
    if key.isdigit():
        if not 1 <= int(key) <= count:
            raise ParameterError(f"--reference is a cut's position (1 to {count}, the order of the CUTs) or its name, got {text!r}")
        return int(key) - 1
    return key


def short_orientation(normal: Any, scenario: Any, parallel_within_deg: float | None) -> str:
    """``9° top``, ``4° front-left``, ``parallel (±2.3°)``: an orientation for a narrow table."""
    from labcut.orientation import side_name
    from labcut.scene import tilt_azimuth

    if parallel_within_deg is not None:
        return f"parallel (±{parallel_within_deg:.1f}°)"
    tilt, az = tilt_azimuth(normal)
    if tilt < 0.5:
        return "parallel"
    return f"{tilt:.0f}° {side_name(az, scenario).split(' (')[0]} ({az:.0f}°)"


def _x(value: float | None) -> str:
    return "–" if value is None else f"x{value:.2f}"


#: how every comparison table explains its ranks and error bars
BARS_NOTE = ("± after a score: its error bar (about 95 %: a much finer sampling lands that close). "
             "=1, =2: cuts whose scores lie within each other's error bars share a rank, a tie.")


def summary_table(cmp: Any) -> Table:
    """The ranked summary: overall rank (=N for a tie), weight, overall score ± its error bar, per
    scenario energy (x reference) and tolerance."""
    from labcut.reports import rank_label

    table = Table(title=f"Ranked by flash (reference: {cmp.reference_cut.name})", title_justify="left",
                  caption=BARS_NOTE, caption_justify="left")
    table.add_column("rank", justify="right")
    table.add_column("cut", overflow="fold")
    table.add_column("ct", justify="right")
    table.add_column("overall", justify="right")
    for n in cmp.scenario_names:
        table.add_column(f"{n}: energy, tolerance", justify="right")
    for c in cmp.ranked():
        cells = [rank_label(c.rank, c.tied), c.name, f"{c.summary.weight_ct:.2f}", f"{c.overall_score:.2f} ±{c.overall_error:.2f}"]
        for n in cmp.scenario_names:
            r = c.scenarios[n]
            cells.append(f"{r.energy:.4f} ±{r.energy_error:.4f} {_x(r.normalised.get('flash_energy'))}; "
                         f"±{r.recommendation.tolerance_deg:.1f}°")
        table.add_row(*cells)
    return table


def scenario_table(cmp: Any, name: str) -> Table:
    """One scenario: each cut's best orientation, tolerances, flash area and energy, flash colour."""
    sc = next(s for s in cmp.scenarios if s.name == name)
    from labcut.reports import rank_label

    table = Table(title=f"Scenario {name}: each cut at its best orientation", title_justify="left",
                  caption=cmp.scenario_verdict(name), caption_justify="left", pad_edge=False)
    along = "t-b" if sc.worn_upright else "f-b"
    longest = max(len(c.name) for c in cmp.cuts)
    for col, just in (("#", "right"), ("cut", "left"), ("best\norientation", "left"), (f"tolerance;\n{along}/side", "right"),
                      ("area", "right"), ("energy", "right"), ("colour", "right")):
        table.add_column(col, justify=just, overflow="fold",  # type: ignore[arg-type]
                         min_width=min(longest, max(12, console.width - 64)) if col == "cut"
                         else 11 if col.startswith("best") else None,
                         max_width=max(11, console.width - 69) if col.startswith("best") else None)
    for c in cmp.cuts:
        r = c.scenarios[name]
        rec, met = r.recommendation, r.recommendation.metrics
        ax = rec.tolerance_by_axis
        nm = r.colour.stats.get("dominant_wavelength_nm") if r.colour is not None else None
        mm2 = "" if met.flash_area_mm2 is None else f" {met.flash_area_mm2:.3g} mm²"
        table.add_row(
            rank_label(r.rank, r.tied), c.name, short_orientation(rec.normal, sc, rec.parallel_within_deg),
            f"±{rec.tolerance_deg:.1f}°\n±{ax['front_back_deg']:.1f}/{ax['left_right_deg']:.1f}°",
            f"{met.flash_area:.1%}\n{mm2.strip()}", f"{met.flash_energy:.4f}\n±{r.energy_error:.4f}\n{_x(r.normalised.get('flash_energy'))}",
            "–" if nm is None else f"{nm:.0f}nm",
        )
    return table


def compromise_table(cmp: Any) -> Table:
    """One lamella orientation per cut for all the scenarios, and what each scenario keeps of its best."""
    from labcut.reports import naming_scenario

    naming = naming_scenario(cmp.scenarios)
    table = Table(title="One orientation for all scenarios", caption=cmp.sides_note, title_justify="left")
    table.add_column("cut", overflow="fold")
    table.add_column("orientation")
    table.add_column("tolerance", justify="right")
    for n in cmp.scenario_names:
        table.add_column(f"{n}: kept", justify="right")
    for c in cmp.cuts:
        table.add_row(c.name, short_orientation(c.compromise.normal, naming, c.compromise.parallel_within_deg),
                      f"±{c.compromise.tolerance_deg:.1f}°", *(f"{c.compromise.relative[n]:.0%}" for n in cmp.scenario_names))
    return table


@app.command("compare")
@mo.takes_mesh_options
@m.takes_material
def compare(
    ctx: typer.Context,
    cuts: Cuts,
    scenario: Scenarios = None,
    reference: Annotated[str, typer.Option("--reference", help="The cut every other is normalised to: its position (1 = the first CUT) or its name.")] = "1",
    mesh_options: Any = None,  # --units, --up-axis, --size (meshes.takes_mesh_options)
    material: Any = None,  # the material options (materials.takes_material)
    quality: Annotated[Optional[str], typer.Option(help="draft, standard (the default) or high: of the recommendations, curves and renders; not with --time-budget.")] = None,
    time_budget: Annotated[Optional[float], typer.Option(
        "--time-budget", metavar="SECONDS",
        help="Seconds the whole comparison may take: the most accurate quality predicted to fit on this machine replaces "
             "--quality (--resolution/--spp, when given, are kept); below the cheapest setting's prediction that one runs, with a note.")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the surface sampling and the renders.", min=0)] = 0,
    resolution: Annotated[Optional[int], typer.Option(help="Size of the renders in pixels (default by quality: 96, 128, 256).")] = None,
    spp: Annotated[Optional[int], typer.Option(help="Samples per pixel of the renders (default by quality: 8, 32, 128).")] = None,
    html_path: Annotated[Optional[Path], typer.Option("--html", help="Write the report: one self-contained HTML page.")] = None,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write every number of the report as JSON ('-' for stdout).")] = None,
    csv_path: Annotated[Optional[Path], typer.Option("--csv", help="Write every number of the report as CSV (one number per row).")] = None,
    estimator: po.Estimator = "auto",
    effect: po.Effect = None,
    plan_flag: po.Plan = False,
    plan_only: po.PlanOnly = False,
) -> None:
    """Compare cuts for their schiller: each at its own best lamella orientation per scenario, plus one
    orientation for all; ranked, normalised to a reference cut, with renders, curves and maps (--html).
    """
    import warnings

    from labcut.errors import LabcutWarning
    from labcut.commands import quality_or_budget
    from labcut.reports import plan_comparison, run_comparison

    from .progress import progress_bar

    # every input is checked before the work starts
    check_outputs({"--html": (html_path, (".html", ".htm")), "--json": (json_path, (".json",)), "--csv": (csv_path, (".csv",))}, ctx)
    effects = po.check(estimator, effect)
    from labcut.planner import check_compare_estimator

    check_compare_estimator(estimator)
    quality_or_budget(quality is not None, time_budget is not None, flags=True)
    unit_arg, up, size = mesh_options.units_arg, mesh_options.up, mesh_options.size
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LabcutWarning)
        plan = plan_comparison(cuts, material, scenario or ["bench"], reference=_reference(reference, len(cuts)),
                               quality=quality or "standard", units=unit_arg, up_axis=up, seed=seed, resolution=resolution,
                               spp=spp, effects=effects, size=size, time_budget=time_budget)
    for w in caught:
        if issubclass(w.category, LabcutWarning):
            mo.print_warning(str(w.message))

    if plan_flag or plan_only:
        for (cut_name, scen_name), eplan in plan.effect_plans.items():
            po.show(eplan, f"{cut_name}, scenario {scen_name!r}", to_stderr=json_path == "-")
        if plan_only:
            data = {"plans": [{"cut": c, "scenario": s, "plan": e.to_dict()} for (c, s), e in plan.effect_plans.items()]}
            if json_path == "-":
                typer.echo(json.dumps(data, indent=2, allow_nan=False))
            elif json_path is not None:
                write_json(json_path, data)
            return

    with progress_bar("comparing", "cut x scenario") as update:
        cmp = run_comparison(plan, progress=update)

    # the answer first (JSON, CSV, tables); the report's figures after it, so a failing report leaves the answer
    with all_or_nothing() as written:
        if json_path not in (None, "-"):
            cmp.save_json(json_path)
            written.append(Path(json_path))
        if csv_path is not None:
            cmp.save_csv(csv_path)
            written.append(Path(csv_path))
    if json_path == "-":
        typer.echo(json.dumps(cmp.to_dict(), indent=2, allow_nan=False))
        if html_path is not None:
            with figure_after_answer(json_path, html_path, "report"):
                cmp.save_html(html_path)
        return
    console.print(summary_table(cmp))
    console.print(f"{cmp.verdict} (The report, --html, says each orientation in a cutter's words.)", highlight=False)
    for n in cmp.scenario_names:
        console.print(scenario_table(cmp, n))
    if len(cmp.scenarios) > 1:
        console.print(compromise_table(cmp))
    console.print(f"{len(cmp.cuts)} cut(s) x {len(cmp.scenarios)} scenario(s) at {cmp.quality} quality in {cmp.seconds:.1f} s")
    if cmp.budget:
        b = cmp.budget
        bars = [c.scenarios[n].recommendation.uncertainty for c in cmp.cuts for n in cmp.scenario_names]
        bars = [u for u in bars if u is not None]
        worst = (f"; its largest error bars ±{max(u.angle_deg for u in bars):.1f}°, ±{max(u.score_rel for u in bars):.0%}"
                 if bars else "")
        console.print(f"time budget {b['budget_seconds']:g} s: quality {b['quality']} (predicted {b['predicted_seconds']:.1f} s, "
                      f"took {cmp.seconds:.1f} s{worst})", highlight=False)
    for label, path in (("JSON", json_path), ("CSV", csv_path)):
        if path is not None:
            console.print(f"{label} written to {path}")
    if html_path is not None:
        with figure_after_answer(json_path, html_path, "report"), err_console.status("writing the report (figures)"):
            cmp.save_html(html_path)
        console.print(f"report written to {html_path}")
