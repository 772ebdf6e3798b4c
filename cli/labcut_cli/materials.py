"""Material options shared by every command that takes a labradorite material.

Exactly one base (``--preset``, ``--peak``, ``--an`` or ``--material FILE.json``),
default the blue-green :class:`labcut.Labradorite`; the layer options
(``--d-a`` ... ``--n-surface``) then override single parameters.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from labcut.errors import ParameterError

Preset = Annotated[Optional[str], typer.Option("--preset", "-p", help="Named material: blue, green, gold, red.", rich_help_panel="Material")]
Peak = Annotated[Optional[float], typer.Option("--peak", help="Flash peak at normal incidence, nm.", rich_help_panel="Material")]
Anorthite = Annotated[Optional[float], typer.Option("--an", help="Bulk anorthite content, mol % (Bøggild range 44-61).", rich_help_panel="Material")]
MaterialFile = Annotated[Optional[Path], typer.Option("--material", help="Material JSON: Labradorite.to_dict, or any labcut --json output that holds one (spectrum, render, recommend-orientation).", rich_help_panel="Material")]
Layer = lambda flag, text: Annotated[Optional[float], typer.Option(flag, help=text, rich_help_panel="Layer parameters")]  # noqa: E731
DA = Layer("--d-a", "Mean thickness of phase a, nm.")
DB = Layer("--d-b", "Mean thickness of phase b, nm.")
SA = Layer("--sigma-a", "Thickness standard deviation of phase a, nm.")
SB = Layer("--sigma-b", "Thickness standard deviation of phase b, nm.")
NA = Layer("--n-a", "Refractive index of phase a.")
NB = Layer("--n-b", "Refractive index of phase b.")
NS = Layer("--n-surface", "Bulk refractive index of the stone.")
SPREAD = Layer("--spread", "Angular spread of the lamellae, degrees.")
Pairs = Annotated[Optional[int], typer.Option("--pairs", help="Number of lamella pairs.", rich_help_panel="Layer parameters")]
#: names of the layer options every material-taking command has, as build_material keywords
LAYER_KEYS = ("d_a", "d_b", "sigma_a", "sigma_b", "n_a", "n_b", "n_surface", "pairs", "spread_deg")


#: every material option of a command, in the order ``--help`` lists them: (parameter name, typer annotation)
OPTIONS: tuple[tuple[str, Any], ...] = (
    ("preset", Preset), ("peak", Peak), ("an", Anorthite), ("material_file", MaterialFile), ("d_a", DA), ("d_b", DB),
    ("sigma_a", SA), ("sigma_b", SB), ("n_a", NA), ("n_b", NB), ("n_surface", NS), ("pairs", Pairs), ("spread", SPREAD),
)


def takes_material(func: Any = None, *, without: tuple[str, ...] = ()) -> Any:
    """Give a typer command the material options (:data:`OPTIONS`) once, in one place: the command
    declares ``material: Any = None`` and receives the :class:`labcut.Labradorite` they describe
    (:func:`build_material`). ``without``: options it has no use for (``("spread",)`` for
    ``spectrum``, which has no directions)."""
    from .groups import option_group

    if func is None:
        return lambda f: takes_material(f, without=without)

    def build(preset=None, peak=None, an=None, material_file=None, spread=None, **layers):  # noqa: ANN001, ANN202
        return build_material(preset, peak, an, material_file, spread_deg=spread, **layers)

    options = [(n, a, None) for n, a in OPTIONS if n not in without]
    return option_group("material", options, build)(func)


def material_block(data: Any, source: str) -> dict[str, Any]:
    """The material parameters in a JSON document: a ``Labradorite.to_dict``, or labcut's own
    outputs that carry one (``material`` of spectrum/render JSON, ``settings.material`` of a
    recommendation). The values are validated by :class:`labcut.Labradorite` (JSON ``true`` is not 1 pair)."""
    if isinstance(data, dict):
        if isinstance(data.get("material"), dict):
            data = data["material"]
        elif isinstance(data.get("settings"), dict) and isinstance(data["settings"].get("material"), dict):
            data = data["settings"]["material"]
    if not isinstance(data, dict):
        raise ParameterError(f"material file {source!r} must hold a JSON object")
    return data


def build_material(
    preset: str | None = None,
    peak: float | None = None,
    an: float | None = None,
    material_file: Path | None = None,
    **overrides: Any,
) -> Any:
    """The material the options describe; conflicting bases are a ParameterError.

    A material whose flash peaks outside the visible range is valid; its
    :meth:`~labcut.Labradorite.visibility_note` is printed once as a ``warning:`` line on
    stderr. The material's own warnings are held back while it is built: a base that
    ``--d-a``/``--d-b`` then change may warn of a peak the final material does not have."""
    from .meshes import print_warning

    material, _ = holding_warnings(lambda: _build_material(preset, peak, an, material_file, **overrides))
    note = material.visibility_note()
    if note is not None:
        print_warning(note)
    return material


def _build_material(preset: str | None, peak: float | None, an: float | None, material_file: Path | None,
                    **overrides: Any) -> Any:
    """:func:`build_material` without its warning."""
    from labcut import Labradorite

    given = [name for name, v in (("--preset", preset), ("--peak", peak), ("--an", an), ("--material", material_file)) if v is not None]
    if len(given) > 1:
        raise ParameterError(f"give only one of {', '.join(given)}")
    changes = {k: v for k, v in overrides.items() if v is not None}
    if material_file is not None:
        from labcut.fileio import read_json

        data = material_block(read_json(material_file, "material file"), str(material_file))
        return Labradorite.from_dict({**data, **changes})
    # a preset, peak or An content sets the lamella thicknesses; explicit --d-a/--d-b go on top
    # (the peak then moves), the other layer options are inputs to that fit
    on_top = {k: changes.pop(k) for k in ("d_a", "d_b") if k in changes}
    if preset is not None:
        base = Labradorite.preset(preset, **changes)
    elif peak is not None:
        base = Labradorite.from_peak_wavelength(peak, **changes)
    elif an is not None:
        base = Labradorite.from_anorthite(an, **changes)
    else:
        return Labradorite(**changes, **on_top)
    return base.replace(**on_top) if on_top else base


ZoningOpt = Annotated[Optional[str], typer.Option("--zoning", help="Colour zones: natural, smooth, sharp, none, or a zoning .json file (docs/zoning.md); a studio --render shows natural zones unless told none.", rich_help_panel="Material")]


def build_zoning(text: str | None, material: Any) -> Any:
    """The :class:`labcut.rendering.zoning.Zoning` of ``--zoning`` (a preset name or a JSON file), or None."""
    if text is None or text.strip().lower() == "none":
        return None
    from labcut.errors import ParameterError
    from labcut.rendering import ZONING_PRESETS as PRESETS, Zoning

    if text.strip().lower() in PRESETS:
        return Zoning.preset(text, material)
    if text.lower().endswith(".json") or Path(text).exists():
        from .meshes import print_warning

        zoning, notes = holding_warnings(lambda: Zoning.load(text, material))
        for note in dict.fromkeys(notes):  # a zoning set that peaks outside the visible, once per text
            print_warning(note)
        return zoning
    raise ParameterError(f"--zoning must be {', '.join(PRESETS)}, none or a zoning .json file, got {text!r}")


def holding_warnings(make: Any) -> tuple[Any, list[str]]:
    """``(make(), the texts of the labcut warnings it issued)``: those are held back for the caller
    to print as ``warning:`` lines, other warnings go on as usual."""
    import warnings

    from labcut.errors import LabcutWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LabcutWarning)
        value = make()
    held = []
    for w in caught:
        if issubclass(w.category, LabcutWarning):
            held.append(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return value, held
