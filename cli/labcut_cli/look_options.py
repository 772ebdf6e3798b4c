"""``--look`` and ``--denoise/--no-denoise``: how a render looks, shared by every command that renders."""

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
