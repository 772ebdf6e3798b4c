"""labcut.batch.runner pinned by mutation testing (issue 37; docs/testing.md, "labcut/batch/runner.py").

The runner as its docstrings define it, without a cluster: a stand-in ``distributed.Client`` runs
each submitted task in this process when it is submitted, and a stand-in ``as_completed`` hands the
futures back in an order and in batches a test chooses; ``recommend_orientation`` is replaced by a
recorder returning a recommendation whose every figure is its own number. Pinned: each catalogue
column's effect on the call a row makes (the mesh as read, the keyword arguments); the record of a
row (every column by hand, its warnings, its one-line error, memory and time); nothing lost or
written twice (a lost task stored as failed, a key answered twice written once, an interrupted run
cancelling only what has not finished); resume and ``retry_failed``; progress counts with and
without the report; the summary figures; the report's groups, cuts, pages and errors; the embedded
cluster's settings; the worker set-up; every message word for word. No cluster, no recommendation:
65 tests in a few seconds (under 3 s of CPU).
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import re
import types
import warnings
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

import distributed

#: the real one (a test puts it back where a run must not reach it: without a client it raises)
REAL_AS_COMPLETED = distributed.as_completed

import labcut
from labcut.batch import runner as rn
from labcut.batch.catalog import Catalog, Defaults, read_catalog
from labcut.batch.store import ResultStore
from labcut.errors import LabcutError, LabcutWarning, OutputError, ParameterError
from labcut.orientation.scoring import FlashMetrics


# ---------------------------------------------------------------------- stand-ins
class Clock:
    """``time`` for the runner: ``perf_counter`` steps by ``step`` seconds a call, from ``start``."""

    def __init__(self, start: float = 100.0, step: float = 1.0) -> None:
        self.now, self.step, self.calls = start - step, step, 0

    def perf_counter(self) -> float:
        self.now += self.step
        self.calls += 1
        return self.now


class FakeRec:
    """A recommendation whose every figure differs from the others (exact in binary)."""

    def __init__(self, payload=None) -> None:
        self.normal = np.array([0.125, -0.25, 0.96875])
        self.tilt_deg, self.azimuth_deg, self.description, self.score = 14.5, -63.25, "tilt 14.5 deg towards the back", 0.8125
        self.metrics = FlashMetrics(flash_area=0.375, flash_intensity=1.75, flash_energy=0.90625, coverage=0.625,
                                    balanced=0.71875, per_view={"weight": [0.25, 0.75], "flash_area": [0.5, 0.25],
                                                                "flash_intensity": [2.0, 1.0]})
        self.tolerance_deg = 3.25
        self.tolerance_by_axis = {"front_back_deg": 4.5, "left_right_deg": 2.75}
        self.parallel_within_deg = 6.5
        self.evaluations = 123
        self.payload = payload if payload is not None else {"f": np.float32(0.5), "a": np.arange(3), "n": np.int64(7),
                                                            "s": "x"}

    def to_dict(self):
        return self.payload


class Recorder:
    """``recommend_orientation`` stand-in: records (mesh extents, keyword arguments) per call."""

    def __init__(self, fail_seeds=(), warn=(), rec=None) -> None:
        self.calls: list[tuple[list[float], dict]] = []
        self.fail_seeds, self.warn, self.rec = set(fail_seeds), list(warn), rec

    def __call__(self, mesh, **kwargs):
        self.calls.append(([round(float(x), 6) for x in np.ptp(np.asarray(mesh.vertices), axis=0)], kwargs))
        for category, text in self.warn:
            warnings.warn(text, category)
        if kwargs.get("seed") in self.fail_seeds:
            raise ParameterError(f"seed {kwargs['seed']}\n  refused")
        return self.rec or FakeRec()


@pytest.fixture
def recommend(monkeypatch):
    import labcut.commands.recommend as cr

    rec = Recorder()
    monkeypatch.setattr(cr, "recommend_orientation", rec)
    return rec


class FakeFuture:
    def __init__(self, fn, args, key, pure) -> None:
        self.key, self.pure, self.fn, self.args = key, pure, fn, args
        self.released = self.cancelled = False
        try:
            self.value, self.exc = fn(*args), None
        except Exception as exc:  # noqa: BLE001
            self.value, self.exc = None, exc

    def result(self):
        if self.exc is not None:
            raise self.exc
        return self.value

    def release(self) -> None:
        self.released = True

    def cancel(self) -> None:
        self.cancelled = True


class FakeClient:
    """A ``distributed.Client`` that runs each task when submitted, in this process."""

    def __init__(self, addresses=("tcp://127.0.0.1:40001",), info=None, has_cache=True, services=None,
                 bokeh=False, link="http://127.0.0.1:8787/status") -> None:
        self.addresses = list(addresses)
        self.info = info if info is not None else {a: {"threads": 2} for a in self.addresses}
        self.has_cache, self.services, self.bokeh, self.dashboard_link = has_cache, services, bokeh, link
        self.plugins: list = []
        self.submitted: list[FakeFuture] = []
        self.calls: list[str] = []

    def scheduler_info(self, n_workers: int = 5):  # distributed's default (5) lists only the first five workers
        shown = self.addresses if n_workers == -1 else self.addresses[:n_workers]
        out = {"workers": {a: {} for a in shown}}
        if self.services is not None:
            out["services"] = self.services
        return out

    def run(self, fn):
        self.calls.append(fn.__name__)
        if fn.__name__ == "_has_node_cache":
            return {a: self.has_cache for a in self.addresses}
        return dict(self.info)

    def register_plugin(self, plugin) -> None:
        self.plugins.append(plugin)

    def run_on_scheduler(self, fn):
        return self.bokeh

    def submit(self, fn, *args, key, pure):
        fut = FakeFuture(fn, args, key, pure)
        self.submitted.append(fut)
        return fut


class FakeAsCompleted:
    """``distributed.as_completed``: the futures in ``order`` (indices; default as given), in batches of ``sizes``."""

    order: list[int] | None = None
    sizes: list[int] | None = None

    def __init__(self, futures) -> None:
        futures = list(futures)
        idx = list(range(len(futures))) if self.order is None else list(self.order)  # an index twice: answered twice
        self.seq = [futures[i] for i in idx]

    def __iter__(self):
        return iter(self.seq)

    def batches(self):
        sizes = self.sizes or [1] * len(self.seq)
        at = 0
        for n in sizes:
            yield self.seq[at:at + n]
            at += n


@pytest.fixture
def completed(monkeypatch):
    class AC(FakeAsCompleted):
        order = None
        sizes = None

    monkeypatch.setattr(distributed, "as_completed", AC)
    return AC


def cube_rows(folder: Path, *seeds, **cells):
    return read_catalog([{"cut": "m/cube.ply", "seed": s, **cells} for s in seeds], base=folder).rows


def catalogue(folder: Path, *seeds, **cells) -> Catalog:
    return Catalog(None, cube_rows(folder, *seeds, **cells))


# ---------------------------------------------------------------------- small parts
def test_one_line_of_an_error():
    assert rn._one_line(ParameterError("bad  value\n  here ")) == "bad value here"  # labcut's own: the text alone
    assert rn._one_line(ValueError("no\n\tmesh")) == "ValueError: no mesh"
    assert rn._one_line(KeyError()) == "KeyError: KeyError"
    assert rn._one_line(ParameterError("  ")) == "ParameterError"


def test_worker_name(monkeypatch):
    assert rn._worker_name() == "local"  # not on a worker: distributed raises ValueError
    monkeypatch.setattr(distributed, "get_worker", lambda: types.SimpleNamespace(address="tcp://10.0.0.7:3456"))
    assert rn._worker_name() == "tcp://10.0.0.7:3456"

    def missing():
        raise ImportError("no distributed")

    monkeypatch.setattr(distributed, "get_worker", missing)
    assert rn._worker_name() == "local"


def test_memory_is_mib_now_and_peak(monkeypatch):
    import psutil
    import resource

    monkeypatch.setattr(resource, "getrusage", lambda who: types.SimpleNamespace(ru_maxrss=3072 if who == resource.RUSAGE_SELF else 1))
    monkeypatch.setattr(psutil, "Process", lambda: types.SimpleNamespace(memory_info=lambda: types.SimpleNamespace(rss=5 * 2**20)))
    assert rn._memory() == (5.0, 3.0)  # ru_maxrss is KiB on Linux


def test_memory_without_resource_or_psutil(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "resource", None)  # importing it raises ImportError (not on Windows)
    monkeypatch.setitem(sys.modules, "psutil", None)
    assert rn._memory() == (None, None)


def test_plain_json_values():
    assert rn._plain(np.float32(0.5)) == 0.5 and type(rn._plain(np.float32(0.5))) is float
    assert rn._plain(np.int64(7)) == 7 and type(rn._plain(np.int64(7))) is int
    assert rn._plain(np.array([[1, 2], [3, 4]])) == [[1, 2], [3, 4]]
    with pytest.raises(TypeError, match=r"^object is not JSON$"):
        rn._plain(object())


def test_base_record_by_hand(catalogue_folder):
    row = read_catalog([{"cut": "m/cube.ply", "name": "c1", "material": "gold", "scenario": "ring", "quality": "draft",
                         "objective": "area", "seed": 4, "max_tilt": 45}], base=catalogue_folder).rows[0]
    assert rn._base_record(row) == {
        "key": row.key, "row": 1, "name": "c1", "cut": "m/cube.ply", "kind": "file", "material": "gold",
        "scenario": "ring", "quality": "draft", "objective": "area", "seed": 4, "max_tilt_deg": 45.0,
        "labcut_version": labcut.__version__}


def test_report_paths():
    p = Path("/x/rep.html")
    assert rn.report_paths(p, 1) == [p]
    assert rn.report_paths(p, 3) == [p, Path("/x/rep-2.html"), Path("/x/rep-3.html")]


def test_default_workers(monkeypatch):
    import labcut.batch.plugin as plugin

    monkeypatch.setattr(plugin, "cores", lambda: 4)
    assert [rn.default_workers(n) for n in (0, 1, 3, 4, 5, 9)] == [1, 1, 3, 4, 4, 4]


def test_trim_key():
    assert rn.TRIM_KEY == "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"


@pytest.mark.parametrize("address, loopback", [
    ("tcp://127.0.0.1:40001", True), ("tcp://127.9.8.7:1", True), ("tcp://localhost:8786", True),
    ("tcp://[::1]:40002", True), ("127.0.0.1:8786", True), ("tls://node7.cluster:1", False),
    ("tcp://10.1.2.3:4", False), ("tcp://localhost.example:4", False), ("tcp://1127.0.0.1:4", False),
    ("tcp://[::2]:4", False), ("tcp://X127.0.0.1:4", False),
])
def test_is_loopback(address, loopback):
    assert rn._is_loopback(address) is loopback


def test_has_node_cache(monkeypatch):
    import labcut.batch.plugin as plugin

    monkeypatch.setattr(plugin, "node_cache_dir", lambda: "/cache/node-a")
    monkeypatch.setenv("DRJIT_CACHE_DIR", "/cache/node-a")
    assert rn._has_node_cache() is True
    monkeypatch.setenv("DRJIT_CACHE_DIR", "/cache/node-b")
    assert rn._has_node_cache() is False
    monkeypatch.delenv("DRJIT_CACHE_DIR")
    assert rn._has_node_cache() is False


def test_finite():
    assert rn._finite(float("nan")) is None and rn._finite(float("inf")) is None and rn._finite(-math.inf) is None
    assert rn._finite(1.5) == 1.5 and rn._finite("nan") == "nan" and rn._finite(None) is None and rn._finite(3) == 3


# ---------------------------------------------------------------------- one row
def test_each_column_reaches_the_rows_call(catalogue_folder, recommend):
    """Each catalogue column as the row's call sees it: the mesh as read (units, up axis, a design's
    size: its extents in mm) and the keyword arguments of ``recommend_orientation``."""
    from labcut.physics.material import Labradorite

    (catalogue_folder / "m" / "box.obj").write_text("v 0 0 0\nv 2 0 0\nv 0 3 0\nv 0 0 5\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    rows = read_catalog([
        {"cut": "m/cube.ply"},
        {"cut": "m/cube.ply", "material": "gold", "scenario": "ring", "quality": "high", "objective": "area", "seed": 3,
         "max_tilt": 30},
        {"cut": "m/cube.ply", "units": "cm"},
        {"cut": "m/box.obj", "units": "mm", "up_axis": "+Y"},
        {"cut": "m/SRB.asc", "size": 8},
    ], Defaults(material="red", scenario="pendant", quality="draft", objective="intensity", seed=9),
        base=catalogue_folder).rows
    records = [rn.run_row(r) for r in rows]
    assert [r["status"] for r in records] == ["ok"] * 5, [r.get("error") for r in records]
    (e0, k0), (e1, k1), (e2, _), (e3, _), (e4, _) = recommend.calls
    assert k0 == {"material": Labradorite.preset("red"), "scenario": "pendant", "quality": "draft",
                  "objective": "intensity", "seed": 9, "max_tilt": 90.0}
    assert k1 == {"material": Labradorite.preset("gold"), "scenario": "ring", "quality": "high", "objective": "area",
                  "seed": 3, "max_tilt": 30.0}
    assert e0 == [10.0, 10.0, 10.0] and e2 == [100.0, 100.0, 100.0]  # cm: ten times the file's numbers
    assert e3 == [2.0, 5.0, 3.0]  # +Y up: the file's y is the stone's height
    assert max(e4[:2]) == pytest.approx(8.0, rel=1e-3)  # the design cut at an 8 mm girdle


def test_a_cabochon_row_builds_its_stone(recommend):
    row = read_catalog([{"cut": "cab:round,8,low,res=24"}]).rows[0]
    rec = rn.run_row(row)
    assert rec["status"] == "ok" and rec["kind"] == "cabochon"
    [(extents, _)] = recommend.calls
    assert extents[0] == pytest.approx(8.0, abs=0.05) and extents[1] == pytest.approx(8.0, abs=0.05)


def test_record_of_a_row_every_column(catalogue_folder, recommend, monkeypatch):
    clock = Clock(10.0, 2.5)
    monkeypatch.setattr(rn, "time", clock)
    monkeypatch.setattr(rn, "_memory", lambda: (12.5, 40.25))
    monkeypatch.setattr(rn, "_worker_name", lambda: "tcp://w:1")
    [row] = cube_rows(catalogue_folder, 1)
    before = datetime.now(timezone.utc).replace(microsecond=0)
    record = rn.run_row(row)
    after = datetime.now(timezone.utc)
    stamp = record.pop("finished_at")
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", stamp)
    assert before <= datetime.fromisoformat(stamp) <= after
    assert record == {
        **rn._base_record(row), "status": "ok", "normal_x": 0.125, "normal_y": -0.25, "normal_z": 0.96875,
        "tilt_deg": 14.5, "azimuth_deg": -63.25, "description": "tilt 14.5 deg towards the back", "score": 0.8125,
        "flash_energy": 0.90625, "flash_area": 0.375, "flash_intensity": 1.75, "coverage": 0.625, "balanced": 0.71875,
        "energy_in_flash": 0.4375,  # 0.25 x 0.5 x 2 + 0.75 x 0.25 x 1
        "tolerance_deg": 3.25, "tolerance_front_back_deg": 4.5, "tolerance_left_right_deg": 2.75,
        "parallel_within_deg": 6.5, "evaluations": 123,
        "recommendation": '{"f": 0.5, "a": [0, 1, 2], "n": 7, "s": "x"}',
        "warnings": None, "seconds": 2.5, "worker": "tcp://w:1", "worker_rss_mib": 12.5, "worker_peak_rss_mib": 40.25}
    assert all(type(record[k]) is float for k in ("normal_x", "normal_y", "normal_z"))
    assert clock.calls == 2


def test_a_missing_tolerance_axis_is_none(catalogue_folder, recommend):
    recommend.rec = FakeRec()
    recommend.rec.tolerance_by_axis = {}
    record = rn.run_row(cube_rows(catalogue_folder, 0)[0])
    assert record["status"] == "ok"
    assert record["tolerance_front_back_deg"] is None and record["tolerance_left_right_deg"] is None


def test_a_failing_row_is_its_one_line_error(catalogue_folder, recommend, monkeypatch):
    monkeypatch.setattr(rn, "time", Clock(5.0, 0.5))
    monkeypatch.setattr(rn, "_memory", lambda: (1.0, 2.0))
    recommend.fail_seeds = {2}
    recommend.warn = [(LabcutWarning, "a note")]
    row = cube_rows(catalogue_folder, 2)[0]
    record = rn.run_row(row)
    record.pop("finished_at")
    # labcut's warnings before the failure are kept (they may say why: units guessed)
    assert record == {**rn._base_record(row), "status": "error", "error": "seed 2 refused", "warnings": "a note",
                      "seconds": 0.5, "worker": "local", "worker_rss_mib": 1.0, "worker_peak_rss_mib": 2.0}


def test_a_mesh_that_cannot_be_read_is_a_failed_row(catalogue_folder, recommend):
    (catalogue_folder / "m" / "broken.ply").write_text("ply\nformat ascii 1.0\nthis is not a mesh\n")
    row = read_catalog([{"cut": "m/broken.ply"}], base=catalogue_folder).rows[0]
    record = rn.run_row(row)
    assert record["status"] == "error" and "broken.ply" in record["error"] and "\n" not in record["error"]
    assert "normal_x" not in record and "tilt_deg" not in record and recommend.calls == []


def test_a_recommendation_that_is_not_json_fails_its_row(catalogue_folder, recommend):
    recommend.rec = FakeRec(payload={"x": object()})
    record = rn.run_row(cube_rows(catalogue_folder, 0)[0])
    assert record["status"] == "error" and record["error"] == "TypeError: object is not JSON"
    assert "normal_x" not in record


def test_row_warnings_are_labcuts_each_on_one_line(catalogue_folder, recommend):
    recommend.warn = [(LabcutWarning, "units\n  guessed"), (UserWarning, "not ours"), (LabcutWarning, "units\n  guessed"),
                      (LabcutWarning, "second")]
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("error", LabcutWarning)  # a caller's -W error: the row's own are still recorded, not raised
        warnings.simplefilter("always", UserWarning)
        record = rn.run_row(cube_rows(catalogue_folder, 0)[0])
    assert record["status"] == "ok", record.get("error")
    assert record["warnings"] == "units guessed; units guessed; second"
    # anyone else's warning is not the row's, and not swallowed either: it reaches the caller's filters
    assert [(w.category, str(w.message)) for w in shown] == [(UserWarning, "not ours")]


def test_other_warnings_follow_the_callers_filters(catalogue_folder, recommend):
    """Only labcut's warnings are always recorded; a ``UserWarning`` under the caller's ``error`` filter fails the row."""
    recommend.warn = [(LabcutWarning, "ours"), (UserWarning, "not\n ours")]
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        record = rn.run_row(cube_rows(catalogue_folder, 0)[0])
    assert (record["status"], record["error"], record["warnings"]) == ("error", "UserWarning: not ours", "ours")


def test_recommend_passes_the_rows_settings(catalogue_folder, recommend):
    [row] = cube_rows(catalogue_folder, 5, objective="balanced")
    mesh = row.load_mesh()
    out = rn._recommend(mesh, row)
    assert isinstance(out, FakeRec)
    assert recommend.calls == [([10.0, 10.0, 10.0], row.recommend_kwargs())]


# ---------------------------------------------------------------------- the report's groups
def test_cut_identity(catalogue_folder):
    a, b, c, d = read_catalog([{"cut": "m/cube.ply"}, {"cut": "m/cube.ply", "units": "cm"},
                               {"cut": "cab:oval,16x12,low"}, {"cut": "m/SRB.asc", "size": 7}], base=catalogue_folder).rows
    assert rn._cut_identity(a) == ("file", str((catalogue_folder / "m" / "cube.ply").resolve()), "auto", "auto", None)
    assert rn._cut_identity(b)[2] == "cm"
    assert rn._cut_identity(c) == ("cabochon", json.dumps(c.cab, sort_keys=True), "auto", "auto", None)
    assert rn._cut_identity(d)[4] == 7.0


def test_report_groups_by_hand(catalogue_folder):
    (catalogue_folder / "blue.json").write_text(json.dumps(labcut.Labradorite.coerce(None).to_dict()))  # the default's
    rows = read_catalog([
        {"cut": "m/cube.ply", "name": "A", "scenario": "ring"},                  # 1 group blue/standard/0
        {"cut": "m/step.ply", "name": "A", "scenario": "bench", "material": "blue.json"},  # same material parameters
        {"cut": "m/cube.ply", "name": "C", "scenario": "bench"},                 # same cut as row 1: not a new cut
        {"cut": "m/cube.ply", "scenario": "ring", "quality": "draft"},           # 2 another quality
        {"cut": "m/cube.ply", "scenario": "ring", "seed": 1},                    # 3 another seed
        {"cut": "m/cube.ply", "scenario": "pendant", "material": "gold"},         # 4 another material
        {"cut": "m/cube.ply", "units": "cm", "name": "A"},                        # group 1: another cut (units)
    ], base=catalogue_folder).rows
    groups = rn.report_groups(rows)
    assert [(g.material_label, g.quality, g.seed) for g in groups] == [
        ("default", "standard", 0), ("default", "draft", 0), ("default", "standard", 1), ("gold", "standard", 0)]
    g = groups[0]
    assert [r.index for r in g.cuts] == [1, 2, 7]
    assert g.names == ("A", "A (2)", "A (3)")
    assert g.scenarios == ("ring", "bench")
    assert [[r.index for r in x.cuts] for x in groups[1:]] == [[4], [5], [6]]
    assert groups[3].scenarios == ("pendant",) and groups[3].names == ("cube.ply",)
    assert g.label == "material default, standard quality, seed 0"
    assert groups[1].label == "material default, draft quality, seed 0"
    assert groups[3].label == "material gold, standard quality, seed 0"
    assert rn.report_groups([]) == []


def test_compare_cut_of_a_mesh_and_of_a_cabochon(catalogue_folder, monkeypatch):
    import labcut.reports.compare as cmp
    from labcut.reports.cuts import Cut

    plans = []
    monkeypatch.setattr(cmp, "plan_comparison", lambda *a, **k: plans.append((a, k)) or "PLAN")
    monkeypatch.setattr(cmp, "run_comparison", lambda plan: ("RAN", plan))
    step, cab = read_catalog([{"cut": "m/step.ply", "quality": "draft", "seed": 3, "material": "gold"},
                              {"cut": "cab:oval,16x12,low"}], base=catalogue_folder).rows
    assert rn.compare_cut(step, "S", ("ring", "bench")) == ("RAN", "PLAN")
    (cuts, material, scens, ref, quality), kw = plans[0]
    assert (material, scens, ref, quality, kw) == (step.material, ["ring", "bench"], 0, "draft", {"seed": 3})
    [(name, cut)] = cuts
    assert name == "S" and isinstance(cut, Cut)
    ext = np.ptp(np.asarray(step.load_mesh().vertices), axis=0)
    assert (cut.name, cut.kind, cut.source) == ("S", "file", step.path)
    assert cut.design == {"length_mm": float(ext[0]), "width_mm": float(ext[1]), "height_mm": float(ext[2])}
    assert len(set(cut.design.values())) == 3 and np.ptp(np.asarray(cut.mesh.vertices), axis=0).tolist() == ext.tolist()
    rn.compare_cut(cab, "C", ("bench",))
    (cuts, material, scens, ref, quality), kw = plans[1]
    assert cuts == [("C", "cab:oval,16x12,low")] and scens == ["bench"] and quality == "standard" and kw == {"seed": 0}


def test_merge_comparisons(monkeypatch):
    import labcut.reports.compare as cmp

    seen = []
    monkeypatch.setattr(cmp, "rank_and_normalise", lambda cuts, scens, ref: seen.append((list(cuts), list(scens), ref)) or {"bench": 0.5})
    render = {"resolution": 32}
    p1 = types.SimpleNamespace(cuts=["a", "b"], scenarios=("S1", "S2"), material="M", quality="draft", render=render,
                               seconds=1.25, tau=0.2, seed=4)
    p2 = types.SimpleNamespace(cuts=["c"], scenarios=("X",), material="N", quality="high", render={}, seconds=2,
                               tau=0.3, seed=5)
    out = rn.merge_comparisons([p1, p2])
    assert seen == [(["a", "b", "c"], ["S1", "S2"], 0)]
    assert (out.cuts, out.scenarios, out.material, out.reference, out.quality) == (["a", "b", "c"], ["S1", "S2"], "M", 0, "draft")
    assert out.exposures == {"bench": 0.5} and out.render == render and out.render is not render
    assert out.seconds == 3.25 and type(out.seconds) is float and (out.tau, out.seed) == (0.2, 4)
    with pytest.raises(ParameterError, match=r"^a report needs at least one compared cut$"):
        rn.merge_comparisons([])


# ---------------------------------------------------------------------- the summary
def summary_table(records):
    return pa.Table.from_pylist(records)


def test_batch_result_summary(tmp_path):
    cat = Catalog(tmp_path / "c.csv", [object(), object(), object()])
    recs = [{"row": 1, "key": "k1", "name": "a", "cut": "a.ply", "material": "blue", "scenario": "bench", "quality": "draft",
             "objective": "energy", "seed": 0, "status": "ok", "error": None, "tilt_deg": 1.5, "azimuth_deg": float("nan"),
             "description": "d", "score": 0.5, "flash_energy": float("inf"), "flash_area": 0.25, "tolerance_deg": 2.0,
             "seconds": 3.0, "worker": "w", "normal_x": 0.1, "kind": "file"}]
    result = rn.BatchResult(tmp_path / "r.parquet", cat, summary_table(recs), 2, 1, 1, 7.5, 1.25, [{"address": "a"}],
                            "http://d/status", [(tmp_path / "r.html", "material blue")], ["report: x"])
    assert result.total == 3 and json.dumps(result.records()) == json.dumps(recs)
    data = result.to_dict()
    row = {k: v for k, v in recs[0].items() if k not in ("normal_x", "kind")}
    row.update(azimuth_deg=None, flash_energy=None)
    assert data == {"kind": "labcut.batch", "labcut_version": labcut.__version__, "catalogue": str(tmp_path / "c.csv"),
                    "results": str(tmp_path / "r.parquet"), "rows": 3, "ran": 2, "skipped": 1, "failed": 1, "seconds": 7.5,
                    "startup_seconds": 1.25, "workers": [{"address": "a"}], "dashboard": "http://d/status",
                    "reports": [{"path": str(tmp_path / "r.html"), "group": "material blue"}], "report_errors": ["report: x"],
                    "results_rows": [row]}
    assert list(data["results_rows"][0]) == ["row", "key", "name", "cut", "material", "scenario", "quality", "objective",
                                             "seed", "status", "error", "tilt_deg", "azimuth_deg", "description", "score",
                                             "flash_energy", "flash_area", "tolerance_deg", "seconds", "worker"]
    bare = rn.BatchResult(tmp_path, Catalog(None, []), summary_table([]), 0, 0, 0, 0.0, 0.0)
    assert (bare.workers, bare.dashboard, bare.reports, bare.report_errors) == ([], None, [], [])
    assert bare.to_dict()["catalogue"] == "catalogue"


def test_catalogue_table_keeps_this_catalogues_rows_in_its_order(catalogue_folder):
    rows = cube_rows(catalogue_folder, 0, 1, 2)
    store = ResultStore(catalogue_folder / "r.parquet")
    store.write([{"key": rows[2].key, "row": 1, "status": "ok"}, {"key": "other", "row": 2, "status": "error"},
                 {"key": rows[0].key, "row": 7, "status": "error"}])
    table = rn._catalogue_table(store, Catalog(None, rows))
    assert table.column("key").to_pylist() == [rows[0].key, rows[2].key]
    assert table.column("row").to_pylist() == [1, 3] and table.schema.field("row").type == pa.int64()
    assert table.column("status").to_pylist() == ["error", "ok"]
    assert table.schema == store.read().schema
    none = rn._catalogue_table(ResultStore(catalogue_folder / "empty.parquet"), Catalog(None, rows))  # nothing stored
    assert none.num_rows == 0 and none.schema == store.read().schema
    other = ResultStore(catalogue_folder / "other.parquet")
    other.write([{"key": "other", "row": 1, "status": "ok"}])
    assert rn._catalogue_table(other, Catalog(None, rows)).schema == store.read().schema


# ---------------------------------------------------------------------- the cluster
def test_a_given_client_is_used_as_it_is(monkeypatch):
    from labcut.batch.plugin import NodeKernelCache

    monkeypatch.setattr(rn, "time", Clock(3.0, 0.75))
    fake = FakeClient(["tcp://10.0.0.1:1"], has_cache=False)
    with rn._client(fake, 4, None) as (cl, embedded, seconds):
        assert cl is fake and embedded is False and seconds == 0.75
    assert [type(p) for p in fake.plugins] == [NodeKernelCache]
    fake = FakeClient(["tcp://10.0.0.1:1", "tcp://10.0.0.2:1"], has_cache=True)
    with rn._client(fake, 4, None) as (cl, embedded, _):
        pass
    assert fake.plugins == [] and fake.calls == ["_has_node_cache"]
    fake = FakeClient(["tcp://127.0.0.1:1", "tcp://localhost:2"], has_cache=False)
    with rn._client(fake, 4, None):
        pass
    assert fake.plugins == [] and fake.calls == []
    fake = FakeClient(["tcp://127.0.0.1:1"], has_cache=False)
    with rn._client(fake, 4, True):
        pass
    assert len(fake.plugins) == 1
    fake = FakeClient(["tcp://10.0.0.1:1"], has_cache=False)
    with rn._client(fake, 4, False):
        pass
    assert fake.plugins == [] and fake.calls == []


class StubCluster:
    made: list = []

    def __init__(self, **kwargs) -> None:
        import dask

        self.kwargs, self.trim = kwargs, dask.config.get(rn.TRIM_KEY, default="unset")
        self.closed = None
        StubCluster.made.append(self)

    def close(self, timeout):
        self.closed = timeout
        raise RuntimeError("already closing")  # suppressed


class StubClient:
    def __init__(self, cluster) -> None:
        self.cluster, self.open = cluster, False

    def __enter__(self):
        self.open = True
        return self

    def __exit__(self, *exc):
        self.open = False


@pytest.mark.parametrize("bokeh", [True, False])
def test_the_embedded_cluster(monkeypatch, bokeh):
    import importlib.util

    import dask

    StubCluster.made = []
    monkeypatch.setattr(distributed, "LocalCluster", StubCluster)
    monkeypatch.setattr(distributed, "Client", StubClient)
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: (object() if bokeh else None) if name == "bokeh" else real(name, *a))
    monkeypatch.setattr(rn, "time", Clock(1.0, 0.25))
    monkeypatch.setenv("DRJIT_CACHE_DIR", "/c/d")
    monkeypatch.setenv("LABCUT_BACKEND", "llvm")
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setenv("OTHER_VARIABLE", "x")
    with dask.config.set({rn.TRIM_KEY: 65536}):
        with rn._client(None, 3, True) as (cl, embedded, seconds):
            assert isinstance(cl, StubClient) and cl.open and embedded is True and seconds == 0.25
            [cluster] = StubCluster.made
            assert cl.cluster is cluster and cluster.closed is None
        assert dask.config.get(rn.TRIM_KEY) == 65536  # set back after
    assert cluster.trim is None  # the nannies start without Dask's MALLOC_TRIM_THRESHOLD_
    assert cluster.kwargs == {"n_workers": 3, "threads_per_worker": 1, "processes": True, "silence_logs": logging.ERROR,
                              "dashboard_address": ":0" if bokeh else None,
                              "env": {"DRJIT_CACHE_DIR": "/c/d", "LABCUT_BACKEND": "llvm"}}
    assert cluster.closed == 30 and not cl.open


def test_the_embedded_cluster_is_closed_after_an_error(monkeypatch):
    StubCluster.made = []
    monkeypatch.setattr(distributed, "LocalCluster", StubCluster)
    monkeypatch.setattr(distributed, "Client", StubClient)
    monkeypatch.delenv("DRJIT_CACHE_DIR", raising=False)
    monkeypatch.delenv("LABCUT_BACKEND", raising=False)
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "/l.so")
    with pytest.raises(KeyboardInterrupt):
        with rn._client(None, 1, None):
            raise KeyboardInterrupt
    [cluster] = StubCluster.made
    assert cluster.closed == 30 and cluster.kwargs["env"] == {"DRJIT_LIBLLVM_PATH": "/l.so"}


def test_set_up_workers(monkeypatch):
    from labcut.batch.plugin import LabcutWorkerPlugin

    monkeypatch.setattr(rn, "time", Clock(10.0, 1.5))
    addresses = [f"tcp://10.0.0.{1 + i % 2}:{4000 + i}" for i in range(6)] + ["10.0.0.1:4006", "tcp://[::1]:9"]
    fake = FakeClient(addresses, info={"tcp://b:2": {"threads": 3}, "tcp://a:1": {"threads": 4, "host": "h"}})
    info, seconds = rn._set_up_workers(fake, 6)
    assert info == [{"address": "tcp://a:1", "threads": 4, "host": "h"}, {"address": "tcp://b:2", "threads": 3}]
    assert seconds == 1.5
    [plugin] = fake.plugins
    assert isinstance(plugin, LabcutWorkerPlugin) and plugin.threads == 6
    assert plugin.workers_per_host == {"10.0.0.1": 4, "10.0.0.2": 3, "[::1]": 1}  # every worker, not Dask's first five
    assert plugin.warm == ("labcut.batch.runner",) and fake.calls == ["worker_info"]

    class OldClient(FakeClient):
        def scheduler_info(self):  # an older distributed: every worker, no n_workers
            return {"workers": {a: {} for a in self.addresses}}

    old = OldClient(["tcp://h:1", "tcp://h:2"])
    rn._set_up_workers(old, None)
    assert old.plugins[0].workers_per_host == {"h": 2} and old.plugins[0].threads is None
    assert rn._takes_n_workers(fake) and not rn._takes_n_workers(old)


def test_dashboard_link(monkeypatch):
    assert rn._dashboard(FakeClient(services={"dashboard": 8787}, bokeh=True)) == "http://127.0.0.1:8787/status"
    assert rn._dashboard(FakeClient(services={"dashboard": 8787}, bokeh=False)) is None
    assert rn._dashboard(FakeClient(services={"other": 1}, bokeh=True)) is None
    assert rn._dashboard(FakeClient(services=None, bokeh=True)) is None
    assert rn._dashboard(FakeClient(services={"dashboard": 8787}, bokeh=True, link="")) is None

    class Broken(FakeClient):
        def run_on_scheduler(self, fn):
            raise OSError("gone")

    assert rn._dashboard(Broken(services={"dashboard": 1}, bokeh=True)) is None


def test_serves_bokeh_on_the_scheduler(monkeypatch):
    import sys

    class BokehTornado:  # bokeh's application class, without importing bokeh's server (a second)
        pass

    monkeypatch.setitem(sys.modules, "bokeh.server.tornado", types.SimpleNamespace(BokehTornado=BokehTornado))
    found = []

    class Capture(FakeClient):
        def run_on_scheduler(self, fn):
            found.append(fn)
            return True

    rn._dashboard(Capture(services={"dashboard": 1}))
    [serves] = found
    app = BokehTornado()
    sched = lambda apps: types.SimpleNamespace(http_application=types.SimpleNamespace(applications=apps))  # noqa: E731
    assert serves(sched([object(), app])) is True
    assert serves(sched([object()])) is False
    assert serves(sched(None)) is False
    assert serves(types.SimpleNamespace()) is False
    assert serves(types.SimpleNamespace(http_application=object())) is False


def test_a_scheduler_without_bokeh_serves_no_dashboard(monkeypatch):
    import sys

    found = []

    class Capture(FakeClient):
        def run_on_scheduler(self, fn):
            found.append(fn)
            return True

    rn._dashboard(Capture(services={"dashboard": 1}))
    monkeypatch.setitem(sys.modules, "bokeh.server.tornado", None)  # bokeh not installed there
    assert found[0](types.SimpleNamespace(http_application=types.SimpleNamespace(applications=[object()]))) is False


def test_connect(monkeypatch):
    made = []

    class Ok:
        def __init__(self, address, timeout):
            made.append((address, timeout))

    probed = []
    monkeypatch.setattr(rn, "_nothing_listens", lambda address, timeout: probed.append((address, timeout)))
    monkeypatch.setattr(distributed, "Client", Ok)
    assert isinstance(rn.connect("  tcp://h:8786 \n"), Ok) and made == [("tcp://h:8786", 20.0)]
    assert probed == [("tcp://h:8786", rn.PROBE_SECONDS)]
    rn.connect("tcp://h:1", 2.5)
    assert made[-1] == ("tcp://h:1", 2.5) and probed[-1] == ("tcp://h:1", 2.5)  # the probe waits no longer than Dask would
    with pytest.raises(ParameterError, match=r"^the scheduler address is empty; give tcp://HOST:PORT \(dask scheduler prints it\)$"):
        rn.connect("   ")
    for exc, detail in ((OSError("refused\n  now"), "refused now"), (TimeoutError(), "TimeoutError"),
                        (ValueError("bad scheme"), "bad scheme")):
        def fail(address, timeout, exc=exc):
            raise exc

        monkeypatch.setattr(distributed, "Client", fail)
        with pytest.raises(ParameterError) as info:
            rn.connect("tcp://h:9", 2.5)
        assert str(info.value) == f"cannot reach the Dask scheduler at 'tcp://h:9' within 2.5 s ({detail})"
        assert info.value.__cause__ is None and info.value.__suppress_context__


def test_connect_says_at_once_that_nothing_listens(monkeypatch):
    """A refused TCP address is an error at once, not after Dask's 20 s of retries; an address where
    something listens, a silent one and another scheme go on to Dask's client."""
    import socket

    made = []
    monkeypatch.setattr(distributed, "Client", lambda address, timeout: made.append(address) or "client")
    with socket.socket() as s:  # a port that was free a moment ago and has no listener now
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for address in (f"tcp://127.0.0.1:{port}", f"127.0.0.1:{port}"):
        with pytest.raises(ParameterError) as info:
            rn.connect(address, 30.0)
        assert str(info.value) == (f"cannot reach the Dask scheduler at {address!r} (nothing listens at port {port}: "
                                   f"connection refused); is `dask scheduler` running there?")
    assert made == []
    with socket.socket() as listening:
        listening.bind(("127.0.0.1", 0))
        listening.listen()
        address = f"tcp://127.0.0.1:{listening.getsockname()[1]}"
        assert rn.connect(address) == "client" and made == [address]
    assert rn._nothing_listens("tls://127.0.0.1:9", 1.0) is None and rn._nothing_listens("inproc://x/1", 1.0) is None
    assert rn._nothing_listens("tcp://127.0.0.1:nine", 1.0) is None  # Dask's parser words that one
    asked = []

    def answer(exc):
        def create_connection(where, timeout):
            asked.append((where, timeout))
            raise exc
        return create_connection

    monkeypatch.setattr(socket, "create_connection", answer(TimeoutError()))
    assert rn._nothing_listens("tcp://[::1]:8786", 0.5) is None and asked[-1] == (("::1", 8786), 0.5)  # silent: Dask's to judge
    monkeypatch.setattr(socket, "create_connection", answer(socket.gaierror(-2, "Name or service not known")))
    assert rn._nothing_listens("tcp://nowhere:8786", 1.0) == "unknown host 'nowhere': Name or service not known"
    monkeypatch.setattr(socket, "create_connection", answer(OSError(113, "No route to host")))
    assert rn._nothing_listens("tcp://10.0.0.9:8786", 1.0) == "no route to host"


