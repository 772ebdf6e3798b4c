"""``labcut spectrum``: the flash of a material at several angles, as a table and a plot."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.table import Table

from . import materials as m
from .root import all_or_nothing, app, console, write_json


def _fmt(x: float, spec: str) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


@app.command()
@m.takes_material(without=("spread",))
def spectrum(
    material: Any = None,  # the material options (materials.takes_material)
    angles: Annotated[str, typer.Option(help="Internal angles to the lamella normal, degrees, comma-separated.")] = "0,15,30,45",
    plot: Annotated[Optional[Path], typer.Option("--plot", "-o", help="Write the reflectance plot to this PNG (none unless asked).")] = None,
    no_plot: Annotated[bool, typer.Option("--no-plot", help="Do not write a plot, even with --plot.")] = False,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the table as JSON to this file ('-' for stdout).")] = None,
) -> None:
    """Peak wavelength, peak reflectance and flash colour of a material at several angles.

    Angles are inside the stone, between the ray and the lamella normal: 0° is the
    face-on flash, tilting moves the peak to shorter wavelengths (Bragg's law). Writes
    files only when asked: --plot/-o FILE.png, --json FILE.
    """
    import json

    from labcut.errors import ParameterError
    from labcut.fileio import check_output_path
    from labcut.physics import check_angles, spectrum_summary

    try:
        angle_list = [float(a) for a in angles.split(",") if a.strip()]
    except ValueError:
        raise ParameterError(f"--angles must be comma-separated numbers, got {angles!r}") from None
    check_angles(angle_list)
    if plot is not None and not no_plot:
        check_output_path(plot, (".png",))
    if json_path not in (None, "-"):
        check_output_path(json_path, (".json",))
    rows = spectrum_summary(material, angle_list)
    result = {"material": material.to_dict(), "angles": rows}

    if json_path == "-":
        typer.echo(json.dumps(result, indent=2, default=lambda x: None))
    else:
        table = Table(title=f"Flash of {material.name or 'labradorite'} (period {material.period_nm:.1f} nm, {material.pairs} pairs)")
        for col, just in (("angle", "right"), ("peak λ", "right"), ("Bragg λ", "right"), ("peak R", "right"),
                          ("dominant λ", "right"), ("purity", "right"), ("colour", "left")):
            table.add_column(col, justify=just)
        for r in rows:
            table.add_row(
                f"{r['angle_deg']:g}°",
                _fmt(r["peak_nm"], ".1f") + " nm",
                f"{r['bragg_nm']:.1f} nm",
                _fmt(r["peak_reflectance"], ".3f"),
                _fmt(r["dominant_nm"], ".1f") + " nm",
                _fmt(r["purity"], ".2f"),
                f"[on {r['hex']}]      [/] {r['hex']}",
            )
        console.print(table)
    with all_or_nothing() as written:
        if json_path not in (None, "-"):
            write_json(json_path, _finite(result))
            written.append(Path(json_path))
        if plot is not None and not no_plot:
            from labcut.plots import plot_spectrum

            plot_spectrum(material, angle_list, plot)
            written.append(Path(plot))
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
