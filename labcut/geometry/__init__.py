"""Stone geometry: the Stone, cabochon builder, outlines, dome profiles, mesh intake, GemCad
designs, carvings.

Frame and units (DESIGN.md §3): millimetres, +Z face-up, base in the XY plane at
z = 0. ``labcut.load_mesh`` and ``labcut.Stone`` are these; the cabochon builder is
``labcut.cabochon`` (here ``cabochon`` is its module).
"""

from __future__ import annotations

from .._exports import lazy_exports

#: the public names of :mod:`labcut.geometry`, imported on first use
_EXPORTS = {
    "Stone": ".stone:Stone",
    "load_mesh": ".meshio:load_mesh",
    "save_mesh": ".meshio:save_mesh",
    "READ_FORMATS": ".meshio:READ_FORMATS",
    "WRITE_FORMATS": ".meshio:WRITE_FORMATS",
    "units_scale": ".meshio:units_scale",
    "OUTLINES": ".outlines:OUTLINES",
    "make_outline": ".outlines:make_outline",
    "MeshSummary": ".inspect:MeshSummary",
    "summarize": ".inspect:summarize",
    "carats": ".inspect:carats",
    "UP_AXES": ".orient:UP_AXES",
    "check_up_axis": ".orient:check_up_axis",
    "detect_up_axis": ".orient:detect_up_axis",
    "Design": ".gemcad:Design",
    "read_design": ".gemcad:read_design",
    "load_design": ".gemcad:load_design",
    "design_size": ".gemcad:design_size",
    "DESIGN_SUFFIXES": ".gemcad:DESIGN_SUFFIXES",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