# ---------------------------------------------------------------------- the rows on the cluster
def stub_row(row):
    """A row's record without a recommendation: ok, or lost for seed 1 (the task raises)."""
    if row.seed == 1:
        raise distributed.comm.CommClosedError("worker\n  died")
    return {**rn._base_record(row), "status": "ok" if row.seed != 2 else "error", "seconds": float(row.seed)}


def test_run_rows_submits_stores_and_counts(catalogue_folder, completed, monkeypatch):
    monkeypatch.setattr(rn, "run_row", stub_row)
    rows = cube_rows(catalogue_folder, 0, 1, 2, 3)
    completed.order, completed.sizes = [3, 1, 0, 3, 2], [2, 1, 2]  # row 4 answered twice, then row 3 in the same batch
    store = ResultStore(catalogue_folder / "r.parquet")
    written, done = [], []
    original = ResultStore.write
    monkeypatch.setattr(ResultStore, "write", lambda self, recs: (written.append([r["key"] for r in recs]), original(self, recs))[1])
    fake = FakeClient()
    assert rn._run_rows(fake, rows, store, done.append) == 4
    keys = [f.key for f in fake.submitted]
    token = keys[0].rsplit("-", 1)[1]
    assert re.fullmatch(r"[0-9a-f]{8}", token)
    assert keys == [f"labcut-row-{r.key}-{token}" for r in rows] and all(f.pure is False for f in fake.submitted)
    assert [f.args for f in fake.submitted] == [(r,) for r in rows]
    assert written == [[rows[3].key, rows[1].key], [rows[0].key], [rows[2].key]]  # the repeat of row 4 is not written
    assert done == [2, 3, 4]
    assert all(f.released for f in fake.submitted) and not any(f.cancelled for f in fake.submitted)
    got = {r["key"]: r for r in store.read().to_pylist()}
    lost = got[rows[1].key]
    assert lost["status"] == "error" and lost["error"] == "CommClosedError: worker died" and lost["seconds"] is None
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", lost["finished_at"])
    assert {k: lost[k] for k in rn._base_record(rows[1])} == rn._base_record(rows[1])
    assert got[rows[3].key]["seconds"] == 3.0 and got[rows[2].key]["status"] == "error"
    fresh = FakeClient()
    completed.order, completed.sizes = None, None
    rn._run_rows(fresh, rows[:1], store, lambda n: None)
    assert fresh.submitted[0].key.rsplit("-", 1)[1] != token  # a run's own task keys


