"""labcut.batch on a 2-worker LocalCluster (one per module): the same answers as direct
recommend_orientation calls, nothing lost or done twice (a failing row, an interrupted batch,
a worker killed mid-row), and ``labcut batch`` with its report."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.batch import read_catalog, run
from labcut.batch.store import ResultStore

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"

CATALOG = """name,cut,material,scenario,quality,seed
cube,m/cube.ply,blue,bench,draft,0
srb,m/SRB.asc,505,pendant,draft,1
cab,"cab:round,8,low,res=32",gold,ring,draft,2
"""
#: three cheap rows (the same cube, three seeds)
CUBES = "cut,quality,seed\nm/cube.ply,draft,0\nm/cube.ply,draft,1\nm/cube.ply,draft,2\n"


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    import logging

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    with Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "m").mkdir()
    shutil.copy(MESHES / "cube-10.ply", tmp_path / "m" / "cube.ply")
    shutil.copy(MESHES / "step-cut-12x10.ply", tmp_path / "m" / "step.ply")
    shutil.copy(MESHES / "designs" / "SRB.asc", tmp_path / "m" / "SRB.asc")
    (tmp_path / "c.csv").write_text(CATALOG)
    return tmp_path


def direct(row):
    """What a user gets calling recommend_orientation on the row's stone, without labcut.batch."""
    if row.kind == "cabochon":
        mesh = labcut.cabochon(**row.cab)
    else:
        mesh = labcut.load_mesh(row.path, size=row.size)
    return labcut.recommend_orientation(mesh, row.material, scenario=row.scenario, quality=row.quality,
                                        objective=row.objective, seed=row.seed, max_tilt=row.max_tilt)


