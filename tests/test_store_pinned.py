"""labcut.batch.store pinned by mutation testing (issue 37; docs/testing.md, "labcut/batch/store.py").

The results store as its module docstring defines it: the columns and their types written out
by hand; every column kept through a write and a read; every part file carrying the store's
schema, so any Parquet reader reads the folder; the part names (``part-000001-<8 hex>.parquet``,
numbered on from the last part, ordered by number, not by name); zstd-compressed parts;
compaction (nothing to do for none or one part; a part removed meanwhile is no error); reading
parts from an older labcut with fewer columns and parts with no rows; a record without a row
first; every error a user reads, word for word. No cluster, no recommendation: under a second.
"""

from __future__ import annotations

import os
import re

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from labcut.batch.store import COLUMNS, ResultStore, read_results, schema
from labcut.errors import OutputError, ParameterError

S, I, F = pa.string(), pa.int64(), pa.float64()

#: the store's columns and types, from the module's schema docstring (degrees, L_ref, seconds, MiB)
EXPECTED = [
    ("key", S), ("row", I), ("name", S), ("cut", S), ("kind", S), ("material", S), ("scenario", S),
    ("quality", S), ("objective", S), ("seed", I), ("max_tilt_deg", F),
    ("status", S), ("error", S), ("warnings", S),
    ("normal_x", F), ("normal_y", F), ("normal_z", F), ("tilt_deg", F), ("azimuth_deg", F),
    ("description", S), ("score", F), ("flash_energy", F), ("flash_area", F), ("flash_intensity", F),
    ("coverage", F), ("balanced", F), ("energy_in_flash", F), ("tolerance_deg", F),
    ("tolerance_front_back_deg", F), ("tolerance_left_right_deg", F), ("parallel_within_deg", F),
    ("evaluations", I), ("seconds", F), ("worker", S), ("worker_rss_mib", F), ("worker_peak_rss_mib", F),
    ("labcut_version", S), ("finished_at", S), ("recommendation", S),
]

PART = re.compile(r"^part-(\d{6})-[0-9a-f]{8}\.parquet$")


def full_record(key: str = "k1", row: int = 3) -> dict:
    """A record with every column set to a value of its own (strings name their column, numbers differ)."""
    rec = {}
    for i, (name, typ) in enumerate(EXPECTED):
        if typ == S:
            rec[name] = f"{name}-value"
        elif typ == I:
            rec[name] = 100 + i
        else:
            rec[name] = 0.5 + i
    rec["key"], rec["row"] = key, row
    return rec


def record(key: str, row, status: str = "ok", **extra) -> dict:
    return {"key": key, "row": row, "status": status, **extra}


def numbers(store: ResultStore) -> list[int]:
    found = [PART.match(p.name) for p in store.parts()]
    assert all(found), [p.name for p in store.parts()]
    return [int(m.group(1)) for m in found]


# ------------------------------------------------------------------ the columns
def test_schema_is_the_documented_columns_and_types():
    """Each column's name and type, written out here: a renamed column (``NAME``) or a changed type
    would break every reader of old results (DuckDB queries, pandas scripts by column name)."""
    sch = schema()
    assert [(f.name, f.type) for f in sch] == EXPECTED
    assert list(COLUMNS) == [name for name, _ in EXPECTED]


def test_every_column_survives_write_and_read(tmp_path):
    """A record with every column set reads back exactly, column by column (a column renamed in the
    schema would read back None, or under another name)."""
    store = ResultStore(tmp_path / "r.parquet")
    rec = full_record()
    store.write([rec])
    rows = store.read().to_pylist()
    assert rows == [rec]
    assert read_results(store.path).to_pylist() == [rec]


def test_every_part_has_the_store_schema(tmp_path):
    """A part of failed rows only (every number None) still has the float and int columns, not
    Arrow's null type: otherwise ``pyarrow.parquet.read_table`` of the folder, which takes the
    first part's schema, could not read the later parts' scores (the docstring's "any Parquet
    reader reads the folder")."""
    store = ResultStore(tmp_path / "r.parquet")
    store.write([record("a", 1, "error", error="boom")])
    store.write([record("b", 2, score=0.25, seed=7)])
    for part in store.parts():
        assert pq.read_schema(part).remove_metadata().equals(schema())
    whole = pq.read_table(store.path)
    assert whole.schema.remove_metadata().equals(schema())
    assert sorted(zip(whole.column("key").to_pylist(), whole.column("score").to_pylist())) == [("a", None), ("b", 0.25)]
    store.compact()
    (part,) = store.parts()
    assert pq.read_schema(part).remove_metadata().equals(schema())


