"""Rough planning: the stones to cut from the rough or slab a cutter holds, where, how big and
how tilted, trading weight against flash (``labcut.plan_rough``, ``labcut rough``; docs/rough.md).

A layer beside the reports (``tests/test_layers.py``): it asks :class:`labcut.Study` for each
candidate cut's flash and the geometry layer for the rough.
"""

from __future__ import annotations

from .._exports import lazy_exports

#: the public names of :mod:`labcut.rough`, imported on first use
_EXPORTS = {
    "plan_rough": ".plan:plan_rough",
    "check_request": ".plan:check_request",
    "RoughPlan": ".plan:RoughPlan",
    "PlannedStone": ".plan:PlannedStone",
    "Rough": ".shape:Rough",
    "load_rough": ".shape:load_rough",
    "slab": ".shape:slab",
    "RANKS": ".search:RANKS",
    "FAMILIES": ".candidates:FAMILIES",
    "CALIBRATED": ".candidates:CALIBRATED",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
