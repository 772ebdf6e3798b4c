"""The commands: what ``labcut.recommend_orientation``, ``labcut.evaluate_orientation``,
``labcut.render`` and the animations run. They check a request, ask the effect planner
(:mod:`labcut.planner`) and the time budgets, then answer with the layers below: the flash
problem and its scorer (:mod:`labcut.orientation`) and the renderer (:mod:`labcut.rendering`).
Nothing below this layer imports it (``tests/test_layers.py``). The commands themselves are
``labcut.recommend_orientation``, ``labcut.render``, ``labcut.animate`` (here ``render`` and
``animate`` are their modules)."""

from __future__ import annotations

from .._exports import lazy_exports

#: the public names of :mod:`labcut.commands`, imported on first use
_EXPORTS = {
    "recommend_orientation": ".recommend:recommend_orientation",
    "evaluate_orientation": ".recommend:evaluate_orientation",
    "render_checked": ".render:render_checked",
    "Animation": ".animate:Animation",
    "ANIMATION_SUFFIXES": ".animate:ANIMATION_SUFFIXES",
    "quality_or_budget": ".budget:quality_or_budget",
    "choose_spp": ".render_budget:choose_spp",
    "RenderForecast": ".render_forecast:RenderForecast",
    "FlashPreview": ".render_forecast:FlashPreview",
    "forecast": ".render_forecast:forecast",
    "check_memory": ".render_forecast:check_memory",
    "flash_preview": ".render_forecast:flash_preview",
    "needs_confirmation": ".render_forecast:needs_confirmation",
    "confirmation_message": ".render_forecast:confirmation_message",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
