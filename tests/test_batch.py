"""labcut.batch on a 2-worker LocalCluster (one per module): the same answers as direct
recommend_orientation calls, nothing lost or done twice (a failing row, an interrupted batch,
a worker killed mid-row), and ``labcut batch`` with its report."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.batch import Defaults, read_catalog, run
from labcut.batch.store import ResultStore


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
def folder(catalogue_folder: Path) -> Path:
    (catalogue_folder / "c.csv").write_text(CATALOG)
    return catalogue_folder


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


def test_a_failing_row_is_recorded_and_the_rest_finish(folder, monkeypatch):
    """On the embedded LocalCluster (client None): one worker, started and closed by run()."""
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)  # a nanny of the module's cluster put it in os.environ
    (folder / "m" / "broken.ply").write_text("ply\nformat ascii 1.0\nthis is not a mesh\n")
    (folder / "c.csv").write_text("name,cut,quality\ncube,m/cube.ply,draft\nbroken,m/broken.ply,draft\n")
    result = run(folder / "c.csv", out=folder / "r.parquet", workers=1)
    assert (result.ran, result.failed) == (2, 1) and len(result.workers) == 1
    assert result.workers[0]["threads"] == len(os.sched_getaffinity(0))  # one worker: every core for Dr.Jit
    assert result.workers[0]["malloc_trim_threshold"] is None  # not Dask's 65536: rows 1.6-1.8x slower with it
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
    # the fixture's scheduler has its HTTP server (metrics) but no dashboard pages: no link to a 404
    assert data["dashboard"] is None and "Dask dashboard" not in proc.stderr
    assert "warning: the workers run with MALLOC_TRIM_THRESHOLD_=" in proc.stderr  # the fixture's plain LocalCluster (Dask default)
    again = cli("batch", str(folder / "small.csv"), "--out", str(out), "--quality", "draft", "--preset", "blue",
                "--scheduler", address, "--json", "-")
    assert again.returncode == 1
    assert (json.loads(again.stdout)["skipped"], json.loads(again.stdout)["ran"]) == (3, 0)
    down = cli("batch", str(folder / "small.csv"), "--out", str(folder / "other.parquet"), "--scheduler", "tcp://127.0.0.1:9")
    assert down.returncode == 2 and "cannot reach the Dask scheduler" in down.stderr and len(down.stderr.strip().splitlines()) == 1


def test_cli_batch_on_the_embedded_cluster_writes_report_and_parquet(folder, cli, monkeypatch):
    """``labcut batch CATALOG --out --html`` end to end as a user runs it (no --scheduler): the
    embedded cluster's dashboard link (bokeh is a dependency), the report page, the Parquet rows."""
    import pyarrow.parquet as pq

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)  # as in a fresh shell (a nanny here may have set it)

    (folder / "tiny.csv").write_text("name,cut,scenario\ncube,m/cube.ply,bench\ncube,m/cube.ply,pendant\n")
    out, html = folder / "r.parquet", folder / "report.html"
    proc = cli("batch", str(folder / "tiny.csv"), "--out", str(out), "--html", str(html), "--quality", "draft", "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "2 of 2 row(s) to run on 1 local worker(s)" in proc.stderr
    links = [line for line in proc.stderr.splitlines() if line.startswith("Dask dashboard: ")]
    assert len(links) == 1 and links[0].split(": ", 1)[1].startswith("http://") and links[0].endswith("/status"), proc.stderr
    page = html.read_text()
    assert "cube" in page and "data:image/png;base64," in page and "pendant" in page
    keys = [r.key for r in read_catalog(folder / "tiny.csv", Defaults(quality="draft")).rows]
    records = pq.read_table(out).to_pylist()  # any Parquet reader: the folder of parts
    assert sorted(r["key"] for r in records) == sorted(keys)
    assert [r["status"] for r in records] == ["ok", "ok"] and {r["scenario"] for r in records} == {"bench", "pendant"}
    assert all(r["tilt_deg"] is not None and r["flash_energy"] > 0 for r in records)
    assert "2: 2 run now, 0 already stored, 0 failed" in proc.stdout and str(html) in proc.stdout
    assert "MALLOC_TRIM_THRESHOLD_" not in proc.stderr  # the embedded cluster's workers start without it


class FakeClient:
    """What ``_client`` asks of a given ``distributed.Client``: its workers' addresses, whether
    each already has its node cache (``client.run``), and the plugins registered."""

    def __init__(self, addresses, has_cache=False):
        self.addresses, self.has_cache, self.plugins = list(addresses), has_cache, []

    def scheduler_info(self, **_):
        return {"workers": {a: {} for a in self.addresses}}

    def run(self, fn):
        return {a: self.has_cache for a in self.addresses}

    def register_plugin(self, plugin):
        self.plugins.append(plugin)


@pytest.mark.parametrize("addresses, node_cache, has_cache, registered", [
    (["tcp://127.0.0.1:40001", "tcp://127.0.0.1:40002"], None, False, False),  # all on this machine: the driver's cache
    (["tcp://localhost:40001", "tcp://[::1]:40002"], None, False, False),
    (["tcp://127.0.0.1:40001", "tcp://10.1.2.3:40002"], None, False, True),   # a worker elsewhere: one folder per node
    (["tls://node7.cluster:40001"], None, False, True),
    (["tcp://10.1.2.3:40002"], None, True, False),                             # already set up: no second restart
    (["tcp://10.1.2.3:40002"], False, False, False),                           # --no-node-cache
    (["tcp://127.0.0.1:40001"], True, False, True),                            # --node-cache
])
def test_node_cache_is_registered_when_workers_are_elsewhere(addresses, node_cache, has_cache, registered):
    from labcut.batch.plugin import NodeKernelCache
    from labcut.batch.runner import _client

    fake = FakeClient(addresses, has_cache)
    with _client(fake, 1, node_cache) as (cl, embedded, _):
        assert cl is fake and not embedded
    assert [type(p) for p in fake.plugins] == ([NodeKernelCache] if registered else [])


def test_node_kernel_cache_plugin_restarts_workers_into_their_own_folder(tmp_path):
    """The nanny plugin on a real (1-worker) cluster: the worker comes back with DRJIT_CACHE_DIR
    set to ``root/<host name>``, a folder that exists, before Dr.Jit is imported there."""
    import logging
    import socket

    from distributed import Client, LocalCluster

    from labcut.batch.plugin import NodeKernelCache, node_cache_dir

    root = tmp_path / "nodes"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",  # any free port
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as c:
        before = set(c.run(os.getpid).values())
        c.register_plugin(NodeKernelCache(str(root)))
        c.wait_for_workers(1, timeout=60)
        seen = c.run(lambda: (os.getpid(), os.environ.get("DRJIT_CACHE_DIR"), "drjit" in __import__("sys").modules))
    [(pid, folder, drjit_loaded)] = seen.values()
    assert pid not in before  # the worker was restarted (a new process)
    assert folder == str(root / socket.gethostname()) == node_cache_dir(str(root))
    assert Path(folder).is_dir() and not drjit_loaded
