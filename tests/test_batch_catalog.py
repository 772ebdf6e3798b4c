"""labcut.batch without a cluster: catalogues are checked whole before any work, row keys, the
Parquet store (parts, latest record per key, compaction, lock), and the CLI's exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from labcut.batch.catalog import CatalogError, Defaults, read_catalog
from labcut.batch.store import ResultStore, read_results
from labcut.errors import LabcutError, OutputError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def folder(catalogue_folder: Path) -> Path:
    """A catalogue folder with two small meshes and a GemCad design next to it."""
    return catalogue_folder


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


GOOD = """# comment lines are skipped
name,cut,material,scenario,quality,seed
cube,m/cube.ply,blue,bench,draft,0
,m/step.ply,505,pendant,,3
srb,m/SRB.asc,,,draft,
cab,"cab:round,8,low,res=32",gold,ring,draft,1
"""


def test_csv_rows_resolve_paths_defaults_and_kinds(folder):
    cat = read_catalog(write(folder / "c.csv", GOOD), Defaults(scenario="display", quality="standard", seed=7))
    rows = cat.rows
    assert [r.kind for r in rows] == ["file", "file", "design", "cabochon"]
    assert rows[0].path == str((folder / "m" / "cube.ply").resolve())  # relative to the catalogue, not the cwd
    assert rows[1].name == "step.ply" and rows[1].material_label == "505 nm" and rows[1].quality == "standard"
    assert rows[1].seed == 3 and rows[2].seed == 7 and rows[2].scenario == "display"
    assert rows[3].cab == {"outline": "round", "length": 8.0, "dome": "low", "resolution": 32}
    assert abs(rows[1].material.peak_wavelength() - 505.0) < 0.05
    assert len({r.key for r in rows}) == 4


def test_yaml_grid_and_defaults(folder):
    text = """
defaults: {quality: draft}
grid:
  cut: [m/cube.ply, m/step.ply]
  material: [blue, gold]
  scenario: [bench, ring, pendant]
rows:
  - {cut: m/SRB.asc, size: 8, name: small SRB}
