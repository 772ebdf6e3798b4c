"""Animations: the stone rocked in the hand, or a turntable, as an animated WebP or GIF.

* ``rock``: the stone tilted front-to-back about the world X axis (the viewer's left-right
  line) by ``amplitude_deg · sin(2π k / frames)`` (default ±30°, as a cutter rocks a stone under
  the lamp), the lamps, tent and camera fixed in the world: the flash comes and goes as it does
  in the hand. The table tilts with the stone (a stone on a tray).
* ``turntable``: a full turn about the world vertical, for carvings.

Every frame is a :func:`~labcut.rendering.api.render` of the scenario with its pose turned
(``Scenario.pose``), in the studio look by default, tonemapped with **one** exposure: the one
given, or the rest pose's automatic one, so brightness changes between frames are real. The file
is written atomically once every frame is done: Ctrl-C leaves no partial file.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene import Scenario, resolve_scene
from ..scene.directions import rotation

MOTIONS = ("rock", "turntable")
ANIMATION_SUFFIXES = (".webp", ".gif")
FRAME_LIMITS = (2, 360)


@dataclass
class Animation:
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

    @property
    def exposure_ev(self) -> float:
        return float(math.log2(self.exposure))

    def save(self, path: str | Path) -> Path:
        """Write an animated WebP (quality 90) or GIF, atomically (by suffix)."""
        return write_animation(self.frames, path, self.exposure, self.fps, self.tonemap)


def frame_angles(motion: str, frames: int, amplitude_deg: float = 30.0) -> list[float]:
    """The angle of each frame (degrees): a sine rock of ±``amplitude_deg`` or a full turn."""
    if motion not in MOTIONS:
        raise ParameterError(f"motion must be one of {', '.join(MOTIONS)}, got {motion!r}")
    if isinstance(frames, bool) or not (isinstance(frames, int | np.integer) and FRAME_LIMITS[0] <= frames <= FRAME_LIMITS[1]):
        raise ParameterError(f"frames must be a whole number in [{FRAME_LIMITS[0]}, {FRAME_LIMITS[1]}], got {frames!r}")
    if not (isinstance(amplitude_deg, int | float) and math.isfinite(amplitude_deg) and 0.0 < amplitude_deg <= 60.0):
        raise ParameterError(f"rock amplitude must lie in (0, 60] degrees, got {amplitude_deg!r}")
    k = np.arange(int(frames))
    if motion == "rock":
        return [float(a) for a in amplitude_deg * np.sin(2.0 * math.pi * k / frames)]
    return [float(a) for a in 360.0 * k / frames]


def posed(scenario: Scenario, motion: str, angle_deg: float) -> Scenario:
    """The scenario with its stone turned by ``angle_deg``: about world X (rock) or world Z (turntable)."""
    axis = [1.0, 0.0, 0.0] if motion == "rock" else [0.0, 0.0, 1.0]
    return Scenario(scenario.name, rotation(axis, angle_deg) @ scenario.pose, scenario.lights, scenario.views,
                    0.0, 0.0, scenario.description, scenario.quality)


def animate(
    mesh: Any,
    material: Any,
    lamella_normal: Any = (0.0, 0.0, 1.0),
    *,
    motion: str = "rock",
    frames: int = 36,
    amplitude_deg: float = 30.0,
    scenario: Any = None,
    lighting: Any = None,
    viewing: Any = None,
    spp: int = 16,
    resolution: int = 320,
    exposure: float | None = None,
    look: Any = "studio",
    denoise: bool | None = None,
    zoning: Any = None,
    fps: float = 24.0,
    seed: int = 0,
    output: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Animation:
    """Render ``frames`` frames of ``motion`` (``rock`` | ``turntable``) under the scenario's lights
    from its main view (see the module docstring) and optionally write them to ``output``
    (.webp or .gif). ``progress(done_frames, frames)`` is called after each frame. ``exposure``:
    a multiplier for every frame (None: the rest pose's automatic exposure, reused for all)."""
    from .api import render
    from .tonemap import check_exposure

    angles = frame_angles(motion, frames, amplitude_deg)
    if exposure is not None:
        check_exposure(exposure)
    if not (isinstance(fps, int | float) and math.isfinite(fps) and 1.0 <= fps <= 60.0):
        raise ParameterError(f"fps must lie in [1, 60], got {fps!r}")
    if output is not None:
        from ..fileio import check_output_path

        check_output_path(output, ANIMATION_SUFFIXES)
    base = resolve_scene(scenario, lighting, viewing)
    if zoning is not None:
        from .zoning import resolve as _resolve_zoning

        zoning = _resolve_zoning(zoning, material)
    images: list[np.ndarray] = []
    plan = None
    used = exposure
    mode = "given" if exposure is not None else "auto"
    tone, look_name, notes, studio = "agx", "studio", [], {}
    start = time.perf_counter()
    for i, angle in enumerate(angles):
        result = render(mesh, material, lamella_normal, scenario=posed(base, motion, angle), spp=spp, resolution=resolution,
                        exposure=used, look=look, denoise=denoise, zoning=zoning, seed=seed, check_flash=(i == 0))
        if used is None:
            used = result.exposure  # the rest pose's (frame 0: angle 0) automatic exposure, for every frame
        if i == 0:
            plan, tone, look_name, notes, studio = result.plan, result.tonemap, result.look, result.notes, result.studio
        images.append(result.image)
        if progress is not None:
            progress(i + 1, len(angles))
    assert used is not None
    anim = Animation(images, motion, angles, float(used), mode, tone, plan, int(spp), time.perf_counter() - start,
                     float(fps), look_name, notes, studio)
    if output is not None:
        anim.save(output)
    return anim


def write_animation(frames: list[np.ndarray], path: str | Path, exposure: float, fps: float = 24.0, curve: str = "agx") -> Path:
    """Tonemap linear frames with one exposure and write them as an animated WebP or
    GIF (one shared 256-colour palette), atomically. WebP: lossy at quality 90 (a tenth of the lossless size)."""
    from PIL import Image

    from ..fileio import atomic_output
    from .images import to_uint8

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