def test_an_interrupted_run_cancels_only_what_has_not_finished(catalogue_folder, completed, monkeypatch):
    monkeypatch.setattr(rn, "run_row", stub_row)
    rows = cube_rows(catalogue_folder, 0, 3, 4, 5)
    completed.order, completed.sizes = [2, 0, 1, 3], [2, 2]

    def stop(done):
        raise KeyboardInterrupt

    fake = FakeClient()
    store = ResultStore(catalogue_folder / "r.parquet")
    with pytest.raises(KeyboardInterrupt):
        rn._run_rows(fake, rows, store, stop)
    assert [f.cancelled for f in fake.submitted] == [False, True, False, True]
    assert sorted(store.statuses()) == sorted([rows[0].key, rows[2].key])


# ---------------------------------------------------------------------- the report
class Page:
    saved: list = []

    def __init__(self, parts) -> None:
        self.parts = parts

    def save_html(self, target):
        Page.saved.append((Path(target), self.parts))


def test_write_reports(catalogue_folder, completed, monkeypatch):
    Page.saved = []
    rows = read_catalog([{"cut": "m/cube.ply", "name": "A"}, {"cut": "m/step.ply", "name": "B"},
                         {"cut": "m/cube.ply", "seed": 1, "scenario": "ring"}, {"cut": "m/step.ply", "seed": 2}],
                        base=catalogue_folder).rows
    groups = rn.report_groups(rows)  # three groups: seeds 0 (A, B), 1 and 2
    assert [len(g.cuts) for g in groups] == [2, 1, 1]

    def compare(row, name, scenarios):
        if row.seed == 2:
            raise ValueError("no\n render")
        return (name, scenarios)

    monkeypatch.setattr(rn, "compare_cut", compare)
    monkeypatch.setattr(rn, "merge_comparisons", Page)
    completed.order = [1, 3, 0, 2]  # B before A: merged in the group's order all the same
    fake, done = FakeClient(), []
    written, errors = rn._write_reports(fake, groups, catalogue_folder / "rep.html", done.append)
    assert [f.key for f in fake.submitted] == [f"labcut-compare-0-0-{rows[0].key}", f"labcut-compare-0-1-{rows[1].key}",
                                               f"labcut-compare-1-0-{rows[2].key}", f"labcut-compare-2-0-{rows[3].key}"]
    assert all(f.pure is False and f.released for f in fake.submitted)
    assert [f.args for f in fake.submitted] == [(rows[0], "A", ("bench",)), (rows[1], "B", ("bench",)),
                                                (rows[2], "cube.ply", ("ring",)), (rows[3], "step.ply", ("bench",))]
    assert done == [1, 2, 3, 4]
    folder = catalogue_folder
    assert Page.saved == [(folder / "rep.html", [("A", ("bench",)), ("B", ("bench",))]),
                          (folder / "rep-2.html", [("cube.ply", ("ring",))])]
    assert written == [(folder / "rep.html", "material default, standard quality, seed 0"),
                       (folder / "rep-2.html", "material default, standard quality, seed 1")]
    assert errors == ["report: cut 'step.ply' (material default, standard quality, seed 2) left out: ValueError: no render",
                      "report for material default, standard quality, seed 2: no cut could be compared"]


