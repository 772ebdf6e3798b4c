"""Faceted designs: GemCad ``.asc`` and ``.gem`` files read into one design model and cut into a solid.

GemCad keeps a faceted design as a list of **tiers**; a tier is one cutting angle and one
centre-to-facet distance, cut at one or more **indices** of the index gear. A design is
dimensionless: only the ratios of the distances matter.

Design frame (GemCad's, kept by labcut): the dop axis is Z, the crown (positive angles) at
+Z; index 0 (written as the gear, e.g. 96) points to +Y (the top of GemCad's drawings) and
indices run clockwise seen from above, so index 24 of 96 points to +X. A facet at index
``i`` has the azimuth (from +X towards +Y)

    phi = 90 deg - (i - location) * 360 deg / gear

where ``gear`` may be negative (the indices then run anticlockwise) and ``location`` (the
``g`` record's second number, in index units) rotates the whole design. A facet at signed
angle ``a`` (crown ``a > 0``, pavilion ``a < 0``, written ``-0`` for a flat culet, ``+-90``
for the girdle) has the outward normal ``n = (sin|a| cos phi, sin|a| sin phi, +-cos a)``
and the plane ``n . x = d``. labcut keeps every facet as its **pole** ``p = n / d``: the
stone is ``{x : p . x <= 1 for every facet}``, which always holds the centre. A negative
distance therefore flips the facet to the opposite normal: a 0 deg tier at a negative
distance is a culet, as GemCad writes it. The binary ``.gem`` stores exactly these poles.

:func:`design_polyhedron` intersects the half-spaces (the dual convex hull of the poles,
:class:`scipy.spatial.ConvexHull`, gives the vertices exactly; their hull gives the faces)
and :func:`design_solid` scales it to a girdle width in mm, certifies it with manifold3d
and puts it in labcut's frame (DESIGN.md §3: mm, +Z face-up = the crown, the culet or
keel on z = 0, centred on the Z axis, the girdle width along X).

Sources for the formats: the GemCad for Windows user's guide (``a``, ``g``, ``y``, ``I``,
``H``, ``F`` records) and the MIT-licensed C# reader github.com/mbparker/gemcad-file-reader
(record layout of ``.gem``); the ``.gem`` sentinel (-99999.0), the pole form of the
normals and the four header plus four footnote slots of the trailer were read off the
sample files bundled in ``meshes/designs/``.
"""

from __future__ import annotations

import math
import os
import re
import struct
from dataclasses import asdict, dataclass, field
from pathlib import Path
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import LabcutWarning, MeshError, ParameterError
from ..validation import check_number
from .orient import check_up_axis, up_rotation
from .report import MeshReport
from .solid import STONE_SIZE_MM, centre_on_base

#: file suffixes read as GemCad designs
DESIGN_SUFFIXES = (".asc", ".gem")

#: girdle width (mm, along X) of a design loaded without a size: a common faceted stone
DEFAULT_SIZE_MM = 10.0

#: gear of a ``.asc`` file without a ``g`` record (GemCad's default index gear)
DEFAULT_GEAR = 96

#: first coordinate of the record that ends the facets of a ``.gem`` file
GEM_SENTINEL = -99999.0

#: vertices of the solid closer than this fraction of its size are one vertex: the 8
#: decimals of a ``.asc`` leave "meet points" a few 1e-9 apart
WELD_RTOL = 1e-7

#: a point lies on a facet plane when ``|p . x - 1|`` is below this
ON_PLANE_TOL = 1e-6

_NUMBER = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")


# ----------------------------------------------------------------------------- the model
@dataclass
class Facet:
    """One facet of a design (design units, design frame; angles in degrees).

    Attributes:
        tier: the tier's number, 1-based, in file order.
        name: the facet's own name, else its tier's name, else ``"tier N"``.
        own_name: the name written for this facet (``n NAME``), or ``""``.
        angle_deg: signed cutting angle: crown > 0, pavilion < 0 (``-0.0`` a culet), +-90 girdle.
        index: the gear index as written (may be fractional or negative).
        azimuth_deg: direction of the facet normal in the girdle plane, from +X towards +Y.
        distance: centre-to-facet distance as written (negative: the facet flipped, see module).
        pole: ``n / d``; the stone is ``pole . x <= 1``.
        polygon: GemCad's solved facet polygon (``.gem`` files only), ``(K, 3)``; None otherwise.
    """

    tier: int
    name: str
    own_name: str
    angle_deg: float
    index: float
    azimuth_deg: float
    distance: float
    pole: np.ndarray
    polygon: np.ndarray | None = None

    @property
    def normal(self) -> np.ndarray:
        """Unit outward normal of the facet plane (design frame)."""
        return self.pole / float(np.linalg.norm(self.pole))

    @property
    def part(self) -> str:
        """Where the facet is: ``table``, ``crown``, ``girdle``, ``pavilion`` or ``culet``."""
        n = self.normal
        if abs(n[2]) < 1e-9:
            return "girdle"
        if abs(n[2]) > 1.0 - 1e-12:
            return "table" if n[2] > 0 else "culet"
        return "crown" if n[2] > 0 else "pavilion"


