"""Catalogues of ``labcut batch``: which cuts to run, with which material, scenario and settings.

A catalogue is a CSV file (a header row, then one cut per row; ``#`` lines are comments) or a
YAML file. Columns (only ``cut`` is required; an empty cell takes the batch's default)::

    name       a label for the row (default: the mesh file's name or the cabochon spec)
    cut        a mesh file (STL, OBJ, PLY, OFF, GLB/GLTF, 3MF), a GemCad design (.asc, .gem),
               both relative to the catalogue's folder, or a cabochon spec such as
               cab:oval,16x12,low (labcut.reports.cuts.parse_cab_spec)
    material   a preset name (blue, green, gold, red), a flash peak wavelength in nm (e.g. 505),
               or a material JSON file (Labradorite.to_dict); default: the batch's material
    scenario   a scenario name (bench, ring, pendant, ...) or a scenario JSON file
    quality    draft | standard | high
    objective  energy | area | intensity | balanced
    seed       surface-sampling seed, an integer >= 0
    units      a mesh file's length unit (auto, mm, cm, m, um, in, ft or mm per file unit)
    up_axis    a mesh file's face-up axis (auto, +Z, -Z, +Y, -Y, +X, -X)
    size       a GemCad design's girdle width, mm (default 10)
    max_tilt   largest allowed tilt of the lamella normal from +Z, degrees (default 90)

A YAML catalogue is a list of rows (mappings with the keys above), or a mapping with
``defaults`` (values for every row), ``rows`` (a list of rows) and/or ``grid`` (lists of values
whose every combination is a row: ``{cut: [a.ply, b.ply], scenario: [bench, ring]}`` is four).

:func:`read_catalog` checks the whole catalogue before any work: an unknown column, a missing
file, a bad value or a row repeated is a :class:`CatalogError` whose one line names the file,
the row and the column; every bad row is reported (the first :data:`MAX_REPORTED_ROWS` in the
message, one line each), not only the first. A CSV file whose quoted cell is never closed is
malformed, named with the line where the quote opens. What only running can tell (a mesh that
cannot be read, a cabochon that cannot be built) is a failed row of the results, not a
catalogue error. A material cell that peaks outside the visible range is a
:class:`~labcut.errors.LabcutWarning` naming its rows, not an error.

Every row gets a *key*: a hash of its resolved inputs (the mesh file's bytes, the cabochon
spec's parameters, the material's parameters, the scenario's name or file bytes, quality,
objective, seed, units, up axis, size, max tilt) and labcut's version. The results store
(:mod:`labcut.batch.store`) is keyed by it: a row whose key is stored is not run again; a
changed mesh file, setting or labcut version is a new key.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import LabcutError, LabcutWarning, ParameterError
from ..geometry.stone import Stone
from ..scene.quality import QUALITIES

COLUMNS = ("name", "cut", "material", "scenario", "quality", "objective", "seed", "units", "up_axis", "size", "max_tilt")
DESIGN_SUFFIXES = (".asc", ".gem")
CATALOG_SUFFIXES = (".csv", ".yaml", ".yml")
#: how many characters of the SHA-256 a row key keeps (80 bits: no collision in any catalogue)
KEY_CHARS = 20
#: bad rows a :class:`CatalogError` message lists (its ``problems`` holds them all)
MAX_REPORTED_ROWS = 20
#: rows a material warning names before it counts the rest
_NAMED_ROWS = 5


class CatalogError(ParameterError):
    """A catalogue cannot be run: unreadable, an unknown column, a missing file, a bad value.

    The message names the catalogue, the row and the column: one line for one problem; for
    several bad rows, a line that counts them, then one indented line per bad row (the first
    :data:`MAX_REPORTED_ROWS`, then how many more). ``problems``: every problem as its own
    one-line message, each starting with the catalogue's name."""

    def __init__(self, message: str, *, problems: Iterable[str] = ()) -> None:
        super().__init__(message)
        self.problems: tuple[str, ...] = tuple(problems) or (message,)


@dataclass(frozen=True)
class Defaults:
    """What an empty cell means: the batch's material (None: the default blue-green
    labradorite), scenario, quality, objective and seed."""

    material: Any = None
    scenario: str = "bench"
    quality: str = "standard"
    objective: str = "energy"
    seed: int = 0


