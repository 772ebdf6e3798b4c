"""The answers ``labcut recommend-orientation`` remembers (labcut_cli.answers): an identical call
prints the computed call's answer without loading the mesh; anything that shapes the answer makes
it compute again; a damaged store is a warning, never a wrong answer."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from labcut_cli import answers

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture
def store(tmp_path, monkeypatch):
    """The store on, in a folder of its own; ``store.computed`` counts the recommendations computed."""
    import labcut

    monkeypatch.delenv(answers.SWITCH, raising=False)
    folder = tmp_path / "answers"
    monkeypatch.setattr(answers, "folder", lambda: folder)
    calls = []
    real = labcut.recommend_orientation

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(labcut, "recommend_orientation", counted)

    class Store:
        path = folder

        @property
        def computed(self) -> int:
            return len(calls)

        def entries(self) -> list[Path]:
            return sorted(folder.glob("*.json.gz")) if folder.exists() else []

    return Store()


@pytest.fixture
def oval(tmp_path):
    path = tmp_path / "oval.ply"
    shutil.copy(MESHES / "oval-16x12-low.ply", path)
    return path


def ask(cli_main, mesh, *options):
    return cli_main("recommend-orientation", str(mesh), "--quality", "draft", *options)


def test_an_identical_call_prints_the_remembered_answer_without_loading_the_mesh(store, oval, cli_main, monkeypatch):
    computed = ask(cli_main, oval, "--scenario", "pendant", "--json", "-")
    assert computed.returncode == 0, computed.stderr
    assert store.computed == 1 and len(store.entries()) == 1
    from labcut_cli import meshes

    def no_load(*args, **kwargs):
        raise AssertionError("a remembered answer loads no mesh")

    with monkeypatch.context() as m:
        m.setattr(meshes, "read", no_load)
        again = ask(cli_main, oval, "--scenario", "pendant", "--json", "-")
        assert again.returncode == 0, again.stderr
        assert store.computed == 1  # read back, not computed
        assert again.stdout == computed.stdout  # the JSON document, to the byte
    # the tables (the output options are not part of the question): computed, then remembered
    table = ask(cli_main, oval, "--scenario", "pendant", "--recompute")
    assert table.returncode == 0 and store.computed == 2 and len(store.entries()) == 1
    with monkeypatch.context() as m:
        m.setattr(meshes, "read", no_load)
        remembered = ask(cli_main, oval, "--scenario", "pendant")
    assert remembered.returncode == 0 and store.computed == 2
    lines = remembered.stdout.splitlines()
    said = [i for i, line in enumerate(lines) if line.startswith("remembered answer of an identical call")]
    assert len(said) == 1
    assert lines[:said[0]] == table.stdout.splitlines()  # the same tables, then the line that says so
    assert "Recommendation for oval.ply" in remembered.stdout and "--recompute computes it again" in remembered.stdout


def test_what_shapes_the_answer_makes_it_compute_again(store, oval, cli_main, tmp_path):
    assert ask(cli_main, oval, "--json", "-").returncode == 0 and store.computed == 1
    assert ask(cli_main, oval, "--json", "-").returncode == 0 and store.computed == 1
    for options in (("--seed", "1"), ("--scenario", "ring"), ("--objective", "area"), ("--preset", "blue"),
                    ("--max-tilt", "10"), ("--units", "cm"), ("--optimizer", "grid"), ("--variants", "2"),
                    ("--tilt-axis", "1,0,0"), ("--estimator", "volume")):
        before = store.computed
        done = ask(cli_main, oval, "--json", "-", *options)
        assert done.returncode == 0, (options, done.stderr)
        assert store.computed == before + 1, options
    # the mesh file: one byte changed (a PLY's trailing space) is another question
    data = oval.read_bytes()
    changed = tmp_path / "changed" / "oval.ply"
    changed.parent.mkdir()
    changed.write_bytes(data.replace(b"end_header", b"end_header ", 1) if b"end_header\n" in data else data + b"\n")
    assert changed.read_bytes() != data
    before = store.computed
    assert ask(cli_main, changed, "--json", "-").returncode == 0 and store.computed == before + 1
    # the same bytes under another folder: the same question
    moved = tmp_path / "moved" / "oval.ply"
    moved.parent.mkdir()
    shutil.copy(oval, moved)
    before = store.computed
    out = ask(cli_main, moved, "--json", "-")
    assert store.computed == before and json.loads(out.stdout)["mesh"]["path"] == str(moved)
    assert json.loads(out.stdout)["mesh"]["source"] == str(moved)
    # --recompute computes it
    assert ask(cli_main, oval, "--json", "-", "--recompute").returncode == 0 and store.computed == before + 1


def test_calls_that_depend_on_time_or_make_pictures_are_always_computed(store, oval, cli_main, tmp_path):
    for options in (("--time-budget", "1"), ("--quality", "draft", "--map", str(tmp_path / "map.png")),
                    ("--quality", "draft", "--plan")):
        for _ in range(2):
            before = store.computed
            done = cli_main("recommend-orientation", str(oval), "--json", str(tmp_path / "a.json"), *options)
            assert done.returncode == 0, (options, done.stderr)
            assert store.computed == before + 1, options
    assert store.entries() == []


def test_switched_off_nothing_is_read_or_kept(store, oval, cli_main, monkeypatch):
    monkeypatch.setenv(answers.SWITCH, "off")
    for _ in range(2):
        assert ask(cli_main, oval, "--json", "-").returncode == 0
    assert store.computed == 2 and store.entries() == []


def test_a_damaged_entry_is_computed_again_with_one_warning(store, oval, cli_main):
    import gzip

    assert ask(cli_main, oval, "--json", "-").returncode == 0
    (entry,) = store.entries()
    good = entry.read_bytes()
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0xFF  # the deflate stream broken in its middle
    whole = json.loads(gzip.decompress(good))
    damages = [b"not gzip at all", gzip.compress(b'{"format": "something else", "answer": {}}'), bytes(flipped),
               gzip.compress(json.dumps({**whole, "answer": {"normal": [0, 0, 1]}}).encode()),  # well formed, no answer
               gzip.compress(json.dumps({**whole, "messages": [["shout", 3]]}).encode())]
    for damage in damages:
        entry.write_bytes(damage)
        from labcut import fileio

        fileio._CACHE_WARNED.clear()
        before = store.computed
        done = ask(cli_main, oval, "--json", "-")
        assert done.returncode == 0 and store.computed == before + 1
        assert "not a remembered answer" in done.stderr and "Traceback" not in done.stderr
        assert json.loads(done.stdout)["normal"] == json.loads(gzip.decompress(good))["answer"]["normal"]  # one document
    assert ask(cli_main, oval, "--json", "-").returncode == 0 and store.computed == before + 1  # written anew


def test_an_unwritable_store_only_costs_time(store, oval, cli_main):
    store.path.parent.mkdir(parents=True, exist_ok=True)
    store.path.write_text("a file where the folder should be")
    from labcut import fileio

    fileio._CACHE_WARNED.clear()
    done = ask(cli_main, oval, "--json", "-")
    assert done.returncode == 0 and json.loads(done.stdout)["normal"]
    notes = [x for x in done.stderr.splitlines() if x.startswith("note:")]
    assert len(notes) == 1 and "cannot be written" in notes[0] and str(store.path) in notes[0], done.stderr
    assert "Traceback" not in done.stderr and store.entries() == []


def noted_twice(monkeypatch, cli_main, oval, *warned):
    """The ``note:`` lines of a computed call whose work warns ``warned`` (``(text, category)``
    pairs) and of the same call asked again."""
    import warnings

    import labcut

    counted = labcut.recommend_orientation

    def noting(*args, **kwargs):
        for text, category in warned:
            warnings.warn(text, category)
        return counted(*args, **kwargs)

    monkeypatch.setattr(labcut, "recommend_orientation", noting)
    first = ask(cli_main, oval, "--json", "-")
    again = ask(cli_main, oval, "--json", "-")
    assert first.returncode == again.returncode == 0
    return [[x for x in done.stderr.splitlines() if x.startswith(("warning:", "note:"))] for done in (first, again)]


def test_the_notes_of_the_computed_call_are_printed_again(store, oval, cli_main, monkeypatch):
    """What the work said (labcut's warnings, printed as ``note:`` lines) is said again by the
    remembered call, in the same words and order."""
    from labcut.errors import LabcutWarning

    first, again = noted_twice(monkeypatch, cli_main, oval, ("first thing the work noted", LabcutWarning),
                               ("second thing", LabcutWarning))
    assert store.computed == 1
    assert first == ["note: first thing the work noted", "note: second thing"] and again == first


def test_the_key_changes_with_the_code_and_the_libraries(monkeypatch, tmp_path):
    from labcut.orientation import FlashQuestion

    q = FlashQuestion.build(None, scenario="bench", quality="draft")
    mesh = MESHES / "oval-16x12-low.ply"
    k = answers.key("recommend-orientation", mesh, None, q, optimizer="nlopt")
    assert k == answers.key("recommend-orientation", mesh, None, q, optimizer="nlopt")
    assert k != answers.key("recommend-orientation", mesh, None, q, optimizer="grid")
    assert k != answers.key("evaluate-orientation", mesh, None, q, optimizer="nlopt")
    monkeypatch.setattr(answers, "_code", lambda: "edited")
    assert k != answers.key("recommend-orientation", mesh, None, q, optimizer="nlopt")
    monkeypatch.undo()
    monkeypatch.setattr(answers, "_distributions", lambda: ["numpy-0.0.dist-info"])
    assert k != answers.key("recommend-orientation", mesh, None, q, optimizer="nlopt")
    assert answers.key("recommend-orientation", tmp_path / "missing.ply", None, q) is None


def test_the_store_keeps_its_newest_entries(monkeypatch, tmp_path):
    monkeypatch.setattr(answers, "folder", lambda: tmp_path)
    monkeypatch.setattr(answers, "KEEP", 3)
    for i in range(5):
        answers.remember(f"k{i}", {"n": i}, {}, [], 0.1)
        os.utime(tmp_path / f"k{i}.json.gz", (1_000_000 + i, 1_000_000 + i))
    answers.remember("k5", {"n": 5}, {}, [], 0.1)
    assert sorted(p.name for p in tmp_path.glob("*.json.gz")) == ["k3.json.gz", "k4.json.gz", "k5.json.gz"]
    assert answers.read("k4")["answer"] == {"n": 4} and answers.read("k0") is None


def test_a_remembered_answer_imports_no_trimesh(tmp_path, cli_main, monkeypatch):
    """The warm call's time is the command's imports: reading back loads no mesh, so neither
    trimesh nor SciPy is imported (a new process, as a user's shell runs it, reads the answer this
    process computed into the same folder)."""
    mesh = tmp_path / "oval.ply"
    shutil.copy(MESHES / "oval-16x12-low.ply", mesh)
    monkeypatch.delenv(answers.SWITCH, raising=False)
    monkeypatch.setattr(answers, "folder", lambda: tmp_path / "cache" / "labcut" / "answers")  # platformdirs' for XDG
    first = ask(cli_main, mesh, "--json", "-")
    assert first.returncode == 0 and len(list((tmp_path / "cache" / "labcut" / "answers").glob("*.json.gz"))) == 1
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    script = ("import sys\nfrom labcut_cli.app import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
              "print('IMPORTED', 'trimesh' in sys.modules, 'scipy' in sys.modules, file=sys.stderr)\n")
    again = subprocess.run([sys.executable, "-c", script, "recommend-orientation", str(mesh), "--quality", "draft", "--json", "-"],
                           capture_output=True, text=True, env=env, timeout=300)
    assert "IMPORTED False False" in again.stderr, again.stderr[-2000:]
    assert again.stdout == first.stdout


def test_a_gltf_whose_buffers_are_other_files_is_always_computed(store, tmp_path, cli_main):
    """A .gltf names the files its buffers are read from: the key would hold its own bytes alone."""
    import labcut

    mesh = tmp_path / "oval.gltf"
    labcut.load_mesh(MESHES / "oval-16x12-low.ply").export(mesh)
    assert any(p.suffix == ".bin" for p in tmp_path.iterdir())  # the buffers beside it
    for _ in range(2):
        done = ask(cli_main, mesh, "--json", "-", "--units", "mm")  # glTF is metres by its specification
        assert done.returncode == 0, done.stderr
    assert store.computed == 2 and store.entries() == []


def test_a_mesh_rewritten_while_it_is_read_is_not_remembered(store, oval, cli_main, monkeypatch):
    states = iter([(1, 1), (2, 2)])
    monkeypatch.setattr(answers, "file_state", lambda path: next(states))
    assert ask(cli_main, oval, "--json", "-").returncode == 0
    assert store.computed == 1 and store.entries() == []


def test_notes_about_the_cache_are_not_remembered(store, oval, cli_main, monkeypatch):
    """A damaged cache file is this run's trouble, not the answer's: not printed again later."""
    from labcut.errors import CacheWarning, LabcutWarning

    first, again = noted_twice(monkeypatch, cli_main, oval, ("labcut's cache file x is damaged", CacheWarning),
                               ("the work's own note", LabcutWarning))
    assert store.computed == 1
    assert first == ["note: labcut's cache file x is damaged", "note: the work's own note"]
    assert again == ["note: the work's own note"]
