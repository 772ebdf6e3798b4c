"""Animations: the stone rocked in the hand, or a turntable, as an animated WebP or GIF.

* ``rock``: the stone tilted front-to-back about the world X axis (the viewer's left-right
  line) by ``amplitude_deg · sin(2π k / frames)`` (default ±30°, as a cutter rocks a stone under
  the lamp), the lamps, tent and camera fixed in the world: the flash comes and goes as it does
  in the hand. The table tilts with the stone (a stone on a tray).
* ``turntable``: a full turn about the world vertical, for carvings.

Every frame is a :func:`~labcut.commands.render.render` of the scenario with its pose turned
(``Scenario.pose``), in the studio look by default, tonemapped with **one** exposure: the one
given, or the rest pose's automatic one, so brightness changes between frames are real. The file
is written atomically once every frame is done: Ctrl-C leaves no partial file.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..geometry.stone import mesh_of
from ..scene import Scenario
from ..scene.directions import rotation

from ..rendering.exposure import Exposed
from ..rendering.request import FRAME_LIMITS, MOTIONS, Motion, RenderRequest  # noqa: F401  (re-exported)

ANIMATION_SUFFIXES = (".webp", ".gif")


@dataclass
class Animation(Exposed):
    """Frames of an animation (linear RGB, float32) and how they were made: the motion, the
    angle of each frame (degrees), the one exposure they are tonemapped with, the tone curve,
    render plan and timing."""

    frames: list[np.ndarray]
    motion: str
    angles_deg: list[float]
    exposure: float
    exposure_mode: str
    tonemap: str
    plan: Any
    spp: int
    seconds: float
    fps: float
    look: str
    notes: list[str] = field(default_factory=list)
    studio: dict[str, Any] = field(default_factory=dict)
    #: the look's reference exposure (:func:`labcut.rendering.exposure.reference_exposure`)
    exposure_reference: float = 1.0

    def save(self, path: str | Path) -> Path:
        """Write an animated WebP (quality 90) or GIF, atomically (by suffix)."""
        return write_animation(self.frames, path, self.exposure, self.fps, self.tonemap)


def frame_angles(motion: str, frames: int, amplitude_deg: float = 30.0) -> list[float]:
    """The angle of each frame (degrees): a sine rock of ±``amplitude_deg`` or a full turn
    (:class:`~labcut.rendering.request.Motion`)."""
    return Motion.build(motion, frames, amplitude_deg).angles_deg


def posed(scenario: Scenario, motion: str, angle_deg: float) -> Scenario:
    """The scenario with its stone turned by ``angle_deg``: about world X (rock) or world Z (turntable)."""
    axis = [1.0, 0.0, 0.0] if motion == "rock" else [0.0, 0.0, 1.0]
    return Scenario(scenario.name, rotation(axis, angle_deg) @ scenario.pose, scenario.lights, scenario.views,
                    0.0, 0.0, scenario.description, scenario.quality)


#: the render and motion arguments of :func:`animate` and their defaults (with ``setup=`` / a
#: :class:`Motion` they stay at these)
_ANIMATION_DEFAULTS: dict[str, Any] = {
    "material": None, "scenario": None, "lighting": None, "viewing": None, "spp": 16, "resolution": 320,
    "exposure": "reference", "look": "studio", "denoise": None, "zoning": "auto", "seed": 0, "frames": 36,
    "amplitude_deg": 30.0, "fps": 24.0,
}


def animate(
    mesh: Any,
    material: Any = None,
    lamella_normal: Any = (0.0, 0.0, 1.0),
    *,
    motion: str | Motion = "rock",
    frames: int = 36,
    amplitude_deg: float = 30.0,
    setup: RenderRequest | None = None,
    scenario: Any = None,
    lighting: Any = None,
    viewing: Any = None,
    spp: int = 16,
    resolution: int = 320,
    exposure: float | str | None = "reference",
    look: Any = "studio",
    denoise: bool | None = None,
    zoning: Any = "auto",
    fps: float = 24.0,
    seed: int = 0,
    output: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Animation:
    """Render ``frames`` frames of ``motion`` (``rock`` | ``turntable``) under the scenario's lights
    from its main view (see the module docstring) and optionally write them to ``output``
    (.webp or .gif). ``progress(done_frames, frames)`` is called after each frame. ``exposure``:
    for every frame: ``"reference"`` (default: the look's, as every render), ``"auto"`` (the rest
    pose's automatic exposure, reused for all) or a multiplier.

    ``motion`` may be a validated :class:`~labcut.rendering.request.Motion` (then ``frames``,
    ``amplitude_deg`` and ``fps`` are its own), and ``setup`` a validated
    :class:`~labcut.rendering.request.RenderRequest` of the rest pose (then ``material`` and the render
    arguments stay at their defaults): what the CLI passes, checked once."""
    mesh = mesh_of(mesh)  # a Stone or a trimesh
    from ..validation import given_besides
    from .render import render_checked

    asked = {"material": material, "scenario": scenario, "lighting": lighting, "viewing": viewing, "spp": spp,
             "resolution": resolution, "exposure": exposure, "look": look, "denoise": denoise, "zoning": zoning, "seed": seed}
    if isinstance(motion, Motion):
        given_besides({"frames": frames, "amplitude_deg": amplitude_deg, "fps": fps}, _ANIMATION_DEFAULTS,
                      "motion= is a Motion that holds its frames, amplitude and fps")
        move = motion
    else:
        move = Motion.build(motion, frames, amplitude_deg, fps)
    if setup is None:
        setup = RenderRequest.build(asked.pop("material"), asked.pop("scenario"), asked.pop("lighting"), asked.pop("viewing"),
                                  **asked)
    elif not isinstance(setup, RenderRequest):
        raise ParameterError(f"setup must be a labcut RenderRequest (RenderRequest.build(...)), got {type(setup).__name__}")
    else:
        given_besides(asked, _ANIMATION_DEFAULTS, "setup= already holds the render request")
    if output is not None:
        from ..fileio import check_output_path

        check_output_path(output, ANIMATION_SUFFIXES)
    from ..geometry.meshio import validate_mesh
    from ..scene.directions import normalize_normal

    validate_mesh(mesh)
    normal = normalize_normal(lamella_normal)
    angles = move.angles_deg
    images: list[np.ndarray] = []
    plan = None
    used: float | str = setup.exposure  # "reference", "auto" or a multiplier
    mode = used if isinstance(used, str) else "given"
    reference = 1.0
    tone, look_name, notes, studio = "agx", "studio", [], {}
    start = time.perf_counter()
    for i, angle in enumerate(angles):
        frame = setup.replace(scenario=posed(setup.scenario, move.motion, angle), exposure=used)
        result = render_checked(mesh, frame, normal, check_flash=(i == 0))
        if i == 0:  # the rest pose's (frame 0: angle 0) exposure, for every frame
            used, reference = result.exposure, result.exposure_reference
            plan, tone, look_name, notes, studio = result.plan, result.tonemap, result.look, result.notes, result.studio
        images.append(result.image)
        if progress is not None:
            progress(i + 1, len(angles))
    anim = Animation(images, move.motion, angles, float(used), mode, tone, plan, int(setup.spp), time.perf_counter() - start,
                     float(move.fps), look_name, notes, studio, reference)
    if output is not None:
        anim.save(output)
    return anim


def write_animation(frames: list[np.ndarray], path: str | Path, exposure: float, fps: float = 24.0, curve: str = "agx") -> Path:
    """Tonemap linear frames with one exposure and write them as an animated WebP or
    GIF (one shared 256-colour palette), atomically. WebP: lossy at quality 90 (a tenth of the lossless size)."""
    from PIL import Image

    from ..fileio import atomic_output
    from ..rendering.images import to_uint8

    if not frames:
        raise ParameterError("an animation needs at least one frame")
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise ParameterError(f"animation file {out.name!r} must end in .webp or .gif")
    pictures = [Image.fromarray(to_uint8(f, exposure, curve), "RGB") for f in frames]
    duration = int(round(1000.0 / fps))
    with atomic_output(out, ANIMATION_SUFFIXES) as tmp:
        if suffix == ".webp":
            pictures[0].save(tmp, format="WEBP", save_all=True, append_images=pictures[1:], duration=duration, loop=0,
                             lossless=False, quality=90, method=4)
        else:
            sheet = Image.fromarray(np.concatenate([np.asarray(p) for p in pictures], axis=0), "RGB")
            palette = sheet.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
            quantised = [p.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG) for p in pictures]
            quantised[0].save(tmp, format="GIF", save_all=True, append_images=quantised[1:], duration=duration, loop=0,
                              disposal=1, optimize=False)
    return out
