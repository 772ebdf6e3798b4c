"""The second estimator of the flash metrics: rendered images (DESIGN.md §4).

For each view an orthographic image of the schiller lobe alone is rendered in the
mono variant (luminance, as the surface-sample estimator uses) under the model's
distant lights (no ambient), with direct lighting and shadow rays. Pixels are
weighted by their coverage (alpha, box filter), so a pixel's weight is the
projected area it sees; ``L/L_ref`` per pixel gives the same metrics as
:meth:`labcut.orientation.scoring.Scorer.metrics` from independent machinery:
Mitsuba's ray tracing, the BSDF plugin and its tables.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError
from ..physics.material import Labradorite
from ..scene import Lights, Setting, Views
from .problem import reference_radiance
from .scoring import FlashMetrics


def render_metrics(
    mesh: Any,
    material: Labradorite,
    normal: Any,
    lights: Lights | None = None,
    views: Views | None = None,
    tau: float = 0.1,
    resolution: int = 160,
    spp: int = 16,
    seed: int = 0,
    *,
    settings: list[Setting] | None = None,
) -> FlashMetrics:
    """Flash metrics of ``normal`` from rendered images, one per view and pose.

    ``lights``/``views`` (mesh frame, one still pose) or ``settings`` (a scenario's poses,
    as :func:`~labcut.orientation.problem.build_problem` takes them)."""
    import mitsuba as mi

    from ..backend import set_variant
    from ..rendering import bsdf as _bsdf  # noqa: F401
    from ..rendering.api import bsdf_dict, normalize_normal
    from ..rendering.scene import CameraView, camera, emitters, to_mitsuba_mesh

    if settings is None:
        if lights is None or views is None:
            raise ParameterError("render_metrics needs lights and views, or settings")
        settings = [Setting(lights, views, 1.0, np.eye(3))]
    m = normalize_normal(normal)
    set_variant("mono")
    l_ref = reference_radiance(material, 1.0)
    stone = to_mitsuba_mesh(mesh, mi.load_dict(bsdf_dict(material, m, ("schiller",))))
    area_v, energy_v, intensity_v, weight_v = [], [], [], []
    pose_total = sum(float(st.weight) for st in settings)
    for st in settings:
        # lights at unit total irradiance, no ambient: L / L_ref as in the sample estimator
        lamps = emitters(st.lights, total_irradiance=1.0, ambient=0.0)
        for d, wv in zip(st.views.directions, st.views.weights):
            weight_v.append(float(st.weight) / pose_total * float(wv))
            sensor = camera(mesh, CameraView("v", tuple(d), tuple(st.up())), resolution)
            sensor["film"]["pixel_format"] = "luminance_alpha"
            sensor["film"]["rfilter"] = {"type": "box"}
            scene = mi.load_dict({"type": "scene", "integrator": {"type": "direct"}, "sensor": sensor, "stone": stone, **lamps})
            img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
            value, alpha = img[..., 0], img[..., 1]
            cover = alpha > 1e-3
            w = alpha[cover]
            ratio = value[cover] / w / l_ref
            flash = ratio >= tau
            total = float(w.sum())
            a = float((w * flash).sum()) / total if total > 0 else 0.0
            e = float((w * ratio).sum()) / total if total > 0 else 0.0
            i = float((w * ratio * flash).sum()) / float((w * flash).sum()) if a > 0 else 0.0
            area_v.append(a)
            energy_v.append(e)
            intensity_v.append(i)
    wv = np.array(weight_v)
    return FlashMetrics.from_views(area_v, intensity_v, energy_v, wv / wv.sum())