@dataclass
class Tier:
    """One tier: facets cut at one angle and one distance (design units, degrees)."""

    number: int
    angle_deg: float
    distance: float
    indices: list[float] = field(default_factory=list)
    name: str = ""
    instructions: str = ""


@dataclass
class Design:
    """A faceted design read from a GemCad file (dimensionless design units).

    Attributes:
        source: the file read.
        format: ``"asc"`` or ``"gem"``.
        title: the first header line (GemCad's design name), or the file's stem.
        headers, footnotes: the text lines of the design.
        gear: the index gear, signed (negative: indices run anticlockwise).
        location: the gear location (``g`` record's second number), in index units.
        symmetry, mirror: the design's rotational symmetry and mirror flag, as recorded.
        refractive_index: the index of the material the design was made for (GemCad's
            ``I``), or None. It is the design's target material, not labradorite's: labcut
            records it and does not apply it.
        tiers, facets: the tiers and their facets, in file order.
        notes: what the reader tolerated or ignored.
    """

    source: str
    format: str
    title: str
    headers: list[str]
    footnotes: list[str]
    gear: int
    location: float
    symmetry: int | None
    mirror: bool | None
    refractive_index: float | None
    tiers: list[Tier]
    facets: list[Facet]
    notes: list[str] = field(default_factory=list)

    def poles(self) -> np.ndarray:
        """``(n, 3)`` facet poles ``n / d``: the stone is ``{x : poles @ x <= 1}``."""
        return np.array([f.pole for f in self.facets], dtype=np.float64).reshape(-1, 3)

    def summary(self) -> dict[str, Any]:
        """Plain-JSON description of the design (no geometry)."""
        return {
            "name": self.title,
            "format": self.format,
            "gear": self.gear,
            "gear_location": self.location,
            "symmetry": self.symmetry,
            "mirror": self.mirror,
            "refractive_index": self.refractive_index,
            "tiers": len(self.tiers),
            "facets_listed": len(self.facets),
            "headers": list(self.headers),
            "footnotes": list(self.footnotes),
            "tier_list": [asdict(t) for t in self.tiers],
        }


def facet_pole(angle_deg: float, index: float, distance: float, gear: int, location: float) -> tuple[np.ndarray, float]:
    """``(pole, azimuth_deg)`` of a facet at a signed angle, gear index and distance (module doc)."""
    azimuth = 90.0 - (float(index) - float(location)) * 360.0 / float(gear)
    azimuth = (azimuth + 180.0) % 360.0 - 180.0
    a = math.radians(abs(angle_deg))
    phi = math.radians(azimuth)
    pavilion = math.copysign(1.0, angle_deg) < 0
    n = np.array([math.sin(a) * math.cos(phi), math.sin(a) * math.sin(phi), math.cos(a) * (-1.0 if pavilion else 1.0)])
    if abs(angle_deg) == 90.0:
        n[2] = 0.0
    return n / float(distance), azimuth


def _number(token: str) -> float | None:
    """A finite decimal number, keeping the sign of ``-0``; None if ``token`` is not one."""
    if not _NUMBER.match(token):
        return None
    return float(token)


def _check_facet_values(where: str, angle: float, distance: float) -> None:
    if abs(angle) > 90.0:
        raise MeshError(f"{where}: angle {angle:g} is outside -90..90 degrees")
    if distance == 0.0:
        raise MeshError(f"{where}: distance 0 puts the facet through the centre of the stone, which leaves no stone")


def _name_facets(tiers: list[Tier], facets: list[Facet]) -> None:
    """Give unnamed facets their tier's name (the first name written in the tier), else ``tier N``."""
    by_tier: dict[int, str] = {}
    for f in facets:
        if f.own_name and f.tier not in by_tier:
            by_tier[f.tier] = f.own_name
    for t in tiers:
        t.name = by_tier.get(t.number, "")
    for f in facets:
        f.name = f.own_name or by_tier.get(f.tier) or f"tier {f.tier}"