def test_write_reports_skips_a_group_and_keeps_the_next_pages_name(catalogue_folder, completed, monkeypatch):
    Page.saved = []
    rows = cube_rows(catalogue_folder, 2, 0)
    groups = rn.report_groups(rows)
    monkeypatch.setattr(rn, "compare_cut", lambda row, name, s: (_ for _ in ()).throw(ValueError("x")) if row.seed == 2 else name)
    monkeypatch.setattr(rn, "merge_comparisons", Page)
    written, errors = rn._write_reports(FakeClient(), groups, catalogue_folder / "rep.html", lambda n: None)
    assert written == [(catalogue_folder / "rep-2.html", groups[1].label)] and len(errors) == 2
    assert rn._write_reports(FakeClient(), [], catalogue_folder / "rep.html", lambda n: None) == (
        [], ["no row succeeded: there is nothing to compare"])


# ---------------------------------------------------------------------- run()
@pytest.fixture
def batch(catalogue_folder, completed, monkeypatch, recommend):
    """run() on a stand-in client; rows of seed 2 fail (their recommendation raises)."""
    recommend.fail_seeds = {2}
    monkeypatch.setattr(rn, "_memory", lambda: (1.0, 2.0))
    return catalogue_folder


def test_run_counts_rows_and_resumes(batch, completed, monkeypatch):
    out = batch / "r.parquet"
    cat = catalogue(batch, 0, 1, 2)
    fake = FakeClient()
    progress, started = [], []
    result = rn.run(cat, fake, out=out, progress=lambda d, t: progress.append((d, t)), on_start=started.append)
    assert (result.ran, result.skipped, result.failed, result.total) == (3, 0, 1, 3)
    assert result.store == out and result.catalog is cat
    assert [r["status"] for r in result.records()] == ["ok", "ok", "error"]
    assert progress == [(0, 3), (1, 3), (2, 3), (3, 3)]
    assert started == [{"dashboard": None, "workers": [{"address": "tcp://127.0.0.1:40001", "threads": 2}],
                        "to_run": 3, "skipped": 0, "startup_seconds": result.startup_seconds}]
    assert result.workers == started[0]["workers"] and len(ResultStore(out).parts()) == 1  # compacted
    assert result.reports == [] and result.report_errors == []
    # again: everything is stored, the failed row too: no cluster
    progress.clear()
    never = types.SimpleNamespace()  # any use of the client fails
    monkeypatch.setattr(distributed, "as_completed", REAL_AS_COMPLETED)  # no client: raises if reached
    again = rn.run(cat, never, out=out, progress=lambda d, t: progress.append((d, t)))
    assert (again.ran, again.skipped, again.failed, again.startup_seconds, again.workers, again.dashboard) == (0, 3, 1, 0.0, [], None)
    assert progress == [(0, 0)]
    # retry_failed: only the failed row runs again, and fails again
    monkeypatch.setattr(distributed, "as_completed", completed)
    fake2 = FakeClient()
    third = rn.run(cat, fake2, out=out, retry_failed=True)
    assert (third.ran, third.skipped, third.failed) == (1, 2, 1)
    assert [f.args[0].seed for f in fake2.submitted] == [2]
    # a longer catalogue over the same store: only the new rows run; another catalogue's records are not its own
    more = catalogue(batch, 1, 5)
    fake3 = FakeClient()
    fourth = rn.run(more, fake3, out=out)
    assert (fourth.ran, fourth.skipped, fourth.failed, fourth.total) == (1, 1, 0, 2)
    assert [r["row"] for r in fourth.records()] == [1, 2] and [r["seed"] for r in fourth.records()] == [1, 5]


