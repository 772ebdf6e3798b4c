"""Before a render starts: how long it will take, how much memory it needs, whether it will flash.

A render that takes minutes should say so before it starts, a render that cannot fit in memory
should be refused at once (an 8192² studio render took 12.3 GB and ignored Ctrl-C for minutes),
and an orbit or animation that shows no flash from any view should not be rendered at all
without being asked twice (``--view orbit`` of the biplane spent 162 s to say "no flash from 8 of
8 views"). :func:`forecast` predicts the time (:func:`labcut.planner.render_seconds`, this
machine's calibration) and the memory (:func:`predicted_bytes`, measured below);
:func:`check_memory` refuses what does not fit; :func:`flash_preview` asks the surface-sample
estimator (draft) whether any view or frame flashes, from a few of them, in well under a second
each.

Memory (peak resident set of ``labcut render`` of the bundled oval, 2 cores, Mitsuba's LLVM
backend): studio look, denoised, 16 spp: 0.55 GB at 512², 1.38 GB at 1024², 4.65 GB at 2048²; not
denoised: 0.57 GB at 1024²;
diagram look: 0.50 GB at 1024², 1.27 GB at 2048² (docs/render-performance.md). OIDN's scratch
memory is most of the denoised renders' share.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..orientation.flash_check import flash_by_view
from ..rendering.request import Motion, RenderRequest
from ..scene import Scenario
from .animate import posed

#: a render predicted to run longer than this (seconds) is started only when asked twice (the
#: CLI's ``--yes``) or under a time budget
CONFIRM_SECONDS = 60.0
#: bytes a render needs whatever its size (the interpreter, Mitsuba, the scene)
FIXED_BYTES = 0.3e9
#: bytes per pixel of a denoised render (colour, guide and normal passes, OIDN's scratch)
DENOISED_PIXEL_BYTES = 1050.0
#: ... and of a render that is not denoised
PLAIN_PIXEL_BYTES = 260.0
#: a polarised (Stokes: 12 channels) or spectral render holds more per pixel
WIDE_FILM_FACTOR = 2.0
#: the share of the machine's free memory a render may plan to use
MEMORY_SHARE = 0.8
#: at most this many frames of an animation are checked for a flash before it renders
PREVIEW_FRAMES = 8


@dataclass(frozen=True)
class RenderForecast:
    """What a render will cost on this machine: ``seconds`` (all its views and frames),
    ``memory_bytes`` (peak), ``available_bytes`` (free memory now; None where unknown), and the
    ``views`` and ``frames`` it renders."""

    seconds: float
    memory_bytes: float
    available_bytes: float | None
    views: int
    frames: int

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def summary(self) -> str:
        """``predicted 3.1 s and 0.6 GB on this machine``."""
        return f"predicted {format_seconds(self.seconds)} and {self.memory_bytes / 1e9:.1f} GB on this machine"


def format_seconds(seconds: float) -> str:
    """``4.2 s``, ``3.5 min`` or ``1.2 h``."""
    if seconds < 90.0:
        return f"{seconds:.1f} s"
    if seconds < 5400.0:
        return f"{seconds / 60.0:.1f} min"
    return f"{seconds / 3600.0:.1f} h"


def predicted_bytes(resolution: int, views: int, denoised: bool, wide_film: bool = False) -> float:
    """Peak memory (bytes) of a render of ``views`` square images of ``resolution`` px (module
    docstring): the cameras are rendered one after another, their images kept."""
    pixels = float(resolution) * float(resolution)
    per = DENOISED_PIXEL_BYTES if denoised else PLAIN_PIXEL_BYTES
    if wide_film:
        per *= WIDE_FILM_FACTOR
    kept = 12.0 * pixels * max(int(views) - 1, 0)  # the finished tiles (float32 RGB)
    return FIXED_BYTES + per * pixels + kept


def available_bytes() -> float | None:
    """Free memory now (``MemAvailable`` of /proc/meminfo, else the free physical pages), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def forecast(ask: RenderRequest, integrator: str, frames: int = 1) -> RenderForecast:
    """The :class:`RenderForecast` of the render request ``ask`` with the plan's ``integrator``
    (``direct`` or ``path``: the mesh decides), ``frames`` times (an animation)."""
    from ..planner import render_seconds

    views = len(ask.cameras)
    per_frame = render_seconds(ask.mode, ask.polarizer_deg is not None, integrator, ask.resolution, ask.spp, views,
                               ask.look)
    memory = predicted_bytes(ask.resolution, views, ask.plan_denoise, ask.polarizer_deg is not None or ask.mode == "spectral")
    return RenderForecast(per_frame * int(frames), memory, available_bytes(), views, int(frames))


