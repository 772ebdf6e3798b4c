"""The Typer application object and helpers shared by every command module.

Command modules import :data:`app` from here and register with ``@app.command()``;
:mod:`labcut_cli.app` imports them all and runs the application.
"""

from __future__ import annotations

import json
import math
from typing import Any

import typer
from rich.console import Console

app = typer.Typer(
    name="labcut",
    help="Plan labradorite cuts: lamella physics, stone geometry, rendering and orientation.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

console = Console()
err_console = Console(stderr=True)


def parse_vector(text: str, name: str = "vector", length: int = 3) -> tuple[float, ...]:
    """Parse ``"x,y,z"`` into floats; a bad value is a :class:`labcut.ParameterError`."""
    from labcut.errors import ParameterError

    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise ParameterError(f"{name} must be {length} comma-separated numbers, got {text!r}") from None
    if len(values) != length:
        raise ParameterError(f"{name} must be {length} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise ParameterError(f"{name} must be finite, got {text!r}")
    return values


def write_json(path: str, data: Any) -> None:
    """Write ``data`` as indented JSON, atomically."""
    from labcut.fileio import atomic_output

    with atomic_output(path, (".json",)) as tmp:
        tmp.write_text(json.dumps(data, indent=2, allow_nan=False) + "\n")


def _version(value: bool) -> None:
    if value:
        from labcut import __version__

        console.print(f"labcut {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print the version and exit.", callback=_version, is_eager=True),
) -> None:
    """Plan labradorite cuts: lamella physics, stone geometry, rendering and orientation."""