def test_results_are_those_of_direct_calls(client, folder):
    result = run(folder / "c.csv", client, out=folder / "r.parquet")
    assert (result.total, result.ran, result.skipped, result.failed) == (3, 3, 0, 0)
    assert {w["threads"] for w in result.workers} == {max(1, len(os.sched_getaffinity(0)) // 2)}  # the worker plugin ran
    records = result.records()
    assert [r["row"] for r in records] == [1, 2, 3]
    assert len({r["worker"] for r in records}) >= 1
    for row, rec in zip(read_catalog(folder / "c.csv").rows, records):
        want = direct(row)
        assert rec["key"] == row.key and rec["status"] == "ok", rec["error"]
        assert [rec["normal_x"], rec["normal_y"], rec["normal_z"]] == [float(x) for x in want.normal]
        assert rec["score"] == want.score and rec["tolerance_deg"] == want.tolerance_deg
        assert rec["flash_energy"] == want.metrics.flash_energy and rec["flash_area"] == want.metrics.flash_area
        assert rec["description"] == want.description
        stored = json.loads(rec["recommendation"])
        assert stored["runners_up"] == json.loads(json.dumps(want.to_dict()["runners_up"]))
        assert np.array_equal(stored["map"]["score"], want.map_scores)


def test_a_failing_row_is_recorded_and_the_rest_finish(folder):
    """On the embedded LocalCluster (client None): one worker, started and closed by run()."""
    (folder / "m" / "broken.ply").write_text("ply\nformat ascii 1.0\nthis is not a mesh\n")
    (folder / "c.csv").write_text("name,cut,quality\ncube,m/cube.ply,draft\nbroken,m/broken.ply,draft\n")
    result = run(folder / "c.csv", out=folder / "r.parquet", workers=1)
    assert (result.ran, result.failed) == (2, 1) and len(result.workers) == 1
    assert result.workers[0]["threads"] == len(os.sched_getaffinity(0))  # one worker: every core for Dr.Jit
    assert result.startup_seconds > 0
    good, bad = result.records()
    assert good["status"] == "ok" and good["error"] is None and good["tilt_deg"] is not None
    assert bad["status"] == "error" and bad["name"] == "broken" and "broken.ply" in bad["error"]
    assert "\n" not in bad["error"] and bad["tilt_deg"] is None
    again = run(folder / "c.csv", out=folder / "r.parquet")  # failed rows are kept, not retried by default
    assert (again.ran, again.skipped, again.failed, again.startup_seconds) == (0, 2, 1, 0.0)  # no cluster started


def test_an_interrupted_batch_resumes_without_repeating_work(client, folder, monkeypatch):
    out = folder / "r.parquet"
    written: list[str] = []
    original = ResultStore.write

    def spy(self, records):
        written.extend(r["key"] for r in records)
        return original(self, records)

    monkeypatch.setattr(ResultStore, "write", spy)

    def stop(done, total):
        if done >= 1:
            raise KeyboardInterrupt

    (folder / "cubes.csv").write_text(CUBES)
    with pytest.raises(KeyboardInterrupt):
        run(folder / "cubes.csv", client, out=out, progress=stop)
    first = ResultStore(out).read().to_pylist()
    assert 1 <= len(first) < 3 and len(written) == len(first)
    result = run(folder / "cubes.csv", client, out=out)
    assert result.skipped == len(first) and result.ran == 3 - len(first)
    keys = [r.key for r in read_catalog(folder / "cubes.csv").rows]
    assert sorted(written) == sorted(keys)  # every row computed and written once over both runs
    table = result.records()
    assert [r["key"] for r in table] == keys
    before = {r["key"]: r["finished_at"] for r in first}
    assert all(r["finished_at"] == before[r["key"]] for r in table if r["key"] in before)  # not redone


def test_a_worker_killed_mid_row_is_retried_and_written_once(client, folder, monkeypatch):
    import labcut.batch.runner as br

    marker = folder / "killed"

    def dies_once(row):  # pickled by value (a local function): the first attempt at row 2 kills its worker
        from labcut.batch.runner import run_row  # the workers' own, unpatched

        if row.index == 2 and not marker.exists():
            marker.touch()
            os._exit(1)
        return run_row(row)

    written: list[str] = []
    original = ResultStore.write
    monkeypatch.setattr(ResultStore, "write", lambda self, recs: (written.extend(r["key"] for r in recs), original(self, recs))[1])
    monkeypatch.setattr(br, "run_row", dies_once)
    (folder / "cubes.csv").write_text(CUBES)
    result = run(folder / "cubes.csv", client, out=folder / "r.parquet")
    assert marker.exists()  # the worker did die
    assert result.failed == 0 and result.ran == 3
    assert sorted(written) == sorted(r.key for r in read_catalog(folder / "cubes.csv").rows)


def test_cli_batch_on_a_scheduler_with_report(client, folder, cli):
    (folder / "m" / "broken.ply").write_text("not a mesh\n")
    (folder / "small.csv").write_text("name,cut,material,seed\ncube,m/cube.ply,,0\nsrb,m/SRB.asc,gold,1\nbroken,m/broken.ply,,0\n")
    out, html, summary = folder / "r.parquet", folder / "report.html", folder / "s.json"
    address = client.scheduler.address
    proc = cli("batch", str(folder / "small.csv"), "--out", str(out), "--html", str(html), "--quality", "draft",
               "--preset", "blue", "--scheduler", address, "--json", str(summary))
    assert proc.returncode == 1, proc.stderr  # one row failed: the batch finished, exit 1
    assert "Traceback" not in proc.stderr
    data = json.loads(summary.read_text())
    assert (data["rows"], data["ran"], data["failed"]) == (3, 3, 1)
    assert [r["status"] for r in data["results_rows"]] == ["ok", "ok", "error"]
    assert [r["material"] for r in data["results_rows"]] == ["blue", "gold", "blue"]
    # one page per material: blue (the cube), then gold (the SRB design)
    assert [r["path"] for r in data["reports"]] == [str(html), str(folder / "report-2.html")]
    assert "cube" in html.read_text() and "srb" in (folder / "report-2.html").read_text()
    assert "data:image/png;base64," in html.read_text()
    assert "Rows" in proc.stdout and "1 failed" in proc.stdout
    again = cli("batch", str(folder / "small.csv"), "--out", str(out), "--quality", "draft", "--preset", "blue",
                "--scheduler", address, "--json", "-")
    assert again.returncode == 1
    assert (json.loads(again.stdout)["skipped"], json.loads(again.stdout)["ran"]) == (3, 0)
    down = cli("batch", str(folder / "small.csv"), "--out", str(folder / "other.parquet"), "--scheduler", "tcp://127.0.0.1:9")
    assert down.returncode == 2 and "cannot reach the Dask scheduler" in down.stderr and len(down.stderr.strip().splitlines()) == 1
