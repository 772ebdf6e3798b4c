"""Entry point of the ``labcut`` console script.

Errors a user can cause print one line on stderr and exit with status 2; no
traceback reaches the terminal (set LABCUT_DEBUG=1 to see one).
"""

from __future__ import annotations

import gc
import os
import sys

import typer

from labcut.hugepages import numpy_off_for_this_process

try:  # typer >= 0.20 vendors click; older releases use click itself
    from typer import TyperException as _UsageError
except ImportError:  # pragma: no cover
    from click.exceptions import ClickException as _UsageError

from . import spectrum  # noqa: F401  (registers its command)
from . import geometry  # noqa: F401  (registers cabochon, inspect)
from . import recommend  # noqa: F401  (registers recommend-orientation, evaluate-orientation)
from . import render  # noqa: F401  (registers render)
from . import scenes  # noqa: F401  (registers scenarios)
from . import compare  # noqa: F401  (registers compare)
from . import batch  # noqa: F401  (registers batch)
from . import rough  # noqa: F401  (registers rough)
from . import explore  # noqa: F401  (registers explore)
from .root import app, err_console


def _fail(message: str, code: int = 2) -> None:
    from rich.markup import escape

    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    sys.exit(code)


#: commands whose process answers for minutes: they keep numpy's huge page advice (labcut.hugepages)
LONG_LIVED = frozenset({"explore"})


def main(argv: list[str] | None = None) -> None:
    """Run the CLI; map every expected failure to a one-line message and exit 2.

    ``argv`` None (the console script): the process is the command's own. Where the kernel acts
    on numpy's huge page advice, a command that runs once and ends makes its arrays without it
    (:func:`labcut.hugepages.numpy_off_for_this_process`; not the :data:`LONG_LIVED` ones, whose
    answers reuse memory already freed); and the process ends with the command, so the objects
    it made are frozen out of the interpreter's last garbage collection, which would walk them
    all only to free memory the exit frees anyway; files and streams are closed as usual."""
    if argv is None and not LONG_LIVED & set(sys.argv[1:2]):
        numpy_off_for_this_process()
    try:
        _run(argv)
    finally:
        if argv is None:
            gc.freeze()


def _run(argv: list[str] | None) -> None:
    from labcut.errors import LabcutError

    args = sys.argv[1:] if argv is None else list(argv)
    if not args:
        args = ["--help"]
    try:
        result = app(args=args, prog_name="labcut", standalone_mode=False)
    except LabcutError as exc:
        _fail(str(exc))
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except typer.Abort:
        _fail("aborted", 130)
    except _UsageError as exc:  # usage errors: unknown option, bad value
        _fail(exc.format_message(), getattr(exc, "exit_code", 2) or 2)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        _fail(f"{exc.strerror}: {exc.filename}" if exc.filename else str(exc))
    except KeyboardInterrupt:
        _fail("interrupted", 130)
    except Exception as exc:  # a bug: still one line unless debugging
        if os.environ.get("LABCUT_DEBUG"):
            raise
        _fail(f"internal error ({type(exc).__name__}): {exc} (set LABCUT_DEBUG=1 for a traceback)", 1)
    else:
        sys.exit(result if isinstance(result, int) else 0)


if __name__ == "__main__":
    main()
