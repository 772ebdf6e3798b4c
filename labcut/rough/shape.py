"""The rough a cutter holds: a scanned nodule or a sawn slab, in its own frame.

Frame and units: millimetres; the rough's frame is the file's (``+Z`` is the rough's top as it
lies on the bench; a slab ``slab:LxWxT`` spans ``[0, L] x [0, W] x [0, T]``, its top face at
``z = T``). The lamella normal of a plan is given in this frame. Six reference faces name where
things are for the workshop: ``top`` (+Z), ``bottom`` (-Z), ``right`` (+X), ``left`` (-X),
``back`` (+Y), ``front`` (-Y): a slab's own faces, a nodule's bounding box.

A rough is described for the planner by the half-spaces of its convex hull (``a . x <= b``, unit
outward ``a``, mm): for a convex rough they are the rough itself, so containment is exact; a
non-convex rough's plans are checked against the rough itself with manifold3d
(:mod:`labcut.rough.check`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshError, ParameterError
from ..geometry.inspect import carats
from ..geometry.stone import Stone

#: labradorite's specific gravity the plans weigh stones with, g/cm³ (the low end of 2.69-2.72)
DENSITY = 2.69

#: the reference faces: name -> unit outward normal in the rough's frame
FACES: dict[str, tuple[float, float, float]] = {
    "top": (0.0, 0.0, 1.0), "bottom": (0.0, 0.0, -1.0), "right": (1.0, 0.0, 0.0), "left": (-1.0, 0.0, 0.0),
    "back": (0.0, 1.0, 0.0), "front": (0.0, -1.0, 0.0),
}

SLAB_PREFIX = "slab:"
#: a slab's sides, mm: thinner than this cannot hold a stone, larger is not a rough
SLAB_LIMITS = (0.5, 500.0)

_SLAB = re.compile(r"^\s*([^x×]+)[x×]([^x×]+)[x×]([^x×]+)\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class Rough:
    """A rough (mesh in mm, the rough's frame) with what the planner needs of it.

    ``kind``: ``"slab"`` (from ``slab:LxWxT``) or ``"mesh"`` (a file or a trimesh);
    ``source``: the spec or path; ``convex``: whether the rough is its own convex hull (then
    containment is exact); ``planes``: (m, 4) half-spaces ``[a, b]`` of the hull, ``a`` unit
    outward, ``a . x <= b``; ``notes``: what loading did (repairs, units)."""

    name: str
    mesh: Any
    kind: str
    source: str | None
    convex: bool
    planes: np.ndarray = field(repr=False)
    notes: tuple[str, ...] = ()
    _derived: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def cached(self, key: str, build: Any) -> Any:
        """``build()``, made once per rough and ``key`` (the checks' solid and tree)."""
        if key not in self._derived:
            self._derived[key] = build()
        return self._derived[key]

    @property
    def volume_mm3(self) -> float:
        return float(self.mesh.volume)

    @property
    def carats(self) -> float:
        """The rough's weight in carats at :data:`DENSITY`."""
        return carats(self.volume_mm3, DENSITY)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3): the lowest and highest corner of the rough's bounding box, mm."""
        return np.asarray(self.mesh.bounds, dtype=np.float64)

    def face_offset(self, name: str) -> float:
        """Where the reference face ``name`` lies along its outward normal (mm): a point ``x`` is
        ``face_offset(name) - FACES[name] . x`` mm inside that face."""
        n = np.asarray(FACES[name])
        lo, hi = self.bounds
        return float(np.dot(n, hi if n.sum() > 0 else lo))

    def depth_from(self, name: str, point: Any) -> float:
        """Distance (mm) of ``point`` inside the reference face ``name``, along its normal."""
        return self.face_offset(name) - float(np.dot(FACES[name], np.asarray(point, dtype=np.float64)))

    def to_dict(self) -> dict[str, Any]:
        lo, hi = self.bounds
        return {"name": self.name, "kind": self.kind, "source": self.source, "convex": self.convex,
                "volume_mm3": self.volume_mm3, "carats": self.carats, "bounds_mm": [lo.tolist(), hi.tolist()],
                "faces": len(self.mesh.faces), "notes": list(self.notes)}


def hull_planes(points: np.ndarray) -> np.ndarray:
    """(m, 4) half-spaces ``[a, b]`` (``a`` unit outward, ``a . x <= b``) of the convex hull of
    ``points`` (mm); coplanar hull triangles give one plane."""
    from scipy.spatial import ConvexHull

    try:
        hull = ConvexHull(np.asarray(points, dtype=np.float64))
    except Exception as exc:  # qhull: flat or degenerate
        raise MeshError(f"the rough has no volume (its points are flat or degenerate: {str(exc).splitlines()[0]})") from None
    eq = hull.equations  # a . x + c <= 0 with unit a
    planes = np.concatenate([eq[:, :3], -eq[:, 3:]], axis=1)
    keys = np.round(planes / np.array([1e-9, 1e-9, 1e-9, 1e-6]), 0)
    _, first = np.unique(keys, axis=0, return_index=True)
    return planes[np.sort(first)]


def slab(length: float, width: float, thickness: float, name: str | None = None) -> Rough:
    """A sawn slab ``length`` (X) x ``width`` (Y) x ``thickness`` (Z) mm, spanning
    ``[0, L] x [0, W] x [0, T]``: its top face at ``z = T`` (its flash plane is measured from it)."""
    import trimesh

    from ..validation import check_number

    dims = [check_number(v, f"slab {what}", SLAB_LIMITS[0], SLAB_LIMITS[1], unit="mm")
            for v, what in ((length, "length"), (width, "width"), (thickness, "thickness"))]
    box = trimesh.creation.box(extents=dims)
    box.apply_translation(np.asarray(dims) / 2.0)
    label = name or f"slab {dims[0]:g}x{dims[1]:g}x{dims[2]:g} mm"
    return Rough(label, box, "slab", f"slab:{dims[0]:g}x{dims[1]:g}x{dims[2]:g}", True, hull_planes(box.vertices))


def parse_slab(spec: str) -> tuple[float, float, float]:
    """``slab:LxWxT`` (mm) -> (L, W, T); a one-line :class:`ParameterError` otherwise."""
    body = spec[len(SLAB_PREFIX):] if spec.lower().startswith(SLAB_PREFIX) else spec
    m = _SLAB.match(body)
    if m is None:
        raise ParameterError(f"a slab is slab:LENGTHxWIDTHxTHICKNESS in mm (e.g. slab:40x30x6), got {spec!r}")
    out = []
    for text, what in zip(m.groups(), ("length", "width", "thickness")):
        try:
            out.append(float(text))
        except ValueError:
            raise ParameterError(f"slab {what} must be a number of mm in {spec!r}, got {text.strip()!r}") from None
    return out[0], out[1], out[2]


def load_rough(rough: Any, units: str | float = "auto", up_axis: str = "+Z") -> Rough:
    """A :class:`Rough` from ``slab:LxWxT``, a mesh file (STL, PLY, OBJ, OFF, GLB/GLTF, 3MF; read
    and repaired by :func:`labcut.load_mesh`, kept in the file's frame: ``up_axis`` ``"+Z"`` by
    default, not guessed, since the lamella normal is given in that frame), a trimesh, a
    :class:`~labcut.Stone` or a Rough (returned as it is).

    Raises :class:`~labcut.errors.MeshError` for a file that cannot be read or repaired (open,
    no volume) and :class:`~labcut.errors.ParameterError` for a bad spec, unit or axis."""
    if isinstance(rough, Rough):
        return rough
    if isinstance(rough, str) and rough.strip().lower().startswith(SLAB_PREFIX):
        return slab(*parse_slab(rough.strip()))
    if isinstance(rough, (str, Path)):
        from ..geometry.meshio import load_mesh

        path = Path(rough)
        mesh = load_mesh(path, units=units, up_axis=up_axis, recentre=False)
        name, source = path.stem, str(path)
    else:
        try:
            mesh = Stone.of(rough, "rough").validate("rough").mesh
        except ParameterError:
            raise ParameterError(f"rough must be slab:LxWxT, a mesh file, a trimesh or a labcut Stone, got {type(rough).__name__}") from None
        name, source = "rough", None
    stone = Stone.of(mesh)
    if not mesh.is_watertight:
        raise MeshError(f"the rough {name!r} is open (not watertight) and could not be repaired: its volume is undefined")
    volume = float(mesh.volume)
    if not (math.isfinite(volume) and volume > 0):
        raise MeshError(f"the rough {name!r} has no volume")
    notes = tuple(str(n) for n in stone.provenance_dict().get("repairs", []) or [])
    return Rough(name, mesh, "mesh", source, bool(stone.convex), hull_planes(mesh.vertices), notes)
