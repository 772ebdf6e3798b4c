"""The flash problem of a cut and the lamella orientation that makes it flash: the question
(:class:`FlashQuestion`), the sample and render estimators, the scorer and its metrics, the
optimisers, error bars and the answer (:class:`Recommendation`). Normals are unit vectors in the
stone's mesh frame (mm, +Z face-up)."""

from __future__ import annotations

from .._exports import lazy_exports

#: the public names of :mod:`labcut.orientation`, imported on first use
_EXPORTS = {
    "FlashQuestion": ".question:FlashQuestion",
    "OBJECTIVES": ".question:OBJECTIVES",
    "Recommendation": ".recommend:Recommendation",
    "METRIC_DEFINITIONS": ".recommend:METRIC_DEFINITIONS",
    "FRAME": ".recommend:FRAME",
    "metrics_dict": ".recommend:metrics_dict",
    "energy_parts": ".recommend:energy_parts",
    "side_name": ".recommend:side_name",
    "workshop": ".recommend:workshop",
    "OPTIMIZERS": ".optimize:OPTIMIZERS",
    "Constraint": ".optimize:Constraint",
    "hemisphere_grid": ".optimize:hemisphere_grid",
    "KernelOptions": ".kernels:KernelOptions",
    "FlashEstimator": ".estimators:FlashEstimator",
    "ESTIMATORS": ".estimators:ESTIMATORS",
    "estimator_for": ".estimators:estimator_for",
    "FlashMetrics": ".scoring:FlashMetrics",
    "MisorientationCurve": ".misorientation:MisorientationCurve",
    "misorientation_curve": ".misorientation:misorientation_curve",
    "UPRIGHT_NAMES": ".misorientation:UPRIGHT_NAMES",
    "Robustness": ".robustness:Robustness",
    "scenario_robustness": ".robustness:scenario_robustness",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
