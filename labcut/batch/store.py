"""The results store of a batch: a Parquet dataset directory that a crash cannot corrupt.

``results.parquet/`` is a folder of Parquet part files (``part-000001-<id>.parquet``, ...), one
table with the columns of :data:`SCHEMA`, one record per catalogue row key. The batch's driver
is the only writer: it writes each group of rows that finish together as a new part file,
written to a hidden temporary file in the folder and renamed into place (``labcut.fileio``), so
a part is either whole or absent: a batch killed at any moment keeps every part written before.
At the end of a run the parts are compacted into one (the new part is complete before the old
ones are removed; a crash in between leaves the same records twice, which reading removes).
Two batches cannot write one store at the same time (a lock file, ``.lock``).

Any Parquet reader reads the folder: ``pyarrow.parquet.read_table("results.parquet")``,
``pandas.read_parquet("results.parquet")``, DuckDB's ``read_parquet('results.parquet/*.parquet')``
(those may see a key twice after a crash mid-compaction; :func:`read_results` never does).
"""

from __future__ import annotations

import contextlib
import os
import re
import uuid
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from ..errors import OutputError, ParameterError

PART_RE = re.compile(r"^part-(\d{6,})-[0-9a-f]+\.parquet$")


def schema() -> Any:
    """The store's columns (``pyarrow.Schema``). Units: degrees, L_ref (flash values), seconds, MiB."""
    import pyarrow as pa

    f64, i64, s = pa.float64(), pa.int64(), pa.string()
    return pa.schema([
        ("key", s), ("row", i64), ("name", s), ("cut", s), ("kind", s), ("material", s), ("scenario", s),
        ("quality", s), ("objective", s), ("seed", i64), ("max_tilt_deg", f64),
        ("status", s), ("error", s), ("warnings", s),
        ("normal_x", f64), ("normal_y", f64), ("normal_z", f64), ("tilt_deg", f64), ("azimuth_deg", f64),
        ("description", s), ("score", f64), ("flash_energy", f64), ("flash_area", f64), ("flash_intensity", f64),
        ("coverage", f64), ("balanced", f64), ("energy_in_flash", f64), ("tolerance_deg", f64),
        ("tolerance_front_back_deg", f64), ("tolerance_left_right_deg", f64), ("parallel_within_deg", f64),
        ("evaluations", i64), ("seconds", f64), ("worker", s), ("worker_rss_mib", f64), ("worker_peak_rss_mib", f64),
        ("labcut_version", s), ("finished_at", s), ("recommendation", s),
    ])


COLUMNS = ("key", "row", "name", "cut", "kind", "material", "scenario", "quality", "objective", "seed", "max_tilt_deg",
           "status", "error", "warnings", "normal_x", "normal_y", "normal_z", "tilt_deg", "azimuth_deg", "description",
           "score", "flash_energy", "flash_area", "flash_intensity", "coverage", "balanced", "energy_in_flash",
           "tolerance_deg", "tolerance_front_back_deg", "tolerance_left_right_deg", "parallel_within_deg", "evaluations",
           "seconds", "worker", "worker_rss_mib", "worker_peak_rss_mib", "labcut_version", "finished_at", "recommendation")


class ResultStore:
    """A batch's results folder (module docstring). ``path``: the folder, created on first write;
    an existing file there (not a folder) is an :class:`~labcut.errors.OutputError`."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"results {str(self.path)!r} is a file; a batch writes a folder of Parquet parts there "
                              "(give a new name, or remove the file)")
        if not self.path.exists() and self.path.parent != Path("") and not self.path.parent.exists():
            raise ParameterError(f"output folder {str(self.path.parent)!r} does not exist")
        self._lock: Any = None

    # ------------------------------------------------------------------ parts
    def parts(self) -> list[Path]:
        """The part files, oldest first (the order records are read in: a later one wins)."""
        if not self.path.is_dir():
            return []
        found = [(int(m.group(1)), p) for p in self.path.iterdir() if (m := PART_RE.match(p.name))]
        return [p for _, p in sorted(found)]

    def _next_part(self) -> Path:
        parts = self.parts()
        last = int(PART_RE.match(parts[-1].name).group(1)) if parts else 0  # type: ignore[union-attr]
        return self.path / f"part-{last + 1:06d}-{uuid.uuid4().hex[:8]}.parquet"

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold the store for writing; another process holding it is an :class:`OutputError`."""
        import fcntl

        try:
            self.path.mkdir(exist_ok=True)
            fh = open(self.path / ".lock", "a+")
        except OSError as exc:
            raise OutputError(f"cannot write {str(self.path)!r}: {exc.strerror or exc}") from None
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            raise OutputError(f"results {str(self.path)!r} are being written by another batch; wait for it or give another --out") from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)
            fh.close()

    def write(self, records: Sequence[dict[str, Any]]) -> Path | None:
        """Write ``records`` (column -> value, :data:`COLUMNS`) as one new part, atomically."""
        if not records:
            return None
        import pyarrow as pa
        import pyarrow.parquet as pq

        from ..fileio import atomic_output

        table = pa.Table.from_pylist([{c: r.get(c) for c in COLUMNS} for r in records], schema=schema())
        self.path.mkdir(exist_ok=True)
        target = self._next_part()
        with atomic_output(target, (".parquet",)) as tmp:
            pq.write_table(table, tmp, compression="zstd")
        return target

    # ------------------------------------------------------------------ reading
    def read(self) -> Any:
        """Every stored record once (the latest per key), as a ``pyarrow.Table`` ordered by row."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        tables = []
        for p in self.parts():
            try:
                tables.append(pq.read_table(p, schema=schema()))
            except (OSError, pa.ArrowInvalid) as exc:
                raise OutputError(f"results part {str(p)!r} cannot be read ({str(exc).splitlines()[0]}); "
                                  "move it away and run the batch again to redo its rows") from None
        if not tables:
            return schema().empty_table()
        table = pa.concat_tables(tables)
        keys = table.column("key").to_pylist()
        last = {k: i for i, k in enumerate(keys)}
        keep = sorted(last.values())
        table = table.take(pa.array(keep, type=pa.int64()))
        order = sorted(range(table.num_rows), key=lambda i: (table.column("row")[i].as_py() or 0, i))
        return table.take(pa.array(order, type=pa.int64()))

    def statuses(self) -> dict[str, str]:
        """key -> status (``ok`` / ``error``) of every stored record."""
        table = self.read()
        return dict(zip(table.column("key").to_pylist(), table.column("status").to_pylist()))

    def compact(self) -> Path | None:
        """Rewrite every part into one (the latest record per key); returns the new part."""
        old = self.parts()
        if len(old) <= 1:
            return old[0] if old else None
        import pyarrow.parquet as pq

        from ..fileio import atomic_output

        table = self.read()
        target = self._next_part()
        with atomic_output(target, (".parquet",)) as tmp:
            pq.write_table(table, tmp, compression="zstd")
        for p in old:
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
        return target


def read_results(path: str | os.PathLike[str]) -> Any:
    """A batch's results (``pyarrow.Table``, one record per row key, by catalogue row)."""
    store = ResultStore(path)
    if not store.path.is_dir():
        raise ParameterError(f"results {str(path)!r} do not exist")
    return store.read()


__all__ = ["COLUMNS", "ResultStore", "read_results", "schema"]