# ----------------------------------------------------------------------------- .asc
def _decode(data: bytes, name: str) -> str:
    if b"\x00" in data[:4096]:
        raise MeshError(f"{name} is a binary file, not a GemCad .asc text design (a .gem file? give it the .gem suffix)")
    if data.startswith(b"\xef\xbb\xbf"):
        return data[3:].decode("utf-8", errors="replace")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("cp1252", errors="replace")  # GemCad for Windows writes Windows-1252


def parse_asc(text: str, name: str = "design.asc", source: str = "") -> Design:
    """Parse the text of a GemCad ``.asc`` file.

    Records (one per line, CRLF or LF; a line that starts with a space or tab continues the
    previous ``a`` record): ``GemCad x.y`` (version), ``g GEAR LOCATION``, ``y FOLDS y|n``,
    ``I INDEX``, ``H header``, ``F footnote``, and one ``a ANGLE DISTANCE INDEX... [n NAME]
    [G instructions]`` per tier, where ``n NAME`` names the index before it and ``G`` starts
    the tier's cutting instructions (a line of its own that starts with ``G `` does too).

    Raises:
        MeshError: not a design (no tier records), or a malformed record (the message names
            the line).
    """
    raw_lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    # join continuation lines onto the record they continue
    lines: list[tuple[int, str]] = []
    for i, line in enumerate(raw_lines, 1):
        if not line.strip():
            continue
        if line[0] in " \t" and lines and lines[-1][1][:1] == "a":
            lines[-1] = (lines[-1][0], lines[-1][1] + " " + line.strip())
            continue
        if line.startswith("G ") and lines and lines[-1][1][:1] == "a":  # instructions on a line of their own
            lines[-1] = (lines[-1][0], lines[-1][1] + " " + line.strip())
            continue
        lines.append((i, line.strip()))

    gear: int | None = None
    location = 0.0
    symmetry: int | None = None
    mirror: bool | None = None
    ri: float | None = None
    headers: list[str] = []
    footnotes: list[str] = []
    notes: list[str] = []
    tiers: list[Tier] = []
    facet_specs: list[tuple[int, float, float, float, str]] = []  # tier, angle, distance, index, own name
    unknown: list[tuple[int, str]] = []
    version = None

    for lineno, line in lines:
        where = f"{name}, line {lineno}"
        kind = line[0]
        spans = list(re.finditer(r"\S+", line[1:]))
        words = [m.group() for m in spans]
        if line.lower().startswith("gemcad"):
            version = line
        elif kind == "g":
            vals = [_number(w) for w in words]
            if len(words) < 1 or len(words) > 2 or any(v is None for v in vals):
                raise MeshError(f"{where}: the gear record must be 'g GEAR LOCATION', got {line!r}")
            g = vals[0]
            if g is None or g != int(g) or g == 0 or abs(g) > 10000:
                raise MeshError(f"{where}: the gear must be a non-zero whole number of teeth, got {words[0]!r}")
            gear = int(g)
            location = float(vals[1]) if len(vals) > 1 and vals[1] is not None else 0.0
        elif kind == "y":
            folds = _number(words[0]) if words else None
            if folds is None or folds != int(folds) or folds < 1 or (len(words) > 1 and words[1].lower() not in ("y", "n")):
                raise MeshError(f"{where}: the symmetry record must be 'y FOLDS y|n', got {line!r}")
            symmetry = int(folds)
            mirror = len(words) > 1 and words[1].lower() == "y"
        elif kind == "I":
            v = _number(words[0]) if len(words) == 1 else None
            if v is None or not 1.0 <= v <= 5.0:
                raise MeshError(f"{where}: the refractive index record must be 'I INDEX' with 1 <= INDEX <= 5, got {line!r}")
            ri = v
        elif kind == "H":
            if line[1:].strip():
                headers.append(line[1:].strip())
        elif kind == "F":
            if line[1:].strip():
                footnotes.append(line[1:].strip())
        elif kind == "a":
            if len(words) < 2 or _number(words[0]) is None or _number(words[1]) is None:
                raise MeshError(f"{where}: a tier record must start 'a ANGLE DISTANCE', got {line[:60]!r}")
            angle, distance = float(words[0]), float(words[1])
            _check_facet_values(where, angle, distance)
            tier = Tier(number=len(tiers) + 1, angle_deg=angle, distance=distance)
            k = 2
            while k < len(words):
                w = words[k]
                if w == "n":
                    if k + 1 >= len(words):
                        raise MeshError(f"{where}: 'n' must be followed by a facet name")
                    if not tier.indices:
                        raise MeshError(f"{where}: the name {words[k + 1]!r} comes before any index")
                    t, a_, d_, i_, _ = facet_specs[-1]
                    facet_specs[-1] = (t, a_, d_, i_, words[k + 1])
                    k += 2
                elif w == "G":
                    tier.instructions = line[1 + spans[k].end():].strip()
                    break
                else:
                    idx = _number(w)
                    if idx is None:
                        raise MeshError(f"{where}: {w!r} is not a gear index, a name ('n NAME') or instructions ('G ...')")
                    tier.indices.append(idx)
                    facet_specs.append((tier.number, angle, distance, idx, ""))
                    k += 1
            if not tier.indices:
                notes.append(f"line {lineno}: the tier at {angle:g} deg lists no index and was skipped")
                continue
            tiers.append(tier)
        elif all(_number(w) is not None for w in line.split()) and len(line.split()) == 2 and not tiers and gear is None:
            g, loc = (float(w) for w in line.split())
            if g == int(g) and g != 0:
                gear, location = int(g), loc
                notes.append(f"line {lineno}: read {line!r} as the gear and its location (no 'g')")
            else:
                unknown.append((lineno, line))
        else:
            unknown.append((lineno, line))

    if not tiers:
        what = "no GemCad header and no" if version is None else "no"
        raise MeshError(f"{name} is not a GemCad .asc design: it has {what} facet records ('a ANGLE DISTANCE INDEX ...')")
    if unknown:
        first_line, first = unknown[0]
        notes.append(f"ignored {len(unknown)} unrecognised line{'s' if len(unknown) > 1 else ''} (line {first_line}: {first[:40]!r})")
    if gear is None:
        gear = DEFAULT_GEAR
        notes.append(f"no gear record: GemCad's default gear {DEFAULT_GEAR} assumed")
    if version is None:
        notes.append("no 'GemCad' version line")

    facets: list[Facet] = []
    for tier_no, angle, distance, idx, own in facet_specs:
        pole, azimuth = facet_pole(angle, idx, distance, gear, location)
        facets.append(Facet(tier=tier_no, name="", own_name=own, angle_deg=angle, index=idx, azimuth_deg=azimuth,
                            distance=distance, pole=pole))
    _name_facets(tiers, facets)
    return Design(source=source or name, format="asc", title=headers[0] if headers else Path(name).stem,
                  headers=headers, footnotes=footnotes, gear=gear, location=location, symmetry=symmetry,
                  mirror=mirror, refractive_index=ri, tiers=tiers, facets=facets, notes=notes)


