"""Figures (matplotlib, Agg backend): spectra and score maps."""

from __future__ import annotations

from .._exports import lazy_exports

#: the public names of :mod:`labcut.plots`, imported on first use
_EXPORTS = {
    "plot_spectrum": ".spectrum:plot_spectrum",
    "plot_score_map": ".scoremap:plot_score_map",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
