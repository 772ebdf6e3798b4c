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

console = Console(emoji=False)  # labcut prints no emoji: its texts are shown as written (and the emoji table is not loaded)
err_console = Console(stderr=True, emoji=False)


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


#: Options whose values are files the command reads (besides its positional arguments).
INPUT_OPTIONS = ("--material", "--lighting", "--zoning", "--cut", "--outline")


def input_files(ctx: Any) -> dict[str, Path]:
    """The files a command reads, ``{argument or option and its value: path}``: every positional
    argument and every :data:`INPUT_OPTIONS` value of its typer context ``ctx`` that names an
    existing file (a spec such as ``cab:oval,16x12`` or ``slab:40x30x8`` is no file; of
    ``FILE@SIZE`` the file counts)."""
    found: dict[str, Path] = {}
    if ctx is None:
        return found
    for param in ctx.command.params:
        if not (param.param_type_name == "argument" or set(param.opts) & set(INPUT_OPTIONS)):
            continue
        values = ctx.params.get(param.name)
        for value in values if isinstance(values, (list, tuple)) else [values]:
            if value is None:
                continue
            for text in (str(value), str(value).rsplit("@", 1)[0]):
                if text and Path(text).is_file():
                    label = (getattr(param, "metavar", None) or param.name.upper()).rstrip(".") if not param.opts[0].startswith("-") else param.opts[0]
                    found.setdefault(f"{label} {text}", Path(text))
                    break
    return found


def check_outputs(outputs: dict[str, tuple[Any, tuple[str, ...] | None]], ctx: Any = None) -> None:
    """Check every output of a command before its work (:func:`labcut.fileio.check_outputs`):
    writable, named once, and (given the command's typer context ``ctx``) none of them a file the
    command reads (:func:`input_files`)."""
    from labcut.fileio import check_outputs as check

    check(outputs, inputs=input_files(ctx))


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
def figure_after_answer(answer_path: Any, figure: Any, what: str) -> Iterator[None]:
    """Write an optional figure after the answer: if it fails (or Ctrl-C), say on stderr that the
    answer already written (``answer_path``: its JSON file, ``"-"`` or None for the table alone)
    stands and which figure was not written, then let the error end the command as usual."""
    try:
        yield
    except BaseException:
        kept = f" in {answer_path}" if answer_path not in (None, "-") else ""
        err_console.print(f"note: the answer above stands{kept}; the {what} {figure} was not written",
                          highlight=False, soft_wrap=True)
        raise


@contextlib.contextmanager
def notes_after(printed: list[tuple[str, str]] | None = None) -> Iterator[None]:
    """Hold labcut's warnings (:class:`~labcut.errors.LabcutWarning`) of the block and print each as
    one ``note:`` line on stderr after it (not inside a progress bar); other warnings go on as usual.
    ``printed``: a list that gets ``("note", text)`` for each line printed but those about labcut's
    user cache (:class:`~labcut.errors.CacheWarning`: this run's, not the answer's)."""
    import warnings

    from labcut.errors import CacheWarning, LabcutWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LabcutWarning)
        yield
    for w in caught:
        if issubclass(w.category, LabcutWarning):
            print_note(str(w.message))
            if printed is not None and not issubclass(w.category, CacheWarning):
                printed.append(("note", str(w.message)))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def print_note(text: str) -> None:
    """One ``note:`` line on stderr."""
    err_console.print(f"note: {text}", highlight=False, soft_wrap=True)


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


#: how often the waiting main thread looks up from a long computation (seconds)
_POLL_SECONDS = 0.1


def interruptibly(work: Any, *args: Any, **kwargs: Any) -> Any:
    """Run ``work(*args, **kwargs)`` so that Ctrl-C ends the command at once (exit 130).

    A render's kernels run inside Mitsuba for seconds to minutes at a time, where Python cannot
    stop them; so the work runs in a worker thread while the main thread waits, and a Ctrl-C
    there ends the process at once, with the one-line message and status 130 of any interrupted
    command. Nothing is left behind: the commands write their files only after the work returns
    (each atomically), and the process ends before that. Errors of the work come back here as
    they were raised."""
    import os
    import sys
    import threading

    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["result"] = work(*args, **kwargs)
        except BaseException as exc:  # noqa: BLE001  (handed to the main thread)
            box["error"] = exc

    worker = threading.Thread(target=run, name="labcut-work", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(_POLL_SECONDS)
    except KeyboardInterrupt:
        for c in (console, err_console):
            c.show_cursor(True)  # a progress bar hid it
        err_console.print("[bold red]error:[/] interrupted", highlight=False)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)  # the worker is inside a kernel: end the process, not the thread
    if "error" in box:
        raise box["error"]
    return box.get("result")
