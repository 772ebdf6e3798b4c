"""``labcut rough``: plan the stones to cut from a rough or slab, trading weight against flash;
a table and the workshop steps for people, JSON for programs, an HTML report and a PNG.

Every option, the rough and the output paths are checked before the search starts; the outputs
are written once the plan is made, each atomically, all or none.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.table import Table

from . import materials as m
from .root import app, check_outputs, console, err_console, figure_after_answer, normal_or_angles, write_json

#: what a library parameter is called on this command line, for its one-line errors
_OPTION_NAMES = {"lamella normal": "--lamella", "count": "--count", "margin": "--margin", "rank": "--rank",
                 "min flash": "--min-flash", "time budget": "--time-budget", "quality": "--quality", "units": "--units",
                 "up axis": "--up-axis"}

RANK_HELP = "How plans are ranked: value (carats^1.5 x flash ratio, the default), weight, or flash."


def stones_table(plan: Any) -> Table:
    table = Table(title=f"{plan.rough.name}: {len(plan.stones)} stone(s), {plan.yield_fraction:.0%} of the rough's weight",
                  title_justify="left")
    for col in ("stone", "size (mm)", "carats", "flash", "flash plane in stone", "off best", "tolerance"):
        table.add_column(col, justify="left" if col == "stone" else "right")
    from labcut.scene import tilt_azimuth

    for s in plan.stones:
        mt, _ = tilt_azimuth(s.lamella_normal_cut)
        table.add_row(s.name, " x ".join(f"{x:.1f}" for x in s.size_mm), f"{s.carats:.2f}", f"{s.flash_ratio:.0%}",
                      f"{mt:.1f}°", f"{s.off_best_deg:.1f}°", f"±{s.tolerance_deg:.1f}°")
    return table


@app.command("rough")
@m.takes_material
def rough(
    ctx: typer.Context,
    rough_spec: Annotated[str, typer.Argument(metavar="ROUGH", help="The rough: a mesh file (STL, PLY, OBJ, OFF, GLB/GLTF, 3MF; "
                                              "its own frame, +Z its top) or slab:LxWxT in mm.")],
    lamella: Annotated[Optional[str], typer.Option("--lamella", help="The lamella normal X,Y,Z in the rough's frame.")] = None,
    flash_tilt: Annotated[Optional[float], typer.Option("--flash-tilt", metavar="DEG", help="Or the flash plane's tilt from the rough's top face, degrees (with --flash-azimuth).")] = None,
    flash_azimuth: Annotated[Optional[float], typer.Option("--flash-azimuth", metavar="DEG", help="The way the flash plane's normal leans, degrees from +X (right) towards +Y (back).")] = None,
    cut: Annotated[Optional[list[str]], typer.Option("--cut", metavar="SPEC", help="A candidate cut (repeatable): cab:OUTLINE,SIZE[,DOME], a mesh file or a GemCad design, scaled to fit. Default: every cabochon outline with low, medium and high domes.")] = None,
    calibrated: Annotated[bool, typer.Option("--calibrated", help="Only standard calibrated sizes of the default cabochons (none scaled).")] = False,
    fixed_size: Annotated[bool, typer.Option("--fixed-size", help="Keep each --cut at its own size (not scaled to fit).")] = False,
    count: Annotated[int, typer.Option("--count", help="How many stones to cut, apart from each other.")] = 1,
    margin: Annotated[float, typer.Option("--margin", metavar="MM", help="Saw margin kept between stones and from the rough's surface, mm.")] = 0.5,
    scenario: Annotated[str, typer.Option("--scenario", "-s", help="How the stones will be lit, worn and seen (a preset or a scenario JSON file).")] = "bench",
    material: Any = None,  # the material options (materials.takes_material)
    quality: Annotated[str, typer.Option(help="draft, standard or high: the flash maps and how many poses are tried.")] = "standard",
    time_budget: Annotated[Optional[float], typer.Option("--time-budget", metavar="SECONDS", help="Stop polishing and sawing when this runs out (the answer says so).")] = None,
    rank: Annotated[str, typer.Option("--rank", help=RANK_HELP)] = "value",
    min_flash: Annotated[float, typer.Option("--min-flash", help="The least flash ratio a stone may keep (0-1).")] = 0.0,
    units: Annotated[str, typer.Option("--units", help="The rough file's length unit: auto, mm, cm, m, um, in, ft or mm per unit.")] = "auto",
    up_axis: Annotated[str, typer.Option("--up-axis", help="The rough file's axis that is its top: +Z (default), -Z, +Y, -Y, +X, -X.")] = "+Z",
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the plan as JSON ('-' for stdout).")] = None,
    html_path: Annotated[Optional[Path], typer.Option("--html", help="Write the report: one self-contained HTML page.")] = None,
    png_path: Annotated[Optional[Path], typer.Option("--png", help="Write the plan's figure as PNG.")] = None,
) -> None:
    """Plan the stones to cut from ROUGH with its flash plane where it is: which cuts, how big, where
    and how tilted, trading weight against flash; saw, template and dop steps for each stone."""
    from labcut import plan_rough
    from labcut.rough import check_request
    from labcut.errors import ParameterError

    from .progress import progress_bar

    check_outputs({"--json": (json_path, (".json",)), "--html": (html_path, (".html", ".htm")), "--png": (png_path, (".png",))}, ctx)
    normal = normal_or_angles(lamella, flash_tilt, flash_azimuth, ("--lamella", "--flash-tilt", "--flash-azimuth"))
    try:
        check_request(rough_spec, normal, count, margin, quality, time_budget, rank, min_flash, units, up_axis,
                      calibrated, fixed_size, cut or None)  # every option, before the progress bar
        with progress_bar("planning", "%") as update:
            plan = plan_rough(rough_spec, normal, cuts=cut or None, material=material, scenario=scenario, count=count,
                              margin_mm=margin, quality=quality, time_budget=time_budget, rank=rank, min_flash=min_flash,
                              calibrated=calibrated, fixed_size=fixed_size, units=units, up_axis=up_axis,
                              progress=lambda stage, fraction: update(int(round(100 * fraction)), 100))
    except ParameterError as exc:
        raise exc.renamed(_OPTION_NAMES) from None
    # the answer first (JSON, tables); the figure and the report after it, so a failing figure leaves the answer
    if json_path is not None:
        write_json(json_path, plan.to_dict())
    if json_path == "-":
        _figures(plan, json_path, png_path, html_path)
        return
    console.print(stones_table(plan))
    for s in plan.stones:
        console.print(f"[bold]{s.name}[/bold]")
        for k, step in enumerate(s.workshop, 1):
            console.print(f"  {k}. {step}", highlight=False)
    for note in plan.notes:
        console.print(f"note: {note}", highlight=False)
    c = plan.checks
    console.print(f"checked with manifold3d: inside {'yes' if c['inside'] else 'NO'}, apart {'yes' if c['apart'] else 'NO'}; "
                  f"planned in {plan.seconds:.1f} s at {plan.settings['quality']} quality", highlight=False)
    if json_path is not None:
        console.print(f"JSON written to {json_path}")
    _figures(plan, json_path, png_path, html_path)
    for label, path in (("figure", png_path), ("report", html_path)):
        if path is not None:
            console.print(f"{label} written to {path}")


def _figures(plan: Any, json_path: str | None, png_path: Path | None, html_path: Path | None) -> None:
    """The plan's optional figure and report, after its answer (:func:`figure_after_answer`)."""
    if png_path is not None:
        with figure_after_answer(json_path, png_path, "figure"):
            plan.save_png(png_path)
    if html_path is not None:
        with figure_after_answer(json_path, html_path, "report"), err_console.status("writing the report (renders and figures)"):
            plan.save_html(html_path)
