"""The cuts a comparison holds: mesh files, meshes built in Python, or cabochon specs.

A *cut* is given as

* a mesh path (STL, OBJ, PLY, OFF, GLB/GLTF, 3MF), read with :func:`labcut.load_mesh`
  (``units``, ``up_axis`` as there); its name is the file name;
* a GemCad design (``.asc``, ``.gem``), cut into its stone at ``size`` (its girdle width, mm),
  or at its own size written ``DESIGN@SIZE`` (``SRB.asc@8``, named so): the same design at
  two sizes is two cuts. Flash shares are scale-free (geometric optics), so two sizes of one
  design tie on every share; their weights and flash areas in mm² differ;
* a ``trimesh.Trimesh`` (mm, +Z face-up), checked with
  :func:`labcut.geometry.meshio.validate_mesh`; its name is ``metadata["name"]`` or ``mesh N``;
* a cabochon spec, built with :func:`labcut.cabochon` so that dome heights and outlines can
  be compared without building files::

      cab:OUTLINE,SIZE[,DOME][,key=value ...]

      cab:oval,16x12,low              16 x 12 mm oval, low dome (0.20 x the width)
      cab:round,12,high,profile=spherical
      cab:oval,16x12,2.5,girdle=0.5   a 2.5 mm dome over a 0.5 mm girdle band
      cab:cushion,14x10,medium,buff_top=0.5,res=128

  ``OUTLINE``: round, oval, cushion, pear, marquise (navette), rectangle. ``SIZE``: length x
  width in mm (``LxW``), or one number for a round stone. ``DOME``: low, medium (default),
  high, or a height in mm. Keys: ``profile`` (elliptic, spherical, tallow), ``girdle`` (mm),
  ``base`` (flat, or a lower dome: low/medium/high/mm), ``buff_top`` (table fraction),
  ``corner`` (rectangle corner radius, mm), ``res`` (points around the outline);
  its name is the spec as written;
* a ``(name, cut)`` pair, or a mapping ``{name: cut}``, to name any of the above.

Names are told apart: a second ``oval.ply`` becomes ``oval.ply (2)``. Every cut is resolved
(specs parsed, files read, meshes checked) before any long work; a bad one is a
:class:`~labcut.errors.ParameterError` or :class:`~labcut.errors.MeshError` whose one-line
message names it (``cut 2 ('cab:ovl,16x12'): unknown outline ...``).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import LabcutError, LabcutWarning, ParameterError
from ..geometry.gemcad import DEFAULT_SIZE_MM
from ..geometry.stone import Stone
from ..validation import check_number, name_or_mm

CAB_PREFIX = "cab:"
#: spec keys -> :func:`labcut.cabochon` keywords
CAB_KEYS = {
    "profile": "profile",
    "girdle": "girdle",
    "base": "base",
    "buff_top": "buff_top",
    "buff-top": "buff_top",
    "corner": "corner_radius",
    "res": "resolution",
}
DOME_NAMES = ("low", "medium", "high")


@dataclass
class Cut:
    """One cut of a comparison: a validated mesh (mm, +Z face-up) and where it came from.

    ``kind``: ``"file"`` (read from ``source``), ``"cabochon"`` (built from the spec
    ``source``) or ``"mesh"`` (a ``trimesh.Trimesh`` given in Python, ``source`` None).
    ``design``: the cut's design parameters in mm: ``length_mm``, ``width_mm`` (bounding box
    along X and Y), ``height_mm`` (along Z; the dome plus any girdle for a flat-based
    cabochon), for cabochon specs ``outline``, ``dome_mm``, ``profile``, ``girdle_mm``, and for
    GemCad designs ``girdle_width_mm`` (the size it was cut at).
    ``warnings``: what loading the file warned about (a turned mesh, units)."""

    name: str
    mesh: Any
    kind: str
    source: str | None = None
    design: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: name, kind, source, design parameters, warnings (not the mesh)."""
        return {"name": self.name, "kind": self.kind, "source": self.source, "design": dict(self.design),
                "warnings": list(self.warnings)}


