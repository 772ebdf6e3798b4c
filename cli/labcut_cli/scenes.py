"""``labcut scenarios``: the scene vocabulary (scenarios, lighting and viewing presets)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from .root import app, check_outputs, console, write_json


@app.command("scenarios")
def scenarios(
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the presets as JSON ('-' for stdout).")] = None,
    studio_map: Annotated[Optional[Path], typer.Option("--studio-map", help="Write the procedural studio environment map (.exr).")] = None,
) -> None:
    """List the wear scenarios, lighting and viewing presets every command accepts."""
    from labcut.scene import LIGHTING, SCENARIOS, VIEWING

    check_outputs({"--json": (json_path, (".json",)), "--studio-map": (studio_map, (".exr",))})
    data = {
        kind: [{"name": e.name, "summary": e.summary} for e in registry.entries()]
        for kind, registry in (("scenarios", SCENARIOS), ("lighting", LIGHTING), ("viewing", VIEWING))
    }
    if studio_map is not None:
        from labcut.scene import studio_environment

        studio_environment().write(studio_map)
    if json_path is not None:
        write_json(json_path, data)
        if json_path == "-":
            return
    for kind, rows in data.items():
        table = Table(title=f"{kind} (--{'scenario' if kind == 'scenarios' else kind})")
        table.add_column("name", style="bold")
        table.add_column("what it means")
        for row in rows:
            table.add_row(row["name"], row["summary"])
        console.print(table)
    if studio_map is not None:
        console.print(f"studio map written to {studio_map}")
