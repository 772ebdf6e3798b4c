"""Rendering with Mitsuba 3: the ``labradorite`` BSDF plugin, scenes, and :func:`render`."""

from .api import RenderPlan, RenderResult, build_scene, plan_render, render
from .scene import CameraView, camera_views, emitters

__all__ = ["CameraView", "RenderPlan", "RenderResult", "build_scene", "camera_views", "emitters", "plan_render", "render"]