def test_run_retries_a_row_stored_failed_that_now_succeeds(batch, recommend):
    out = batch / "r.parquet"
    cat = catalogue(batch, 2, 3)
    assert rn.run(cat, FakeClient(), out=out).failed == 1
    recommend.fail_seeds = set()
    result = rn.run(cat, FakeClient(), out=out, retry_failed=True)
    assert (result.ran, result.skipped, result.failed) == (1, 1, 0)
    assert [r["status"] for r in result.records()] == ["ok", "ok"]


def test_run_settings_reach_the_cluster(batch, monkeypatch):
    seen = {}

    @contextlib.contextmanager
    def client(cl, workers, node_cache):
        seen["client"] = (cl, workers, node_cache)
        yield FakeClient(), True, 2.0

    monkeypatch.setattr(rn, "_client", client)
    monkeypatch.setattr(rn, "_set_up_workers", lambda cl, threads: (seen.setdefault("threads", threads), ([{"address": "w"}], 0.5))[1])
    monkeypatch.setattr(rn, "_dashboard", lambda cl: "http://dash/status" if isinstance(cl, FakeClient) else None)
    import labcut.batch.plugin as plugin

    monkeypatch.setattr(plugin, "cores", lambda: 8)
    result = rn.run(catalogue(batch, 0, 1, 3), out=batch / "r.parquet", threads_per_worker=3)
    assert seen == {"client": (None, 3, None), "threads": 3}
    assert result.startup_seconds == 2.5 and result.dashboard == "http://dash/status" and result.workers == [{"address": "w"}]
    result = rn.run(catalogue(batch, 4), out=batch / "r2.parquet", workers=2, node_cache=False)
    assert seen["client"] == (None, 2, False) and seen["threads"] == 3  # setdefault: the first call's
    monkeypatch.setattr(plugin, "cores", lambda: 1)
    rn.run(catalogue(batch, 4, 5, 6), out=batch / "r3.parquet")
    assert seen["client"][1] == 1