def test_parts_are_zstd_compressed(tmp_path):
    """Each part, written or compacted, is zstd-compressed (the store's choice: about half the size
    of pyarrow's default snappy for these mostly-repeated strings)."""
    store = ResultStore(tmp_path / "r.parquet")
    store.write([full_record("a", 1)])
    store.write([full_record("b", 2)])
    for part in store.parts():
        assert codecs(part) == {"ZSTD"}, part.name
    assert codecs(store.compact()) == {"ZSTD"}


def codecs(part) -> set[str]:
    meta = pq.ParquetFile(part).metadata
    return {meta.row_group(0).column(j).compression for j in range(meta.num_columns)}


# ------------------------------------------------------------------ part names
def test_part_names_number_on_from_the_last_part(tmp_path):
    """``part-000001-<id>.parquet``: six digits, then eight hex digits; each new part one past the
    highest number in the folder (a gap left by a removed part is not reused); compaction's part too."""
    store = ResultStore(tmp_path / "r.parquet")
    first = store.write([record("a", 1)])
    assert first.parent == store.path and PART.match(first.name) and first.name.startswith("part-000001-")
    store.write([record("b", 2)])
    store.write([record("c", 3)])
    assert numbers(store) == [1, 2, 3]
    new = store.compact()
    assert new.name.startswith("part-000004-") and PART.match(new.name)
    assert store.parts() == [new]
    (store.path / "part-000041-0123abcd.parquet").write_bytes(new.read_bytes())  # a copied part
    assert store.write([record("d", 4)]).name.startswith("part-000042-")


def test_parts_ordered_by_number_not_name(tmp_path):
    """Past part 999999 the number grows to seven digits: ``part-1000000`` sorts before
    ``part-999999`` by name, yet it is the later part, whose record for a key wins."""
    store = ResultStore(tmp_path / "r.parquet")
    store.path.mkdir()
    old = store.path / "part-999999-00000000.parquet"
    pq.write_table(pa.Table.from_pylist([record("a", 1, score=1.0)], schema=schema()), old)
    new = store.write([record("a", 1, score=2.0)])
    assert new.name.startswith("part-1000000-")
    assert store.parts() == [old, new]
    assert store.read().column("score").to_pylist() == [2.0]


def test_other_files_in_the_folder_are_not_parts(tmp_path):
    """Only ``part-<6+ digits>-<hex>.parquet`` are parts: the lock, a hidden temporary file, a
    short number or an upper-case id are ignored (and not read)."""
    store = ResultStore(tmp_path / "r.parquet")
    with store.lock():
        pass
    for name in (".part-000009-dead.parquet", "part-00001-abcd.parquet", "part-000002-ABCD.parquet",
                 "part-000003-abcd.parquet.tmp", "notes.txt"):
        (store.path / name).write_bytes(b"not a part")
    assert store.parts() == []
    assert store.read().num_rows == 0


# ------------------------------------------------------------------ compaction
def test_compact_nothing_to_do(tmp_path):
    """No parts: None (no folder made); one part: that part, left as it is (not rewritten under a
    new number)."""
    store = ResultStore(tmp_path / "r.parquet")
    assert store.compact() is None
    assert not store.path.exists()
    only = store.write([record("a", 1)])
    before = (only.name, only.stat().st_mtime_ns, only.read_bytes())
    assert store.compact() == only
    assert store.parts() == [only]
    assert (only.name, only.stat().st_mtime_ns, only.read_bytes()) == before


def test_compact_keeps_the_latest_record_per_key(tmp_path):
    store = ResultStore(tmp_path / "r.parquet")
    store.write([record("b", 2, "error", error="boom"), record("a", 1, score=1.0)])
    store.write([record("b", 2, score=3.0)])
    new = store.compact()
    assert store.parts() == [new]
    table = pq.read_table(new)
    assert table.column("key").to_pylist() == ["a", "b"]
    assert table.column("status").to_pylist() == ["ok", "ok"]
    assert table.column("score").to_pylist() == [1.0, 3.0]


def test_compact_a_part_removed_meanwhile_is_no_error(tmp_path, monkeypatch):
    """A part that disappears between the compaction's read and its clean-up (moved away by the user,
    as the unreadable-part error tells them to) is not an error: the compacted part has its records."""
    store = ResultStore(tmp_path / "r.parquet")
    store.write([record("a", 1)])
    store.write([record("b", 2)])
    first = store.parts()[0]
    original = ResultStore.read

    def read_then_remove(self):
        table = original(self)
        first.unlink()
        return table

    monkeypatch.setattr(ResultStore, "read", read_then_remove)
    new = store.compact()
    monkeypatch.undo()
    assert store.parts() == [new]
    assert store.read().column("key").to_pylist() == ["a", "b"]


