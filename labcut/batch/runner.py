"""``labcut.batch.run``: every row of a catalogue on Dask distributed, results streamed to Parquet.

Each row runs :func:`labcut.recommend_orientation` on a Dask worker (an embedded
``LocalCluster`` of processes with one task thread each, or a cluster the caller gives as a
``distributed.Client``); the driver, the only writer, stores each row as it finishes
(:mod:`labcut.batch.store`). Nothing finished is lost: rows already stored under their key are
skipped, a row that fails is stored with its one-line error and the batch goes on, a row whose
worker dies is run again by Dask on another worker (up to ``distributed.scheduler.allowed-failures``
times, then stored as failed), and a key is written once. Optionally the comparison report of
``labcut compare`` over the rows (:func:`labcut.reports.compare.run_comparison` per cut, on the
workers too).

Units and frames as :func:`labcut.recommend_orientation`: lamella normals in the mesh frame
(+Z face-up, -Y the front), degrees, flash values in units of L_ref, seconds, MiB.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from ..errors import LabcutError, LabcutWarning, ParameterError
from .catalog import Catalog, Defaults, Row, read_catalog
from .store import ResultStore


# ---------------------------------------------------------------------- one row (runs on a worker)
def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if isinstance(exc, LabcutError) else f"{type(exc).__name__}: {text}"


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return "local"


def _memory() -> tuple[float | None, float | None]:
    """(current, peak) resident memory of this process, MiB."""
    try:
        import resource

        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
    except (ImportError, OSError):  # pragma: no cover
        peak = None
    try:
        import psutil

        now = psutil.Process().memory_info().rss / 2**20
    except (ImportError, OSError):  # pragma: no cover
        now = None
    return now, peak


def _base_record(row: Row) -> dict[str, Any]:
    from .. import __version__

    return {"key": row.key, "row": row.index, "name": row.name, "cut": row.cut, "kind": row.kind,
            "material": row.material_label, "scenario": row.scenario, "quality": row.quality, "objective": row.objective,
            "seed": row.seed, "max_tilt_deg": row.max_tilt, "labcut_version": __version__}


def run_row(row: Row) -> dict[str, Any]:
    """Run one row: read or build its stone, :func:`labcut.recommend_orientation` with the row's
    settings; a record of :data:`labcut.batch.store.COLUMNS`. An error the row causes is caught and
    recorded (``status`` ``error``, ``error`` its one line); the process dying is not."""
    from ..orientation.recommend import energy_parts

    start = time.perf_counter()
    record = _base_record(row)
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", LabcutWarning)
            mesh = row.load_mesh()
            rec = _recommend(mesh, row)
        in_flash, _ = energy_parts(rec.metrics)
        m = rec.metrics
        record.update({
            "status": "ok", "normal_x": float(rec.normal[0]), "normal_y": float(rec.normal[1]), "normal_z": float(rec.normal[2]),
            "tilt_deg": rec.tilt_deg, "azimuth_deg": rec.azimuth_deg, "description": rec.description, "score": rec.score,
            "flash_energy": m.flash_energy, "flash_area": m.flash_area, "flash_intensity": m.flash_intensity,
            "coverage": m.coverage, "balanced": m.balanced, "energy_in_flash": in_flash,
            "tolerance_deg": rec.tolerance_deg, "tolerance_front_back_deg": rec.tolerance_by_axis.get("front_back_deg"),
            "tolerance_left_right_deg": rec.tolerance_by_axis.get("left_right_deg"),
            "parallel_within_deg": rec.parallel_within_deg, "evaluations": rec.evaluations,
            "recommendation": json.dumps(rec.to_dict(), default=_plain),
        })
    except Exception as exc:  # a row's failure is recorded; the batch goes on
        record.update({"status": "error", "error": _one_line(exc)})
    # labcut's warnings before a failure are kept too: "units guessed" may say why the row failed;
    # anyone else's go on to the caller's filters (recorded above only to keep them in order)
    notes = [" ".join(str(w.message).split()) for w in caught if issubclass(w.category, LabcutWarning)]
    for w in caught:
        if not issubclass(w.category, LabcutWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    now, peak = _memory()
    record.update({"warnings": "; ".join(notes) or None, "seconds": time.perf_counter() - start, "worker": _worker_name(),
                   "worker_rss_mib": now, "worker_peak_rss_mib": peak,
                   "finished_at": datetime.now(timezone.utc).isoformat(timespec="seconds")})
    return record


def _recommend(mesh: Any, row: Row) -> Any:
    """:func:`labcut.recommend_orientation` of a row: what a direct call with the row's settings returns."""
    from ..commands.recommend import recommend_orientation

    return recommend_orientation(mesh, **row.recommend_kwargs())