def check_memory(fc: RenderForecast, resolution: int, denoised: bool) -> None:
    """Refuse (one-line :class:`~labcut.errors.ParameterError`) a render whose predicted memory
    exceeds :data:`MEMORY_SHARE` of the free memory, naming both and the largest size that fits."""
    if fc.available_bytes is None or fc.memory_bytes <= MEMORY_SHARE * fc.available_bytes:
        return
    budget = MEMORY_SHARE * fc.available_bytes - FIXED_BYTES
    per = DENOISED_PIXEL_BYTES if denoised else PLAIN_PIXEL_BYTES
    side = int(math.sqrt(max(budget, 0.0) / (per * max(fc.views, 1)))) if budget > 0 else 0
    fits = f"at most about {side}² px fits" if side >= 8 else "no size fits now"
    raise ParameterError(f"a {resolution}² px render needs about {fc.memory_bytes / 1e9:.1f} GB of memory, more than the "
                         f"{fc.available_bytes / 1e9:.1f} GB this machine has free: lower the resolution ({fits})",
                         parameter="resolution")


@dataclass(frozen=True)
class FlashPreview:
    """Whether a render's views (or an animation's frames) flash, by the surface-sample estimator
    at draft quality: ``flash``, per checked view or frame, what
    :func:`~labcut.orientation.flash_check.flash_by_view` says of a camera (``view``: its label,
    ``flash_area``: None when edge-on, ``flash``), so a render can take it as its own."""

    flash: tuple[dict[str, Any], ...]

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(f["view"] for f in self.flash)

    @property
    def areas(self) -> tuple[float | None, ...]:
        return tuple(f["flash_area"] for f in self.flash)

    @property
    def any_flash(self) -> bool:
        return any(f["flash"] for f in self.flash)

    def note(self, what: str) -> str:
        """Why a render would show no flash, for a person (``what``: ``views`` or ``frames``)."""
        return (f"no part of the stone reaches the flash threshold in any of the {len(self.flash)} {what} checked "
                "at this lamella orientation: the render would show surface glare and the body only")


def flash_preview(mesh: Any, ask: RenderRequest, normal: Any, motion: Motion | None = None) -> FlashPreview:
    """:class:`FlashPreview` of a render before it starts: every camera of ``ask`` (an orbit's 8),
    or, for an animation, up to :data:`PREVIEW_FRAMES` of its frames spread over the motion."""
    if motion is None:
        flash, _ = flash_by_view(mesh, ask.material, normal, ask.scenario.main_setting(), ask.cameras)
        return FlashPreview(tuple(flash))
    angles = motion.angles_deg
    picks = sorted(set(np.linspace(0, len(angles) - 1, min(PREVIEW_FRAMES, len(angles))).round().astype(int).tolist()))
    frames = []
    for i in picks:
        scenario: Scenario = posed(ask.scenario, motion.motion, angles[i])
        flash, _ = flash_by_view(mesh, ask.material, normal, scenario.main_setting(), ask.cameras[:1])
        frames.append({**flash[0], "view": f"frame {i + 1} ({angles[i]:+.0f}°)"})
    return FlashPreview(tuple(frames))


def needs_confirmation(fc: RenderForecast, time_budget: float | None) -> bool:
    """Whether a render is long enough (over :data:`CONFIRM_SECONDS`) to start only when asked twice."""
    return time_budget is None and fc.seconds > CONFIRM_SECONDS


def confirmation_message(fc: RenderForecast, option: str = "--yes", budget: bool = True) -> str:
    """The one line that stops a long render until it is confirmed (``budget``: the command takes
    a render time budget, ``--time-budget``)."""
    parts = f"{fc.views} views, " if fc.views > 1 else ""
    parts += f"{fc.frames} frames, " if fc.frames > 1 else ""
    lower = "--spp, --resolution or --frames" if fc.frames > 1 else "--spp or --resolution"
    instead = f"give --time-budget SECONDS, or lower {lower}" if budget else f"lower {lower}"
    return f"this render is {fc.summary()} ({parts}over {CONFIRM_SECONDS:.0f} s): add {option} to start it, or {instead}"


__all__: Sequence[str] = ("CONFIRM_SECONDS", "FlashPreview", "RenderForecast", "available_bytes", "check_memory",
                          "confirmation_message", "flash_preview", "forecast", "needs_confirmation", "predicted_bytes")
