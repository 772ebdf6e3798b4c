"""Material tables kept on disk (labcut.fileio.cached_array): the same arrays, rebuilt when anything they depend on changes.

A CLI call is a new process: its first recommendation would spend ~0.1 s on the luminance table
(1024 cosines x 471 wavelengths of stack spectra). The tables are kept in the user cache folder,
keyed by the material's parameters and a hash of the code and versions that compute them. A
stale table would be a silent wrong answer, so these tests check that every part of the key
counts and that a damaged file is rebuilt, never read.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import labcut
from labcut import colour, fileio


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setattr(fileio, "cache_path", lambda name: tmp_path / name)
    return tmp_path / "tables"


def _counting(value):
    calls = []

    def build():
        calls.append(1)
        return value

    return build, calls


def test_an_array_is_built_once_then_read_back_bit_for_bit(cache):
    value = np.random.default_rng(0).random(17)
    build, calls = _counting(value)
    first = fileio.cached_array("t", "key A", build, shape=(17,), dtype=np.float64)
    again = fileio.cached_array("t", "key A", build, shape=(17,), dtype=np.float64)
    assert len(calls) == 1 and np.array_equal(first, value) and np.array_equal(again, value)
    assert len(list(cache.glob("t-*.npy"))) == 1
    # another key is another file, built
    fileio.cached_array("t", "key B", build, shape=(17,), dtype=np.float64)
    assert len(calls) == 2 and len(list(cache.glob("t-*.npy"))) == 2


def test_a_damaged_or_mismatched_file_is_built_again(cache):
    value = np.arange(6, dtype=np.float32)
    build, calls = _counting(value)
    fileio.cached_array("t", "k", build, shape=(6,), dtype=np.float32)
    (path,) = cache.glob("t-*.npy")
    path.write_bytes(b"not a numpy file")
    assert np.array_equal(fileio.cached_array("t", "k", build, shape=(6,), dtype=np.float32), value)
    assert len(calls) == 2
    np.save(path, np.zeros(5, dtype=np.float32))  # another shape under the same key
    assert np.array_equal(fileio.cached_array("t", "k", build, shape=(6,), dtype=np.float32), value)
    np.save(path, np.zeros(6, dtype=np.float64))  # another dtype
    assert np.array_equal(fileio.cached_array("t", "k", build, shape=(6,), dtype=np.float32), value)
    assert len(calls) == 4
    with pytest.raises(ValueError, match="expected"):
        fileio.cached_array("t", "k2", lambda: np.zeros(3), shape=(6,), dtype=np.float32)


def test_an_unwritable_cache_folder_is_no_error(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setattr(fileio, "cache_path", lambda name: blocker / name)  # a folder below a file
    build, calls = _counting(np.ones(3))
    for _ in range(2):
        assert np.array_equal(fileio.cached_array("t", "k", build, shape=(3,), dtype=np.float64), np.ones(3))
    assert len(calls) == 2


def test_code_hash_follows_the_bytes_of_the_code(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "b.py").write_text("y = 2\n")
    before = fileio.code_hash(tmp_path)
    assert fileio.code_hash(tmp_path) == before
    (tmp_path / "b.py").write_text("y = 3\n")
    assert fileio.code_hash(tmp_path) != before
    assert fileio.code_hash(tmp_path / "a.py") != fileio.code_hash(tmp_path)


def test_material_tables_from_disk_are_the_computed_ones(cache):
    """Read back in a 'new process' (the in-process cache cleared), the luminance and RGB tables
    equal a fresh computation; another material, or another polarisation, has its own table."""
    blue, red = labcut.Labradorite.preset("blue"), labcut.Labradorite.from_peak_wavelength(620.0)
    c = np.linspace(0.0, 1.0, colour.LUMINANCE_TABLE_SIZE)
    for _ in range(2):  # built, then read from disk
        colour.luminance_table.cache_clear()
        colour.rgb_table.cache_clear()
        for mat in (blue, red):
            assert np.array_equal(colour.luminance_table(mat)[1], colour.reflectance_luminance(mat, c))
            assert np.array_equal(colour.rgb_table(mat), np.clip(colour.reflectance_rgb(mat, c), 0.0, None).astype(np.float32))
            assert np.array_equal(colour.rgb_table(mat, "s"),
                                  np.clip(colour.reflectance_rgb(mat, c, polarization="s"), 0.0, None).astype(np.float32))
    assert len(list(cache.glob("luminance-*.npy"))) == 2 and len(list(cache.glob("rgb-*.npy"))) == 4
    colour.luminance_table.cache_clear()
    colour.rgb_table.cache_clear()


def test_the_table_key_holds_every_parameter_and_the_code():
    blue = labcut.Labradorite.preset("blue")
    base = colour._table_key(blue, "luminance", None)
    for field, value in blue.to_dict().items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            continue  # the name: no parameter of the physics
        changed = value + 1 if isinstance(value, int) else value * (1 + 1e-12) + 1e-12
        other = labcut.Labradorite.from_dict({**blue.to_dict(), field: changed})
        assert colour._table_key(other, "luminance", None) != base, field
    assert colour._table_key(blue, "luminance", "s") != base
    assert colour._table_key(blue, "rgb", None) != base
    assert "code " in base and "mitsuba " in base and "numpy " in base


def test_a_calibration_file_is_read_once_per_process_and_merged_on_write(tmp_path, monkeypatch):
    """Many keys of one file (a plan asks one polarisation bias per pose) cost one read, not one
    each; a value measured here is written next to what another process wrote meanwhile."""
    monkeypatch.setattr(fileio, "cache_path", lambda name: tmp_path / name)
    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    fileio.write_cache(tmp_path / "c.json", {f"k{i}": {"v": i} for i in range(5)})
    reads = []
    real = fileio.read_cache
    monkeypatch.setattr(fileio, "read_cache", lambda p: reads.append(p) or real(p))
    for i in range(5):
        assert fileio.calibration("c.json", f"k{i}", lambda: pytest.fail("stored, not measured")) == {"v": i}
    assert len(reads) == 1
    # another process adds a key; this one measures a new key: both are in the file afterwards
    fileio.write_cache(tmp_path / "c.json", {**real(tmp_path / "c.json"), "other": {"v": -1}})
    assert fileio.calibration("c.json", "new", lambda: {"v": 9}) == {"v": 9}
    on_disk = real(tmp_path / "c.json")
    assert on_disk["other"] == {"v": -1} and on_disk["new"] == {"v": 9} and on_disk["k0"] == {"v": 0}


def test_arrays_are_built_once_then_read_back_and_a_damaged_file_is_built_again(cache):
    value = {"a": np.arange(5.0), "b": np.eye(3, dtype=np.int64)}
    build, calls = _counting(value)
    first = fileio.cached_arrays("s", "key A", build)
    again = fileio.cached_arrays("s", "key A", build)
    assert len(calls) == 1 and set(again) == {"a", "b"}
    assert all(np.array_equal(first[k], value[k]) and again[k].dtype == value[k].dtype for k in value)
    (path,) = cache.glob("s-*.npz")
    path.write_bytes(b"PK not a zip")
    assert np.array_equal(fileio.cached_arrays("s", "key A", build)["b"], value["b"]) and len(calls) == 2
    np.savez(path, __key__=np.array("another key"), __names__=np.array(["a", "b"]), **value)  # a hash collision
    fileio.cached_arrays("s", "key A", build)
    assert len(calls) == 3
    fileio.cached_arrays("s", "key B", build)
    assert len(calls) == 4 and len(list(cache.glob("s-*.npz"))) == 2


def test_the_smooth_split_is_read_back_the_same_and_follows_the_mesh(cache):
    """A stone's smooth-shaded split copy is kept on disk: read back, it is trimesh's split to the
    last bit; a moved vertex or another angle is another entry."""
    import math

    import trimesh

    from labcut.geometry.surface import smooth_split

    mesh = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
    ref = trimesh.graph.smooth_shade(mesh, angle=math.radians(30.0))
    for _ in range(2):
        got = smooth_split(mesh, 30.0)
        for name in ("vertices", "faces", "face_normals", "vertex_normals", "area_faces"):
            assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    assert len(list(cache.glob("smooth-split-*.npz"))) == 1
    smooth_split(mesh, 20.0)
    moved = mesh.copy()
    moved.vertices[0] += 1e-9
    smooth_split(moved, 30.0)
    assert len(list(cache.glob("smooth-split-*.npz"))) == 3


# ----------------------------------------------------------------------------- damaged or unwritable: one warning
@pytest.mark.parametrize("instrument", ["profile", "trace"])
def test_a_timing_measured_under_a_profiler_or_tracer_is_used_but_not_kept(tmp_path, monkeypatch, instrument):
    """cProfile (``sys.setprofile``) or coverage and debuggers (``sys.settrace``) make a timing
    measure the instrumentation: a ``timed`` calibration measured so is this process's value, the
    file is not written, one warning per file says why; a value that is not a timing is kept as
    always; and the same timing measured without instrumentation is kept. A budget's correction
    learns nothing from a run under instrumentation."""
    import sys
    import warnings

    from labcut.commands import budget

    monkeypatch.setattr(fileio, "cache_path", lambda name: tmp_path / name)
    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    monkeypatch.setattr(fileio, "_UNKEPT_WARNED", set())
    monkeypatch.setattr(budget, "corrections_path", lambda: tmp_path / "corrections.json")
    monkeypatch.setattr("labcut.planner.sample_timing", lambda: type("T", (), {"key": "k1"})())
    setter, getter = (sys.setprofile, sys.getprofile) if instrument == "profile" else (sys.settrace, sys.gettrace)
    before = getter()
    assert not fileio.instrumented()
    setter(lambda *args: None)
    try:
        assert fileio.instrumented()
        with pytest.warns(labcut.LabcutWarning, match=r"under a profiler or tracer: the timing is used in this process "
                                                       r"but not kept in .*t\.json") as caught:
            assert fileio.calibration("t.json", "k", lambda: {"s": 1.0}, timed=True) == {"s": 1.0}
            assert fileio.calibration("t.json", "k", lambda: pytest.fail("kept in the process"), timed=True) == {"s": 1.0}
            assert fileio.calibration("t.json", "k2", lambda: {"s": 2.0}, timed=True) == {"s": 2.0}
        assert len(caught) == 1 and not (tmp_path / "t.json").exists()
        assert fileio.calibration("v.json", "k", lambda: {"v": 1}) == {"v": 1}  # not a timing: kept
        assert fileio.read_cache(tmp_path / "v.json") == {"k": {"v": 1}}
        assert budget.record(False, 1.0, 4.0) == 1.0 and not (tmp_path / "corrections.json").exists()
    finally:
        setter(before)
    assert not fileio.instrumented()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fileio.calibration("t.json", "k3", lambda: {"s": 3.0}, timed=True) == {"s": 3.0}
    assert fileio.read_cache(tmp_path / "t.json") == {"k3": {"s": 3.0}}
    assert budget.record(False, 1.0, 4.0) == pytest.approx(2.0)


def test_every_timing_of_this_machine_is_a_timed_calibration(monkeypatch):
    """The five timings (the sample estimator's recommendation and evaluation, labcut.render's, the
    render estimator's and a comparison's renders) ask :func:`fileio.calibration` with
    ``timed=True``, so none is kept when measured under a profiler or tracer."""
    from labcut import planner
    from labcut.orientation import render_estimator, timing
    from labcut.reports import budget as report_budget

    asked = []
    value = {"fixed": 0.0, "per_term": 0.0, "per_ray": 0.0, "per_sample": 0.0, "per_pixel": 0.0, "first": 0.0,
             "primal": {}, "adjoint": {}, "compile": {}, "setup": 0.0}

    def recorder(name, key, measure, **kw):
        asked.append((name, kw.get("timed")))
        return value

    monkeypatch.setattr(fileio, "calibration", recorder)
    timing.sample_timing(lambda mesh, quality: None)
    planner.evaluate_timing()
    planner.render_command_timing("rgb", False, "direct")
    render_estimator.render_timing()
    report_budget.compare_render_timing("direct")
    assert asked == [("sample-estimator-timing.json", True), ("planner-evaluate-timing.json", True),
                     ("planner-render-timing.json", True), ("render-estimator-timing.json", True),
                     ("compare-render-timing.json", True)]


@pytest.fixture
def fresh_warnings(monkeypatch):
    monkeypatch.setattr(fileio, "_CACHE_WARNED", set())


def test_a_damaged_cache_file_is_ignored_with_one_warning(tmp_path, monkeypatch, fresh_warnings):
    monkeypatch.setattr(fileio, "cache_path", lambda name: tmp_path / name)
    bad = tmp_path / "c.json"
    bad.write_text("{not json")
    with pytest.warns(labcut.LabcutWarning, match=r"cache file .*c\.json is damaged \(not JSON\): ignored") as caught:
        assert fileio.read_cache(bad) is None
        assert fileio.read_cache(bad) is None  # once per file and process
        assert fileio.calibration("c.json", "k", lambda: {"v": 1}) == {"v": 1}  # measured again, written over
    assert len([w for w in caught if "damaged" in str(w.message)]) == 1
    assert fileio.read_cache(bad) == {"k": {"v": 1}}
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.warns(labcut.LabcutWarning, match="not a JSON object"):
        assert fileio.read_cache(tmp_path / "list.json") is None
    assert fileio.read_cache(tmp_path / "missing.json") is None  # a missing file is no damage: no warning


def test_an_unwritable_cache_folder_warns_once(tmp_path, monkeypatch, fresh_warnings):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setattr(fileio, "cache_path", lambda name: blocker / name)  # a folder below a file
    with pytest.warns(labcut.LabcutWarning, match="cannot be written") as caught:
        for _ in range(3):
            fileio.write_cache(blocker / "a.json", {"x": 1})
            fileio.cached_array("t", "k", lambda: np.ones(3), shape=(3,), dtype=np.float64)
    assert len([w for w in caught if "cannot be written" in str(w.message)]) == 2  # the folder, and tables/ below it


def test_damaged_arrays_warn_once(cache, fresh_warnings):
    fileio.cached_array("t", "k", lambda: np.ones(3), shape=(3,), dtype=np.float64)
    (path,) = cache.glob("t-*.npy")
    path.write_bytes(b"garbage")
    with pytest.warns(labcut.LabcutWarning, match="is damaged"):
        fileio.cached_array("t", "k", lambda: np.ones(3), shape=(3,), dtype=np.float64)
    fileio.cached_arrays("s", "k", lambda: {"a": np.ones(2)})
    (npz,) = cache.glob("s-*.npz")
    npz.write_bytes(b"PK garbage")
    with pytest.warns(labcut.LabcutWarning, match="is damaged"):
        fileio.cached_arrays("s", "k", lambda: {"a": np.ones(2)})


def test_damaged_pilot_and_budget_caches_are_ignored_with_a_warning(tmp_path, monkeypatch, fresh_warnings):
    import labcut.planner as planner
    from labcut.commands import budget

    monkeypatch.setattr(planner, "_pilot_cache_path", lambda: tmp_path / "planner-pilot.json")
    monkeypatch.setattr(planner, "_PILOT_CACHE", {})
    (tmp_path / "planner-pilot.json").write_text('{"abc": "not a number"}')
    mesh = labcut.load_mesh(planner.__file__.replace("labcut/planner.py", "meshes/carving-biplane.ply"))
    from labcut.scene import resolve_scene

    with pytest.warns(labcut.LabcutWarning, match="planner-pilot.json is damaged"):
        assert planner.measured_interreflection(mesh, labcut.Labradorite(), resolve_scene("bench", None, None, "standard"),
                                                max_seconds=0.0) is None
    monkeypatch.setattr(budget, "corrections_path", lambda: tmp_path / "corrections.json")
    from labcut.planner import sample_timing

    (tmp_path / "corrections.json").write_text(json.dumps({"key": sample_timing().key, "plain": "fast"}))
    with pytest.warns(labcut.LabcutWarning, match="corrections.json is damaged"):
        assert budget.correction(False) == 1.0
