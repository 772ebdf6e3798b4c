"""Batch runs of catalogues on Dask (docs/batch.md): ``labcut.batch.run(catalog, client=None, ...)``.

A catalogue (CSV or YAML, :mod:`labcut.batch.catalog`) lists cuts with their material,
scenario, quality, objective and seed; :func:`run` runs :func:`labcut.recommend_orientation`
for every row on Dask distributed and streams the results to a Parquet store
(:mod:`labcut.batch.store`) that survives interruptions and is resumed by key.
"""

from __future__ import annotations

from .catalog import Catalog, CatalogError, Defaults, Row, read_catalog
from .runner import BatchResult, connect, run, run_row
from .store import ResultStore, read_results

__all__ = ["BatchResult", "Catalog", "CatalogError", "Defaults", "connect", "ResultStore", "Row", "read_catalog", "read_results",
           "run", "run_row"]
