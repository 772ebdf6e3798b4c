"""The CLI's progress bars (``labcut_cli.progress``) show their descriptions as written."""

from __future__ import annotations

import io

from rich.console import Console

from labcut_cli import progress


def test_a_description_is_plain_text_not_markup(monkeypatch):
    """A mesh file's name goes into the loading bar's description: brackets in it (``gem[/b].ply``,
    ``stone[2].ply``) are shown as written; as rich markup, a closing tag without its opening one
    was an error and a tag's text went missing."""
    out = io.StringIO()
    monkeypatch.setattr(progress, "err_console", Console(file=out, force_terminal=False, width=100, emoji=False))
    with progress.progress_bar("loading gem[/b].ply and stone[2].ply [red]x", "[%]") as update:
        update(1, 2)
    text = out.getvalue()
    assert "loading gem[/b].ply and stone[2].ply [red]x" in text and "[%]" in text