def _plain(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON")


# ---------------------------------------------------------------------- the report (runs on workers)
@dataclass(frozen=True)
class ReportGroup:
    """Rows a comparison report compares together: one material, quality and seed. ``cuts``: one
    row per distinct cut (its first); ``scenarios``: the distinct scenarios, catalogue order."""

    material_label: str
    quality: str
    seed: int
    cuts: tuple[Row, ...]
    names: tuple[str, ...]
    scenarios: tuple[str, ...]

    @property
    def label(self) -> str:
        return f"material {self.material_label}, {self.quality} quality, seed {self.seed}"


def _cut_identity(row: Row) -> tuple[Any, ...]:
    return (row.kind, row.path or json.dumps(row.cab, sort_keys=True), row.units, row.up_axis, row.size)


def report_groups(rows: list[Row]) -> list[ReportGroup]:
    """The comparisons a report over ``rows`` holds: rows grouped by material, quality and seed;
    in each, every cut under every scenario of the group (the grid: a cut the catalogue runs
    under fewer scenarios is compared under all of them too)."""
    from ..reports.cuts import unique_names

    groups: dict[tuple[Any, ...], list[Row]] = {}
    for r in rows:
        groups.setdefault((json.dumps(r.material.to_dict(), sort_keys=True), r.quality, r.seed), []).append(r)
    out = []
    for members in groups.values():
        cuts: dict[tuple[Any, ...], Row] = {}
        scenarios: list[str] = []
        for r in members:
            cuts.setdefault(_cut_identity(r), r)
            if r.scenario not in scenarios:
                scenarios.append(r.scenario)
        first = members[0]
        chosen = tuple(cuts.values())
        out.append(ReportGroup(first.material_label, first.quality, first.seed, chosen,
                               tuple(unique_names(c.name for c in chosen)), tuple(scenarios)))
    return out


def compare_cut(row: Row, name: str, scenarios: tuple[str, ...]) -> Any:
    """The comparison of one cut under ``scenarios`` (:func:`labcut.reports.compare.run_comparison`,
    the work of ``labcut compare`` for that cut): merged with the others' by :func:`merge_comparisons`."""
    import numpy as np

    from ..reports.compare import plan_comparison, run_comparison
    from ..reports.cuts import Cut

    if row.kind == "cabochon":
        cut: Any = (name, row.cut)
    else:
        mesh = row.load_mesh()
        ext = np.ptp(np.asarray(mesh.vertices, dtype=np.float64), axis=0)
        design = {"length_mm": float(ext[0]), "width_mm": float(ext[1]), "height_mm": float(ext[2])}
        cut = (name, Cut(name, mesh, "file", row.path, design))
    plan = plan_comparison([cut], row.material, list(scenarios), 0, row.quality, seed=row.seed)
    return run_comparison(plan)


def merge_comparisons(parts: list[Any]) -> Any:
    """One :class:`~labcut.reports.compare.Comparison` from single-cut comparisons of the same
    material, scenarios, quality and seed: as :func:`~labcut.reports.compare.run_comparison`
    finishes one, one exposure per scenario over every cut's renders, ranks and normalised values
    against the first cut (the reference), overall scores."""
    from ..reports.compare import Comparison, rank_and_normalise

    if not parts:
        raise ParameterError("a report needs at least one compared cut")
    cuts = [c for p in parts for c in p.cuts]
    scens = parts[0].scenarios
    exposures = rank_and_normalise(cuts, scens, 0)
    first = parts[0]
    return Comparison(cuts, list(scens), first.material, 0, first.quality, exposures, dict(first.render),
                      float(sum(p.seconds for p in parts)), first.tau, first.seed)


def report_paths(path: Path, count: int) -> list[Path]:
    """Where the reports of ``count`` groups go: ``path`` itself, then ``stem-2.html``, ..."""
    return [path] + [path.with_name(f"{path.stem}-{k}{path.suffix}") for k in range(2, count + 1)]


# ---------------------------------------------------------------------- the batch
@dataclass
class BatchResult:
    """What :func:`run` did. ``table``: the catalogue's records (``pyarrow.Table``, columns of
    :data:`labcut.batch.store.COLUMNS`, by row); ``ran``: rows computed now; ``skipped``: rows
    found in the store; ``failed``: rows stored with an error; ``seconds``: wall time of the
    whole run; ``startup_seconds``: starting the embedded cluster and setting up its workers
    (0 with a given client); ``workers``: what each worker's plugin set (host, threads, malloc trim threshold,
    variant, kernel cache); ``dashboard``: Dask's dashboard link, when it serves one;
    ``reports``: ``(path, group label)`` of each HTML report written."""

    store: Path
    catalog: Catalog
    table: Any
    ran: int
    skipped: int
    failed: int
    seconds: float
    startup_seconds: float
    workers: list[dict[str, Any]] = field(default_factory=list)
    dashboard: str | None = None
    reports: list[tuple[Path, str]] = field(default_factory=list)
    report_errors: list[str] = field(default_factory=list)

    @property
    def total(self) -> int:
        return len(self.catalog.rows)

    def records(self) -> list[dict[str, Any]]:
        """The catalogue's records as plain dicts (by row)."""
        return self.table.to_pylist()

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON summary (the CLI's ``--json``): counts, times, workers, reports, and per row its
        key, name, status, error and headline numbers (the store holds everything)."""
        from .. import __version__

        keep = ("row", "key", "name", "cut", "material", "scenario", "quality", "objective", "seed", "status", "error",
                "tilt_deg", "azimuth_deg", "description", "score", "flash_energy", "flash_area", "tolerance_deg",
                "seconds", "worker")
        rows = [{k: _finite(r.get(k)) for k in keep} for r in self.records()]
        return {"kind": "labcut.batch", "labcut_version": __version__, "catalogue": self.catalog.label,
                "results": str(self.store), "rows": self.total, "ran": self.ran, "skipped": self.skipped,
                "failed": self.failed, "seconds": self.seconds, "startup_seconds": self.startup_seconds,
                "workers": self.workers, "dashboard": self.dashboard,
                "reports": [{"path": str(p), "group": g} for p, g in self.reports], "report_errors": self.report_errors,
                "results_rows": rows}


def _finite(value: Any) -> Any:
    return None if isinstance(value, float) and not math.isfinite(value) else value


def default_workers(rows: int) -> int:
    """Workers of the embedded cluster: one per core, no more than there are rows to run (>= 1)."""
    from .plugin import cores

    return max(1, min(cores(), rows))


#: Dask's nanny starts each worker with ``MALLOC_TRIM_THRESHOLD_=65536`` (this config key), which
#: turns off glibc's adaptive mmap threshold: every NumPy temporary over 128 KiB is then mapped and
#: unmapped again, and a row runs 1.6-1.8x slower than without it (docs/batch.md,
#: "Throughput and memory"). The embedded cluster's workers start without it (None unsets it);
#: a variable set in the driver's environment is still inherited (as it is when a nanny of another
#: cluster in the same process has put Dask's value there: the CLI then warns).
TRIM_KEY = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"


@contextlib.contextmanager
def _client(client: Any, workers: int, node_cache: bool) -> Any:
    """Yield ``(client, embedded?, startup seconds)``: the given client, or a new LocalCluster."""
    start = time.perf_counter()
    if client is not None:
        if node_cache is None:  # auto: a cluster on more than this machine's loopback
            node_cache = not all(_is_loopback(a) for a in client.scheduler_info()["workers"])
        if node_cache and not all(client.run(_has_node_cache).values()):
            from .plugin import NodeKernelCache

            client.register_plugin(NodeKernelCache())  # restarts the workers once
        yield client, False, time.perf_counter() - start
        return
    import importlib.util
    import logging

    import dask
    from distributed import Client, LocalCluster

    env = {k: os.environ[k] for k in ("DRJIT_CACHE_DIR", "DRJIT_LIBLLVM_PATH", "LABCUT_BACKEND") if k in os.environ}
    has_dashboard = importlib.util.find_spec("bokeh") is not None
    with dask.config.set({TRIM_KEY: None}):  # read once by each nanny when created; a restarted worker gets the same
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, silence_logs=logging.ERROR,
                               dashboard_address=":0" if has_dashboard else None, env=env)
    try:
        with Client(cluster) as own:
            yield own, True, time.perf_counter() - start
    finally:
        with contextlib.suppress(Exception):
            cluster.close(timeout=30)


def _is_loopback(address: str) -> bool:
    host = address.split("://")[-1].rsplit(":", 1)[0].strip("[]")
    return host in ("localhost", "::1") or host.startswith("127.")


def _has_node_cache() -> bool:
    """Does this worker already use its machine's own kernel cache (:class:`NodeKernelCache`)?"""
    from .plugin import node_cache_dir

    return os.environ.get("DRJIT_CACHE_DIR") == node_cache_dir()


def run(
    catalog: Any,
    client: Any = None,
    *,
    out: str | os.PathLike[str] = "results.parquet",
    workers: int | None = None,
    material: Any = None,
    scenario: str = "bench",
    quality: str = "standard",
    objective: str = "energy",
    seed: int = 0,
    html: str | os.PathLike[str] | None = None,
    retry_failed: bool = False,
    threads_per_worker: int | None = None,
    node_cache: bool | None = None,
    progress: Callable[[int, int], None] | None = None,
    on_start: Callable[[dict[str, Any]], None] | None = None,
) -> BatchResult:
    """Run every row of a catalogue on Dask; stream the results to a Parquet store.

    Parameters
    ----------
    catalog: a CSV or YAML file, a list of rows (mappings column -> value) or a
        :class:`~labcut.batch.catalog.Catalog` (:mod:`labcut.batch.catalog` lists the columns).
        The whole catalogue is checked first: a bad one is a :class:`~labcut.batch.catalog.CatalogError`
        (a :class:`~labcut.errors.ParameterError`) before any work or cluster starts.
    client: a ``distributed.Client`` of a running cluster; None starts an embedded
        ``LocalCluster`` (processes, one task thread each) for the run and closes it after.
    out: the results folder (Parquet parts, :mod:`labcut.batch.store`).
    workers: workers of the embedded cluster (default: one per core, no more than rows to run);
        not allowed with ``client``.
    material, scenario, quality, objective, seed: what a row's empty cell means.
    html: write the comparison report of ``labcut compare`` over the rows that succeeded (one
        page per material, quality and seed: ``html``, then ``stem-2.html``, ...).
    retry_failed: run rows again that are stored with an error (default: skip them too).
    threads_per_worker: Dr.Jit threads of each worker (default: the machine's cores / its workers).
    node_cache: with ``client``, give each machine its own kernel cache folder (restarts the
        workers once, when they do not have it yet: :class:`~labcut.batch.plugin.NodeKernelCache`);
        None (default): when some worker is not on this machine's loopback address.
    progress: ``callback(done, total)`` over the rows to run (and the report's cuts).
    on_start: ``callback(info)`` once the cluster is up: ``dashboard``, ``workers``, ``to_run``, ``skipped``,
        ``startup_seconds`` (the cluster's start and the workers' set-up).

    Returns a :class:`BatchResult`. Ctrl-C (``KeyboardInterrupt``) stops the batch; every row
    finished before is already stored, and the same call again runs only the rest.
    """
    start = time.perf_counter()
    defaults = Defaults(material, scenario, quality, objective, seed)
    from ..orientation.scoring import OBJECTIVES
    from ..scene.quality import QUALITIES

    for name, value, choices in (("quality", quality, QUALITIES), ("objective", objective, OBJECTIVES)):
        if value not in choices:
            raise ParameterError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
    cat = read_catalog(catalog, defaults)
    if workers is not None:
        if client is not None:
            raise ParameterError("workers is the size of the embedded cluster; a given client (scheduler) brings its own workers")
        from ..validation import check_number

        workers = check_number(workers, "workers", 1, 4096, integer=True)
    if threads_per_worker is not None:
        from ..validation import check_number

        threads_per_worker = check_number(threads_per_worker, "threads per worker", 1, 4096, integer=True)
    html_path = None
    if html is not None:
        from ..fileio import check_output_path

        html_path = check_output_path(html, (".html", ".htm"))
    store = ResultStore(out)
    report = progress or (lambda done, total: None)

    with store.lock():
        stored = store.statuses()
        todo = [r for r in cat.rows if r.key not in stored or (retry_failed and stored[r.key] != "ok")]
        skipped = len(cat.rows) - len(todo)
        ran = 0
        report_errors: list[str] = []
        reports: list[tuple[Path, str]] = []
        dashboard = None
        info: list[dict[str, Any]] = []
        startup = 0.0
        needs_cluster = bool(todo) or html_path is not None
        try:
            with (_client(client, workers or default_workers(max(1, len(todo))), node_cache) if needs_cluster
                  else contextlib.nullcontext((None, False, 0.0))) as (cl, embedded, startup):
                if cl is not None:
                    info, setup_seconds = _set_up_workers(cl, threads_per_worker)
                    if embedded:
                        startup += setup_seconds
                    dashboard = _dashboard(cl)
                total = len(todo)
                if html_path is not None:
                    # the report's cuts are known only once the rows are done; count them from the plan
                    ok_now = [r for r in cat.rows if stored.get(r.key) == "ok" or r in todo]
                    total += sum(len(g.cuts) for g in report_groups(ok_now))
                if on_start is not None:
                    on_start({"dashboard": dashboard, "workers": info, "to_run": len(todo), "skipped": skipped,
                              "startup_seconds": startup})
                report(0, total)
                ran = _run_rows(cl, todo, store, lambda done: report(done, total)) if todo else 0
                if html_path is not None:
                    statuses = store.statuses()
                    groups = report_groups([r for r in cat.rows if statuses.get(r.key) == "ok"])
                    total = len(todo) + sum(len(g.cuts) for g in groups)
                    reports, report_errors = _write_reports(cl, groups, html_path, lambda done: report(len(todo) + done, total))
        finally:
            with contextlib.suppress(LabcutError):
                store.compact()
    table = _catalogue_table(store, cat)
    failed = sum(1 for s in table.column("status").to_pylist() if s != "ok")
    return BatchResult(store.path, cat, table, ran, skipped, failed, time.perf_counter() - start, startup, info, dashboard,
                       reports, report_errors)


def connect(address: str, timeout: float = 20.0) -> Any:
    """A ``distributed.Client`` of the running cluster whose scheduler listens at ``address``
    (``tcp://host:8786``); one where nothing listens (refused, unknown host, no route:
    :func:`_nothing_listens`, at once) or that does not answer in ``timeout`` seconds is a one-line
    :class:`~labcut.errors.ParameterError`."""
    from distributed import Client

    text = str(address).strip()
    if not text:
        raise ParameterError("the scheduler address is empty; give tcp://HOST:PORT (dask scheduler prints it)")
    refused = _nothing_listens(text, min(timeout, PROBE_SECONDS))
    if refused:
        raise ParameterError(f"cannot reach the Dask scheduler at {text!r} ({refused}); is `dask scheduler` running there?")
    try:
        return Client(text, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        detail = " ".join(str(exc).split()) or type(exc).__name__
        raise ParameterError(f"cannot reach the Dask scheduler at {text!r} within {timeout:g} s ({detail})") from None


#: how long :func:`connect`'s first look at a TCP address may wait (s): a refused or unroutable
#: address answers at once; one that stays silent is left to Dask's own connection timeout
PROBE_SECONDS = 3.0


def _nothing_listens(address: str, timeout: float) -> str | None:
    """Why nothing can answer at the TCP ``address`` (``tcp://host:port`` or ``host:port``), or None
    where something may: Dask's client retries a refused connection until its timeout runs out
    (20 s for an address mistyped by one digit), where the system says at once that no process
    listens there, that the host has no address or that no route leads to it. Other schemes
    (``tls://``, ``inproc://``, ``ucx://``) and a silent address (a firewall dropping the packets)
    are Dask's to judge."""
    import socket

    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        return None
    host, sep, port_text = rest.rstrip("/").rpartition(":")
    if not sep or not port_text.isdigit():
        return None  # Dask's parser words the error
    host = host.strip("[]") or "127.0.0.1"
    try:
        with socket.create_connection((host, int(port_text)), timeout=timeout):
            return None
    except ConnectionRefusedError:
        return f"nothing listens at port {port_text}: connection refused"
    except socket.gaierror as exc:
        return f"unknown host {host!r}: {exc.strerror or exc}"
    except TimeoutError:
        return None
    except OSError as exc:  # no route to host, network unreachable
        return " ".join(str(exc.strerror or exc).split()).lower()


def _set_up_workers(client: Any, threads: int | None) -> tuple[list[dict[str, Any]], float]:
    """Register :class:`~labcut.batch.plugin.LabcutWorkerPlugin` (every worker, now and later);
    return what each worker set up and the seconds that took."""
    from .plugin import LabcutWorkerPlugin, worker_info

    t0 = time.perf_counter()
    hosts: dict[str, int] = {}
    for address in client.scheduler_info(n_workers=-1)["workers"] if _takes_n_workers(client) else client.scheduler_info()["workers"]:
        host = address.split("://")[-1].rsplit(":", 1)[0]
        hosts[host] = hosts.get(host, 0) + 1
    client.register_plugin(LabcutWorkerPlugin(threads, hosts, warm=(__name__,)))
    info = client.run(worker_info)
    return [{"address": a, **v} for a, v in sorted(info.items())], time.perf_counter() - t0


def _takes_n_workers(client: Any) -> bool:
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters


def _dashboard(client: Any) -> str | None:
    """Dask's dashboard link, when the scheduler serves one (it needs bokeh installed there). A
    scheduler always has an HTTP server on its "dashboard" port (metrics, health), without the
    dashboard's pages (``/status`` is not found) unless bokeh's application is attached to it."""

    def serves_bokeh(dask_scheduler: Any) -> bool:  # on the scheduler; a local function: pickled by value
        try:
            from bokeh.server.tornado import BokehTornado
        except ImportError:
            return False
        app = getattr(dask_scheduler, "http_application", None)
        return any(isinstance(a, BokehTornado) for a in getattr(app, "applications", None) or [])

    try:
        served = "dashboard" in (client.scheduler_info().get("services") or {}) and client.run_on_scheduler(serves_bokeh)
        link = client.dashboard_link if served else None
    except Exception:  # no dashboard served
        return None
    return str(link) if link else None


def _run_rows(client: Any, rows: list[Row], store: ResultStore, done: Callable[[int], None]) -> int:
    """Submit the rows; store each as it finishes (the driver is the only writer, a key once)."""
    from distributed import as_completed

    import uuid

    token = uuid.uuid4().hex[:8]  # a run's own task keys: a cancelled run's tasks never answer for this one
    futures = {client.submit(run_row, row, key=f"labcut-row-{row.key}-{token}", pure=False): row for row in rows}
    written: set[str] = set()
    count = 0
    pending = set(futures)
    try:
        completed = as_completed(list(futures))
        for batch in completed.batches():
            records = []
            for fut in batch:
                pending.discard(fut)
                row = futures[fut]
                if row.key in written:
                    continue
                try:
                    record = fut.result()
                except Exception as exc:  # the worker died too often (KilledWorker), the task was lost
                    record = {**_base_record(row), "status": "error", "error": _one_line(exc),
                              "finished_at": datetime.now(timezone.utc).isoformat(timespec="seconds")}
                written.add(row.key)
                records.append(record)
                fut.release()
            store.write(records)
            count += len(records)
            done(count)
    finally:
        for fut in pending:  # interrupted: what has not finished is not waited for
            fut.cancel()
    return count


def _write_reports(client: Any, groups: list[ReportGroup], path: Path, done: Callable[[int], None]) -> tuple[list[tuple[Path, str]], list[str]]:
    """Compare each group's cuts on the workers, merge, write one HTML page per group."""
    from distributed import as_completed

    if not groups:
        return [], ["no row succeeded: there is nothing to compare"]
    jobs = {}
    for g, group in enumerate(groups):
        for c, (row, name) in enumerate(zip(group.cuts, group.names)):
            fut = client.submit(compare_cut, row, name, group.scenarios, key=f"labcut-compare-{g}-{c}-{row.key}", pure=False)
            jobs[fut] = (g, c)
    parts: dict[int, dict[int, Any]] = {g: {} for g in range(len(groups))}
    errors: list[str] = []
    count = 0
    for fut in as_completed(list(jobs)):
        g, c = jobs[fut]
        try:
            parts[g][c] = fut.result()
        except Exception as exc:
            errors.append(f"report: cut {groups[g].names[c]!r} ({groups[g].label}) left out: {_one_line(exc)}")
        fut.release()
        count += 1
        done(count)
    written = []
    for (g, group), target in zip(enumerate(groups), report_paths(path, len(groups))):
        found = [parts[g][c] for c in sorted(parts[g])]
        if not found:
            errors.append(f"report for {group.label}: no cut could be compared")
            continue
        merge_comparisons(found).save_html(target)
        written.append((target, group.label))
    return written, errors


def _catalogue_table(store: ResultStore, cat: Catalog) -> Any:
    import pyarrow as pa

    table = store.read()
    wanted = {r.key: r.index for r in cat.rows}
    keys = table.column("key").to_pylist()
    keep = [i for i, k in enumerate(keys) if k in wanted]
    table = table.take(pa.array(keep, type=pa.int64()))
    order = sorted(range(table.num_rows), key=lambda i: wanted[table.column("key")[i].as_py()])
    table = table.take(pa.array(order, type=pa.int64()))
    # the row numbers of this catalogue (a stored record may come from another catalogue's run)
    rows = [wanted[k] for k in table.column("key").to_pylist()]
    return table.set_column(table.schema.get_field_index("row"), "row", pa.array(rows, type=pa.int64()))


__all__ = ["BatchResult", "ReportGroup", "compare_cut", "connect", "default_workers", "merge_comparisons", "report_groups", "run",
           "run_row"]