@dataclass(frozen=True)
class Row:
    """One checked row of a catalogue, ready to run on any worker.

    ``index``: 1-based position in the catalogue; ``kind``: ``file`` (a mesh), ``design`` (a
    GemCad design) or ``cabochon`` (a spec); ``path``: the absolute path of a mesh or design;
    ``material``: the :class:`~labcut.Labradorite`; ``material_label``: as written (``default``
    when empty); ``scenario``: a scenario name or the absolute path of a scenario JSON file;
    ``size``: mm; ``max_tilt``: degrees; ``key``: the row's key (module docstring)."""

    index: int
    name: str
    cut: str
    kind: str
    path: str | None
    material: Any
    material_label: str
    scenario: str
    quality: str
    objective: str
    seed: int
    units: str | float
    up_axis: str
    size: float | None
    max_tilt: float
    key: str = ""
    cab: dict[str, Any] | None = None

    def recommend_kwargs(self) -> dict[str, Any]:
        """The keyword arguments of :func:`labcut.recommend_orientation` for this row (all but the mesh)."""
        return {"material": self.material, "scenario": self.scenario, "quality": self.quality,
                "objective": self.objective, "seed": self.seed, "max_tilt": self.max_tilt}

    def load_mesh(self) -> Any:
        """The row's stone as a ``trimesh.Trimesh`` (mm, +Z face-up), read or built as the CLI does."""
        if self.kind == "cabochon":
            from ..geometry.cabochon import cabochon

            return Stone(cabochon(**dict(self.cab or {})), source=self.cut).mesh
        from ..geometry.meshio import load_mesh

        return load_mesh(self.path, units=self.units, up_axis=self.up_axis, size=self.size if self.kind == "design" else None)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON of the row's inputs (the material as its parameters)."""
        return {"row": self.index, "name": self.name, "cut": self.cut, "kind": self.kind, "path": self.path,
                "material": self.material_label, "material_parameters": self.material.to_dict(),
                "scenario": self.scenario, "quality": self.quality, "objective": self.objective, "seed": self.seed,
                "units": self.units, "up_axis": self.up_axis, "size": self.size, "max_tilt": self.max_tilt, "key": self.key}


@dataclass
class Catalog:
    """A checked catalogue: its file (None for rows given in Python) and its rows."""

    path: Path | None
    rows: list[Row] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.rows)

    @property
    def label(self) -> str:
        return str(self.path) if self.path is not None else "catalogue"


# ---------------------------------------------------------------------- reading
def _fail(where: str, message: str) -> CatalogError:
    return CatalogError(" ".join(f"{where}: {message}".split()))


#: a row as a reader hands it on: where it is (``line 3``, ``row 2``) and its cells, or why it
#: cannot be read (checked with the others, so that every bad row is reported)
RawRow = tuple[str, dict[str, Any] | CatalogError]


def _unclosed_quote(lines: list[tuple[int, str]]) -> int | None:
    """The number of the line where a quoted cell opens that no quote closes, or None.

    The csv module's own rules: a quote opens a quoted cell only as the cell's first
    character; inside one, ``""`` is a literal quote, a lone ``"`` closes it, and a line end
    belongs to the cell. csv itself reads an unclosed cell to the end of the file, taking
    every later row into it, and says nothing."""
    opened: int | None = None
    quoted = False
    for number, line in lines:
        at_start, i = not quoted, 0
        while i < len(line):
            char = line[i]
            if quoted:
                if char == '"':
                    if line[i + 1:i + 2] == '"':
                        i += 1  # "" inside a quoted cell: a literal quote
                    else:
                        quoted = False
            elif char == ",":
                at_start = True
                i += 1
                continue
            elif char == '"' and at_start:
                quoted, opened = True, number
            at_start = False
            i += 1
    return opened if quoted else None