"""
    cat = read_catalog(write(folder / "c.yaml", text))
    assert len(cat) == 1 + 2 * 2 * 3
    assert {r.quality for r in cat.rows} == {"draft"}
    assert cat.rows[0].size == 8.0 and cat.rows[0].name == "small SRB"
    assert [(r.material_label, r.scenario) for r in cat.rows[1:4]] == [("blue", "bench"), ("blue", "ring"), ("blue", "pendant")]


def test_key_follows_the_inputs_not_the_label(folder):
    base = "cut,seed,name\nm/cube.ply,0,a\n"
    key = read_catalog(write(folder / "a.csv", base)).rows[0].key
    assert read_catalog(write(folder / "b.csv", "cut,seed,name\nm/cube.ply,0,another name\n")).rows[0].key == key
    assert read_catalog(write(folder / "c.csv", "cut,seed\nm/cube.ply,1\n")).rows[0].key != key
    assert read_catalog(write(folder / "d.csv", "cut,seed,quality\nm/cube.ply,0,draft\n")).rows[0].key != key
    data = (folder / "m" / "cube.ply").read_bytes()
    (folder / "m" / "cube.ply").write_bytes(data + b"\n")  # an edited mesh file is a new row
    assert read_catalog(write(folder / "e.csv", base)).rows[0].key != key


BAD = [
    ("cut,colour\nm/cube.ply,red\n", "header (line 1): unknown column 'colour'"),
    ("name,material\nx,blue\n", "no 'cut' column"),
    ("cut,quality\nm/cube.ply,draft\nm/step.ply,hgih\n", "line 3, column 'quality': must be one of draft, standard, high"),
    ("cut\nm/missing.ply\n", "line 2, column 'cut': mesh file 'm/missing.ply' does not exist"),
    ("cut\nm/cube.txt\n", "line 2, column 'cut': 'm/cube.txt' is neither a mesh"),
    ("cut,seed\nm/cube.ply,-1\n", "line 2, column 'seed': must be an integer >= 0"),
    ("cut,seed\nm/cube.ply,1.5\n", "line 2, column 'seed'"),
    ("cut,material\nm/cube.ply,purple\n", "line 2, column 'material': unknown material preset 'purple'"),
    ("cut,material\nm/cube.ply,5000\n", "line 2, column 'material'"),
    ("cut,scenario\nm/cube.ply,disco\n", "line 2, column 'scenario': unknown scenario 'disco'"),
    ("cut,objective\nm/cube.ply,beauty\n", "line 2, column 'objective'"),
    ("cut\n\"cab:ovl,16x12\"\n", "line 2, column 'cut': unknown outline 'ovl'"),
    ("cut\n\"cab:oval,16x12,hgh\"\n", "line 2, column 'cut': dome must be"),
    ("cut,max_tilt\nm/cube.ply,120\n", "line 2, column 'max_tilt'"),
    ("cut,units\nm/cube.ply,furlong\n", "line 2, column 'units'"),
    ("cut,size\nm/cube.ply,10\n", "line 2, column 'size'"),
    ("cut,seed\nm/cube.ply,0\nm/cube.ply,0\n", "line 3: repeats line 2"),
    ("cut,name\n,empty\n", "line 2, column 'cut': is empty"),
    ("cut,name\nm/cube.ply,a,b\n", "line 2: has 3 cells"),
]


@pytest.mark.parametrize("text,expected", BAD, ids=[e for _, e in BAD])
def test_a_bad_catalogue_is_one_line_naming_row_and_column(folder, text, expected):
    with pytest.raises(CatalogError) as info:
        read_catalog(write(folder / "bad.csv", text))
    message = str(info.value)
    assert expected in message, message
    assert "\n" not in message and message.startswith(f"catalogue {str(folder / 'bad.csv')!r}")
    assert isinstance(info.value, LabcutError)


def test_bad_yaml_and_files(folder):
    for text, expected in (("rows: [{cut: m/cube.ply, colour: red}]", "row 1: unknown column 'colour'"),
                           ("grid: {cut: []}", "grid, column 'cut': is an empty list"),
                           ("what: 1", "unknown top-level key 'what'"),
                           ("- [1, 2]", "row 1: must be a mapping"),
                           ("rows: [{cut: m/cube.ply, seed: true}]", "column 'seed'"),
                           ("{cut: [", "is not readable YAML")):
        with pytest.raises(CatalogError, match=None) as info:
            read_catalog(write(folder / "bad.yaml", text))
        assert expected in str(info.value), str(info.value)
    with pytest.raises(CatalogError, match="does not exist"):
        read_catalog(folder / "nowhere.csv")
    with pytest.raises(CatalogError, match="CSV .* or YAML"):
        read_catalog(write(folder / "c.txt", "cut\n"))


# ---------------------------------------------------------------------- the store
def record(key: str, row: int, status: str = "ok", **extra):
    return {"key": key, "row": row, "name": key, "status": status, "seed": 0, **extra}


def test_store_parts_latest_record_wins_and_compaction(tmp_path):
    store = ResultStore(tmp_path / "r.parquet")
    assert store.read().num_rows == 0
    store.write([record("a", 2, score=1.0), record("b", 1, "error", error="boom")])
    store.write([record("b", 1, score=2.0)])  # --retry-failed: b again
    assert len(store.parts()) == 2
    (store.path / ".part-000009-dead.parquet").write_bytes(b"half a file")  # a crash mid-write: hidden, ignored
    table = store.read()
    assert table.column("key").to_pylist() == ["b", "a"]  # by row
    assert table.column("status").to_pylist() == ["ok", "ok"] and table.column("score").to_pylist() == [2.0, 1.0]
    assert store.statuses() == {"a": "ok", "b": "ok"}
    store.compact()
    assert len(store.parts()) == 1
    assert read_results(store.path).column("key").to_pylist() == ["b", "a"]
    import pyarrow.parquet as pq

    assert pq.read_table(store.path).num_rows == 2  # any Parquet reader reads the folder


def test_store_lock_and_bad_paths(tmp_path):
    store = ResultStore(tmp_path / "r.parquet")
    with store.lock():
        with pytest.raises(OutputError, match="being written by another batch"):
            with ResultStore(tmp_path / "r.parquet").lock():
                pass
    with ResultStore(tmp_path / "r.parquet").lock():  # released
        pass
    (tmp_path / "file.parquet").write_bytes(b"x")
    with pytest.raises(OutputError, match="is a file"):
        ResultStore(tmp_path / "file.parquet")
    with pytest.raises(LabcutError, match="does not exist"):
        ResultStore(tmp_path / "no" / "r.parquet")


def test_cli_malformed_catalogue_exits_2_before_any_work(folder, cli):
    bad = write(folder / "bad.csv", "cut,quality\nm/cube.ply,draft\nm/step.ply,superb\n")
    out = folder / "out.parquet"
    proc = cli("batch", str(bad), "--out", str(out), "--html", str(folder / "r.html"))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "line 3, column 'quality'" in lines[0] and "Traceback" not in proc.stderr
    assert not out.exists() and not (folder / "r.html").exists()
    proc = cli("batch", str(write(folder / "good.csv", "cut\nm/cube.ply\n")), "--out", str(out), "--workers", "2",
               "--scheduler", "tcp://127.0.0.1:1")
    assert proc.returncode == 2 and "--workers sizes the embedded cluster" in proc.stderr


@pytest.mark.parametrize("name, rows", [("catalog.csv", 12), ("catalog.yaml", 13), ("catalog-demo.csv", 6)])
def test_bundled_catalogues_are_valid(name, rows):
    """The catalogues the docs, README and ``make demo`` run read without error (read_catalog
    refuses a row whose file is missing), with the rows they are documented to have, each once."""
    cat = read_catalog(ROOT / "examples" / name, Defaults(quality="draft"))
    assert len(cat.rows) == rows and len({r.key for r in cat.rows}) == rows


# ---------------------------------------------------------------------- malformed CSV, every bad row
@pytest.mark.parametrize("text, line", [
    ('name,cut\n"a,m/cube.ply\nb,m/step.ply\n', 2),  # csv read it as a name running to the end, and no cut
    ('cut,name\nm/cube.ply,a\n# a comment\nm/step.ply,"b\nm/cube.ply,c\n', 4),
    ('cut,name\nm/cube.ply,"two\nlines"\nm/step.ply,"say ""hi""\nm/cube.ply,c\n', 4),  # "" is a quote
])
def test_an_unclosed_quote_is_malformed_csv_at_the_line_it_opens(folder, text, line):
    with pytest.raises(CatalogError) as info:
        read_catalog(write(folder / "bad.csv", text))
    message = str(info.value)
    assert message.startswith(f"catalogue {str(folder / 'bad.csv')!r}, line {line}: is malformed CSV"), message
    assert "quote" in message and "\n" not in message and "column 'cut'" not in message


def test_rows_spanning_lines_keep_their_line_numbers(folder):
    """A quoted cell may hold a line break; the rows after it are still named by their own lines."""
    text = 'cut,name\nm/cube.ply,"two\nlines"\nm/step.ply,x\nm/cube.ply,y,extra\n'
    with pytest.raises(CatalogError, match=r"line 5: has 3 cells"):
        read_catalog(write(folder / "bad.csv", text))
    cat = read_catalog(write(folder / "good.csv", 'cut,name\nm/cube.ply,"two\nlines"\nm/step.ply,x\n'))
    assert [r.name for r in cat.rows] == ["two\nlines", "x"]


def test_every_bad_row_is_reported_at_once(folder):
    text = ("cut,quality,seed\nm/cube.ply,draft,0\nm/cube.ply,fast,0\nm/missing.ply,draft,1\n"
            "m/cube.ply,draft,-1\nm/cube.ply,draft,0\nm/step.ply,draft,0,9\nm/step.ply,draft,0\n")
    with pytest.raises(CatalogError) as info:
        read_catalog(write(folder / "bad.csv", text))
    label = f"catalogue {str(folder / 'bad.csv')!r}"
    lines = str(info.value).splitlines()
    assert lines == [f"{label} has 5 bad rows:",
                     "  line 3, column 'quality': must be one of draft, standard, high, got 'fast'",
                     lines[2], "  line 5, column 'seed': must be an integer >= 0, got '-1'",
                     "  line 6: repeats line 2 (same cut and settings); each row runs once",
                     "  line 7: has 4 cells but the header names 3 columns"]
    assert lines[2].startswith("  line 4, column 'cut': mesh file 'm/missing.ply' does not exist")
    assert [p.startswith(f"{label}, line ") for p in info.value.problems] == [True] * 5
    assert isinstance(info.value, LabcutError)


def test_the_bad_rows_listed_stop_at_twenty(folder):
    from labcut.batch.catalog import MAX_REPORTED_ROWS

    text = "cut,seed\n" + "".join(f"m/cube.ply,{-k}\n" for k in range(1, 26))
    with pytest.raises(CatalogError) as info:
        read_catalog(write(folder / "bad.csv", text))
    lines = str(info.value).splitlines()
    assert MAX_REPORTED_ROWS == 20 and len(lines) == 1 + 20 + 1 and len(info.value.problems) == 25
    assert lines[0].endswith("has 25 bad rows:") and lines[1].startswith("  line 2, column 'seed'")
    assert lines[20].startswith("  line 21, column 'seed'") and lines[-1] == "  ... and 5 more bad rows"


def test_every_bad_yaml_row_and_python_row_is_reported(folder):
    text = "rows:\n  - {cut: m/cube.ply, colour: red}\n  - {cut: m/cube.ply}\n  - {cut: m/cube.ply, seed: -2}\n"
    with pytest.raises(CatalogError) as info:
        read_catalog(write(folder / "bad.yaml", text))
    assert [line.split(":")[0] for line in str(info.value).splitlines()[1:]] == ["  row 1", "  row 3, column 'seed'"]
    with pytest.raises(CatalogError) as info:
        read_catalog([{"cut": "m/nope.ply"}, "not a row", {"cut": "m/cube.ply"}], base=folder)
    assert len(info.value.problems) == 2 and "row 2: must be a mapping" in str(info.value)


def test_a_material_cell_outside_the_visible_warns_once_naming_its_rows(folder):
    from labcut.errors import LabcutWarning

    text = "cut,material,seed\nm/cube.ply,2000,0\nm/cube.ply,2000,1\nm/step.ply,blue,0\n"
    with pytest.warns(LabcutWarning) as caught:
        cat = read_catalog(write(folder / "ir.csv", text))
    assert len(cat) == 3
    notes = [str(w.message) for w in caught if issubclass(w.category, LabcutWarning)]
    assert len(notes) == 1 and notes[0].startswith(f"catalogue {str(folder / 'ir.csv')!r}, line 2, line 3, column 'material': ")
    assert "outside the visible range" in notes[0]


def test_cli_reports_every_bad_row_and_exits_2_before_any_work(folder, cli):
    bad = write(folder / "bad.csv", "cut,quality\nm/cube.ply,superb\nm/step.ply,draft\nm/nope.ply,draft\n")
    out = folder / "out.parquet"
    proc = cli("batch", str(bad), "--out", str(out))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines[0] == f"error: catalogue {str(bad)!r} has 2 bad rows:"
    assert lines[1].startswith("  line 2, column 'quality'") and lines[2].startswith("  line 4, column 'cut'") and len(lines) == 3
    proc = cli("batch", str(write(folder / "q.csv", 'name,cut\n"a,m/cube.ply\nb,m/step.ply\n')), "--out", str(out))
    assert proc.returncode == 2 and "line 2: is malformed CSV" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not out.exists()
