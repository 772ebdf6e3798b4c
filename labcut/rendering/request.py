"""One frozen, validated description of how to render a stone: :class:`RenderRequest`.

Everything but the stone and the lamella normal that decides a :func:`labcut.render`: the
material, the scenario (its rest pose's lights and main viewer, mesh frame), the cameras, the
samples per pixel or a time budget, resolution (px), colour mode, polarizer angle (degrees),
lobes, path depth, look (:class:`~labcut.rendering.studio.Studio` or the diagram look),
denoising, colour zoning, exposure (``reference``, ``auto`` or a multiplier) and the sampler seed.
:meth:`RenderRequest.build` is the one place these are checked: the CLI builds a setup once, before
the mesh is read, and hands it to :func:`labcut.render` / :func:`labcut.commands.animate.animate`,
which do not check again. :class:`Motion` does the same for an animation's motion.

The lamella normal stays out of the setup: ``recommend-orientation --render`` builds its render
setup before the answer (the normal) exists. The parts of the render plan that depend on the
mesh (convex: direct lighting; a carving: a path tracer) are decided per mesh by
:func:`labcut.rendering.plan.plan_render`; every check that does not depend on it runs here.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from ..errors import ParameterError
from ..physics.material import Labradorite
from ..scene import Scenario, resolve_scene
from ..validation import check_number
from .plan import LOBES
from .scene import CameraView, camera_views
from .zoning import Zoning

MODES = ("rgb", "spectral", "mono")
#: the samples per pixel when neither ``spp`` nor a time budget is given
DEFAULT_SPP = 64
#: ... and of a denoised render (the studio look's default): OIDN, guided by a noise-free shading
#: estimate, makes 16 samples look like 64 raw ones and better (docs/render-performance.md)
DENOISED_SPP = 16


def presentation(studio: Any, polarizer_deg: float | None, mode: str) -> bool:
    """Whether a render is a picture to show, not a measurement: the studio look, in colour, without
    a polarizer. Such a render is denoised and shows the natural colour zones by default."""
    return studio is not None and polarizer_deg is None and mode != "mono"


@dataclass(frozen=True)
class RenderRequest:
    """A validated render request (module docstring); build it with :meth:`build`."""

    material: Labradorite
    scenario: Scenario
    cameras: tuple[CameraView, ...]
    spp: int = DEFAULT_SPP
    resolution: int = 512
    mode: str = "rgb"
    polarizer_deg: float | None = None
    lobes: tuple[str, ...] = LOBES
    max_depth: int | None = None
    perspective: bool = False
    seed: int = 0
    #: colour zones (a :class:`~labcut.rendering.zoning.Zoning`), or None for a uniform material
    zoning: Any = None
    #: the PNG exposure: ``"reference"`` (the bench's, one for every scene), ``"auto"`` (brightened to
    #: the scene) or a multiplier (:mod:`labcut.rendering.exposure`)
    exposure: float | str = "reference"
    #: a :class:`~labcut.rendering.studio.Studio`, or None: the diagram look
    studio: Any = None
    denoise: bool | None = None
    #: seconds the render may take (the samples per pixel are then chosen per mesh), or None
    time_budget: float | None = None
    #: the ``view`` as asked (a name, (tilt°, azimuth°) or a CameraView), for the record
    view: Any = field(default="main", compare=False)

    @classmethod
    def build(
        cls,
        material: Labradorite | str | None = None,
        scenario: str | Scenario | None = None,
        lighting: Any = None,
        viewing: Any = None,
        *,
        view: str | CameraView | tuple[float, float] = "main",
        spp: int | None = None,
        time_budget: float | None = None,
        resolution: int = 512,
        mode: str = "rgb",
        polarizer_deg: float | None = None,
        lobes: Any = LOBES,
        max_depth: int | None = None,
        perspective: bool = False,
        seed: int = 0,
        zoning: Any = "auto",
        exposure: float | str | None = "reference",
        look: Any = "diagram",
        denoise: bool | None = None,
    ) -> RenderRequest:
        """Check every argument once and return the setup; arguments as :func:`labcut.render`
        (``spp`` None: 64, 16 for a denoised render, or chosen by ``time_budget``; both at once
        is an error). Raises a
        one-line :class:`~labcut.errors.ParameterError` naming the first bad one.

        Examples
        --------
        >>> from labcut.rendering.request import RenderRequest
        >>> s = RenderRequest.build("blue", "ring", look="studio", spp=16, resolution=128)
        >>> s.scenario.name, s.spp, s.look, s.plan_denoise
        ('ring', 16, 'studio', True)
        >>> RenderRequest.build(look="studio").spp, RenderRequest.build(look="studio", denoise=False).spp
        (16, 64)
        >>> RenderRequest.build(mode="mono", denoise=True)
        Traceback (most recent call last):
        ...
        labcut.errors.ParameterError: denoising needs rgb or spectral colour without a polarizer
        """
        from .plan import plan_render
        from .studio import resolve_look

        material = Labradorite.coerce(material)
        if not isinstance(mode, str) or mode not in MODES:
            raise ParameterError(f"mode must be one of {', '.join(MODES)}, got {mode!r}", parameter="mode")
        if polarizer_deg is not None:
            polarizer_deg = check_number(polarizer_deg, "polarizer angle", unit="degrees")
        if time_budget is not None:
            from ..validation import check_budget

            time_budget = check_budget(time_budget)
            if spp is not None:
                raise ParameterError("spp or time budget: give one, not both (the budget chooses the samples per pixel)",
                                     parameter="spp or time budget")
        elif spp is not None:
            spp_v = check_number(spp, "spp", 1, 1 << 20, integer=True)
        res = check_number(resolution, "resolution", 8, 8192, integer=True, unit="pixels")
        if max_depth is not None:
            max_depth = check_number(max_depth, "max_depth", 1, 64, integer=True)
        seed_v = check_number(seed, "seed", 0, 2**31 - 1, integer=True)
        from .exposure import check_mode

        exposure = check_mode(exposure)
        studio = resolve_look(look)
        if denoise is not None and not isinstance(denoise, bool):
            raise ParameterError(f"denoise must be True, False or None, got {denoise!r}")
        lobes_t = tuple(lobes) if not isinstance(lobes, str) else (lobes,)
        plan_render(True, None, mode, polarizer_deg, lobes_t, max_depth, look=studio or "diagram",
                    denoise=denoise)  # mode, polarizer, lobes, look and denoise together
        shown = presentation(studio, polarizer_deg, mode)
        denoised = denoise if denoise is not None else shown
        if spp is None:
            spp_v = DENOISED_SPP if denoised else DEFAULT_SPP
        scene = resolve_scene(scenario, lighting, viewing)
        cameras = tuple(camera_views(view, scene.main_setting()))
        from .zoning import resolve as resolve_zoning

        if isinstance(zoning, str) and zoning.strip().lower() == "auto":
            # presentation renders show a real stone's zoning; the diagram look the clean model
            zoning = Zoning.preset("natural", material, seed=int(seed_v)) if shown else None
        zone = resolve_zoning(zoning, material)
        return cls(material, scene, cameras, int(spp_v), int(res), mode, polarizer_deg, lobes_t, max_depth,
                   bool(perspective), int(seed_v), zone, exposure, studio, denoise, time_budget, view)

    @property
    def look(self) -> str:
        """``studio`` or ``diagram``."""
        return "diagram" if self.studio is None else "studio"

    @property
    def look_spec(self) -> Any:
        """What :func:`~labcut.rendering.plan.plan_render` takes as ``look=``."""
        return self.studio if self.studio is not None else "diagram"

    @property
    def plan_denoise(self) -> bool:
        """Whether the render is denoised (the default: in the studio look, for rgb/spectral colour)."""
        if self.denoise is not None:
            return self.denoise
        return presentation(self.studio, self.polarizer_deg, self.mode)

    def replace(self, **changes: Any) -> RenderRequest:
        """The same setup with fields changed, for callers that already hold valid values (a
        scenario turned by an animation's pose, the spp a time budget chose)."""
        from dataclasses import replace

        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: what a render records of how it was asked."""
        return {
            "material": self.material.to_dict(), "scenario": self.scenario.to_dict(),
            "views": [c.name for c in self.cameras], "spp": self.spp, "time_budget": self.time_budget,
            "resolution": self.resolution, "mode": self.mode, "polarizer_deg": self.polarizer_deg,
            "lobes": list(self.lobes), "max_depth": self.max_depth, "perspective": self.perspective, "seed": self.seed,
            "zoning": None if self.zoning is None else (self.zoning.name or "custom"),
            "exposure": self.exposure, "look": self.look, "denoise": self.denoise,
        }

    def __repr__(self) -> str:
        budget = f", time_budget={self.time_budget:g} s" if self.time_budget is not None else f", spp={self.spp}"
        return (f"RenderRequest({self.material.name!r}, scenario={self.scenario.name!r}, {len(self.cameras)} view(s), "
                f"{self.resolution}² px{budget}, mode={self.mode!r}, look={self.look!r})")


MOTIONS = ("rock", "turntable")
FRAME_LIMITS = (2, 360)


@dataclass(frozen=True)
class Motion:
    """A validated animation motion: ``rock`` (tilted ±``amplitude_deg`` about the world X axis)
    or ``turntable`` (a full turn about the world vertical), ``frames`` frames at ``fps``."""

    motion: str = "rock"
    frames: int = 36
    amplitude_deg: float = 30.0
    fps: float = 24.0

    @classmethod
    def build(cls, motion: str = "rock", frames: int = 36, amplitude_deg: float = 30.0, fps: float = 24.0) -> Motion:
        """Check and return the motion (one-line :class:`~labcut.errors.ParameterError`).

        >>> Motion.build("turntable", frames=4).angles_deg
        [0.0, 90.0, 180.0, 270.0]
        """
        key = motion.strip().lower() if isinstance(motion, str) else motion
        if key not in MOTIONS:
            raise ParameterError(f"motion must be one of {', '.join(MOTIONS)}, got {motion!r}", parameter="motion")
        if isinstance(frames, bool) or not (isinstance(frames, int) and FRAME_LIMITS[0] <= frames <= FRAME_LIMITS[1]):
            raise ParameterError(f"frames must be a whole number in [{FRAME_LIMITS[0]}, {FRAME_LIMITS[1]}], got {frames!r}", parameter="frames")
        amp = check_number(amplitude_deg, "rock amplitude", 0.0, 60.0, low_open=True, unit="degrees")
        rate = check_number(fps, "fps", 1.0, 60.0)
        return cls(key, int(frames), float(amp), float(rate))

    @property
    def angles_deg(self) -> list[float]:
        """The angle of each frame (degrees): a sine rock of ±``amplitude_deg`` or a full turn."""
        k = range(self.frames)
        if self.motion == "rock":
            return [float(self.amplitude_deg * math.sin(2.0 * math.pi * i / self.frames)) for i in k]
        return [float(360.0 * i / self.frames) for i in k]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
