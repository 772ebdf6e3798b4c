"""The Typer application object and helpers shared by every command module.

Command modules import :data:`app` from here and register with ``@app.command()``;
:mod:`labcut_cli.app` imports them all and runs the application.
"""

from __future__ import annotations

import contextlib
import json
import math
from collections.abc import Iterator
from pathlib import Path
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


def normal_or_angles(vector: str | None, tilt: float | None, azimuth: float | None, options: tuple[str, str, str],
                     default: str | None = None) -> Any:
    """A unit lamella normal from a vector option (``options[0]``, text ``X,Y,Z``) or from a tilt
    and an azimuth option (degrees; ``options[1:]``), one of the two ways; ``default`` (a vector's
    text) when neither is given, else a one-line error naming the options."""
    from labcut.errors import ParameterError
    from labcut.scene import lamella_normal

    v_opt, t_opt, a_opt = options
    if vector is not None and (tilt is not None or azimuth is not None):
        raise ParameterError(f"give {v_opt} or {t_opt} with {a_opt}, not both")
    if (tilt is None) != (azimuth is None):
        raise ParameterError(f"give {t_opt} and {a_opt} together (degrees), or {v_opt}")
    if vector is None and tilt is None:
        if default is None:
            raise ParameterError(f"give {v_opt} X,Y,Z or {t_opt} DEG with {a_opt} DEG")
        vector = default
    try:
        return lamella_normal(None if vector is None else parse_vector(vector, v_opt), tilt, azimuth)
    except ParameterError as exc:
        raise exc.renamed({"tilt": t_opt, "azimuth": a_opt, "lamella normal": v_opt}) from None


@contextlib.contextmanager
def all_or_nothing() -> Iterator[list[Path]]:
    """Collect the output files a command writes; if it fails half-way, remove them again,
    so a failed command leaves no output behind (each file is itself written atomically)."""
    written: list[Path] = []
    try:
        yield written
    except BaseException:
        for p in written:
            with contextlib.suppress(OSError):
                p.unlink()
        raise


@contextlib.contextmanager
def notes_after() -> Iterator[None]:
    """Hold labcut's warnings (:class:`~labcut.errors.LabcutWarning`) of the block and print each as
    one ``note:`` line on stderr after it (not inside a progress bar); other warnings go on as usual."""
    import warnings

    from labcut.errors import LabcutWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LabcutWarning)
        yield
    for w in caught:
        if issubclass(w.category, LabcutWarning):
            err_console.print(f"note: {w.message}", highlight=False, soft_wrap=True)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def write_json(path: str, data: Any) -> None:
    """Write ``data`` as indented JSON, atomically; ``-`` prints it to stdout."""
    from labcut.fileio import atomic_output

    if str(path) == "-":
        typer.echo(json.dumps(data, indent=2, allow_nan=False))
        return
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
