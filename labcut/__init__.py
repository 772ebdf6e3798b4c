"""labcut: find the lamella orientation that makes a labradorite cut flash.

Public API (DESIGN.md §5; these names are a contract)::

    import labcut
    lab = labcut.Labradorite.from_peak_wavelength(470.0)
    lab.reflectance(wavelength_nm, cos_theta)
    mesh = labcut.load_mesh("stone.stl")
    cab = labcut.cabochon(outline="oval", length=16, width=12, dome="low")

Importing labcut registers the ``labradorite`` BSDF with Mitsuba (every JIT variant) and
checks that Dr.Jit has a libLLVM it can run on; it changes nothing else in the process (no
environment variables, no import hooks, no other package's modules). The other heavy modules
(trimesh, manifold3d, the optimiser) load on first use.
"""

from __future__ import annotations

from . import backend as _backend
from ._exports import lazy_exports as _lazy_exports

_backend.check_llvm()  # before Mitsuba loads Dr.Jit: a libLLVM it would abort on is a clear error

from .errors import (  # noqa: E402
    BackendError,
    LabcutError,
    LabcutWarning,
    LLVMVersionError,
    MeshError,
    OutputError,
    ParameterError,
)

__version__ = "0.1.0"

# A plugin package: after ``import labcut`` the ``labradorite`` BSDF is registered with
# Mitsuba for the current JIT variant and again on every variant change, so
# ``mi.set_variant(...)`` then ``mi.load_dict({"type": "labradorite"})`` works in either order.
from .rendering import bsdf as _bsdf  # noqa: E402,F401

# name -> "module:attribute", resolved on first access
_LAZY = {
    "Labradorite": "labcut.physics.material:Labradorite",
    "physics": "labcut.physics",
    "colour": "labcut.colour",
    "cabochon": "labcut.geometry.cabochon:cabochon",
    "load_mesh": "labcut.geometry.meshio:load_mesh",
    "Stone": "labcut.geometry.stone:Stone",
    "Study": "labcut.study:Study",
    "render": "labcut.commands.render:render",
    "animate": "labcut.commands.animate:animate",
    "recommend_orientation": "labcut.commands.recommend:recommend_orientation",
    "evaluate_orientation": "labcut.commands.recommend:evaluate_orientation",
    "Recommendation": "labcut.orientation.recommend:Recommendation",
    "Lights": "labcut.scene.sets:Lights",
    "Views": "labcut.scene.sets:Views",
    "Scenario": "labcut.scene.scenario:Scenario",
    "Quality": "labcut.scene.quality:Quality",
    "Variation": "labcut.scene.variants:Variation",
    "scene": "labcut.scene",
    "RenderResult": "labcut.rendering.api:RenderResult",
    "compare_cuts": "labcut.reports.compare:compare_cuts",
    "Comparison": "labcut.reports.compare:Comparison",
    "plan_effects": "labcut.planner:plan_effects",
    "EffectPlan": "labcut.planner:EffectPlan",
    "plan_rough": "labcut.rough.plan:plan_rough",
    "RoughPlan": "labcut.rough.plan:RoughPlan",
    "explore": "labcut.explorer:explore",
    "Explorer": "labcut.explorer:Explorer",
}


__getattr__, __dir__, __all__ = _lazy_exports(__name__, _LAZY, eager=(
    "BackendError", "LabcutError", "LabcutWarning", "LLVMVersionError", "MeshError", "OutputError", "ParameterError",
))
