"""``labcut render``: an image of a stone cut with a given lamella orientation."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from . import materials as m
from . import meshes as mo
from . import scene_options as so
from .recommend import Exposure, parse_exposure, print_render_notes
from .root import all_or_nothing, app, console, parse_vector, write_json


@app.command()
def render(
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh: STL, OBJ, PLY, OFF, GLB/GLTF, 3MF.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Image file to write (required): .png (tonemapped) or .exr (linear HDR).")],
    normal: Annotated[str, typer.Option("--normal", "-n", help="Lamella normal X,Y,Z in the mesh frame (axial; +Z face-up, -Y front).")] = "0,0,1",
    units: mo.Units = "auto",
    up_axis: mo.UpAxis = "auto",
    size: mo.Size = None,
    preset: m.Preset = None,
    peak: m.Peak = None,
    an: m.Anorthite = None,
    material_file: m.MaterialFile = None,
    d_a: m.DA = None,
    d_b: m.DB = None,
    n_a: m.NA = None,
    n_b: m.NB = None,
    n_surface: m.NS = None,
    sigma_a: m.SA = None,
    sigma_b: m.SB = None,
    pairs: m.Pairs = None,
    spread: m.SPREAD = None,
    scenario: so.Scenario = None,
    lighting: so.Lighting = None,
    viewing: so.Viewing = None,
    view: Annotated[str, typer.Option(help="Camera: main (the scenario's main viewer), face-up, orbit, or TILT,AZIMUTH in degrees from the face.")] = "main",
    spp: Annotated[int, typer.Option(help="Samples per pixel.", min=1)] = 64,
    resolution: Annotated[int, typer.Option(help="Image width and height in pixels.", min=8, max=8192)] = 512,
    mode: Annotated[str, typer.Option(help="Colour transport: rgb, spectral or mono.")] = "rgb",
    polarizer: Annotated[Optional[float], typer.Option(help="Look through a linear polarizer at this angle (degrees).")] = None,
    zoning: Annotated[Optional[str], typer.Option(help="Colour zones: smooth, sharp, or a zoning .json file (docs/zoning.md).")] = None,
    schiller_only: Annotated[bool, typer.Option("--schiller-only", help="Render only the schiller flash (no glare, no body).")] = False,
    exposure: Exposure = "auto",
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the render plan and timing as JSON ('-' for stdout).")] = None,
) -> None:
    """Render MESH cut from labradorite with its lamella plane normal to --normal.

    Shows the stone as the scenario's main viewer sees it, under the scenario's lights.
    Simulates only what the request needs: RGB unless --mode spectral/mono, polarized
    only with --polarizer, direct lighting for convex stones, a path tracer for carvings.
    """
    import json

    import labcut
    from labcut.fileio import check_output_path
    from labcut.rendering.images import IMAGE_SUFFIXES

    from .progress import progress_bar

    check_output_path(output, IMAGE_SUFFIXES)
    if json_path not in (None, "-"):
        check_output_path(json_path, (".json",))
    material = m.build_material(preset, peak, an, material_file, d_a=d_a, d_b=d_b, sigma_a=sigma_a, sigma_b=sigma_b,
                                n_a=n_a, n_b=n_b, n_surface=n_surface, pairs=pairs, spread_deg=spread)
    lamella = parse_vector(normal, "--normal")
    zoning_spec = None
    if zoning is not None:
        from labcut.errors import ParameterError
        from labcut.rendering.zoning import PRESETS, Zoning

        if zoning.strip().lower() in PRESETS:
            zoning_spec = Zoning.preset(zoning, material)
        elif zoning.lower().endswith(".json") or Path(zoning).exists():
            zoning_spec = Zoning.load(zoning, material)
        else:
            raise ParameterError(f"--zoning must be {', '.join(PRESETS)} or a zoning .json file, got {zoning!r}")
    view_spec: str | tuple[float, float] = view
    if "," in view:
        view_spec = parse_vector(view, "--view", length=2)  # type: ignore[assignment]
    from labcut.backend import variant_name
    from labcut.rendering.api import normalize_normal
    from labcut.rendering.scene import camera_views

    normalize_normal(lamella)  # validate everything before the long work starts
    import math

    from labcut.errors import ParameterError

    if polarizer is not None and not math.isfinite(polarizer):
        raise ParameterError(f"--polarizer must be a finite angle in degrees, got {polarizer}")
    exposure_value = parse_exposure(exposure)
    scene = so.resolve(scenario, lighting, viewing)
    camera_views(view_spec, scene.main_setting())
    variant_name(mode, polarizer is not None and mode != "rgb")
    mo.check_mesh_options(units, up_axis, size)
    mesh = mo.load(mesh_path, units, up_axis, size=size)
    lobes = ("schiller",) if schiller_only else ("surface", "schiller", "body")
    with progress_bar("rendering", "samples/pixel") as update:
        result = labcut.render(
            mesh, material, lamella, scenario=scene, view=view_spec, spp=spp, resolution=resolution,
            mode=mode, polarizer_deg=polarizer, lobes=lobes, progress=update, zoning=zoning_spec, exposure=exposure_value,
        )
    summary = {
        "output": str(output),
        "mesh": {**result.mesh, "path": str(mesh_path)},
        "normal": [float(x) for x in normalize_normal(lamella)],
        "material": material.to_dict(),
        "scenario": result.scenario,
        "plan": result.plan.to_dict(),
        "spp": result.spp,
        "resolution": resolution,
        "seconds": result.seconds,
        "samples_per_second": result.samples_per_second,
        "views": result.views,
        "exposure": result.exposure if output.suffix.lower() == ".png" else None,
        "exposure_mode": result.exposure_mode if output.suffix.lower() == ".png" else "linear (EXR: no exposure applied)",
        "flash_by_view": result.flash,
        "notes": result.notes,
    }
    if zoning_spec is not None:
        summary["zoning"] = zoning_spec.to_dict()
    with all_or_nothing() as written:
        result.save(output)
        written.append(Path(output))
        if json_path == "-":
            typer.echo(json.dumps(summary, indent=2))
            return
        if json_path is not None:
            write_json(json_path, summary)
    mo.print_provenance(mesh, mesh_path.name)
    console.print(f"[bold]{output}[/]: {'; '.join(result.plan.reasons)}")
    print_render_notes(result)
    exposure_text = (f"exposure {result.exposure:.3g} ({result.exposure_mode})" if output.suffix.lower() == ".png"
                     else "linear HDR, no exposure")
    console.print(f"{result.spp} spp at {resolution}², {result.seconds:.1f} s ({result.samples_per_second / 1e6:.2f} Msamples/s); "
                  f"{exposure_text}")
