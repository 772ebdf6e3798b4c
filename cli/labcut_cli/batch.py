"""``labcut batch``: every row of a catalogue (CSV or YAML) on Dask, results streamed to Parquet.

The catalogue, the options and the output paths are checked before any cluster starts; a bad
one is one line on stderr and exit status 2. Rows already in the results (same key) are skipped;
a failing row is stored with its error and the batch goes on (exit status 1 at the end when any
row failed); Ctrl-C keeps every finished row. docs/batch.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.table import Table

from labcut.scene import SCENARIOS

from . import materials as m
from .root import app, check_outputs, console, err_console


def _short(value: float | None, fmt: str) -> str:
    return "–" if value is None else format(value, fmt)


def rows_table(result: Any, show: int) -> Table:
    """One line per row (the failed ones first when not all fit): status, orientation, energy, tolerance, time."""
    records = result.records()
    failed = [r for r in records if r["status"] != "ok"]
    ok = [r for r in records if r["status"] == "ok"]
    shown = records if len(records) <= show else (failed + ok)[:show]
    title = f"Rows ({len(shown)} of {len(records)}{', failed first' if len(shown) < len(records) and failed else ''})"
    table = Table(title=title, title_justify="left")
    for col, just in (("#", "right"), ("name", "left"), ("material", "left"), ("scenario", "left"), ("status", "left"),
                      ("lamellae", "left"), ("energy", "right"), ("tolerance", "right"), ("s", "right")):
        table.add_column(col, justify=just)  # type: ignore[arg-type]
    for r in sorted(shown, key=lambda r: r["row"]):
        if r["status"] == "ok":
            orient = "parallel" if r["parallel_within_deg"] is not None else f"{r['tilt_deg']:.0f}° az {r['azimuth_deg']:.0f}°"
            status = "[green]ok[/]"
        else:
            orient = r["error"] or ""
            status = "[red]failed[/]"
        table.add_row(str(r["row"]), r["name"], r["material"], Path(r["scenario"]).name, status, orient,
                      _short(r["flash_energy"], ".4f"), "–" if r["tolerance_deg"] is None else f"±{r['tolerance_deg']:.1f}°",
                      _short(r["seconds"], ".1f"))
    return table


def summary_table(result: Any) -> Table:
    """The batch in numbers: rows run, skipped, failed, times, workers."""
    table = Table(title="Batch", title_justify="left", show_header=False)
    table.add_column("what", style="bold")
    table.add_column("value")
    secs = [r["seconds"] for r in result.records() if r["status"] == "ok" and r["seconds"] is not None]
    table.add_row("rows", f"{result.total}: {result.ran} run now, {result.skipped} already stored, {result.failed} failed")
    table.add_row("wall time", f"{result.seconds:.1f} s (cluster start-up and worker set-up {result.startup_seconds:.1f} s)")
    if secs:
        table.add_row("per row", f"{sum(secs) / len(secs):.2f} s on average on a worker ({min(secs):.2f}-{max(secs):.2f} s)")
    if result.workers:
        hosts = sorted({w.get("host", "?") for w in result.workers})
        threads = sorted({w.get("threads") for w in result.workers if w.get("threads") is not None})
        table.add_row("workers", f"{len(result.workers)} on {', '.join(hosts)}, {'/'.join(map(str, threads))} Dr.Jit thread(s) each")
    table.add_row("results", str(result.store))
    for path, group in result.reports:
        table.add_row("report", f"{path} ({group})")
    return table


@app.command("batch")
def batch(
    ctx: typer.Context,
    catalog: Annotated[Path, typer.Argument(metavar="CATALOG", help="CSV or YAML catalogue: one cut per row (docs/batch.md).", show_default=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Results: a folder of Parquet parts (e.g. results.parquet); rows already there are skipped.", show_default=False)],
    html_path: Annotated[Optional[Path], typer.Option("--html", help="Write the comparison report (as labcut compare) over the rows that succeeded.")] = None,
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="Run on an existing Dask cluster: its scheduler's address, tcp://HOST:8786.")] = None,
    workers: Annotated[Optional[int], typer.Option("--workers", "-w", help="Workers of the embedded cluster (default: one per core, no more than rows).", min=1)] = None,
    threads: Annotated[Optional[int], typer.Option("--threads", help="Dr.Jit threads per worker (default: the machine's cores / its workers).", min=1)] = None,
    quality: Annotated[str, typer.Option(help="draft, standard or high: for rows that do not say.")] = "standard",
    objective: Annotated[str, typer.Option(help="energy, area, intensity or balanced: for rows that do not say.")] = "energy",
    scenario: Annotated[str, typer.Option("--scenario", "-s", help=f"For rows that do not say: {SCENARIOS.choices()}.")] = "bench",
    seed: Annotated[int, typer.Option(help="Surface-sampling seed for rows that do not say.", min=0)] = 0,
    preset: m.Preset = None,
    peak: m.Peak = None,
    material_file: m.MaterialFile = None,
    retry_failed: Annotated[bool, typer.Option("--retry-failed", help="Run rows again that are stored as failed.")] = False,
    node_cache: Annotated[Optional[bool], typer.Option("--node-cache/--no-node-cache", help="With --scheduler: give each machine its own Dr.Jit kernel cache, restarting the workers once (default: when the workers are not all on this machine).", show_default=False)] = None,
    show: Annotated[int, typer.Option("--show", help="Rows listed in the table at the end.", min=0)] = 30,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write a summary of the batch as JSON ('-' for stdout).")] = None,
) -> None:
    """Run a catalogue of cuts (x materials x scenarios) on Dask: each row's recommended lamella
    orientation, streamed to Parquet as rows finish; re-running skips rows already done."""
    from labcut.batch import Defaults, read_catalog
    from labcut.batch import connect, run
    from labcut.batch import ResultStore
    from labcut.errors import ParameterError

    from .meshes import print_warning
    from .progress import progress_bar
    from .root import write_json

    # every input is checked before a cluster starts
    if scheduler is not None and workers is not None:
        raise ParameterError("--workers sizes the embedded cluster; with --scheduler the cluster's own workers run the rows")
    check_outputs({"--html": (html_path, (".html", ".htm")), "--json": (json_path, (".json",))}, ctx)
    ResultStore(out)
    material = m.build_material(preset, peak, None, material_file) if (preset, peak, material_file) != (None, None, None) else None
    cat, notes = m.holding_warnings(lambda: read_catalog(catalog, Defaults(material, scenario, quality, objective, seed)))
    for note in notes:  # a material cell that peaks outside the visible: its rows, once per material
        print_warning(note)
    quiet = json_path == "-"

    def started(info: dict[str, Any]) -> None:
        if quiet:
            return
        where = "the Dask cluster at " + scheduler if scheduler else f"{len(info['workers'])} local worker(s)"
        kept = f"; {info['skipped']} already stored in {out}" if info["skipped"] else ""
        err_console.print(f"{info['to_run']} of {len(cat.rows)} row(s) to run on {where}{kept}", highlight=False)
        if info.get("dashboard"):
            err_console.print(f"Dask dashboard: {info['dashboard']}", highlight=False)

    client = connect(scheduler) if scheduler is not None else None
    try:
        # with --html the bar also counts the report's per-cut comparisons (run on the workers after the rows)
        with progress_bar("batch", "rows + report cuts" if html_path is not None else "rows") as update:
            result = run(cat, client, out=out, workers=workers, html=html_path, retry_failed=retry_failed,
                         threads_per_worker=threads, node_cache=node_cache, progress=update, on_start=started)
    except KeyboardInterrupt:
        stored = ResultStore(out).statuses() if Path(out).is_dir() else {}
        done = sum(1 for r in cat.rows if r.key in stored)
        err_console.print(f"[bold red]interrupted:[/] {done} of {len(cat.rows)} row(s) are stored in {out}; "
                          "run the same command again to finish the rest", highlight=False)
        raise typer.Exit(130) from None
    finally:
        if client is not None:
            client.close()

    if json_path is not None:
        write_json(json_path, result.to_dict())
    if not quiet:
        console.print(rows_table(result, show))
        console.print(summary_table(result))
        for line in result.report_errors:
            err_console.print(f"[bold yellow]warning:[/] {line}", highlight=False, soft_wrap=True)
        trimmed = sorted({str(w["malloc_trim_threshold"]) for w in result.workers if w.get("malloc_trim_threshold")})
        if trimmed:  # a cluster of the user's started with Dask's default (labcut.batch.runner.TRIM_KEY)
            err_console.print(f"[bold yellow]warning:[/] the workers run with MALLOC_TRIM_THRESHOLD_={'/'.join(trimmed)} "
                              "(Dask's nanny default), which makes rows 1.6-1.8x slower; docs/batch.md, "
                              "'On a real Dask cluster', shows the Dask config that unsets it", highlight=False, soft_wrap=True)
        if json_path is not None:
            console.print(f"summary JSON written to {json_path}")
    if result.failed:
        raise typer.Exit(1)
