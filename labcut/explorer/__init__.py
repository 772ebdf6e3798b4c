"""Explore a stone live: ``labcut explore`` in the browser and :func:`explore` in a notebook.

:class:`ExploreSession` holds the controls' state and answers from :class:`labcut.Study` objects;
:mod:`labcut.explorer.server` serves it as a local web page (docs/explore.md).
"""

from __future__ import annotations

from .._exports import lazy_exports as _lazy_exports

_LAZY = {
    "ExploreSession": "labcut.explorer.session:ExploreSession",
    "ExploreState": "labcut.explorer.state:ExploreState",
    "ControlError": "labcut.explorer.state:ControlError",
    "Explorer": "labcut.explorer.server:Explorer",
    "explore": "labcut.explorer.server:explore",
    "serve": "labcut.explorer.server:serve",
}

__getattr__, __dir__, __all__ = _lazy_exports(__name__, _LAZY)
