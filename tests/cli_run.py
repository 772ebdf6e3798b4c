"""The CLI run in the test's own process (``labcut_cli.app.main``, as the console script runs it,
without a new interpreter's start-up and imports: about 1.5 s a call): one runner for every test
that does so (conftest's ``cli_main`` fixture and the modules' ``(code, out, err)`` helpers)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import Any


def in_process(args: Any, capsys: Any, *, cwd: Path | None = None, columns: int | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``labcut *args`` here; its exit status, stdout and stderr (captured by pytest's
    ``capsys``) as a ``CompletedProcess``. ``cwd``: the folder it runs in; ``columns``: the
    terminal's width for rich's tables (None: as the console is)."""
    from labcut_cli.app import main
    from labcut_cli.root import console, err_console

    capsys.readouterr()
    widths = console.width, err_console.width
    if columns is not None:
        console.width = err_console.width = columns
    here = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        main([str(a) for a in args])
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        os.chdir(here)
        console.width, err_console.width = widths
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(["labcut", *map(str, args)], code, out, err)


def run_in_process(argv: Any, capsys: Any) -> tuple[int, str, str]:
    """:func:`in_process` as ``(exit status, stdout, stderr)``."""
    done = in_process(argv, capsys)
    return done.returncode, done.stdout, done.stderr