def _read_csv(path: Path, text: str) -> list[RawRow]:
    where = f"catalogue {str(path)!r}"
    lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise _fail(where, "is empty; it needs a header row (e.g. cut,material,scenario) and one row per cut")
    opened = _unclosed_quote(lines)
    if opened is not None:
        raise _fail(f"{where}, line {opened}", 'is malformed CSV: a quoted cell opens here and no " closes it, so '
                    'every line after it would be read into that cell; close the quote, or remove it')
    consumed = 0  # lines handed to the reader so far: a record that spans lines is numbered by its first

    def feed() -> Iterable[str]:
        nonlocal consumed
        for _, line in lines:
            consumed += 1
            yield line + "\n"

    reader = csv.reader(feed())
    records: list[tuple[int, list[str]]] = []
    try:
        while consumed < len(lines):
            first = lines[consumed][0]
            cells = next(reader, None)
            if cells is None:
                break
            records.append((first, cells))
    except csv.Error as exc:
        raise _fail(f"{where}, line {lines[max(consumed - 1, 0)][0]}", f"is not readable CSV ({exc})") from None
    header_line, header_cells = records[0]
    header = [h.strip().lower() for h in header_cells]
    _check_columns(header, f"{where}, header (line {header_line})")
    if "cut" not in header:
        raise _fail(f"{where}, header (line {header_line})",
                    "has no 'cut' column (a mesh file, a GemCad design or a cab: spec per row)")
    rows: list[RawRow] = []
    for lineno, cells in records[1:]:
        if len(cells) > len(header):
            rows.append((f"line {lineno}", _fail(f"{where}, line {lineno}",
                                                 f"has {len(cells)} cells but the header names {len(header)} columns")))
            continue
        values = {h: c.strip() for h, c in zip(header, cells) if c.strip() != ""}
        rows.append((f"line {lineno}", values))
    if not rows:
        raise _fail(where, "has a header but no rows")
    return rows


def _check_columns(names: Iterable[Any], where: str) -> None:
    seen = set()
    for name in names:
        key = str(name).strip().lower()
        if key not in COLUMNS:
            raise _fail(where, f"unknown column {str(name)!r}; the columns are {', '.join(COLUMNS)}")
        if key in seen:
            raise _fail(where, f"column {key!r} is given twice")
        seen.add(key)


def _mapping(item: Any, where: str) -> dict[str, Any]:
    if not isinstance(item, Mapping):
        raise _fail(where, f"must be a mapping of column: value, got {type(item).__name__}")
    _check_columns(item.keys(), where)
    return {str(k).strip().lower(): v for k, v in item.items() if v is not None and str(v).strip() != ""}


def _listed_row(item: Any, where: str, defaults: Mapping[str, Any] | None = None) -> dict[str, Any] | CatalogError:
    """A listed row's cells over ``defaults``, or the :class:`CatalogError` that says why it is not a row."""
    try:
        return {**(defaults or {}), **_mapping(item, where)}
    except CatalogError as exc:
        return exc


def _read_yaml(path: Path, text: str) -> list[RawRow]:
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise _fail(f"catalogue {str(path)!r}", f"is not readable YAML ({str(exc).splitlines()[0]})") from None
    where = f"catalogue {str(path)!r}"
    defaults: dict[str, Any] = {}
    listed: list[Any] = []
    grid: dict[str, Any] = {}
    if isinstance(data, list):
        listed = data
    elif isinstance(data, Mapping):
        unknown = sorted(set(map(str, data)) - {"defaults", "rows", "grid"})
        if unknown:
            raise _fail(where, f"unknown top-level key {unknown[0]!r}; a YAML catalogue holds defaults, rows and/or grid")
        defaults = _mapping(data.get("defaults") or {}, f"{where}, defaults")
        listed = data.get("rows") or []
        grid = data.get("grid") or {}
        if not isinstance(listed, list):
            raise _fail(where, "'rows' must be a list of rows")
        if not isinstance(grid, Mapping):
            raise _fail(where, "'grid' must map columns to lists of values")
    else:
        raise _fail(where, "must hold a list of rows or a mapping with defaults, rows and/or grid")
    rows: list[RawRow] = [(f"row {k}", _listed_row(item, f"{where}, row {k}", defaults)) for k, item in enumerate(listed, start=1)]
    if grid:
        _check_columns(grid.keys(), f"{where}, grid")
        columns = [str(k).strip().lower() for k in grid]
        values = [v if isinstance(v, list) else [v] for v in grid.values()]
        for c, v in zip(columns, values):
            if not v:
                raise _fail(f"{where}, grid, column {c!r}", "is an empty list")
        for k, combo in enumerate(itertools.product(*values), start=1):
            rows.append((f"grid row {k}", {**defaults, **{c: x for c, x in zip(columns, combo) if x is not None}}))
    if not rows:
        raise _fail(where, "has no rows")
    return rows


# ---------------------------------------------------------------------- checking one row
def _file_digest(path: Path, cache: dict[str, str]) -> str:
    key = str(path)
    if key not in cache:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
        cache[key] = h.hexdigest()
    return cache[key]


