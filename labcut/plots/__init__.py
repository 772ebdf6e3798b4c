"""Figures (matplotlib, Agg backend): spectra, and later score maps and reports."""
