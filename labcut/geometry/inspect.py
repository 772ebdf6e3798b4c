"""Stone summary: dimensions, volume and weight in carats of a mesh in mm.

Weight uses labradorite's specific gravity, 2.69-2.72 g/cm^3 (plagioclase of
An50-An70; GIA and Deer, Howie & Zussman list 2.68-2.72); the nominal weight uses
the midpoint 2.705 g/cm^3. 1 ct = 0.2 g, 1 cm^3 = 1000 mm^3, so
``ct = volume_mm3 * 1e-3 * density / 0.2``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .stone import Stone

#: labradorite density range, g/cm^3
DENSITY_RANGE = (2.69, 2.72)
DENSITY_NOMINAL = 0.5 * (DENSITY_RANGE[0] + DENSITY_RANGE[1])
GRAMS_PER_CARAT = 0.2


def carats(volume_mm3: float, density_g_cm3: float = DENSITY_NOMINAL) -> float:
    """Weight in carats of ``volume_mm3`` of a material of the given density."""
    return float(volume_mm3) * 1e-3 * float(density_g_cm3) / GRAMS_PER_CARAT


@dataclass
class MeshSummary:
    """Dimensions and weight of a stone mesh (mm, mm^2, mm^3, ct).

    ``length``/``width``/``height`` are the bounding-box extents along X, Y, Z
    (labcut frame: +Z face-up). ``weight_ct`` uses 2.705 g/cm^3 and
    ``weight_ct_range`` 2.69-2.72 g/cm^3.
    """

    name: str
    length_mm: float
    width_mm: float
    height_mm: float
    bounds_mm: list[list[float]]
    volume_mm3: float
    surface_area_mm2: float
    weight_ct: float
    weight_ct_range: list[float]
    triangles: int
    vertices: int
    watertight: bool
    winding_consistent: bool
    convex: bool
    repairs: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON dictionary."""
        return asdict(self)


def summarize(mesh: Any, name: str = "mesh") -> MeshSummary:
    """Summarise a stone (a :class:`~labcut.Stone` or ``trimesh.Trimesh``) in mm, with its
    loader's repairs and notes."""
    stone = Stone.of(mesh, name)
    mesh = stone.mesh
    meta = stone.record
    lo, hi = (np.asarray(b, dtype=float) for b in mesh.bounds)
    ext = hi - lo
    vol = float(abs(mesh.volume)) if mesh.is_watertight else float("nan")
    convex = stone.convex if (mesh.is_watertight or "convex" in meta) else False  # an open mesh has no inside
    w = carats(vol) if np.isfinite(vol) else float("nan")
    return MeshSummary(
        name=name,
        length_mm=float(ext[0]),
        width_mm=float(ext[1]),
        height_mm=float(ext[2]),
        bounds_mm=[lo.tolist(), hi.tolist()],
        volume_mm3=vol,
        surface_area_mm2=float(mesh.area),
        weight_ct=w,
        weight_ct_range=[carats(vol, DENSITY_RANGE[0]), carats(vol, DENSITY_RANGE[1])],
        triangles=int(len(mesh.faces)),
        vertices=int(len(mesh.vertices)),
        watertight=bool(mesh.is_watertight),
        winding_consistent=bool(mesh.is_winding_consistent),
        convex=bool(convex),
        repairs=list(meta.get("repairs", [])),
        notes=list(meta.get("notes", [])),
    )