def _local_file(text: str, base: Path, what: str) -> Path:
    p = Path(os.path.expanduser(text))
    p = p if p.is_absolute() else base / p
    if not p.exists():
        raise ParameterError(f"{what} {text!r} does not exist (looked for {str(p)!r})")
    if not p.is_file():
        raise ParameterError(f"{what} {text!r} is not a file")
    return p.resolve()


def _material(value: Any, base: Path, default: Any) -> tuple[Any, str, dict[str, Any]]:
    """(Labradorite, label, what the key hashes) of a material cell."""
    from ..physics.material import Labradorite

    if value is None:
        lab = Labradorite.coerce(default)
        label = default if isinstance(default, str) else (lab.name or "default")
        return lab, str(label), lab.to_dict()
    if isinstance(value, bool):
        raise ParameterError(f"must be a preset name, a peak wavelength in nm or a material JSON file, got {value!r}")
    if isinstance(value, int | float):
        text = repr(value)
    else:
        text = str(value).strip()
    try:
        nm = float(text)
    except ValueError:
        nm = None
    if nm is not None:
        lab = Labradorite.from_peak_wavelength(nm)
        return lab, f"{nm:g} nm", lab.to_dict()
    if text.lower().endswith(".json"):
        from ..fileio import read_json

        p = _local_file(text, base, "material file")
        data = read_json(p, "material file")
        if isinstance(data, dict) and isinstance(data.get("material"), dict):
            data = data["material"]
        elif isinstance(data, dict) and isinstance(data.get("settings"), dict) and isinstance(data["settings"].get("material"), dict):
            data = data["settings"]["material"]
        if not isinstance(data, dict):
            raise ParameterError(f"material file {text!r} must hold a JSON object")
        lab = Labradorite.from_dict(data)
        return lab, text, lab.to_dict()
    lab = Labradorite.preset(text)
    return lab, text.lower(), lab.to_dict()


def _scenario(value: Any, base: Path, quality: str, digests: dict[str, str]) -> tuple[str, dict[str, Any]]:
    """(what recommend_orientation takes, what the key hashes) of a scenario cell."""
    from ..scene import scenario_from

    text = str(value).strip()
    if text.lower().endswith(".json"):
        p = _local_file(text, base, "scenario file")
        scenario_from(str(p), quality)
        return str(p), {"file_sha256": _file_digest(p, digests)}
    scen = scenario_from(text, quality)
    return text.lower(), {"name": scen.name}


def _cut(value: Any, base: Path, digests: dict[str, str]) -> tuple[str, str | None, dict[str, Any] | None, dict[str, Any]]:
    """(kind, absolute path, cabochon keywords, what the key hashes) of a cut cell."""
    from ..geometry.meshio import READ_FORMATS
    from ..reports.cuts import CAB_PREFIX, parse_cab_spec

    text = str(value).strip()
    if text.lower().startswith(CAB_PREFIX):
        from ..geometry.outlines import OUTLINES, check_size

        kwargs = parse_cab_spec(text)
        if kwargs["outline"] not in (*OUTLINES, "navette"):
            raise ParameterError(f"unknown outline {kwargs['outline']!r} in {text!r}; choose one of {', '.join(OUTLINES)}")
        for dim in ("length", "width"):
            if dim in kwargs:
                check_size(dim, kwargs[dim])
        return "cabochon", None, kwargs, {"cabochon": kwargs}
    suffix = Path(text).suffix.lower()
    if suffix not in (*READ_FORMATS, *DESIGN_SUFFIXES):
        raise ParameterError(
            f"{text!r} is neither a mesh ({', '.join(READ_FORMATS)}), a GemCad design (.asc, .gem) nor a cabochon "
            "spec such as cab:oval,16x12,low"
        )
    p = _local_file(text, base, "mesh file" if suffix in READ_FORMATS else "design file")
    kind = "design" if suffix in DESIGN_SUFFIXES else "file"
    return kind, str(p), None, {"file_sha256": _file_digest(p, digests), "suffix": suffix}


def _integer(value: Any, low: int) -> int:
    if isinstance(value, bool):
        raise ParameterError(f"must be an integer >= {low}, got {value!r}")
    try:
        number = float(str(value).strip())
    except ValueError:
        raise ParameterError(f"must be an integer >= {low}, got {value!r}") from None
    if not math.isfinite(number) or number != int(number) or number < low:
        raise ParameterError(f"must be an integer >= {low}, got {value!r}")
    return int(number)


