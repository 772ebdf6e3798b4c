"""What a loader found and did to a stone's file: :class:`MeshReport` (units, up axis, repairs,
bodies), the record :func:`labcut.load_mesh` and the GemCad readers keep with a mesh; a
:class:`~labcut.geometry.stone.Stone` reads it as its provenance."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np


@dataclass
class MeshReport:
    """What :func:`load_mesh` found and did. Lengths in mm, in the output frame.

    Attributes:
        source: the file read.
        format: the file type (``"stl"``, ``"ply"``, ...).
        units: the file's unit (``"mm"``, ``"in"``, ... or ``"x<factor>"``).
        units_source: where the unit came from: ``"given"``, ``"file"`` (glTF is metres by
            specification, 3MF declares its unit) or ``"default"`` (the file does not say: mm).
        scale_to_mm: factor applied to the file's coordinates.
        up_axis: the file's axis that became labcut's +Z (face-up): ``"+Z"`` ... ``"-X"``.
        up_axis_source: ``"given"``, ``"shape: <what the shape showed>"`` or
            ``"convention: <why>"`` (the shape does not say; the format's convention holds).
        rotation: 3 x 3 rotation applied to the file's coordinates (p' = R p), before re-centring.
        translation_mm: offset added after scaling and rotating (re-centring), or zeros.
        dimensions_mm: bounding-box extents along X, Y, Z of the returned mesh.
        repairs: one sentence per repair made to the geometry or topology.
        notes: other things worth knowing (coincident vertices merged, ...).
        warnings: things that may make the answer wrong (the file looked upside down or
            Y-up and was turned; a given up axis disagrees with the shape).
        convex: the solid equals its convex hull (to :data:`CONVEX_RTOL`).
        watertight: always True for a returned mesh.
        triangles, vertices: counts of the returned mesh.
        bodies: number of separate closed shells.
    """

    source: str
    format: str
    units: str
    scale_to_mm: float
    translation_mm: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    repairs: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    units_source: str = "given"
    up_axis: str = "+Z"
    up_axis_source: str = "given"
    rotation: list[list[float]] = field(default_factory=lambda: np.eye(3).tolist())
    dimensions_mm: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    convex: bool = False
    watertight: bool = True
    triangles: int = 0
    vertices: int = 0
    bodies: int = 1

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON dictionary of the report."""
        return asdict(self)
