"""A stone: its mesh and everything labcut knows about it, in one typed, immutable object.

:class:`Stone` holds the trimesh (mm, mesh frame: +Z face-up, the front at -Y, DESIGN.md §3) and
the facts the loaders established: where it came from and what was done to it
(:class:`Provenance`: path, units and why, up axis and why, rotation, repairs, bodies), whether it
is convex, whether it is a faceted design and that design (facets, tiers, refractive index), and
the builder's parameters for a cabochon or carving (:attr:`Stone.shape`). It also owns the
geometry every consumer derives from the mesh (face areas, the smooth-shaded split copy, surface
samples per count and seed, and whatever the renderer keeps per stone: :meth:`Stone.cached`),
each computed once.

:func:`labcut.load_mesh`, :func:`labcut.cabochon` and the GemCad readers return a
``trimesh.Trimesh`` (DESIGN.md §5) that carries its record in ``mesh.metadata["labcut"]``; this
module is the one reader of that record. Every API accepts a Stone or a trimesh:
:meth:`Stone.of` wraps a trimesh on entry and keeps the Stone with the mesh (in the mesh's own
trimesh cache, which drops it when the vertices or faces change), so that the modules a question
passes through see one Stone and its derived geometry is made once. A Stone made with other
facts (``Stone(mesh, convex=False)``) is the one later calls with that mesh see.
"""

from __future__ import annotations

import copy
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshError, ParameterError
from .gemcad import design_provenance
from .meshio import load_mesh, validate_mesh
from .solid import extent, is_convex_mesh, mesh_digest
from .surface import (
    FACETED_ANGLE_DEG,
    FAST_SMOOTH_FACES,
    SMOOTH_ANGLE_DEG,
    SurfaceSamples,
    draw_samples,
    face_areas,
    face_cells,
    smooth_split,
)

#: the key of a stone's record in ``mesh.metadata`` and of the Stone in the mesh's trimesh cache
RECORD_KEY = "labcut"
_CACHE_KEY = "labcut_stone"

#: the record's keys that make up a stone's provenance (in this order in :meth:`Stone.provenance_dict`)
PROVENANCE_FIELDS = ("kind", "source", "format", "units", "units_source", "scale_to_mm", "up_axis",
                     "up_axis_source", "rotation", "repairs", "notes", "warnings", "bodies", "convex", "triangles")


@dataclass(frozen=True)
class Provenance:
    """Where a stone came from and what was done to it; lengths in mm.

    ``kind``: ``loaded`` (a mesh file), ``design`` (a GemCad design), ``cabochon``, a carving's
    kind, or ``given`` (a mesh labcut did not make or read). ``units_source`` / ``up_axis_source``
    say why the unit and the up axis are what they are; ``rotation`` is the 3 x 3 rotation applied
    to the file's coordinates; ``repairs``, ``notes`` and ``warnings`` are one sentence each.
    """

    kind: str = "given"
    source: str | None = None
    format: str | None = None
    units: str = "mm"
    units_source: str | None = None
    scale_to_mm: float = 1.0
    up_axis: str = "+Z"
    up_axis_source: str | None = None
    rotation: tuple[tuple[float, ...], ...] | None = None
    repairs: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    bodies: int = 1


def _frozen(value: Any) -> Any:
    """A read-only deep copy of plain JSON-like data (mappings become read-only, lists tuples)."""
    if isinstance(value, Mapping):
        return types.MappingProxyType({k: _frozen(v) for k, v in value.items()})
    if isinstance(value, list | tuple):
        return tuple(_frozen(v) for v in value)
    return value