# ----------------------------------------------------------------------------- .gem
class _Reader:
    """Little-endian reads from bytes that raise a one-line MeshError at the end of the data."""

    def __init__(self, data: bytes, name: str) -> None:
        self.data, self.name, self.pos = data, name, 0

    def take(self, fmt: str, what: str) -> tuple[Any, ...]:
        size = struct.calcsize(fmt)
        if self.pos + size > len(self.data):
            raise MeshError(f"{self.name} is a truncated GemCad .gem file: it ends at byte {len(self.data)} inside {what}")
        out = struct.unpack_from(fmt, self.data, self.pos)
        self.pos += size
        return out

    def text(self, what: str) -> str:
        (n,) = self.take("<B", what)
        (raw,) = self.take(f"<{n}s", what)
        return raw.decode("cp1252", errors="replace")


def parse_gem(data: bytes, name: str = "design.gem", source: str = "") -> Design:
    """Parse a binary GemCad ``.gem`` file.

    Layout (little-endian): one record per facet, in tier order: the pole ``n / d`` (3
    float64), the tier number (int32), the facet's text (a length byte, then ``name`` TAB
    ``instructions`` in Windows-1252), then GemCad's solved polygon as points, each an int32
    1 followed by 3 float64, ended by an int32 0. The facets end with a float64 -99999.0 in
    place of a pole, then the trailer: symmetry folds, mirror (0/1), gear (int32, signed),
    refractive index (float64), an int32 (0x7fff in every sample), gear location (float64),
    then eight length-prefixed strings: four header lines and four footnote lines (empty
    when unused). Anything after that (a ``preform`` section) is ignored with a note.

    Raises:
        MeshError: truncated or corrupt data (the message says where).
    """
    r = _Reader(data, name)
    records: list[tuple[np.ndarray, int, str, str, np.ndarray]] = []
    while True:
        k = len(records) + 1
        (x,) = r.take("<d", f"facet record {k}")
        if x == GEM_SENTINEL:
            break
        y, z = r.take("<2d", f"facet record {k}")
        pole = np.array([x, y, z])
        (tier,) = r.take("<i", f"facet record {k}")
        if not np.all(np.isfinite(pole)) or not 1e-9 < float(np.linalg.norm(pole)) < 1e9 or not 1 <= tier <= 100000:
            raise MeshError(f"{name} is not a GemCad .gem file (or is corrupt): facet record {k} at byte {r.pos - 28} "
                            f"holds no facet plane")
        if records and tier < records[-1][1]:
            raise MeshError(f"{name} is corrupt: facet record {k} goes back from tier {records[-1][1]} to tier {tier}")
        label = r.text(f"the text of facet record {k}")
        own, _, instructions = label.partition("\t")
        pts: list[tuple[float, float, float]] = []
        while True:
            (flag,) = r.take("<i", f"the polygon of facet record {k}")
            if flag == 0:
                break
            if flag != 1:
                raise MeshError(f"{name} is corrupt: facet record {k} has a polygon marker {flag} at byte {r.pos - 4} (0 or 1 expected)")
            pts.append(r.take("<3d", f"the polygon of facet record {k}"))
        records.append((pole, int(tier), own.strip(), instructions.strip(), np.array(pts, dtype=np.float64).reshape(-1, 3)))

    symmetry, mirror_flag, gear = r.take("<3i", "the trailer")
    (ri,) = r.take("<d", "the trailer")
    r.take("<i", "the trailer")
    (location,) = r.take("<d", "the trailer")
    if gear == 0 or abs(gear) > 10000 or mirror_flag not in (0, 1) or not math.isfinite(location):
        raise MeshError(f"{name} is corrupt: its trailer holds gear {gear}, mirror flag {mirror_flag}")
    texts = [r.text("the header and footnote lines") for _ in range(8)]
    notes: list[str] = []
    if r.pos < len(data):
        notes.append(f"ignored {len(data) - r.pos} bytes after the footnotes (a preform)")
    if not records:
        raise MeshError(f"{name} holds no facets")

    tiers: list[Tier] = []
    facets: list[Facet] = []
    for pole, tier_no, own, instructions, polygon in records:
        n = pole / float(np.linalg.norm(pole))
        distance = 1.0 / float(np.linalg.norm(pole))
        if abs(n[2]) < 1e-9:
            angle = -90.0
        else:
            tilt = math.degrees(math.atan2(math.hypot(n[0], n[1]), abs(n[2])))
            angle = tilt if n[2] > 0 else -tilt
            if angle == 0.0 and n[2] < 0:
                angle = -0.0
        angle = round(angle, 6) if angle != 0 else angle
        if abs(n[2]) > 1.0 - 1e-12:  # a table or culet has no direction: GemCad writes the gear as its index
            index = float(gear)
            azimuth = (90.0 - (index - location) * 360.0 / gear + 180.0) % 360.0 - 180.0
        else:
            azimuth = math.degrees(math.atan2(n[1], n[0]))
            index = location + (90.0 - azimuth) * gear / 360.0
            index = round(index % abs(gear), 6) or float(abs(gear))
        if not tiers or tiers[-1].number != tier_no:
            tiers.append(Tier(number=tier_no, angle_deg=angle, distance=round(distance, 9), instructions=instructions))
        elif instructions and not tiers[-1].instructions:
            tiers[-1].instructions = instructions
        tiers[-1].indices.append(index)
        facets.append(Facet(tier=tier_no, name="", own_name=own, angle_deg=angle, index=index, azimuth_deg=azimuth,
                            distance=distance, pole=pole, polygon=polygon))
    # tiers renumbered 1.. in file order (GemCad's numbers may skip)
    renumber = {t.number: i for i, t in enumerate(tiers, 1)}
    for t in tiers:
        t.number = renumber[t.number]
    for f in facets:
        f.tier = renumber[f.tier]
    _name_facets(tiers, facets)
    headers = [t.strip() for t in texts[:4] if t.strip()]
    footnotes = [t.strip() for t in texts[4:] if t.strip()]
    return Design(source=source or name, format="gem", title=headers[0] if headers else Path(name).stem, headers=headers,
                  footnotes=footnotes, gear=int(gear), location=float(location), symmetry=int(symmetry),
                  mirror=bool(mirror_flag), refractive_index=float(ri) if math.isfinite(ri) and ri >= 1.0 else None,
                  tiers=tiers, facets=facets, notes=notes)


