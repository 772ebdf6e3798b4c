"""Mesh options shared by every command that reads a mesh (``--units``, ``--up-axis``, ``--size``) and the
loader that reports what it did: warnings on stderr, repairs with the answer, progress for long loads.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from .root import console, err_console

Units = Annotated[
    str,
    typer.Option(
        "--units",
        help="Length unit of the mesh file: auto (what the file declares: glTF is metres, 3MF says; else mm), "
             "mm, cm, m, um, in, ft, or a number of mm per file unit.",
        rich_help_panel="Mesh",
    ),
]
UpAxis = Annotated[
    str,
    typer.Option(
        "--up-axis",
        help="The file's face-up axis: auto (read from a flat base, a table or a dome; else +Z, +Y for glTF), "
             "+Z, -Z, +Y, -Y, +X or -X.",
        rich_help_panel="Mesh",
    ),
]
Size = Annotated[
    Optional[float],
    typer.Option(
        "--size",
        metavar="MM",
        help="Girdle width in mm (along X) of a GemCad design (.asc, .gem), which has no unit of its own; "
             "default 10. Meshes take --units instead.",
        rich_help_panel="Mesh",
    ),
]

@dataclass(frozen=True)
class MeshOptions:
    """``--units``, ``--up-axis`` and ``--size`` of a command, checked (:func:`check_mesh_options`):
    ``units_arg`` and ``up`` as ``load_mesh`` takes them; :meth:`load` reads a mesh with them."""

    units: str = "auto"
    up_axis: str = "auto"
    size: float | None = None
    units_arg: str | float = "auto"
    up: str = "auto"

    def load(self, path: Path, printed: list[tuple[str, str]] | None = None, **kwargs: Any) -> Any:
        """Read ``path`` with these (already checked) options: :func:`read`."""
        return read(path, self.units_arg, self.up, self.size, printed=printed, **kwargs)


def _mesh_options(units: str = "auto", up_axis: str = "auto", size: float | None = None) -> MeshOptions:
    unit_arg, up = check_mesh_options(units, up_axis, size)
    return MeshOptions(units, up_axis, size, unit_arg, up)


def takes_mesh_options(func: Any) -> Any:
    """Give a typer command ``--units``, ``--up-axis`` and ``--size`` once: the command declares
    ``mesh_options: Any = None`` and receives the checked :class:`MeshOptions`."""
    from .groups import option_group

    return option_group("mesh_options", (("units", Units, "auto"), ("up_axis", UpAxis, "auto"), ("size", Size, None)),
                        _mesh_options)(func)


#: files at least this large get a progress bar while they load (bytes)
PROGRESS_BYTES = 2_000_000


def check_mesh_options(units: str, up_axis: str, size: float | None = None) -> tuple[str | float, str]:
    """Validate ``--units``, ``--up-axis`` (and ``--size``) before any work; returns units and up axis as
    ``load_mesh`` takes them."""
    from labcut.geometry import design_size
    from labcut.geometry import units_scale
    from labcut.geometry import check_up_axis

    design_size(size)
    unit_arg: str | float = units.strip()
    try:
        unit_arg = float(units)
    except ValueError:
        pass
    if not (isinstance(unit_arg, str) and unit_arg.lower() == "auto"):
        units_scale(unit_arg)  # a bad unit is an error now, not after the mesh is read
    return unit_arg, check_up_axis(up_axis)


def load(mesh_path: Path, units: str = "auto", up_axis: str = "auto", size: float | None = None, **kwargs: Any) -> Any:
    """``labcut.load_mesh`` for a command: its warnings as ``warning:`` lines on stderr, a
    progress bar (stderr) for large files; ``size`` is a GemCad design's girdle width (mm)."""
    unit_arg, up = check_mesh_options(units, up_axis, size)
    return read(mesh_path, unit_arg, up, size, **kwargs)


def read(mesh_path: Path, unit_arg: str | float, up: str, size: float | None = None,
         printed: list[tuple[str, str]] | None = None, **kwargs: Any) -> Any:
    """:func:`load` with options :func:`check_mesh_options` already checked (``unit_arg``, ``up``);
    ``printed``: a list that gets ``("warning", text)`` for each warning line printed."""
    from labcut.errors import LabcutWarning
    from labcut.geometry import load_mesh

    big = Path(mesh_path).is_file() and Path(mesh_path).stat().st_size >= PROGRESS_BYTES
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LabcutWarning)
        if big:
            from .progress import progress_bar

            with progress_bar(f"loading {Path(mesh_path).name}", "%") as update:
                mesh = load_mesh(mesh_path, units=unit_arg, up_axis=up, size=size,
                                 progress=lambda stage, fraction: update(int(round(100 * fraction)), 100), **kwargs)
        else:
            mesh = load_mesh(mesh_path, units=unit_arg, up_axis=up, size=size, **kwargs)
    for w in caught:
        if issubclass(w.category, LabcutWarning):
            print_warning(str(w.message))
            if printed is not None:
                printed.append(("warning", str(w.message)))
    return mesh


def print_warning(message: str) -> None:
    """One ``warning:`` line on stderr."""
    from rich.markup import escape

    err_console.print(f"[bold yellow]warning:[/] {escape(message)}", highlight=False, soft_wrap=True)


def print_provenance(mesh: Any, name: str) -> None:
    """What loading changed, for people: units and up axis when they were not the plain defaults,
    and every repair."""
    import labcut

    print_provenance_facts(labcut.Stone.of(mesh).metadata(), name)


def print_provenance_facts(info: dict[str, Any], name: str) -> None:
    """:func:`print_provenance` from the stone's record (``Stone.metadata()``, as JSON keeps it)."""
    design = info.get("design")
    if design:
        sized = "as given" if design.get("size_source") == "given" else "the default; --size sets it"
        ri = design.get("refractive_index")
        made_for = f"; made for a refractive index of {ri:g}, the material's own index is used" if ri else ""
        console.print(f"{name}: GemCad design {design['name']!r}, {design['facets']} facets in {design['tiers']} tiers, "
                      f"girdle width {design['size_mm']:g} mm ({sized}){made_for}.", highlight=False)
    parts = []
    if info.get("units_source") == "file":
        parts.append(f"read in {info['units']} as the file declares")
    if info.get("up_axis", "+Z") != "+Z":
        parts.append(f"turned so that the file's {info['up_axis']} side is face-up ({info.get('up_axis_source', '')})")
    if parts:
        console.print(f"{name}: {'; '.join(parts)}.", highlight=False)
    repairs = info.get("repairs") or []
    if repairs:
        console.print(f"{name} was repaired on loading: {'; '.join(repairs)}.", highlight=False)
    if int(info.get("bodies", 1)) > 1:
        console.print(f"{name} holds {info['bodies']} separate bodies, scored and rendered together.", highlight=False)