def _number(text: str, what: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ParameterError(f"{what} must be a number of mm in {spec!r}, got {text!r}") from None
    if not np.isfinite(value):
        raise ParameterError(f"{what} must be finite in {spec!r}, got {text!r}")
    return value


def parse_cab_spec(spec: str) -> dict[str, Any]:
    """The :func:`labcut.cabochon` keywords of a ``cab:OUTLINE,SIZE[,DOME][,key=value ...]`` spec.

    Sizes are in mm. Raises :class:`~labcut.errors.ParameterError` (one line, naming the spec)
    for a malformed spec; the values themselves are checked by :func:`labcut.cabochon`.

    >>> parse_cab_spec("cab:oval,16x12,low")
    {'outline': 'oval', 'length': 16.0, 'width': 12.0, 'dome': 'low'}
    """
    if not isinstance(spec, str) or not spec.lower().startswith(CAB_PREFIX):
        raise ParameterError(f"a cabochon spec starts with {CAB_PREFIX!r}, got {spec!r}")
    body = spec[len(CAB_PREFIX):]
    parts = [p.strip() for p in body.split(",")]
    if len(parts) < 2 or not parts[0] or not parts[1]:
        raise ParameterError(f"cabochon spec {spec!r} needs at least an outline and a size, e.g. cab:oval,16x12,low")
    kwargs: dict[str, Any] = {"outline": parts[0].lower()}
    size = parts[1].lower().replace("×", "x")
    if "x" in size:
        dims = size.split("x")
        if len(dims) != 2:
            raise ParameterError(f"size must be LENGTHxWIDTH in mm in {spec!r}, got {parts[1]!r}")
        kwargs["length"] = _number(dims[0], "length", spec)
        kwargs["width"] = _number(dims[1], "width", spec)
    else:
        kwargs["length"] = _number(size, "size", spec)
        if kwargs["outline"] != "round":
            raise ParameterError(f"{spec!r}: {kwargs['outline']} cabochons need LENGTHxWIDTH in mm (one number is a round's diameter)")
    rest = parts[2:]
    if rest and "=" not in rest[0]:
        kwargs["dome"] = name_or_mm(rest[0], DOME_NAMES, "dome", spec)
        rest = rest[1:]
    for item in rest:
        key, sep, value = item.partition("=")
        key = key.strip().lower()
        if not sep or key not in CAB_KEYS:
            raise ParameterError(
                f"unknown part {item!r} in {spec!r}; after OUTLINE,SIZE[,DOME] come key=value pairs with keys "
                f"{', '.join(k for k in CAB_KEYS if k != 'buff-top')}"
            )
        target = CAB_KEYS[key]
        if target in kwargs:
            raise ParameterError(f"{key!r} given twice in {spec!r}")
        value = value.strip()
        if target == "profile":
            kwargs[target] = value.lower()
        elif target == "base":
            kwargs[target] = "flat" if value.lower() == "flat" else name_or_mm(value, DOME_NAMES, "base", spec)
        elif target == "resolution":
            kwargs[target] = check_number(value, f"res in {spec!r}", 1, integer=True)
        else:
            kwargs[target] = _number(value, key, spec)
    return kwargs


def _design(mesh: Any, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    ext = np.ptp(np.asarray(mesh.vertices, dtype=np.float64), axis=0)
    out: dict[str, Any] = {"length_mm": float(ext[0]), "width_mm": float(ext[1]), "height_mm": float(ext[2])}
    out.update(extra or {})
    return out


def _label(item: Any, position: int) -> str:
    """How an error names a cut: its spec or path, a mesh's name, or the type given."""
    if isinstance(item, str | os.PathLike):
        return str(item)
    if isinstance(item, Cut):
        return item.name
    if isinstance(item, Stone):
        return item.name or f"mesh {position}"
    if hasattr(item, "faces") and hasattr(item, "vertices"):
        return str((getattr(item, "metadata", None) or {}).get("name") or f"mesh {position}")
    return type(item).__name__


#: file suffixes of GemCad designs (sized by ``size``, their girdle width in mm)
DESIGN_SUFFIXES = (".asc", ".gem")


def _resolve_one(item: Any, position: int, units: Any, up_axis: str, size: float | None = None) -> Cut:
    """One cut (not yet told apart from the others' names)."""
    import trimesh

    from ..geometry.meshio import load_mesh, validate_mesh

    if isinstance(item, Cut):
        validate_mesh(item.mesh, item.name)
        return replace(item, design=dict(item.design), warnings=list(item.warnings))
    if isinstance(item, Stone | trimesh.Trimesh):
        stone = Stone.of(item)
        name = stone.name or f"mesh {position}"
        validate_mesh(stone.mesh, name)
        return Cut(name, stone.mesh, "mesh", None, _design(stone.mesh))
    if isinstance(item, str) and item.lower().startswith(CAB_PREFIX):
        from ..geometry.cabochon import cabochon

        kwargs = parse_cab_spec(item)
        stone = Stone(cabochon(**kwargs), source=item)
        extra = {k: stone.shape.get(k) for k in ("outline", "dome_mm", "profile", "girdle_mm")}
        return Cut(item, stone.mesh, "cabochon", item, _design(stone.mesh, extra))
    if isinstance(item, str | os.PathLike):
        path, own_size = split_size(item)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", LabcutWarning)
            design = path.suffix.lower() in DESIGN_SUFFIXES
            given = own_size if own_size is not None else size
            mesh = load_mesh(path, units=units, up_axis=up_axis, size=given if design else None)
        notes = [str(w.message) for w in caught if issubclass(w.category, LabcutWarning)]
        name = path.name if own_size is None else f"{path.name}@{own_size:g}"
        extra = {"girdle_width_mm": given if given is not None else DEFAULT_SIZE_MM} if design else None
        return Cut(name, mesh, "file", str(item), _design(mesh, extra), notes)
    raise ParameterError(
        f"a cut must be a mesh path, a cabochon spec like 'cab:oval,16x12,low', a trimesh.Trimesh or a (name, cut) pair, "
        f"got {type(item).__name__}"
    )


def split_size(item: str | os.PathLike[str]) -> tuple[Path, float | None]:
    """A cut file and its own size: ``SRB.asc@8`` is the design SRB.asc cut 8 mm across its girdle
    (its ``size``, beside --size for all); a path that exists as written is that file (no size).
    Only GemCad designs (.asc, .gem) take a size: a mesh has its own, in its units."""
    text = os.fspath(item)
    base, at, tail = str(text).rpartition("@")
    if not at or Path(text).exists() or not base:
        return Path(text), None
    path = Path(base)
    if path.suffix.lower() not in DESIGN_SUFFIXES:
        raise ParameterError(f"{text!r}: @SIZE is the girdle width (mm) of a GemCad design (.asc, .gem); "
                             f"{path.name} is a mesh, which keeps its own size (give its unit with --units)")
    try:
        value = float(tail.strip().lower().removesuffix("mm"))
    except ValueError:
        raise ParameterError(f"{text!r}: @SIZE must be a girdle width in mm, e.g. {path.name}@8, got {tail!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(f"{text!r}: @SIZE must be a positive girdle width in mm, got {tail!r}")
    return path, value


def unique_names(names: Iterable[str]) -> list[str]:
    """Tell equal names apart: the first keeps its name, later ones get `` (2)``, `` (3)``, ...

    >>> unique_names(["a.ply", "b.ply", "a.ply"])
    ['a.ply', 'b.ply', 'a.ply (2)']
    """
    names = list(names)
    taken = set(names)
    seen: dict[str, int] = {}
    out = []
    for name in names:
        count = seen.get(name, 0) + 1
        seen[name] = count
        if count == 1:
            out.append(name)
            continue
        k = count
        candidate = f"{name} ({k})"
        while candidate in taken:
            k += 1
            candidate = f"{name} ({k})"
        taken.add(candidate)
        out.append(candidate)
    return out


def resolve_cuts(cuts: Any, units: str | float = "auto", up_axis: str = "auto", size: float | None = None) -> list[Cut]:
    """Resolve every cut (see the module docstring) before any long work starts.

    ``cuts``: a sequence of cuts, or a mapping ``{name: cut}``. ``units`` and ``up_axis`` apply
    to mesh files (:func:`labcut.load_mesh`); ``size`` (mm) is the girdle width of every GemCad
    design among them (``.asc``, ``.gem``; default :data:`labcut.geometry.gemcad.DEFAULT_SIZE_MM`). Warnings from loading a file are kept on the
    :class:`Cut` and issued again as :class:`~labcut.errors.LabcutWarning`, prefixed with the
    cut's name. Raises a one-line :class:`~labcut.errors.ParameterError` /
    :class:`~labcut.errors.MeshError` naming the first bad cut (``cut 2 ('x.stl'): ...``).
    """
    if isinstance(cuts, Mapping):
        items: list[Any] = list(cuts.items())
    elif isinstance(cuts, str | os.PathLike) or not isinstance(cuts, Iterable):
        raise ParameterError("cuts must be a list of cuts (mesh paths, cabochon specs, meshes), not a single one")
    else:
        items = list(cuts)
    if not items:
        raise ParameterError("give at least one cut to compare")
    def design_file(x: Any) -> bool:
        x = x[1] if isinstance(x, tuple) and len(x) == 2 else x
        return isinstance(x, str | os.PathLike) and Path(os.fspath(x).rpartition("@")[0] or x).suffix.lower() in DESIGN_SUFFIXES

    if size is not None and not any(design_file(x) for x in items):
        raise ParameterError("--size (size=) is the girdle width of a GemCad design (.asc, .gem); no cut is one")
    resolved: list[Cut] = []
    fresh: list[bool] = []  # read or built here (not a Cut given again): its warnings are new
    for k, item in enumerate(items, start=1):
        given_name = None
        if isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str):
            given_name, item = item
            if not given_name.strip():
                raise ParameterError(f"cut {k}: its name is empty")
        try:
            cut = _resolve_one(item, k, units, up_axis, size)
        except LabcutError as exc:
            label = given_name or _label(item, k)
            raise type(exc)(f"cut {k} ({label!r}): {exc}") from None
        if given_name is not None:
            cut.name = given_name
        resolved.append(cut)
        fresh.append(not isinstance(item, Cut))
    for cut, name in zip(resolved, unique_names(c.name for c in resolved)):
        cut.name = name
    for cut, new in zip(resolved, fresh):
        if new:
            for message in cut.warnings:
                warnings.warn(f"{cut.name}: {message}", LabcutWarning, stacklevel=2)
    return resolved


__all__ = ["CAB_PREFIX", "Cut", "parse_cab_spec", "resolve_cuts", "split_size", "unique_names"]