def read_design(path: str | os.PathLike[str]) -> Design:
    """Read a GemCad ``.asc`` or ``.gem`` design (by suffix). Raises :class:`MeshError`."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in DESIGN_SUFFIXES:
        raise MeshError(f"{p.name}: a GemCad design ends in .asc or .gem")
    if not p.exists():
        raise MeshError(f"design file {str(path)!r} does not exist")
    if p.is_dir():
        raise MeshError(f"{str(path)!r} is a folder, not a design file")
    data = p.read_bytes()
    if not data:
        raise MeshError(f"{p.name} is empty (0 bytes)")
    if suffix == ".gem":
        return parse_gem(data, p.name, str(p))
    return parse_asc(_decode(data, p.name), p.name, str(p))


# ----------------------------------------------------------------------------- the solid
@dataclass
class Polyhedron:
    """The stone of a design in design units and frame (before scaling and centring).

    Attributes:
        vertices: ``(V, 3)``.
        faces: ``(F, 3)`` triangles, outward (counter-clockwise seen from outside).
        face_facet: ``(F,)`` the facet (index into ``design.facets``) each triangle belongs to.
        facet_area: ``(n,)`` area of each facet on the stone (0: the facet does not reach it).
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_facet: np.ndarray
    facet_area: np.ndarray


