"""Rendering with Mitsuba 3: the ``labradorite`` BSDF plugin, render plans and scenes
(:func:`labcut.render`, the command, is :mod:`labcut.commands.render`)."""

from .api import RenderPlan, RenderResult, build_scene, plan_render, render_image
from .scene import CameraView, camera_views, emitters

__all__ = ["CameraView", "RenderPlan", "RenderResult", "build_scene", "camera_views", "emitters", "plan_render",
           "render_image"]
