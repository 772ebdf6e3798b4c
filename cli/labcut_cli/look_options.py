"""``--look``, ``--denoise/--no-denoise`` and ``--exposure``: how a render looks, shared by every
command that renders; and the lines that tell a person how a picture was exposed and where it flashes."""

from __future__ import annotations

from typing import Annotated, Any, Optional

import typer

LOOK_HELP = ("studio: a photograph on a table under the scenario's lamps (area lights, tent, AgX, denoised); "
             "diagram: the plain physics view.")


def _check_look(value: str) -> str:
    """Checked while the options are parsed, so a bad --look fails before any work."""
    spec(value)
    return value.strip().lower()


Look = Annotated[str, typer.Option(help=LOOK_HELP, callback=_check_look)]
Denoise = Annotated[Optional[bool], typer.Option("--denoise/--no-denoise",
                                                 help="OIDN denoising, demodulated by a noise-free shading guide (default: on in the studio look).")]


def spec(look: str, seed: int = 0) -> Any:
    """The ``look=`` of :func:`labcut.render` for ``--look``: a :class:`~labcut.rendering.studio.Studio`
    whose inclusions use ``seed``, or ``"diagram"``. A bad name is a ParameterError naming --look."""
    from labcut.errors import ParameterError
    from labcut.rendering import LOOKS, Studio, resolve_look

    try:
        studio = resolve_look(look)
    except ParameterError:
        raise ParameterError(f"--look must be one of {', '.join(LOOKS)}, got {look!r}") from None
    return "diagram" if studio is None else Studio(seed=seed)


EXPOSURE_HELP = ("Exposure of the PNG: reference (default: the bench's, one for every scene, so a dimmer scene looks "
                 "dimmer), auto (brightened to this scene; the caption says by how many stops), a multiplier > 0, "
                 "or stops like -1.5ev; one value for every frame of an animation.")
Exposure = Annotated[str, typer.Option("--exposure", help=EXPOSURE_HELP)]


def parse_exposure(text: str) -> float | str:
    """``reference`` or ``auto`` -> that mode; ``2.5`` -> that multiplier; ``-1.5ev`` -> 2**-1.5 (stops),
    checked by the library (``labcut.rendering.check_exposure_mode``, ``from_ev``).
    Anything else is a one-line ParameterError naming --exposure."""
    from labcut.errors import ParameterError
    from labcut.rendering import EXPOSURE_MODES, check_exposure_mode, from_ev

    key = text.strip().lower()
    try:
        if key in EXPOSURE_MODES:
            return check_exposure_mode(key)
        return from_ev(float(key[:-2])) if key.endswith("ev") else check_exposure_mode(float(key))
    except ParameterError as exc:  # (a ValueError too: first)
        raise exc.renamed({"exposure": "--exposure"}) from None
    except ValueError:
        raise ParameterError(f"--exposure must be reference, auto, a multiplier > 0 or stops like -1.5ev, got {text!r}") from None


def exposure_line(result: Any) -> str:
    """How a PNG (a render or an animation) was exposed, for a person: the multiplier and stops,
    the mode against the reference, and the option that repeats it."""
    return (f"exposure {result.exposure:.3g} = {result.exposure_ev:+.2f} EV: {result.exposure_caption}; "
            f"--exposure {result.exposure:.6g} repeats it")


def exposure_json(result: Any) -> dict[str, Any]:
    """The JSON fields of a PNG's exposure (a render or an animation)."""
    return {"exposure": result.exposure, "exposure_ev": result.exposure_ev, "exposure_mode": result.exposure_mode,
            "exposure_reference": result.exposure_reference,
            "exposure_vs_reference_ev": result.exposure_vs_reference_ev, "exposure_caption": result.exposure_caption}


def flash_mask_line(result: Any, path: Any) -> str:
    """The flash mask's share of the stone beside the estimator's flash area, view by view."""
    parts = []
    for f, v in zip(result.flash, result.flash_mask.to_dict()["by_view"]):
        est = "edge-on" if f["flash_area"] is None else f"{f['flash_area']:.0%}"
        parts.append(f"{v['share']:.0%} of the stone's pixels flash (the estimator's flash area: {est})"
                     + ("" if len(result.flash) == 1 else f" from {v['view']}"))
    return f"flash mask written to {path}: " + "; ".join(parts)