def _number(value: Any, low: float, high: float, unit: str) -> float:
    if isinstance(value, bool):
        raise ParameterError(f"must be a number of {unit}, got {value!r}")
    try:
        number = float(str(value).strip())
    except ValueError:
        raise ParameterError(f"must be a number of {unit}, got {value!r}") from None
    if not math.isfinite(number) or not low < number <= high:
        raise ParameterError(f"must be a number of {unit} in ({low:g}, {high:g}], got {value!r}")
    return number


def check_row(values: Mapping[str, Any], index: int, where: str, base: Path, defaults: Defaults,
              digests: dict[str, str] | None = None) -> Row:
    """One row (column -> cell) checked and resolved; a bad cell is a :class:`CatalogError`
    whose message starts with ``where`` and names the column."""
    from .. import __version__
    from ..geometry.meshio import units_scale
    from ..geometry.orient import check_up_axis
    from ..orientation.scoring import OBJECTIVES

    digests = {} if digests is None else digests
    cell = dict(values)

    def column(name: str, check: Any) -> Any:
        try:
            return check(cell.get(name))
        except CatalogError:
            raise
        except LabcutError as exc:
            raise _fail(f"{where}, column {name!r}", str(exc)) from None

    if cell.get("cut") is None:
        raise _fail(f"{where}, column 'cut'", "is empty; give a mesh file, a GemCad design or a cab: spec")
    quality = column("quality", lambda v: _choice(defaults.quality if v is None else v, QUALITIES))
    objective = column("objective", lambda v: _choice(defaults.objective if v is None else v, OBJECTIVES))
    seed = column("seed", lambda v: _integer(defaults.seed if v is None else v, 0))
    kind, path, cab, cut_key = column("cut", lambda v: _cut(v, base, digests))
    material, material_label, material_key = column("material", lambda v: _material(v, base, defaults.material))
    scenario, scenario_key = column("scenario", lambda v: _scenario(defaults.scenario if v is None else v, base, quality, digests))
    units: str | float = column("units", lambda v: _units(v, units_scale))
    up_axis = column("up_axis", lambda v: check_up_axis("auto" if v is None else str(v)))
    size = column("size", lambda v: None if v is None else _number(v, 0.0, 500.0, "mm"))
    max_tilt = column("max_tilt", lambda v: 90.0 if v is None else _number(v, 0.0, 90.0, "degrees"))
    if kind == "cabochon" and (cell.get("units") is not None or cell.get("up_axis") is not None or size is not None):
        raise _fail(f"{where}, column 'cut'", "a cabochon spec is built in mm, +Z face-up: units, up_axis and size do not apply")
    if kind == "design" and cell.get("units") is not None:
        raise _fail(f"{where}, column 'units'", "a GemCad design has no unit; give its girdle width in mm as size")
    if kind == "file" and size is not None:
        raise _fail(f"{where}, column 'size'", "size is a GemCad design's girdle width; a mesh file takes units")
    cut_text = str(cell["cut"]).strip()
    name = str(cell.get("name") or (cut_text if kind == "cabochon" else Path(cut_text).name))
    inputs = {"labcut": __version__, "cut": cut_key, "material": material_key, "scenario": scenario_key,
              "quality": quality, "objective": objective, "seed": seed, "units": units, "up_axis": up_axis,
              "size": size, "max_tilt": max_tilt}
    key = hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()[:KEY_CHARS]
    return Row(index, name, str(cell["cut"]).strip(), kind, path, material, material_label, scenario, quality, objective,
               seed, units, up_axis, size, max_tilt, key, cab)


def _choice(value: Any, choices: tuple[str, ...]) -> str:
    key = str(value).strip().lower()
    if key not in choices:
        raise ParameterError(f"must be one of {', '.join(choices)}, got {value!r}")
    return key


def _units(value: Any, scale: Any) -> str | float:
    if value is None or str(value).strip().lower() == "auto":
        return "auto"
    text = str(value).strip()
    try:
        unit: str | float = float(text)
    except ValueError:
        unit = text.lower()
    scale(unit)
    return unit


