"""``labcut.render``: a render of a stone, as a command: check the request, choose the samples
per pixel (a time budget's choice), record the effect plan, render (:func:`labcut.rendering.api.render_image`).

The rendering itself (the plan of variant, integrator, depth and lobes; the Mitsuba scene; the
passes, the denoiser, the exposure) is :mod:`labcut.rendering.api`'s; this layer adds what asks
the planner: the budget (:func:`labcut.commands.render_budget.choose_spp`) and the effect plan's record
(:func:`labcut.planner.plan_effects`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import LabcutWarning
from ..geometry.meshio import validate_mesh
from ..geometry.stone import mesh_of
from ..physics.material import Labradorite
from ..orientation.flash_check import flash_by_view, flash_notes
from ..orientation.flash_mask import flash_mask as flash_mask_of
from ..planner import plan_effects
from ..rendering.api import LOBES, RenderResult, camera_framing, plan_for, render_image, render_question
from .render_budget import choose_spp
from ..rendering.scene import CameraView
from ..scene import Scenario
from ..scene.directions import normalize_normal


def render(
    mesh: Any,
    material: Labradorite | str | None = None,
    lamella_normal: Any = (0.0, 0.0, 1.0),
    *,
    setup: Any = None,
    scenario: str | Scenario | None = None,
    lighting: Any = None,
    viewing: Any = None,
    view: str | CameraView | tuple[float, float] = "main",
    spp: int | None = None,
    resolution: int = 512,
    mode: str = "rgb",
    polarizer_deg: float | None = None,
    lobes: Sequence[str] = LOBES,
    max_depth: int | None = None,
    perspective: bool = False,
    seed: int = 0,
    output: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
    zoning: Any = "auto",
    exposure: float | str | None = "reference",
    check_flash: bool = True,
    flash_mask: bool = False,
    look: Any = "diagram",
    denoise: bool | None = None,
    time_budget: float | None = None,
) -> RenderResult:
    """Render ``mesh`` (mm, +Z face-up) cut from ``material`` with lamellae normal to ``lamella_normal``.

    Parameters
    ----------
    setup: the whole request at once, validated (:meth:`RenderRequest.build
        <labcut.rendering.request.RenderRequest.build>`, what the CLI passes); then ``material`` and
        the request's arguments below stay at their defaults (``lamella_normal``, ``output``,
        ``progress`` and ``check_flash`` are not part of it).
    scenario: how the stone is lit, worn and seen (default ``bench``): a name, a JSON file or a
        :class:`~labcut.Scenario`. The render shows its rest pose under its own lights.
    lighting, viewing: replace the scenario's lights / viewers, as in
        :func:`labcut.recommend_orientation` (presets of :data:`labcut.scene.LIGHTING` and
        :data:`labcut.scene.VIEWING`, files, an .exr/.hdr map, ``Lights``/``Views``).
    view: the camera: ``main`` (the scenario's main viewer) | ``face-up`` | ``orbit`` (8 views tiled
        4 x 2) | (tilt°, azimuth°) in the mesh frame.
    spp: samples per pixel (>= 1; default 16 for a denoised render, the studio look's default, else 64); rendered in passes so ``progress(done, total)`` can report.
    time_budget: seconds the render may take: the most samples per pixel (a power of two) predicted
        to fit on this machine replace ``spp`` (:mod:`labcut.commands.render_budget`; below 1 spp's
        prediction 1 spp runs with a one-line :class:`~labcut.errors.LabcutWarning`); the choice
        is in ``RenderResult.budget``.
    mode: ``rgb`` | ``mono`` | ``spectral``; ``polarizer_deg`` renders polarized and returns the
        intensity through an ideal linear polarizer at that angle (0° = transmission axis along
        the image's horizontal).
    output: optional .png / .exr path written atomically.
    zoning: ``"auto"`` (default: the ``natural`` preset in the studio look, seeded by ``seed``, as a
        real stone shows zones of colour and brightness; none in the diagram look) | ``None`` or
        ``"none"`` (the clean model) | ``"smooth"`` | ``"sharp"`` | ``"natural"`` | a
        :class:`~labcut.rendering.zoning.Zoning`: colour zones, lamella parameters blended through
        the stone by a noise field (paper §3.2.2; docs/zoning.md). Presets are built on ``material``.
    exposure: the PNG exposure (:mod:`labcut.rendering.exposure`): ``"reference"`` (default; None
        too) tonemaps every render of a look with one exposure, the bench scenario's metered from
        its lamps, so a dimmer scene looks dimmer and renders of a series compare; ``"auto"``
        brightens to the scene (studio look: metered from its lights, as an incident-light meter
        would; diagram look: from the whole image, the tiles of an orbit sharing it) and the
        result says by how many stops (:attr:`RenderResult.exposure_vs_reference_ev`); a
        multiplier > 0 is used as given. Recorded on the result and in the PNG.
    look: ``"diagram"`` (default) or ``"studio"`` / a :class:`~labcut.rendering.studio.Studio`: a
        photograph of the stone on a table under the scenario's lamps (module docstring).
    denoise: None (default: on in the studio look for rgb/spectral colour), True or False: OIDN
        demodulated by a noise-free shading guide, with the normal (:mod:`labcut.rendering.denoise`).
    flash_mask: also render which pixels flash by the metrics' threshold (``tau`` 0.1, the lights
        as the metrics model them, the render's cameras and framing): ``RenderResult.flash_mask``
        (:class:`~labcut.orientation.flash_mask.FlashMask`; its share of the stone's pixels is the
        view's flash area as a render sees it), drawn over the picture by
        :meth:`RenderResult.save_flash_mask`.
    check_flash: estimate, per camera, whether any part of the stone flashes from there (the
        surface-sample estimator at draft quality, the material without zoning); a view with
        none gets a note (:attr:`RenderResult.notes`): an auto-exposed image of glare and body
        colour looks like a stone, not like a stone that does not flash.

    Returns a :class:`RenderResult` whose ``image`` is linear RGB float32 and ``plan`` says
    what was simulated.

    Raises :class:`~labcut.errors.MeshError` for a mesh that is not a closed, finite solid
    (:func:`labcut.geometry.meshio.validate_mesh`) and :class:`~labcut.errors.ParameterError`
    for bad parameters.
    """
    mesh = mesh_of(mesh)  # a Stone or a trimesh
    validate_mesh(mesh)
    ask = render_question(setup, material=material, scenario=scenario, lighting=lighting, viewing=viewing, view=view,
                          spp=spp, resolution=resolution, mode=mode, polarizer_deg=polarizer_deg, lobes=lobes,
                          max_depth=max_depth, perspective=perspective, seed=seed, zoning=zoning, exposure=exposure,
                          look=look, denoise=denoise, time_budget=time_budget)
    normal = normalize_normal(lamella_normal)
    if output is not None:
        from ..fileio import check_output_path

        check_output_path(output, (".png", ".exr"))
    result = render_checked(mesh, ask, normal, progress=progress, check_flash=check_flash, flash_mask=flash_mask)
    if output is not None:
        result.save(output)
    return result


def render_checked(mesh: Any, ask: Any, normal: np.ndarray, *, progress: Callable[[int, int], None] | None = None,
                 check_flash: bool = True, flash_mask: bool = False,
                 flash: list[dict[str, Any]] | None = None) -> RenderResult:
    """:func:`render` of a checked mesh, :class:`~labcut.rendering.request.RenderRequest` ``ask`` and
    unit lamella ``normal`` (checks nothing again); the result is not saved. ``flash``: each
    camera's flash as :func:`~labcut.orientation.flash_check.flash_by_view` gives it, when the
    caller already estimated it (before rendering), so it is not estimated again."""
    rplan = plan_for(mesh, ask)
    spp = ask.spp
    budget = None
    views = len(ask.cameras)
    if ask.time_budget is not None:
        budget = choose_spp(ask.time_budget, mode=ask.mode, polarised=ask.polarizer_deg is not None,
                            integrator=rplan.integrator, resolution=ask.resolution, views=views, look=rplan.look)
        if budget.note:
            warnings.warn(budget.note, LabcutWarning, stacklevel=3)
        spp = budget.spp
    effects = plan_effects(mesh, ask.material, command="render", scenario=ask.scenario,
                           mode=None if ask.mode == "rgb" else ask.mode, polarizer_deg=ask.polarizer_deg,
                           zoning=ask.zoning, max_depth=ask.max_depth, resolution=ask.resolution, spp=int(spp),
                           views=views, look=rplan.look,
                           predict=False).to_dict()  # what the render did; --plan predicts beforehand
    result = render_image(mesh, ask, normal, int(spp), progress=progress, effects=effects, budget=budget)
    if flash is not None:
        result.flash, result.notes = list(flash), flash_notes(flash)
    elif check_flash:
        result.flash, result.notes = flash_by_view(mesh, ask.material, normal, ask.scenario.main_setting(), ask.cameras)
    if flash_mask:
        result.flash_mask = mask_of_render(mesh, ask, normal)
    return result


def mask_of_render(mesh: Any, ask: Any, normal: np.ndarray) -> Any:
    """The :class:`~labcut.orientation.flash_mask.FlashMask` of a render request: its cameras,
    resolution and framing (the studio look's perspective camera, or the diagram's), the rest
    pose's lights as the metrics model them."""
    return flash_mask_of(mesh, ask.material, normal, ask.scenario.main_setting(), ask.cameras, ask.resolution,
                         **camera_framing(ask))