def _thawed(value: Any) -> Any:
    """Plain, mutable JSON-like data of :func:`_frozen` data (tuples become lists)."""
    if isinstance(value, Mapping):
        return {k: _thawed(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thawed(v) for v in value]
    return value


class Stone:
    """A stone (module docstring). Immutable: its facts are fixed when it is made; another stone
    with other facts is :meth:`replace`'s.

    ``Stone(mesh)`` reads the facts from the mesh's record (the loaders'), computing convexity
    when the record does not say; keyword arguments override them (``convex``, ``faceted``,
    ``kind``, ``source``, ``name``). The Stone becomes the one :meth:`of` returns for this mesh.
    """

    __slots__ = ("mesh", "kind", "convex", "faceted", "provenance", "design", "shape", "name", "_record", "_derived")

    mesh: Any
    kind: str
    convex: bool
    faceted: bool
    provenance: Provenance
    design: Mapping[str, Any] | None
    shape: Mapping[str, Any]
    name: str | None

    def __init__(self, mesh: Any, *, convex: bool | None = None, faceted: bool | None = None, kind: str | None = None,
                 source: str | None = None, name: str | None = None) -> None:
        import trimesh

        if isinstance(mesh, Stone):
            raise MeshError("Stone(...) takes a trimesh.Trimesh; a Stone is already one (use Stone.of or stone.replace)")
        if not isinstance(mesh, trimesh.Trimesh):
            raise MeshError(f"a stone's mesh must be a trimesh.Trimesh (labcut.load_mesh or labcut.cabochon), "
                            f"got {type(mesh).__name__}")
        metadata = getattr(mesh, "metadata", None) or {}
        read = dict(metadata.get(RECORD_KEY) or {})
        record = dict(read)
        if kind is not None:
            record["kind"] = str(kind)
        if source is not None:
            record["source"] = str(source)
        if faceted is not None:
            record["faceted"] = bool(faceted)
        if convex is not None:
            record["convex"] = bool(convex)
        # a record that does not say (a mesh labcut did not make): computed, not written into it
        is_convex = bool(record["convex"]) if "convex" in record else bool(len(mesh.faces) > 0 and is_convex_mesh(mesh))
        self._fill(mesh, record, is_convex, name if name is not None else
                   (str(metadata["name"]) if metadata.get("name") else None))
        if record != read:  # facts given: the trimesh a user holds says what the Stone says
            mesh.metadata[RECORD_KEY] = _thawed(self._record)
        self._attach()

    def _fill(self, mesh: Any, record: dict[str, Any], convex: bool, name: str | None) -> None:
        """Set every fact from ``record`` (what ``__init__`` and unpickling share)."""
        set_ = object.__setattr__
        set_(self, "mesh", mesh)
        set_(self, "_record", _frozen(record))
        set_(self, "_derived", {})
        set_(self, "kind", str(record.get("kind", "given")))
        set_(self, "convex", bool(convex))
        set_(self, "faceted", bool(record.get("faceted", False)))
        set_(self, "design", self._record.get("design") if isinstance(record.get("design"), Mapping) else None)
        set_(self, "name", name)
        rotation = record.get("rotation")
        set_(self, "provenance", Provenance(
            kind=self.kind, source=None if record.get("source") is None else str(record["source"]),
            format=record.get("format"), units=str(record.get("units", "mm")), units_source=record.get("units_source"),
            scale_to_mm=float(record.get("scale_to_mm", 1.0)), up_axis=str(record.get("up_axis", "+Z")),
            up_axis_source=record.get("up_axis_source"),
            rotation=None if rotation is None else tuple(tuple(float(x) for x in row) for row in rotation),
            repairs=tuple(str(r) for r in record.get("repairs", ())), notes=tuple(str(r) for r in record.get("notes", ())),
            warnings=tuple(str(r) for r in record.get("warnings", ())), bodies=int(record.get("bodies", 1))))
        known = set(PROVENANCE_FIELDS) | {"faceted", "design", "watertight", "vertices", "dimensions_mm", "translation_mm"}
        set_(self, "shape", types.MappingProxyType({k: v for k, v in self._record.items() if k not in known}))

    def __getstate__(self) -> dict[str, Any]:
        """Pickled (a batch row's mesh travels to a worker with its stone): the mesh and the facts;
        the derived geometry (ray scenes, samples) is made again where it is needed."""
        return {"mesh": self.mesh, "record": _thawed(self._record), "convex": self.convex, "name": self.name}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._fill(state["mesh"], state["record"], state["convex"], state["name"])

    # ------------------------------------------------------------------ making and finding stones
    @classmethod
    def of(cls, obj: Any, name: str = "mesh") -> Stone:
        """The Stone of ``obj``: ``obj`` itself when it is one; for a trimesh, the Stone kept with
        it (made by its loader's record, or by ``Stone(mesh, ...)``) while its vertices and faces
        are unchanged, else a new one from its record. Anything else is a :class:`MeshError`
        naming ``name``."""
        if isinstance(obj, Stone):
            return obj
        cache = getattr(obj, "_cache", None)
        if cache is not None:
            try:
                hit = cache[_CACHE_KEY]  # trimesh's Cache: None when missing or stale
            except Exception:  # noqa: BLE001 - a cache that cannot be read: make the stone again
                hit = None
            if isinstance(hit, Stone) and hit.mesh is obj and hit._current():
                return hit
        import trimesh

        if not isinstance(obj, trimesh.Trimesh):
            raise MeshError(f"{name} must be a trimesh.Trimesh or a labcut.Stone (labcut.load_mesh or labcut.cabochon), "
                            f"got {type(obj).__name__}")
        return cls(obj)

    @classmethod
    def load(cls, path: str | Path, **kwargs: Any) -> Stone:
        """:func:`labcut.load_mesh` (same arguments: ``units``, ``up_axis``, ``size`` ...) as a Stone."""
        return cls.of(load_mesh(path, **kwargs))

    def replace(self, *, convex: bool | None = None, faceted: bool | None = None, kind: str | None = None,
                source: str | None = None, name: str | None = None) -> Stone:
        """A Stone of a copy of this mesh with the facts given changed (this one stays as it is)."""
        mesh = self.mesh.copy()
        mesh.metadata[RECORD_KEY] = _thawed(self._record)
        if self.name is not None:
            mesh.metadata["name"] = self.name
        return Stone(mesh, convex=convex, faceted=faceted, kind=kind, source=source,
                     name=self.name if name is None else name)

    def _attach(self) -> None:
        try:
            self.mesh._cache[_CACHE_KEY] = self
        except Exception:  # noqa: BLE001 - a mesh without trimesh's cache: Stone.of makes the stone again
            pass

    def _current(self) -> bool:
        """Whether the mesh's record is still the one this stone wrote or read (not replaced)."""
        record = (getattr(self.mesh, "metadata", None) or {}).get(RECORD_KEY) or {}
        return record.get("convex", self.convex) == self.convex and bool(record.get("faceted", False)) == self.faceted

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError(f"a Stone is immutable: {key!r} cannot be set (stone.replace(...) makes another)")

    def __repr__(self) -> str:
        return (f"Stone({self.name or self.provenance.source or self.kind!r}, {len(self.mesh.faces)} triangles, "
                f"{'convex' if self.convex else 'not convex'}{', faceted' if self.faceted else ''})")

    def validate(self, name: str = "mesh") -> Stone:
        """This stone, after :func:`labcut.geometry.meshio.validate_mesh` of its mesh (closed,
        consistently wound, positive volume; a one-line :class:`MeshError` otherwise)."""
        validate_mesh(self.mesh, name)
        return self

    # ------------------------------------------------------------------ facts as plain data
    @property
    def record(self) -> Mapping[str, Any]:
        """The stone's whole record (read-only): what ``mesh.metadata["labcut"]`` holds."""
        return self._record

    def metadata(self) -> dict[str, Any]:
        """The record as a plain, mutable dict (a copy)."""
        return copy.deepcopy(_thawed(self._record))

    def provenance_dict(self) -> dict[str, Any]:
        """Where the stone came from and what was done to it (path, units, up axis, repairs, bodies,
        dimensions, a design's summary): plain JSON, the ``mesh`` block of every answer."""
        info = self._record
        out: dict[str, Any] = {k: _thawed(info[k]) for k in PROVENANCE_FIELDS if k in info}
        out.setdefault("kind", "given")  # built or loaded by the caller, not by labcut
        out.setdefault("units", "mm")
        out.setdefault("repairs", [])
        out.setdefault("bodies", int(info.get("bodies", 1)))
        out["dimensions_mm"] = [float(x) for x in extent(np.asarray(self.mesh.vertices, dtype=np.float64))]
        out["triangles"] = int(len(self.mesh.faces))
        if self.design is not None:  # a GemCad design: what it is and how it was sized
            out["design"] = design_provenance(_thawed(self.design))
        return out

    def facet_names(self) -> list[str]:
        """The facet name of each triangle of a design's mesh (``""`` for a stone that is not one)."""
        names = (self.design or {}).get("face_names")
        if names is None or len(names) != len(self.mesh.faces):
            return [""] * len(self.mesh.faces)
        return list(names)

    # ------------------------------------------------------------------ derived geometry, made once
    @property
    def shading_angle_deg(self) -> float:
        """The smooth-shading angle: 30° (curved domes smooth, step-cut junctions crisp), or 0.5°
        for a faceted design, whose facets meet at angles as gentle as a few degrees (a
        brilliant's pavilion mains: 7.6°) and must stay flat. The renderer and the flash
        estimator both shade with it."""
        return FACETED_ANGLE_DEG if self.faceted else SMOOTH_ANGLE_DEG

    def cached(self, key: str, build: Callable[[], Any]) -> Any:
        """``build()``, made once per stone and ``key`` and kept by the stone (the renderer's ray
        scenes, a stone's surface offset: geometry derived by a layer above this one)."""
        derived = self._derived
        if key not in derived:
            derived[key] = build()
        return derived[key]

    @property
    def digest(self) -> str:
        """A hash of the mesh's vertices (float64) and faces (int64), 32 hex digits: the key under which
        what is derived from this geometry is kept between processes (labcut's user cache;
        :func:`labcut.geometry.solid.mesh_digest`, made once per stone)."""
        return self.cached("digest", lambda: mesh_digest(self.mesh))

    @property
    def face_areas(self) -> np.ndarray:
        """Area of every face, mm² (read-only; trimesh's ``area_faces`` values)."""
        return self.cached("face_areas", lambda: face_areas(self.mesh))

    def smooth_split(self, angle_deg: float | None = None) -> Any:
        """The mesh split along edges sharper than ``angle_deg`` (default :attr:`shading_angle_deg`),
        whose vertex normals shade it as the renderer does (:func:`labcut.geometry.surface.smooth_split`)."""
        angle = self.shading_angle_deg if angle_deg is None else float(angle_deg)
        return self.cached(f"smooth_split_{angle:.6g}", lambda: smooth_split(self.mesh, angle, digest=self.digest))

    def surface_samples(self, count: int, seed: int, sampling: str = "stratified") -> SurfaceSamples:
        """``count`` area-uniform samples of the smooth-shaded surface drawn from
        ``numpy.random.default_rng(seed)`` (:func:`labcut.geometry.surface.draw_samples`; ``sampling``
        ``"stratified"`` or ``"random"``), once per count, seed and sampling: a recommendation's error
        bars and a repeated question reuse them."""
        count, seed = int(count), int(seed)
        angle = self.shading_angle_deg

        def build() -> SurfaceSamples:
            big = len(self.mesh.faces) > FAST_SMOOTH_FACES
            split = None if big else self.smooth_split(angle)
            cells = None
            if sampling == "stratified":  # the faces' Morton cells, once per stone and shading
                cells = self.cached(f"face_cells_{'mesh' if big else f'{angle:.6g}'}",
                                    lambda: face_cells(self.mesh if big else split))
            return draw_samples(self.mesh, count, seed, angle, self.convex, split=split,
                                areas=self.face_areas if big else None, sampling=sampling, cells=cells)

        return self.cached(f"surface_samples_{angle:.6g}_{count}_{seed}_{sampling}", build)


def facet_names(mesh: Any) -> list[str]:
    """The facet name of each triangle of a design's stone (``""`` for a stone that is not a design)."""
    return Stone.of(mesh).facet_names()


def by_facet(mesh: Any, values: Sequence[float] | np.ndarray) -> dict[str, float]:
    """Sum per-triangle ``values`` (e.g. flash area in mm²) by facet name, largest first.

    For a design's stone this says which facets carry a quantity, e.g. ``{"1": 12.3, "A": 4.5}``:
    the facets named 1 (the pavilion mains of the bundled brilliant) flash most.
    """
    vals = np.asarray(values, dtype=np.float64).ravel()
    names = facet_names(mesh)
    if len(vals) != len(names):
        raise ParameterError(f"by_facet needs one value per triangle ({len(names)}), got {len(vals)}")
    out: dict[str, float] = {}
    for n, x in zip(names, vals):
        out[n] = out.get(n, 0.0) + float(x)
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def mesh_of(obj: Any) -> Any:
    """The trimesh of a Stone, or ``obj`` itself (an API's entry: whatever it is, the API's own
    checks of a mesh then run on it, with their own messages)."""
    return obj.mesh if isinstance(obj, Stone) else obj