# ------------------------------------------------------------------ reading
def test_read_part_from_an_older_labcut_with_fewer_columns(tmp_path):
    """A part written before a column existed (here only key, row and status) reads with that
    column empty (None), alongside parts with every column."""
    store = ResultStore(tmp_path / "r.parquet")
    store.path.mkdir()
    pq.write_table(pa.table({"key": ["old"], "row": pa.array([1], I), "status": ["ok"]}),
                   store.path / "part-000001-00000000.parquet")
    store.write([full_record("new", 2)])
    table = store.read()
    assert table.schema.equals(schema())
    old, new = table.to_pylist()
    assert old == {**{c: None for c in COLUMNS}, "key": "old", "row": 1, "status": "ok"}
    assert new == full_record("new", 2)


def test_read_parts_without_rows(tmp_path):
    """A part with no rows (any Parquet writer can leave one) reads as no records, alone or with others."""
    store = ResultStore(tmp_path / "r.parquet")
    store.path.mkdir()
    pq.write_table(schema().empty_table(), store.path / "part-000001-00000000.parquet")
    table = store.read()
    assert table.num_rows == 0 and table.schema.equals(schema())
    assert store.statuses() == {}
    store.write([record("a", 1)])
    assert store.statuses() == {"a": "ok"}


def test_read_orders_by_row_a_record_without_row_first(tmp_path):
    """Records come by catalogue row; one without a row counts as row 0 (before row 1); equal rows
    keep the order they were stored in."""
    store = ResultStore(tmp_path / "r.parquet")
    store.write([record("r2", 2), record("r1", 1), record("none", None), record("r1b", 1)])
    assert store.read().column("key").to_pylist() == ["none", "r1", "r1b", "r2"]
    assert store.read().column("row").to_pylist() == [None, 1, 1, 2]


def test_read_a_key_twice_in_one_part_keeps_the_later(tmp_path):
    store = ResultStore(tmp_path / "r.parquet")
    store.write([record("a", 1, score=1.0), record("a", 1, score=2.0)])
    assert store.read().column("score").to_pylist() == [2.0]


def test_write_nothing_writes_no_part(tmp_path):
    store = ResultStore(tmp_path / "r.parquet")
    assert store.write([]) is None
    assert not store.path.exists()


# ------------------------------------------------------------------ errors, word for word
def test_unreadable_part_message(tmp_path):
    """One line: the part's path, the reader's first line, and what to do."""
    store = ResultStore(tmp_path / "r.parquet")
    store.write([record("a", 1)])
    bad = store.path / "part-000002-deadbeef.parquet"
    bad.write_bytes(b"half a file")
    with pytest.raises(OutputError) as info:
        store.read()
    msg = str(info.value)
    assert msg.startswith(f"results part {str(bad)!r} cannot be read (")
    assert msg.endswith("); move it away and run the batch again to redo its rows")
    assert "Parquet magic bytes not found" in msg and "\n" not in msg


def test_results_path_is_a_file_message(tmp_path):
    path = tmp_path / "file.parquet"
    path.write_bytes(b"x")
    with pytest.raises(OutputError) as info:
        ResultStore(path)
    assert str(info.value) == (f"results {str(path)!r} is a file; a batch writes a folder of Parquet parts there "
                               "(give a new name, or remove the file)")


def test_missing_output_folder_message(tmp_path):
    with pytest.raises(ParameterError) as info:
        ResultStore(tmp_path / "no" / "r.parquet")
    assert str(info.value) == f"output folder {str(tmp_path / 'no')!r} does not exist"


def test_relative_store_in_the_current_folder(tmp_path, monkeypatch):
    """A bare name (its folder the current one) is accepted and written there."""
    monkeypatch.chdir(tmp_path)
    store = ResultStore("r.parquet")
    store.write([record("a", 1)])
    assert (tmp_path / "r.parquet").is_dir() and read_results("r.parquet").num_rows == 1


def test_read_results_missing_message(tmp_path):
    """The path as the user gave it, not made absolute; a missing folder inside an existing one."""
    path = tmp_path / "r.parquet"
    with pytest.raises(ParameterError) as info:
        read_results(path)
    assert str(info.value) == f"results {str(path)!r} do not exist"
    with pytest.raises(ParameterError) as info:
        read_results(os.fspath(path))
    assert str(info.value) == f"results {str(path)!r} do not exist"