# ---------------------------------------------------------------------- the catalogue
def read_catalog(catalog: Any, defaults: Defaults | None = None, base: str | os.PathLike[str] | None = None) -> Catalog:
    """Read and check a whole catalogue before any work.

    ``catalog``: a CSV or YAML file, a :class:`Catalog` (returned as is), or rows given in
    Python (a list of mappings column -> value; relative paths are taken from ``base``,
    default the current folder). ``defaults``: what empty cells mean. Raises a
    :class:`CatalogError` naming the catalogue, the row and the column of every bad row (one
    line for one, a line per row for several: the first :data:`MAX_REPORTED_ROWS`; all in its
    ``problems``); a file that cannot be read as a whole (not CSV or YAML, an unknown column
    in the header, a quote never closed) is one line. A material cell whose flash peaks
    outside the visible range gives one :class:`~labcut.errors.LabcutWarning` per material,
    naming its rows.
    """
    defaults = defaults or Defaults()
    if isinstance(catalog, Catalog):
        return catalog
    if isinstance(catalog, str | os.PathLike):
        path = Path(catalog)
        if path.suffix.lower() not in CATALOG_SUFFIXES:
            raise CatalogError(f"catalogue {str(path)!r} must be a CSV (.csv) or YAML (.yaml, .yml) file")
        try:
            text = path.read_text(encoding="utf-8-sig")
        except FileNotFoundError:
            raise CatalogError(f"catalogue {str(path)!r} does not exist") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise CatalogError(f"catalogue {str(path)!r} cannot be read ({getattr(exc, 'strerror', None) or exc})") from None
        raw = _read_csv(path, text) if path.suffix.lower() == ".csv" else _read_yaml(path, text)
        folder, label = path.resolve().parent, f"catalogue {str(path)!r}"
    elif isinstance(catalog, Iterable) and not isinstance(catalog, Mapping):
        items = list(catalog)
        raw = [(f"row {k}", _listed_row(item, f"catalogue, row {k}")) for k, item in enumerate(items, start=1)]
        if not raw:
            raise CatalogError("the catalogue has no rows")
        path, folder, label = None, Path(base or ".").resolve(), "catalogue"
    else:
        raise CatalogError(f"a catalogue is a CSV or YAML file or a list of rows, got {type(catalog).__name__}")
    digests: dict[str, str] = {}
    rows: list[Row] = []
    first: dict[str, str] = {}
    problems: list[str] = []
    invisible: dict[str, list[str]] = {}  # a material's visibility note -> the rows whose cell gives it
    for index, (where, values) in enumerate(raw, start=1):
        if isinstance(values, CatalogError):
            problems.append(str(values))
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", LabcutWarning)
            try:
                row: Row | None = check_row(values, index, f"{label}, {where}", folder, defaults, digests)
            except CatalogError as exc:
                row, problem = None, str(exc)
        # the material's own warning of a flash outside the visible is given once below, naming
        # every row with that material; other warnings go on
        note = None if row is None else row.material.visibility_note()
        for w in caught:
            if not (issubclass(w.category, LabcutWarning) and str(w.message) == note):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        if row is None:
            problems.append(problem)
            continue
        if row.key in first:
            problems.append(str(_fail(f"{label}, {where}", f"repeats {first[row.key]} (same cut and settings); each row runs once")))
            continue
        first[row.key] = where
        rows.append(row)
        if note is not None and values.get("material") is not None:  # not the batch's default: its caller's
            invisible.setdefault(note, []).append(where)
    if problems:
        raise _bad_rows(label, problems)
    for text, wheres in invisible.items():
        named = ", ".join(wheres[:_NAMED_ROWS]) + (f" and {len(wheres) - _NAMED_ROWS} more" if len(wheres) > _NAMED_ROWS else "")
        warnings.warn(f"{label}, {named}, column 'material': {text}", LabcutWarning, stacklevel=2)
    return Catalog(path, rows)


def _bad_rows(label: str, problems: list[str]) -> CatalogError:
    """One :class:`CatalogError` for every bad row of a catalogue: the problem itself when there
    is one; else a line that counts them and one indented line per row, without the catalogue's
    name each repeats, the first :data:`MAX_REPORTED_ROWS` of them."""
    if len(problems) == 1:
        return CatalogError(problems[0])
    prefix = f"{label}, "
    lines = [f"{label} has {len(problems)} bad rows:"]
    lines += ["  " + (p[len(prefix):] if p.startswith(prefix) else p) for p in problems[:MAX_REPORTED_ROWS]]
    if len(problems) > MAX_REPORTED_ROWS:
        lines.append(f"  ... and {len(problems) - MAX_REPORTED_ROWS} more bad rows")
    return CatalogError("\n".join(lines), problems=problems)


__all__ = ["COLUMNS", "MAX_REPORTED_ROWS", "Catalog", "CatalogError", "Defaults", "Row", "check_row", "read_catalog"]
