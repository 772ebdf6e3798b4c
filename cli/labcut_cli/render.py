"""``labcut render``: an image of a stone cut with a given lamella orientation."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from . import look_options as lo
from . import materials as m
from . import meshes as mo
from . import plan_options as po
from . import scene_options as so
from .recommend import print_render_notes
from .preflight import Yes, before_rendering
from .root import (all_or_nothing, app, check_outputs, console, interruptibly, normal_or_angles, notes_after, parse_vector,
                   write_json)


STILL_SUFFIXES = (".png", ".exr")
#: the default size of a still and of an animation's frames (px)
STILL_RESOLUTION = 512
ANIMATION_RESOLUTION = 320
ANIMATION_SUFFIXES = (".webp", ".gif")


def parse_normal(text: str) -> tuple[float, ...]:
    """``X,Y,Z`` or a recommendation JSON (``labcut recommend-orientation --json``) holding ``normal``."""
    from labcut.errors import ParameterError

    if text.strip().lower().endswith(".json"):
        from labcut.fileio import read_json

        data = read_json(text, "recommendation file")
        if not isinstance(data, dict) or "normal" not in data:
            raise ParameterError(f"{text} holds no 'normal' (a labcut recommend-orientation --json file does)")
        normal = data["normal"]
        if not (isinstance(normal, list) and len(normal) == 3):
            raise ParameterError(f"{text}: 'normal' must be three numbers")
        return parse_vector(",".join(str(x) for x in normal), "--normal")
    return parse_vector(text, "--normal")


@app.command()
@mo.takes_mesh_options
@m.takes_material
def render(
    ctx: typer.Context,
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh: STL, OBJ, PLY, OFF, GLB/GLTF, 3MF.")],
    output: Annotated[Path, typer.Option("--output", "-o", "--out", help="File to write (required): .png (tonemapped) or .exr (linear HDR); with --animate .webp or .gif.")],
    normal: Annotated[Optional[str], typer.Option("--normal", "-n", help="Lamella normal X,Y,Z in the mesh frame (axial; +Z face-up, -Y front), or a recommend-orientation --json file; default 0,0,1.")] = None,
    tilt: Annotated[Optional[float], typer.Option("--tilt", help="Or the normal's tilt from the face-up axis, degrees (with --azimuth).")] = None,
    azimuth: Annotated[Optional[float], typer.Option("--azimuth", help="The normal's azimuth from +X (the stone's right) towards +Y, degrees (with --tilt).")] = None,
    mesh_options: Any = None,  # --units, --up-axis, --size (meshes.takes_mesh_options)
    material: Any = None,  # the material options (materials.takes_material)
    scenario: so.Scenario = None,
    lighting: so.Lighting = None,
    viewing: so.Viewing = None,
    view: Annotated[str, typer.Option(help="Camera: main (the scenario's main viewer), face-up, orbit, or TILT,AZIMUTH in degrees from the face.")] = "main",
    spp: Annotated[Optional[int], typer.Option(help="Samples per pixel (default 16 denoised, as the studio look is; 64 otherwise); not with --time-budget.", min=1)] = None,
    time_budget: Annotated[Optional[float], typer.Option(
        "--time-budget", metavar="SECONDS",
        help="Seconds the render may take: the most samples per pixel (a power of two) predicted to fit on this machine "
             "replace --spp; below 1 spp's prediction 1 spp runs, with a note.")] = None,
    resolution: Annotated[Optional[int], typer.Option(help="Image width and height in pixels (default 512; 320 for --animate).", min=8, max=8192)] = None,
    mode: Annotated[str, typer.Option(help="Colour transport: rgb, spectral or mono.")] = "rgb",
    polarizer: Annotated[Optional[float], typer.Option(help="Look through a linear polarizer at this angle (degrees).")] = None,
    zoning: Annotated[Optional[str], typer.Option(help="Colour zones: natural (the studio look's default: a real stone's zones), none (the clean model), smooth, sharp, or a zoning .json file (docs/zoning.md).")] = None,
    schiller_only: Annotated[bool, typer.Option("--schiller-only", help="Render only the schiller flash (no glare, no body).")] = False,
    look: lo.Look = "studio",
    denoise: lo.Denoise = None,
    animate: Annotated[Optional[str], typer.Option(help="Animate: rock (tilted ±30° in the hand) or turntable (a full turn, for carvings); writes .webp or .gif.")] = None,
    frames: Annotated[int, typer.Option(help="Frames of an animation.", min=2, max=360)] = 36,
    rock_deg: Annotated[float, typer.Option(help="Rocking amplitude of --animate rock, degrees.")] = 30.0,
    fps: Annotated[float, typer.Option(help="Frames per second of an animation.")] = 24.0,
    seed: Annotated[int, typer.Option(help="Seed of the studio body's inclusions and of the sampler.")] = 0,
    exposure: lo.Exposure = "reference",
    flash_mask: Annotated[Optional[Path], typer.Option(
        "--flash-mask", metavar="PNG",
        help="Also write the picture with the pixels that flash marked (the metrics' threshold, tau 0.1, from the same "
             "camera); their share of the stone is reported beside the estimator's flash area of the view.")] = None,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the render plan and timing as JSON ('-' for stdout).")] = None,
    yes: Annotated[bool, Yes] = False,
    plan: po.Plan = False,
    plan_only: po.PlanOnly = False,
) -> None:
    """Render MESH cut from labradorite with its lamella plane normal to --normal (or at --tilt and --azimuth).

    Shows the stone as the scenario's main viewer sees it, under the scenario's lights.
    Simulates only what the request needs: RGB unless --mode spectral/mono, polarized
    only with --polarizer, direct lighting for convex stones, a path tracer for carvings.
    """
    from labcut.commands import render_checked
    from labcut.scene import normalize_normal
    from labcut.rendering import LOBES, Motion, RenderRequest
    from labcut.rendering import IMAGE_SUFFIXES

    from .progress import progress_bar

    from labcut.errors import ParameterError

    move = None
    if animate is not None:
        move = _option_error(lambda: Motion.build(animate, frames, rock_deg, fps))
        if output.suffix.lower() not in ANIMATION_SUFFIXES:
            raise ParameterError(f"an animation is written as .webp or .gif, not {output.name!r}")
        if view != "main" or polarizer is not None or mode != "rgb" or schiller_only:
            raise ParameterError("--animate renders the scenario's main view in rgb: leave out --view, --polarizer, --mode and --schiller-only")
        if time_budget is not None:
            raise ParameterError("--time-budget chooses the samples per pixel of one image: give --spp for an animation")
        if flash_mask is not None:
            raise ParameterError("--flash-mask marks the flash of one picture: leave it out of an animation")
    elif output.suffix.lower() in ANIMATION_SUFFIXES:
        raise ParameterError(f"{output.name!r} is an animation file: add --animate rock or --animate turntable")
    resolution = resolution or (ANIMATION_RESOLUTION if animate else STILL_RESOLUTION)
    check_outputs({"--output": (output, ANIMATION_SUFFIXES if animate else IMAGE_SUFFIXES), "--json": (json_path, (".json",)),
                   "--flash-mask": (flash_mask, (".png",))}, ctx)
    if tilt is None and azimuth is None:  # a vector, or a recommendation's JSON file
        lamella = normalize_normal(parse_normal("0,0,1" if normal is None else normal))
    else:  # the angles evaluate-orientation and recommend-orientation print
        lamella = normal_or_angles(normal, tilt, azimuth, ("--normal", "--tilt", "--azimuth"))
    zoning_spec = "auto" if zoning is None else m.build_zoning(zoning, material)
    view_spec: str | tuple[float, float] = view
    if "," in view:
        view_spec = parse_vector(view, "--view", length=2)  # type: ignore[assignment]
    scene = so.resolve(scenario, lighting, viewing)
    # the whole request, checked once (RenderRequest.build), before the mesh loads; the library takes it as it is
    setup = _option_error(lambda: RenderRequest.build(
        material, scene, view=view_spec, spp=spp, time_budget=time_budget, resolution=resolution, mode=mode,
        polarizer_deg=polarizer, lobes=("schiller",) if schiller_only else LOBES, seed=seed, zoning=zoning_spec,
        exposure=lo.parse_exposure(exposure), look=lo.spec(look, seed), denoise=denoise))
    mesh = mesh_options.load(mesh_path)
    if plan or plan_only:
        from labcut.planner import plan_effects

        the_plan = plan_effects(mesh, material, command="render", scenario=scene, mode=None if mode == "rgb" else mode,
                                polarizer_deg=polarizer, zoning=setup.zoning, resolution=resolution, spp=setup.spp,
                                views=len(setup.cameras), look=setup.look)
        po.show(the_plan, mesh_path.name, to_stderr=json_path == "-")
        if plan_only:
            po.finish_plan_only(the_plan, json_path)
            return
    preview = interruptibly(before_rendering, mesh, setup, lamella, move, yes, quiet=json_path == "-")
    if move is not None:
        _animate(mesh_path, mesh, lamella, setup, move, output, json_path)
        return
    with notes_after(), progress_bar("rendering", "samples/pixel") as update:
        result = interruptibly(render_checked, mesh, setup, lamella, progress=update, flash_mask=flash_mask is not None,
                               flash=preview)
    summary = {
        "output": str(output),
        "mesh": {**result.mesh, "path": str(mesh_path)},
        "normal": [float(x) for x in lamella],
        "material": material.to_dict(),
        "scenario": result.scenario,
        "plan": result.plan.to_dict(),
        "spp": result.spp,
        "time_budget": result.budget or None,
        "resolution": resolution,
        "seconds": result.seconds,
        "samples_per_second": result.samples_per_second,
        "views": result.views,
        "look": result.look,
        "denoised": result.plan.denoise,
        **(lo.exposure_json(result) if output.suffix.lower() == ".png" else
           {"exposure": None, "exposure_ev": None, "exposure_mode": "linear (EXR: no exposure applied)"}),
        "exposure_metering": result.exposure_metering,
        "tonemap": result.tonemap,
        "studio": result.studio,
        "flash_by_view": result.flash,
        "notes": result.notes,
    }
    if flash_mask is not None:
        summary["flash_mask"] = {"path": str(flash_mask), **result.flash_mask.to_dict()}
    if _write(result, output, summary, json_path, setup.zoning, flash_mask):
        return
    mo.print_provenance(mesh, mesh_path.name)
    console.print(f"[bold]{output}[/]: {'; '.join(result.plan.reasons)}")
    print_render_notes(result)
    exposure_text = lo.exposure_line(result) if output.suffix.lower() == ".png" else "linear HDR, no exposure"
    console.print(f"{result.spp} spp at {resolution}², {result.seconds:.1f} s ({result.samples_per_second / 1e6:.2f} Msamples/s); "
                  f"{exposure_text}")
    if flash_mask is not None:
        console.print(lo.flash_mask_line(result, flash_mask), highlight=False)
    if result.budget:
        console.print(f"time budget {result.budget['budget_seconds']:g} s: {result.spp} spp (predicted "
                      f"{result.budget['predicted_seconds']:.2f} s, took {result.seconds:.2f} s)", highlight=False)


def _write(made: Any, output: Path, summary: dict[str, Any], json_path: Optional[str], zoning_spec: Any,
           flash_mask: Optional[Path] = None) -> bool:
    """Save a render or an animation (and a render's flash mask) and its JSON summary, all or
    nothing; True when the JSON went to stdout (then nothing else is printed)."""
    import json

    if zoning_spec is not None:
        summary["zoning"] = zoning_spec.to_dict()
    with all_or_nothing() as written:
        made.save(output)
        written.append(Path(output))
        if flash_mask is not None:
            made.save_flash_mask(flash_mask)
            written.append(Path(flash_mask))
        if json_path == "-":
            typer.echo(json.dumps(summary, indent=2))
            return True
        if json_path is not None:
            write_json(json_path, summary)
    return False


#: what a library parameter is called on this command line, for its one-line errors
_OPTION_NAMES = {"spp": "--spp", "resolution": "--resolution", "mode": "--mode", "polarizer angle": "--polarizer",
                 "time budget": "--time-budget", "seed": "--seed", "frames": "--frames", "rock amplitude": "--rock-deg",
                 "fps": "--fps", "motion": "--animate", "exposure": "--exposure", "lobes": "--schiller-only",
                 "spp or time budget": "--spp or --time-budget"}


def _option_error(build: Any) -> Any:
    """``build()``, a ParameterError's library parameter name replaced by the option's."""
    from labcut.errors import ParameterError

    try:
        return build()
    except ParameterError as exc:
        raise exc.renamed(_OPTION_NAMES) from None


def _animate(mesh_path: Path, mesh, lamella, setup, move, output: Path, json_path: Optional[str]) -> None:
    """``labcut render --animate``: every frame under one exposure, the file written once all are done."""
    import labcut
    from labcut import animate

    from .progress import progress_bar

    with progress_bar(f"{move.motion} animation", "frames") as update:
        anim = interruptibly(animate, mesh, lamella_normal=lamella, motion=move, setup=setup, progress=update)
    motion = move.motion
    summary = {
        "output": str(output),
        "mesh": {**labcut.Stone.of(mesh).provenance_dict(), "path": str(mesh_path)},
        "normal": [float(x) for x in lamella],
        "material": setup.material.to_dict(),
        "scenario": setup.scenario.to_dict(),
        "plan": anim.plan.to_dict(),
        "animation": {"motion": motion, "frames": len(anim.frames), "angles_deg": anim.angles_deg, "fps": anim.fps},
        "spp": anim.spp,
        "resolution": setup.resolution,
        "seconds": anim.seconds,
        "look": anim.look,
        **lo.exposure_json(anim),
        "tonemap": anim.tonemap,
        "studio": anim.studio,
        "notes": anim.notes,
    }
    if _write(anim, output, summary, json_path, setup.zoning):
        return
    console.print(f"[bold]{output}[/]: {len(anim.frames)} frames of {motion}, {'; '.join(anim.plan.reasons)}")
    print_render_notes(anim)
    console.print(f"{anim.spp} spp at {setup.resolution}², {anim.seconds:.1f} s; every frame: {lo.exposure_line(anim)}")
