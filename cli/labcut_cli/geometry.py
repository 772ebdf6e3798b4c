"""``labcut cabochon`` (build and export a cabochon) and ``labcut inspect`` (summarise a mesh).

Units are mm; the mesh frame is DESIGN.md §3 (+Z face-up, base on z = 0).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.table import Table

from . import meshes as mo
from .root import app, check_outputs, console, write_json


def _read_outline_file(path: Path) -> Any:
    """Points (mm) from a JSON list of [x, y] pairs or a CSV / whitespace text file."""
    import numpy as np

    from labcut.errors import ParameterError

    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError(f"cannot read outline file {str(path)!r}: {exc}") from None
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ParameterError(f"outline file {path.name} is not valid JSON: {exc.msg} (line {exc.lineno})") from None
        if isinstance(data, dict):
            data = data.get("points", data.get("outline"))
        return data
    rows = []
    for i, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").replace(";", " ").split()
        try:
            rows.append([float(p) for p in parts])
        except ValueError:
            if not rows:  # a header line
                continue
            raise ParameterError(f"outline file {path.name}, line {i}: expected two numbers x, y in mm") from None
    if not rows or any(len(r) != 2 for r in rows):
        raise ParameterError(f"outline file {path.name} must hold lines of two numbers x, y in mm")
    return np.array(rows)


def _summary_table(summary: Any, title: str, load_report: dict[str, Any] | None = None) -> Table:
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("quantity", style="bold")
    table.add_column("value")
    d = summary.to_dict()
    table.add_row("dimensions", f"{d['length_mm']:.3f} x {d['width_mm']:.3f} x {d['height_mm']:.3f} mm (L x W x H)")
    table.add_row("volume", f"{d['volume_mm3']:.3f} mm³")
    table.add_row("surface area", f"{d['surface_area_mm2']:.3f} mm²")
    lo, hi = d["weight_ct_range"]
    table.add_row("weight", f"{d['weight_ct']:.3f} ct ({lo:.3f}–{hi:.3f} ct at 2.69–2.72 g/cm³)")
    table.add_row("triangles", f"{d['triangles']} ({d['vertices']} vertices)")
    table.add_row("watertight", "yes" if d["watertight"] else "no")
    table.add_row("outward winding", "yes" if d["winding_consistent"] else "no")
    table.add_row("convex", "yes" if d["convex"] else "no")
    if load_report is not None:
        source = {"given": "as given", "file": "declared by the file", "default": "default: the file does not say"}
        table.add_row("units", f"{load_report['units']} ({source.get(load_report['units_source'], load_report['units_source'])})")
        table.add_row("face-up", f"the file's {load_report['up_axis']} — {load_report['up_axis_source']}")
        table.add_row("bodies", str(load_report.get("bodies", 1)))
    table.add_row("repaired", "; ".join(d["repairs"]) if d["repairs"] else "nothing")
    if d["notes"]:
        table.add_row("notes", "; ".join(d["notes"]))
    if load_report is not None and load_report.get("warnings"):
        table.add_row("warnings", "; ".join(load_report["warnings"]))
    return table


@app.command()
def cabochon(
    ctx: typer.Context,
    outline: Annotated[
        str,
        typer.Option(
            help="round, oval, cushion, pear, marquise (navette), rectangle, or a file of x,y points in mm (.csv, .txt, .json)."
        ),
    ] = "oval",
    length: Annotated[Optional[float], typer.Option(help="Length along X in mm (round: the diameter).")] = None,
    width: Annotated[Optional[float], typer.Option(help="Width along Y in mm (round: may be omitted).")] = None,
    dome: Annotated[str, typer.Option(help="Crown height: low, medium, high (0.20 / 0.33 / 0.50 of the width) or mm.")] = "medium",
    profile: Annotated[str, typer.Option(help="Dome profile: elliptic, spherical or tallow.")] = "elliptic",
    girdle: Annotated[float, typer.Option(help="Height in mm of a vertical girdle band (0: none).")] = 0.0,
    base: Annotated[str, typer.Option(help="flat, or a lower dome (double cabochon): low, medium, high or mm.")] = "flat",
    buff_top: Annotated[float, typer.Option("--buff-top", help="Flat table as a fraction (0-0.95) of the outline; 0: none.")] = 0.0,
    corner_radius: Annotated[Optional[float], typer.Option(help="Corner radius in mm of the rectangle outline.")] = None,
    resolution: Annotated[str, typer.Option(help="Points around the outline (16-4096) or 'default' (256).")] = "default",
    output: Annotated[
        Optional[Path], typer.Option("--output", "-o", help="Mesh file to write: .ply .stl .obj .off .glb .3mf.")
    ] = None,
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Also write the summary as JSON to this file ('-' for stdout).")] = None,
) -> None:
    """Build a watertight cabochon (mm, +Z face-up, base on z = 0), summarise it and export it."""
    from labcut.errors import ParameterError
    from labcut import cabochon as build
    from labcut.geometry import summarize
    from labcut.geometry import WRITE_FORMATS, save_mesh
    from labcut.geometry import OUTLINES

    # check the outputs before the work
    check_outputs({"--output": (output, WRITE_FORMATS + tuple(s.upper() for s in WRITE_FORMATS)), "--json": (json_path, (".json",))}, ctx)
    to_stdout = json_path is not None and str(json_path) == "-"

    names = OUTLINES + ("navette",)
    if outline.strip().lower() in names:
        shape: Any = outline.strip().lower()
    else:
        p = Path(outline)
        if not p.is_file():
            raise ParameterError(f"unknown outline {outline!r}: use one of {', '.join(names)} or a file of x,y points")
        shape = _read_outline_file(p)
    from labcut.validation import name_or_mm

    dome_v = name_or_mm(dome, ("low", "medium", "high"), "--dome")
    base_v = name_or_mm(base, ("flat", "low", "medium", "high"), "--base")
    res: int | str = resolution if resolution.strip().lower() == "default" else resolution.strip()
    mesh = build(
        outline=shape,
        length=length,
        width=width,
        dome=dome_v,
        profile=profile,
        girdle=girdle,
        base=base_v,
        buff_top=buff_top if buff_top else False,
        corner_radius=corner_radius,
        resolution=res,
    )
    name = output.name if output is not None else "cabochon"
    summary = summarize(mesh, name)
    if output is not None:
        save_mesh(mesh, output)
    import labcut

    meta = labcut.Stone.of(mesh).metadata()
    if not to_stdout:
        console.print(_summary_table(summary, f"{meta['outline']} cabochon, {meta['profile']} dome {meta['dome_mm']:.3f} mm"))
        if output is not None:
            console.print(f"wrote {output}")
    if json_path is not None:
        data = summary.to_dict()
        data["parameters"] = {k: v for k, v in meta.items() if k not in ("repairs",)}
        data["output"] = str(output) if output is not None else None
        write_json(str(json_path), data)


@app.command("inspect")
@mo.takes_mesh_options
def inspect_mesh(
    ctx: typer.Context,
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="STL, OBJ, PLY, OFF, GLB/GLTF or 3MF file.")],
    mesh_options: Any = None,  # --units, --up-axis, --size (meshes.takes_mesh_options)
    recentre: Annotated[bool, typer.Option(help="Centre on the Z axis with the base on z = 0.")] = True,
    repair: Annotated[bool, typer.Option(help="Repair what can be repaired (else any defect is an error).")] = True,
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Also write the summary as JSON to this file ('-' for stdout).")] = None,
) -> None:
    """Validate a mesh and print its dimensions, volume, weight in carats, triangles, convexity and repairs."""
    from labcut.geometry import summarize

    check_outputs({"--json": (json_path, (".json",))}, ctx)
    to_stdout = json_path is not None and str(json_path) == "-"
    mesh = mesh_options.load(mesh_path, recentre=recentre, repair=repair)
    summary = summarize(mesh, mesh_path.name)
    import labcut

    info = labcut.Stone.of(mesh).metadata()
    if not to_stdout:
        console.print(_summary_table(summary, f"{mesh_path.name} (in mm)", info))
    if json_path is not None:
        data = summary.to_dict()
        data["load_report"] = info
        write_json(str(json_path), data)
