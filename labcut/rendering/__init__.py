"""Rendering with Mitsuba 3: the ``labradorite`` BSDF plugin, render requests and plans, scenes,
the studio look, colour zoning and images (:func:`labcut.render`, the command, is
:mod:`labcut.commands.render`)."""

from __future__ import annotations

from .._exports import lazy_exports

#: the public names of :mod:`labcut.rendering`, imported on first use
_EXPORTS = {
    "RenderPlan": ".plan:RenderPlan",
    "plan_render": ".plan:plan_render",
    "plan_for": ".api:plan_for",
    "EXPOSURE_MODES": ".exposure:MODES",
    "check_exposure_mode": ".exposure:check_mode",
    "reference_exposure": ".exposure:reference_exposure",
    "from_ev": ".tonemap:from_ev",
    "LOBES": ".plan:LOBES",
    "RenderResult": ".api:RenderResult",
    "build_scene": ".api:build_scene",
    "render_image": ".api:render_image",
    "CameraView": ".scene:CameraView",
    "camera_views": ".scene:camera_views",
    "emitters": ".scene:emitters",
    "RenderRequest": ".request:RenderRequest",
    "Motion": ".request:Motion",
    "MOTIONS": ".request:MOTIONS",
    "MODES": ".request:MODES",
    "FRAME_LIMITS": ".request:FRAME_LIMITS",
    "IMAGE_SUFFIXES": ".images:IMAGE_SUFFIXES",
    "save_image": ".images:save_image",
    "LOOKS": ".studio:LOOKS",
    "Studio": ".studio:Studio",
    "resolve_look": ".studio:resolve_look",
    "Zoning": ".zoning:Zoning",
    "ZONING_PRESETS": ".zoning:PRESETS",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
