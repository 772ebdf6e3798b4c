"""Does a render's stone flash from each of its cameras? (:func:`flash_by_view`)

A render that shows no flash from a camera is surface glare and the grey body; :func:`labcut.render`
says so in its notes. The answer is the surface-
sample estimator's at draft quality, under the render's lights and from its cameras (mesh frame).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..physics.material import Labradorite
from ..rendering.scene import CameraView
from ..scene import Setting, Views
from ..scene.directions import normalize_normal
from .problem import build_problem
from .scoring import Scorer


def flash_by_view(mesh: Any, material: Labradorite, lamella_normal: Any, setting: Setting,
                  cameras: Sequence[CameraView]) -> tuple[list[dict[str, Any]], list[str]]:
    """Does the stone flash from each camera? The surface-sample estimator (standard quality) under
    the render's lights, one view per camera (mesh frame). Returns per camera ``{"view", "flash_area",
    "flash"}`` (None for a camera that sees the face edge-on or from behind) and the notes to show."""
    normal = normalize_normal(lamella_normal)
    dirs = np.array([c.direction for c in cameras], dtype=np.float64)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    usable = np.flatnonzero(dirs[:, 2] > 1e-3)
    areas: list[float | None] = [None] * len(cameras)
    if len(usable):
        try:
            problem = build_problem(mesh, material, quality="standard",
                                    settings=[Setting(setting.lights, Views(dirs[usable]), 1.0, setting.pose)])
            per_view = Scorer(problem).metrics(normal).per_view["flash_area"]
        except ParameterError:  # no light reaches what any camera sees
            per_view = [0.0] * len(usable)
        for i, a in zip(usable, per_view):
            areas[int(i)] = float(a)
    flash = [{"view": c.name, "flash_area": a, "flash": None if a is None else a > 0.0} for c, a in zip(cameras, areas)]
    return flash, flash_notes(flash)


def flash_notes(flash: Sequence[dict[str, Any]]) -> list[str]:
    """The notes a render shows for its cameras' flash (:func:`flash_by_view`'s list): which views
    show none."""
    dark = [f["view"] for f in flash if f["flash"] is False]
    if not dark:
        return []
    where = "this view" if len(flash) == 1 else f"{len(dark)} of {len(flash)} views ({', '.join(dark)})"
    return [f"the stone shows no flash from {where}: no part of it reaches the flash threshold there, so what the "
            "image shows is surface glare and the grey body"]