def _direction_words(u: np.ndarray) -> str:
    if u[2] < -0.7:
        return "below (no pavilion facets close it)"
    if u[2] > 0.7:
        return "above (no crown facets close it)"
    az = math.degrees(math.atan2(u[1], u[0])) % 360.0
    return f"the side at azimuth {az:.0f} deg (no girdle or facet closes it there)"


def design_polyhedron(design: Design) -> Polyhedron:
    """Intersect the facet half-spaces ``pole . x <= 1`` of a design: a closed convex polyhedron.

    The vertices are the duals of the facets of the poles' convex hull (exact, Qhull); points
    closer than :data:`WELD_RTOL` of the size are merged; the faces are their convex hull,
    and each triangle is given the facet whose plane it lies in (the first one listed when
    two facets share a plane).

    Raises:
        MeshError: the facets do not close (the stone would be open on one side), or there
            are too few of them.
    """
    from scipy.spatial import ConvexHull, QhullError, cKDTree

    name = Path(design.source).name
    poles = design.poles()
    if len(poles) < 4:
        raise MeshError(f"{name}: {len(poles)} facet{'s' if len(poles) != 1 else ''} cannot close a stone (at least 4 are needed)")
    try:
        dual = ConvexHull(poles)
    except QhullError:
        raise MeshError(f"{name}: its facets do not close a stone: every facet is parallel to one direction "
                        f"(only girdle facets, or only crown and pavilion facets in one plane)") from None
    eq = dual.equations  # unit normal a, offset b: a . x + b <= 0 inside
    open_rows = eq[:, 3] > -1e-9 * float(np.abs(poles).max())
    if open_rows.any():
        u = eq[np.argmax(eq[:, 3]), :3]
        raise MeshError(f"{name}: its facets do not close the stone: it is open towards {_direction_words(u)}")
    pts = -eq[:, :3] / eq[:, 3:4]
    size = float(np.ptp(pts, axis=0).max())
    # weld the copies of each vertex (one per dual triangle around it)
    pairs = cKDTree(pts).query_pairs(WELD_RTOL * size, output_type="ndarray")
    parent = np.arange(len(pts))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in pairs:
        ri, rj = root(int(i)), root(int(j))
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    roots = np.array([root(i) for i in range(len(pts))])
    _, cluster = np.unique(roots, return_inverse=True)
    cluster = cluster.ravel()
    verts = np.zeros((cluster.max() + 1, 3))
    np.add.at(verts, cluster, pts)
    verts /= np.bincount(cluster)[:, None]

    primal = ConvexHull(verts)
    used = np.unique(primal.simplices)
    remap = -np.ones(len(verts), dtype=np.int64)
    remap[used] = np.arange(len(used))
    v = verts[used]
    f = remap[primal.simplices]
    # outward winding: each triangle's normal along its hull facet's outward normal
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", cross, primal.equations[:, :3]) < 0
    f[flip] = f[flip][:, ::-1]
    cross[flip] *= -1
    area = 0.5 * np.linalg.norm(cross, axis=1)
    keep = area > 0
    f, cross, area = f[keep], cross[keep], area[keep]
    # which facet each triangle lies in
    centroid = (v[f[:, 0]] + v[f[:, 1]] + v[f[:, 2]]) / 3.0
    level = centroid @ poles.T  # 1 on the facet's plane, < 1 inside
    unit_n = poles / np.linalg.norm(poles, axis=1, keepdims=True)
    tri_n = cross / np.linalg.norm(cross, axis=1, keepdims=True)
    on = np.abs(level - 1.0) <= ON_PLANE_TOL
    align = np.where(on, tri_n @ unit_n.T, -np.inf)
    face_facet = np.argmax(align, axis=1)  # the first of equal scores: the facet listed first
    lost = ~on.any(axis=1)
    if lost.any():  # pragma: no cover - every hull triangle lies in some facet plane
        face_facet[lost] = np.argmax(level[lost], axis=1)
    facet_area = np.bincount(face_facet, weights=area, minlength=len(poles))
    return Polyhedron(vertices=v, faces=f.astype(np.int64), face_facet=face_facet.astype(np.int64), facet_area=facet_area)


