"""``labcut spectrum``: the flash of a material at several angles, as a table and a plot."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.table import Table

from . import materials as m
from .root import app, check_outputs, console, figure_after_answer, write_json


#: width of the colour swatch before the hex code in the table
_SWATCH = 4


def _fmt(x: float, spec: str, unit: str = "") -> str:
    """``x`` formatted with ``unit`` appended, or a dash (no unit) for a missing value."""
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec) + unit


@app.command()
@m.takes_material(without=("spread",))
def spectrum(
    ctx: typer.Context,
    material: Any = None,  # the material options (materials.takes_material)
    angles: Annotated[str, typer.Option(help="Internal angles to the lamella normal, degrees, comma-separated.")] = "0,15,30,45",
    plot: Annotated[Optional[Path], typer.Option("--plot", "-o", help="Write the reflectance plot to this PNG (none unless asked).")] = None,
    no_plot: Annotated[bool, typer.Option("--no-plot", help="Do not write a plot, even with --plot.")] = False,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the table as JSON to this file ('-' for stdout).")] = None,
) -> None:
    """Peak wavelength, peak reflectance and flash colour of a material at several angles.

    Angles are inside the stone, between the ray and the lamella normal: 0° is the
    face-on flash, tilting moves the peak to shorter wavelengths (Bragg's law). A purple
    flash's dominant λ is its complementary wavelength, marked c. A material whose
    face-on peak lies outside the visible (380-780 nm) gets a warning. Writes files only
    when asked: --plot/-o FILE.png, --json FILE.
    """
    import json

    from labcut import colour
    from labcut.errors import ParameterError
    from labcut.physics import check_angles, spectrum_summary

    try:
        angle_list = [float(a) for a in angles.split(",") if a.strip()]
    except ValueError:
        raise ParameterError(f"--angles must be comma-separated numbers, got {angles!r}") from None
    check_angles(angle_list)
    check_outputs({"--plot": (None if no_plot else plot, (".png",)), "--json": (json_path, (".json",))}, ctx)
    rows = spectrum_summary(material, angle_list)
    note = material.visibility_note()  # printed as a warning: line when the material was built
    depth = {"stack_depth_mm": material.stack_depth_mm, "flash_depth_mm": material.flash_depth_mm}
    result = {"material": material.to_dict(), "depth": depth, "angles": rows, "warnings": [note] if note else []}

    if json_path == "-":
        typer.echo(json.dumps(_finite(result), indent=2))
    else:
        purple = any(r["hue"] == "purple" for r in rows)
        depth_line = (f"stack {depth['stack_depth_mm']:.2f} mm deep; its flash mirrored {depth['flash_depth_mm']:.2f} mm "
                      "below the surface on average (the flash depth)")
        table = Table(title=f"Flash of {material.name or 'labradorite'} (period {material.period_nm:.1f} nm, {material.pairs} pairs)",
                      caption=(colour.PURPLE_CAPTION + "\n" if purple else "") + depth_line, caption_justify="left")
        # every column readable at 80 columns: the numbers and the hex code never wrap or cut;
        # a value too wide for its column (a peak past 10 µm) folds onto a second line
        for col, just in (("angle", "right"), ("peak λ", "right"), ("Bragg λ", "right"), ("peak R", "right"),
                          ("dominant λ", "right"), ("purity", "right")):
            table.add_column(col, justify=just, overflow="fold")  # type: ignore[arg-type]
        table.add_column("colour", justify="left", no_wrap=True, min_width=len(" #rrggbb") + _SWATCH)
        for r in rows:
            table.add_row(
                f"{r['angle_deg']:g}°",
                _fmt(r["peak_nm"], ".1f", " nm"),
                f"{r['bragg_nm']:.1f} nm",
                _fmt(r["peak_reflectance"], ".3f"),
                colour.dominant_text(r["dominant_nm"]),
                _fmt(r["purity"], ".2f"),
                f"[on {r['hex']}]{' ' * _SWATCH}[/] {r['hex']}",
            )
        console.print(table)
    if json_path not in (None, "-"):
        write_json(json_path, _finite(result))
    if plot is not None and not no_plot:  # the figure after the answer: a failing plot leaves the table and JSON
        with figure_after_answer(json_path, plot, "plot"):
            from labcut.plots import plot_spectrum

            plot_spectrum(material, angle_list, plot)
    if json_path not in (None, "-"):
        console.print(f"table written to {json_path}")
    if plot is not None and not no_plot and json_path != "-":
        console.print(f"plot written to {plot}")


def _finite(obj):  # JSON has no NaN: write null
    if isinstance(obj, float):
        return None if math.isnan(obj) or math.isinf(obj) else obj
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    return obj
