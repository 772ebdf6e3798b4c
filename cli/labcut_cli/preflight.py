"""Before a render starts (``labcut render``, ``recommend-orientation --render``): its predicted
time and memory, and whether its views or frames flash (:mod:`labcut.commands.render_forecast`)."""

from __future__ import annotations

from typing import Any

import typer

from .root import console, err_console

Yes = typer.Option("--yes", "-y", help="Start a render predicted to take over a minute, or one whose views or frames "
                                       "show no flash.")


def before_rendering(mesh: Any, setup: Any, lamella: Any, move: Any, yes: bool, quiet: bool) -> Any:
    """What a render will cost and whether it will show a flash, before it starts: refuse one that
    cannot fit in memory, print the predicted time, and stop (exit 2) one predicted over a minute,
    or an orbit or animation with no flash in any view or frame, unless ``--yes``. Returns the
    flash of each view (:func:`labcut.render`'s ``flash=``) when it was estimated here, else None."""
    from labcut.commands import flash_preview
    from labcut.errors import ParameterError

    check_cost(mesh, setup, yes, quiet, frames=move.frames if move is not None else 1)
    if move is None and len(setup.cameras) == 1:
        return None
    preview = flash_preview(mesh, setup, lamella, move)
    if not preview.any_flash:
        what = "frames" if move is not None else "views"
        if not yes:
            raise ParameterError(f"{preview.note(what)}; add --yes to render it anyway, or choose another --normal")
        (err_console if quiet else console).print(f"note: {preview.note(what)}", highlight=False)
    if move is not None:
        return None
    return list(preview.flash)


def check_cost(mesh: Any, setup: Any, yes: bool, quiet: bool, frames: int = 1, budget: bool = True) -> None:
    """Refuse a render that cannot fit in memory, print its predicted time and memory (stderr when
    ``quiet``: the JSON goes to stdout), and stop one predicted over a minute unless ``yes``
    (``budget``: the command's ``--time-budget`` is the render's)."""
    from labcut.commands import check_memory, confirmation_message, forecast, needs_confirmation
    from labcut.errors import ParameterError
    from labcut.rendering import plan_for

    fc = forecast(setup, plan_for(mesh, setup).integrator, frames=frames)
    check_memory(fc, setup.resolution, setup.plan_denoise)
    (err_console if quiet else console).print(f"render: {fc.summary()}", highlight=False)
    if not yes and needs_confirmation(fc, setup.time_budget):
        raise ParameterError(confirmation_message(fc, budget=budget))