def design_size(size: Any) -> tuple[float, bool]:
    """``(girdle width in mm, given?)`` of a design's ``size`` (None: :data:`DEFAULT_SIZE_MM`), validated."""
    if size is None:
        return DEFAULT_SIZE_MM, False

    return check_number(size, "the girdle width (--size, size=)", *STONE_SIZE_MM, unit="mm"), True


def design_solid(
    design: Design,
    size: float | None = None,
    up_axis: str = "auto",
    recentre: bool = True,
    progress: Callable[[str, float], None] | None = None,
):
    """The stone of a design as a watertight ``trimesh.Trimesh`` in mm, labcut frame.

    Args:
        design: a :class:`Design` (:func:`read_design`).
        size: girdle width in mm: the stone's extent along X (GemCad's width, across
            indices 24 and 72 of 96). None: :data:`DEFAULT_SIZE_MM`. The whole design is
            scaled by one factor; the stone must come out 0.5-500 mm across.
        up_axis: the design's axis that is face-up: ``"auto"`` or ``"+Z"`` (the crown,
            GemCad's convention), or another of ``+-X``, ``+-Y``, ``-Z`` to turn it (with a
            warning), as for meshes.
        recentre: centre the bounding box on the Z axis with the lowest point (culet or keel)
            on z = 0; False keeps the dop axis at x = y = 0 and the design's origin at z = 0.
        progress: optional ``callback(stage, fraction)``.

    Returns:
        The mesh; ``mesh.metadata["labcut"]`` is a load report (as :func:`labcut.load_mesh`
        gives, ``kind="design"``, ``units_source="design"``) with a ``design`` block: name,
        headers, footnotes, gear, gear location, symmetry, mirror, refractive index (the
        design's target material, recorded and not applied), tiers, facets on the stone and
        listed, ``size_mm`` and ``size_source``, ``length_to_width``, ``facet_list`` (per facet:
        tier, name, part, angle, index, azimuth, distance, normal, area in mm²) and per
        triangle ``face_facet`` (into ``facet_list``) and ``face_names``.

    Raises:
        MeshError: the facets do not close a solid.
        ParameterError: a bad ``size`` or ``up_axis``.
    """
    import warnings as _warnings

    import manifold3d as m3
    import trimesh


    stage = progress or (lambda s, x: None)
    size_mm, given = design_size(size)
    up_key = check_up_axis(up_axis)
    name = Path(design.source).name
    stage("intersecting the facet planes", 0.2)
    poly = design_polyhedron(design)
    width = float(np.ptp(poly.vertices[:, 0]))
    scale = size_mm / width
    v = poly.vertices * scale
    f = poly.faces
    stage("certifying the solid", 0.6)
    man = m3.Manifold(m3.Mesh64(vert_properties=np.ascontiguousarray(v), tri_verts=np.ascontiguousarray(f, dtype=np.uint64)))
    if man.status() != m3.Error.NoError or man.is_empty() or not man.volume() > 0:
        raise MeshError(f"{name}: the facets did not make a closed solid (manifold3d: {man.status().name})")
    lo_mm, hi_mm = STONE_SIZE_MM
    largest = float(np.ptp(v, axis=0).max())
    if largest > hi_mm:
        raise ParameterError(f"{name} would be {largest:.0f} mm long at a girdle width of {size_mm:g} mm, more than the "
                             f"{hi_mm:g} mm of a stone; give a smaller --size (size=)")

    warns: list[str] = []
    if up_key in ("auto", "+Z"):
        up = "+Z"
        up_source = "given" if up_key == "+Z" else "design: the crown (positive facet angles) is face-up"
    else:
        up, up_source = up_key, "given"
        warns.append(f"{name}: you gave up axis {up_key}, but a GemCad design's crown (+Z) is its face-up side; "
                     f"--up-axis auto (up_axis='auto') keeps the crown up")
    rot = up_rotation(up)
    v = v @ rot.T
    v, shift = centre_on_base(v) if recentre else (v, np.zeros(3))
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):  # pragma: no cover
        raise MeshError(f"{name}: the facets did not make a closed, outward-wound solid")

    facet_area_mm2 = poly.facet_area * scale**2
    on_stone = facet_area_mm2 > 1e-12 * size_mm**2
    ext = np.ptp(poly.vertices, axis=0)
    facet_list = []
    for i, fc in enumerate(design.facets):
        facet_list.append({
            "id": i, "tier": fc.tier, "name": fc.name, "own_name": fc.own_name, "part": fc.part,
            "angle_deg": float(fc.angle_deg), "index": float(fc.index), "azimuth_deg": round(float(fc.azimuth_deg), 9),
            "distance": float(fc.distance), "normal": [round(float(x), 12) for x in rot @ fc.normal],
            "area_mm2": float(facet_area_mm2[i]), "on_stone": bool(on_stone[i]),
        })
    missing = [fc for fc, ok in zip(design.facets, on_stone) if not ok]
    notes = [f"GemCad design {design.title!r} ({design.format}): {int(on_stone.sum())} facets in {len(design.tiers)} tiers, "
             f"gear {design.gear}, scaled to a girdle width of {size_mm:g} mm "
             f"({'as given' if given else 'the default; --size MM (size=) sets it'})"]
    if design.refractive_index is not None:
        notes.append(f"the design was made for a refractive index of {design.refractive_index:g}; labcut uses the "
                     f"material's own index")
    if missing:
        ex = ", ".join(f"{m.name} at index {m.index:g}" for m in missing[:3])
        notes.append(f"{len(missing)} listed facet{'s do' if len(missing) > 1 else ' does'} not reach the surface ({ex}"
                     f"{', ...' if len(missing) > 3 else ''})")
    notes.extend(design.notes)
    report = MeshReport(
        source=design.source, format=design.format, units="mm", scale_to_mm=float(scale),
        translation_mm=[float(x) for x in shift], repairs=[], notes=notes, warnings=warns, units_source="design",
        up_axis=up, up_axis_source=up_source, rotation=rot.tolist(),
        dimensions_mm=[float(x) for x in np.ptp(v, axis=0)], convex=True, watertight=True,
        triangles=len(f), vertices=len(v), bodies=1,
    )
    summary = design.summary()
    summary.update({
        "facets": int(on_stone.sum()),
        "size_mm": size_mm,
        "size_source": "given" if given else "default",
        "width_design_units": width,
        "length_to_width": float(ext[1] / ext[0]),
        "height_to_width": float(ext[2] / ext[0]),
        "refractive_index_applied": False,
        "facet_list": facet_list,
        "face_facet": [int(x) for x in poly.face_facet],
        "face_names": [design.facets[int(x)].name for x in poly.face_facet],
    })
    mesh.metadata["labcut"] = {"kind": "design", "faceted": True, **report.to_dict(), "design": summary}
    for w in warns:
        _warnings.warn(w, LabcutWarning, stacklevel=3)
    stage("loaded", 1.0)
    return mesh


def load_design(
    path: str | os.PathLike[str],
    size: float | None = None,
    up_axis: str = "auto",
    recentre: bool = True,
    progress: Callable[[str, float], None] | None = None,
):
    """Read a GemCad ``.asc`` or ``.gem`` design and cut its stone (:func:`design_solid`)."""
    design_size(size)  # a bad size is an error before the file is read
    (progress or (lambda s, x: None))(f"reading {Path(path).name}", 0.0)
    return design_solid(read_design(path), size=size, up_axis=up_axis, recentre=recentre, progress=progress)


#: the keys of a design's metadata that travel with every answer's ``mesh`` block (:func:`labcut.geometry.meshio.provenance`)
PROVENANCE_KEYS = ("name", "format", "gear", "gear_location", "symmetry", "mirror", "refractive_index",
                   "refractive_index_applied", "tiers", "facets", "facets_listed", "size_mm", "size_source",
                   "length_to_width", "headers", "footnotes")


def design_provenance(design: dict[str, Any]) -> dict[str, Any]:
    """The compact part of ``metadata["labcut"]["design"]`` (:data:`PROVENANCE_KEYS`; no per-face lists)."""
    return {k: design[k] for k in PROVENANCE_KEYS if k in design}
