"""The effects a flash question may simulate, and the overrides a user may give them.

The effect planner (:mod:`labcut.planner`) decides, for a stone in a scene, which of
:data:`EFFECTS` are simulated and which estimator (:data:`ESTIMATORS`) answers; a user may force
the :data:`SWITCHABLE` ones on or off (``effects=`` / ``--effect NAME=on|off``). These names and
their checks live here, below both the question (:class:`~labcut.orientation.question.FlashQuestion`
checks a question's overrides) and the planner that reads them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ParameterError

EFFECTS = ("occlusion", "inter_reflection", "depth", "environment", "polarisation", "colour", "zoning")
#: who answers a flash question: the planner's choice, the surface samples, the samples with the
#: light carried through the stone's volume (docs/physics.md, "Depth"), or renders
ESTIMATORS = ("auto", "samples", "volume", "render")
#: the effects a user may switch with ``effects=`` / ``--effect NAME=on|off`` (the others follow
#: from the scene and from their own options: lighting, --mode, --polarizer, --zoning)
SWITCHABLE = ("occlusion", "inter_reflection", "depth")


def check_effects(effects: Mapping[str, Any] | None) -> dict[str, bool]:
    """``effects`` as ``{name: bool}`` of switchable effects (one-line errors for the rest)."""
    if effects is None:
        return {}
    if not isinstance(effects, Mapping):
        raise ParameterError(f"effects must map effect names to on/off, got {effects!r}")
    out = {}
    for name, value in effects.items():
        key = str(name).replace("-", "_")
        if key not in EFFECTS:
            raise ParameterError(f"unknown effect {name!r}; effects: {', '.join(EFFECTS)}")
        if key not in SWITCHABLE:
            how = {"environment": "the lighting (an .exr/.hdr map or a map preset: ceiling, sky)",
                   "polarisation": "--polarizer (renders only)", "colour": "--mode (renders only)",
                   "zoning": "--zoning (render, recommend-orientation, evaluate-orientation)"}[key]
            raise ParameterError(f"effect {key.replace('_', '-')!r} follows from {how}; it cannot be switched on its own")
        if isinstance(value, str):
            if value.lower() not in ("on", "off", "true", "false", "yes", "no"):
                raise ParameterError(f"effect {name!r} must be on or off, got {value!r}")
            value = value.lower() in ("on", "true", "yes")
        if not isinstance(value, bool | np.bool_):
            raise ParameterError(f"effect {name!r} must be on or off, got {value!r}")
        out[key] = bool(value)
    return out


def parse_effects(specs: Sequence[str] | None) -> dict[str, bool]:
    """``["inter-reflection=off", ...]`` (the CLI's ``--effect``) as a mapping for ``effects=``."""
    out: dict[str, Any] = {}
    for spec in specs or ():
        name, sep, value = str(spec).partition("=")
        if not sep or not name.strip():
            raise ParameterError(f"--effect takes NAME=on|off, got {spec!r}")
        out[name.strip()] = value.strip()
    return check_effects(out)
