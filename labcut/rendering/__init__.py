"""Rendering with Mitsuba 3: the ``labradorite`` BSDF plugin, scenes, and :func:`render`."""

from .api import RenderPlan, RenderResult, build_scene, plan_render, render
from .scene import Lighting, View, lighting_preset, view_presets

__all__ = ["Lighting", "RenderPlan", "RenderResult", "View", "build_scene", "lighting_preset", "plan_render", "render", "view_presets"]