def test_a_report_alone_on_the_embedded_cluster_takes_one_worker(batch, monkeypatch):
    import labcut.batch.plugin as plugin

    seen = []

    @contextlib.contextmanager
    def client(cl, workers, node_cache):
        seen.append(workers)
        yield FakeClient(), True, 0.0

    monkeypatch.setattr(rn, "_client", client)
    monkeypatch.setattr(plugin, "cores", lambda: 8)
    monkeypatch.setattr(rn, "compare_cut", lambda row, name, s: name)
    monkeypatch.setattr(rn, "merge_comparisons", Page)
    cat = catalogue(batch, 0, 1)
    rn.run(cat, out=batch / "r.parquet")
    rn.run(cat, out=batch / "r.parquet", html=batch / "rep.html")  # nothing to run: the report's cluster
    assert seen == [2, 1]


def test_a_given_client_does_not_count_worker_set_up_as_start_up(batch, monkeypatch):
    @contextlib.contextmanager
    def client(cl, workers, node_cache):
        yield cl, False, 2.0

    monkeypatch.setattr(rn, "_client", client)
    monkeypatch.setattr(rn, "_set_up_workers", lambda cl, threads: ([], 0.5))
    result = rn.run(catalogue(batch, 0), FakeClient(), out=batch / "r.parquet", node_cache=True)
    assert result.startup_seconds == 2.0


