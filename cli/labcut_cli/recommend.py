"""``labcut recommend-orientation`` and ``labcut evaluate-orientation``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from . import materials as m
from . import scene_options as so
from .root import all_or_nothing, app, console, parse_vector, write_json

Quality = Annotated[str, typer.Option(help="draft, standard or high.")]


def _metrics_table(title: str, metrics, score_name: str | None = None, score: float | None = None) -> Table:
    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_column("meaning")
    rows = [
        ("flash area", f"{metrics.flash_area:.1%}", "share of the visible stone that flashes"),
        ("flash intensity", f"{metrics.flash_intensity:.3f}", "mean brightness of the flash / a face-on flat flash"),
        ("flash energy", f"{metrics.flash_energy:.4f}", "area x intensity"),
        ("coverage", f"{metrics.coverage:.1%}", "share of viewing directions that see a flash (> 5 % area)"),
    ]
    for r in rows:
        table.add_row(*r)
    return table


def _scene_label(scene) -> str:
    """``scenario 'ring' (ceiling, above)``: what a result was computed under."""
    return f"scenario {scene.name!r}: {scene.lights.name} light, {scene.views.name} viewers"


@app.command("recommend-orientation")
def recommend_orientation(
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh (mm, +Z face-up).")],
    preset: m.Preset = None,
    peak: m.Peak = None,
    an: m.Anorthite = None,
    material_file: m.MaterialFile = None,
    spread: m.SPREAD = None,
    scenario: so.Scenario = None,
    lighting: so.Lighting = None,
    viewing: so.Viewing = None,
    objective: Annotated[str, typer.Option(help="energy, area, intensity or balanced.")] = "energy",
    quality: Quality = "standard",
    optimizer: Annotated[str, typer.Option(help="nlopt, gradient or grid.")] = "nlopt",
    max_tilt: Annotated[float, typer.Option("--max-tilt", help="Largest allowed tilt of the lamella normal, degrees.")] = 90.0,
    tilt_axis: Annotated[Optional[str], typer.Option("--tilt-axis", help="Only tilt about this horizontal axis X,Y,Z.")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the surface sampling.", min=0)] = 0,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the result as JSON ('-' for stdout).")] = None,
    render_path: Annotated[Optional[Path], typer.Option("--render", help="Render the stone at the recommended orientation (.png/.exr).")] = None,
    map_path: Annotated[Optional[Path], typer.Option("--map", help="Write a polar map of the score over the hemisphere (.png).")] = None,
    spp: Annotated[int, typer.Option(help="Samples per pixel of --render.", min=1)] = 64,
) -> None:
    """Find the lamella orientation that makes MESH flash most, and how precisely it must be cut."""
    import labcut
    from labcut.errors import ParameterError
    from labcut.fileio import check_output_path
    from labcut.orientation.optimize import OPTIMIZERS, Constraint
    from labcut.orientation.scoring import OBJECTIVES

    from .progress import progress_bar

    # validate everything before the work starts
    if json_path not in (None, "-"):
        check_output_path(json_path, (".json",))
    if render_path is not None:
        check_output_path(render_path, (".png", ".exr"))
    if map_path is not None:
        check_output_path(map_path, (".png",))
    if objective not in OBJECTIVES:
        raise ParameterError(f"--objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if optimizer not in OPTIMIZERS:
        raise ParameterError(f"--optimizer must be one of {', '.join(OPTIMIZERS)}, got {optimizer!r}")
    axis = parse_vector(tilt_axis, "--tilt-axis") if tilt_axis else None
    Constraint(max_tilt, axis)
    scene = so.resolve(scenario, lighting, viewing, quality)
    material = m.build_material(preset, peak, an, material_file, spread_deg=spread)
    mesh = labcut.load_mesh(mesh_path)

    with progress_bar("recommending", "%") as update:
        rec = labcut.recommend_orientation(
            mesh, material, scenario=scene, objective=objective, quality=quality,
            optimizer=optimizer, max_tilt=max_tilt, tilt_axis=axis, seed=seed,
            progress=lambda stage, fraction: update(int(round(100 * fraction)), 100),
        )
        if render_path is not None:
            result = labcut.render(mesh, material, rec.normal, scenario=rec.scenario, spp=spp, resolution=512,
                                   progress=lambda d, t: update(int(d * 100 / t), 100))
    data = rec.to_dict()
    with all_or_nothing() as written:
        if render_path is not None:
            result.save(render_path)
            written.append(Path(render_path))
            data["render"] = {"path": str(render_path), "plan": result.plan.to_dict(), "scenario": result.scenario,
                              "views": result.views}
        if map_path is not None:
            from labcut.plots.scoremap import plot_score_map

            plot_score_map(rec, map_path, title=f"{mesh_path.name}: {objective}, {_scene_label(scene)}")
            written.append(Path(map_path))
        if json_path == "-":
            typer.echo(json.dumps(data, indent=2, allow_nan=False))
            return
        if json_path is not None:
            write_json(json_path, data)

    console.print(f"[bold]Recommendation for {mesh_path.name}[/] ({_scene_label(scene)}): {rec.description}.")
    ax = rec.tolerance_by_axis
    console.print(
        f"Keep within [bold]±{rec.tolerance_deg:.1f}°[/] of it in any direction to keep 90 % of the {objective} score "
        f"(±{ax['front_back_deg']:.1f}° front-to-back, ±{ax['left_right_deg']:.1f}° side-to-side; "
        f"normal {rec.normal[0]:+.3f}, {rec.normal[1]:+.3f}, {rec.normal[2]:+.3f} in the mesh frame)."
    )
    console.print(_metrics_table("Flash at the recommended orientation", rec.metrics))
    if rec.metrics.flash_area == 0.0:
        console.print(
            f"No part of the stone reaches the flash threshold ({rec.settings['tau']:g} x a face-on flash under one lamp "
            "of the same total light): diffuse lighting spreads the schiller thin. The energy score still ranks orientations."
        )
    if rec.runners_up:
        table = Table(title="Other good orientations (distinct optima)")
        for col in ("#", "orientation", f"{objective} vs best"):
            table.add_column(col)
        for i, r in enumerate(rec.runners_up, start=2):
            table.add_row(str(i), r["description"], f"{r['relative_score']:.0%}")
        console.print(table)
    console.print(f"{rec.optimizer}: {rec.evaluations} evaluations, {rec.seconds:.2f} s; "
                  f"{rec.settings['triples']} (point, light, view) triples")
    for label, path in (("JSON", json_path), ("render", render_path), ("score map", map_path)):
        if path is not None:
            console.print(f"{label} written to {path}")


@app.command("evaluate-orientation")
def evaluate_orientation(
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh (mm, +Z face-up).")],
    normal: Annotated[str, typer.Option("--normal", "-n", help="Lamella normal X,Y,Z in the mesh frame.")] = "0,0,1",
    preset: m.Preset = None,
    peak: m.Peak = None,
    an: m.Anorthite = None,
    material_file: m.MaterialFile = None,
    spread: m.SPREAD = None,
    scenario: so.Scenario = None,
    lighting: so.Lighting = None,
    viewing: so.Viewing = None,
    quality: Quality = "standard",
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the metrics as JSON ('-' for stdout).")] = None,
) -> None:
    """Flash metrics of MESH cut with its lamella plane normal to --normal."""
    import labcut
    from labcut.fileio import check_output_path
    from labcut.rendering.api import normalize_normal

    if json_path not in (None, "-"):
        check_output_path(json_path, (".json",))
    m_vec = normalize_normal(parse_vector(normal, "--normal"))
    material = m.build_material(preset, peak, an, material_file, spread_deg=spread)
    scene = so.resolve(scenario, lighting, viewing, quality)
    mesh = labcut.load_mesh(mesh_path)
    metrics = labcut.evaluate_orientation(mesh, m_vec, material, scenario=scene, quality=quality)
    data = {"normal": m_vec.tolist(), "scenario": scene.to_dict(), **metrics.to_dict()}
    if json_path == "-":
        typer.echo(json.dumps(data, indent=2))
        return
    if json_path is not None:
        write_json(json_path, data)
    console.print(_metrics_table(f"Flash of {mesh_path.name} with lamella normal ({', '.join(f'{float(x):.3f}' for x in m_vec)}), "
                                 f"{_scene_label(scene)}", metrics))