def test_run_times_the_whole_batch(batch, monkeypatch):
    clock = Clock(50.0, 1.0)
    monkeypatch.setattr(rn, "time", clock)
    result = rn.run(catalogue(batch, 0), FakeClient(["tcp://10.0.0.1:1"]), out=batch / "r.parquet", node_cache=False)
    assert result.seconds == clock.calls - 1.0  # from the first reading to the last
    assert result.startup_seconds == 1.0  # the given client's own reading; not the workers' set-up


def test_run_checks_its_arguments_before_any_work(batch, monkeypatch):
    def no_store(*a, **k):
        raise AssertionError("the store was opened")

    cat = catalogue(batch, 0)
    monkeypatch.setattr(rn, "ResultStore", no_store)
    cases = [
        (dict(quality="best"), "quality must be one of draft, standard, high, got 'best'"),
        (dict(objective="flash"), "objective must be one of energy, area, intensity, balanced, got 'flash'"),
        (dict(workers=2, client=FakeClient()),
         "workers is the size of the embedded cluster; a given client (scheduler) brings its own workers"),
        (dict(workers=0), "workers must lie in [1, 4096], got 0"),
        (dict(workers=4097), "workers must lie in [1, 4096], got 4097"),
        (dict(workers=1.5), "workers must be a whole number, got 1.5"),
        (dict(threads_per_worker=0), "threads per worker must lie in [1, 4096], got 0"),
        (dict(threads_per_worker=4097), "threads per worker must lie in [1, 4096], got 4097"),
        (dict(threads_per_worker=1.5), "threads per worker must be a whole number, got 1.5"),
        (dict(html=batch / "rep.txt"), "output file 'rep.txt' must end in one of .html, .htm"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ParameterError) as info:
            rn.run(cat, **kwargs)
        assert str(info.value) == message
    # the ends of the ranges are accepted (the store is then opened)
    for kwargs in (dict(workers=1), dict(workers=4096), dict(threads_per_worker=1), dict(threads_per_worker=4096),
                   dict(html=batch / "rep.HTM"), dict(quality="high", objective="balanced")):
        with pytest.raises(AssertionError, match="the store was opened"):
            rn.run(cat, **kwargs)


def test_run_defaults_fill_empty_cells(batch, recommend):
    from labcut.physics.material import Labradorite

    cube = str(batch / "m" / "cube.ply")
    rows = [{"cut": cube}, {"cut": cube, "seed": 5, "quality": "high"}]
    result = rn.run(rows, FakeClient(), out=batch / "r.parquet", material="gold", scenario="ring", quality="draft",
                    objective="area", seed=4)
    assert [c[1] for c in recommend.calls] == [
        {"material": Labradorite.preset("gold"), "scenario": "ring", "quality": "draft", "objective": "area", "seed": 4,
         "max_tilt": 90.0},
        {"material": Labradorite.preset("gold"), "scenario": "ring", "quality": "high", "objective": "area", "seed": 5,
         "max_tilt": 90.0}]
    assert result.catalog.rows[0].material_label == "gold"


def test_run_defaults(batch, recommend, monkeypatch):
    """Without settings: the default material, bench, standard quality, energy, seed 0, into ./results.parquet."""
    from labcut.physics.material import Labradorite

    monkeypatch.chdir(batch)
    result = rn.run([{"cut": "m/cube.ply"}], FakeClient())
    assert recommend.calls[0][1] == {"material": Labradorite.coerce(None), "scenario": "bench", "quality": "standard",
                                     "objective": "energy", "seed": 0, "max_tilt": 90.0}
    assert result.store == Path("results.parquet") and (batch / "results.parquet").is_dir()
    assert len(ResultStore(batch / "results.parquet").statuses()) == 1


def test_run_reads_a_catalogue_file(batch, recommend):
    (batch / "c.csv").write_text("cut,seed\nm/cube.ply,0\nm/cube.ply,1\n")
    result = rn.run(batch / "c.csv", FakeClient(), out=batch / "r.parquet")
    assert result.total == 2 and result.catalog.path == batch / "c.csv" and len(recommend.calls) == 2


def test_run_with_a_report_counts_its_cuts(batch, monkeypatch):
    Page.saved = []
    monkeypatch.setattr(rn, "compare_cut", lambda row, name, s: name)
    monkeypatch.setattr(rn, "merge_comparisons", Page)
    out, html = batch / "r.parquet", batch / "rep.html"
    # stored before: seeds 0 and 4 ok, seed 3 failed; now: seeds 1 (ok) and 2 (fails)
    rows = cube_rows(batch, 0, 1, 2, 3, 4)
    ResultStore(out).write([{**rn._base_record(rows[0]), "status": "ok"}, {**rn._base_record(rows[3]), "status": "error"},
                            {**rn._base_record(rows[4]), "status": "ok"}])
    progress = []
    result = rn.run(Catalog(None, rows), FakeClient(), out=out, html=html, progress=lambda d, t: progress.append((d, t)))
    # planned: 2 rows + the report's cuts of the rows ok or to run (seeds 0, 1, 2, 4: four groups of one cut)
    # after the rows: seed 2 failed, so 2 rows + 3 cuts
    assert progress == [(0, 6), (1, 6), (2, 6), (3, 5), (4, 5), (5, 5)]
    assert (result.ran, result.skipped, result.failed) == (2, 3, 2)
    assert result.reports == [(html, "material default, standard quality, seed 0"),
                              (batch / "rep-2.html", "material default, standard quality, seed 1"),
                              (batch / "rep-3.html", "material default, standard quality, seed 4")]
    assert result.report_errors == [] and [p for p, _ in Page.saved] == [html, batch / "rep-2.html", batch / "rep-3.html"]


def test_a_report_alone_still_starts_the_cluster(batch, monkeypatch):
    Page.saved = []
    monkeypatch.setattr(rn, "compare_cut", lambda row, name, s: name)
    monkeypatch.setattr(rn, "merge_comparisons", Page)
    out = batch / "r.parquet"
    cat = catalogue(batch, 0, 2)
    rn.run(cat, FakeClient(), out=out)
    fake, progress = FakeClient(), []
    result = rn.run(cat, fake, out=out, html=batch / "rep.html", progress=lambda d, t: progress.append((d, t)))
    assert result.ran == 0 and result.skipped == 2 and result.workers != []
    assert progress == [(0, 1), (1, 1)] and len(Page.saved) == 1
    assert [f.key.split("-")[1] for f in fake.submitted] == ["compare"]
    nothing = rn.run(catalogue(batch, 2), FakeClient(), out=batch / "r2.parquet", html=batch / "rep.html")
    assert nothing.reports == [] and nothing.report_errors == ["no row succeeded: there is nothing to compare"]


def test_an_interrupted_run_keeps_what_finished_compacted(batch, completed, monkeypatch):
    out = batch / "r.parquet"
    cat = catalogue(batch, 0, 1, 3)
    completed.sizes = [1, 1, 1]

    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        rn.run(cat, FakeClient(), out=out, progress=stop)
    store = ResultStore(out)
    assert len(store.parts()) == 1 and len(store.statuses()) == 2
    again = rn.run(cat, FakeClient(), out=out)
    assert (again.ran, again.skipped) == (1, 2)


def test_a_store_that_cannot_be_compacted_is_no_error(batch, monkeypatch):
    def compact(self):
        raise OutputError("no room")

    monkeypatch.setattr(ResultStore, "compact", compact)
    result = rn.run(catalogue(batch, 0, 1), FakeClient(), out=batch / "r.parquet")
    assert result.ran == 2 and len(ResultStore(batch / "r.parquet").parts()) == 2
