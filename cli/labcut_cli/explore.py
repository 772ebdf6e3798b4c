"""``labcut explore``: the stone live in the browser (docs/explore.md)."""

from __future__ import annotations

import os
import sys
import webbrowser
from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from . import materials as m
from . import meshes as mo
from .root import app, console

#: seconds the worker may take to finish its step after Ctrl-C before the process ends anyway
STOP_SECONDS = 5.0


@app.command("explore")
@mo.takes_mesh_options
@m.takes_material
def explore(
    mesh_path: Annotated[Path, typer.Argument(metavar="MESH", help="Stone mesh: STL, OBJ, PLY, OFF, GLB/GLTF, 3MF, or a GemCad design.")],
    mesh_options: Any = None,  # --units, --up-axis, --size (meshes.takes_mesh_options)
    material: Any = None,  # the material options (materials.takes_material): the page's "given" material
    scenario: Annotated[str, typer.Option(help="The scenario the page starts with: a preset name (docs/scenarios.md).")] = "bench",
    quality: Annotated[str, typer.Option(help="draft, standard or high (where the page starts).")] = "standard",
    port: Annotated[int, typer.Option(help="Port to listen on (0: any free port).", min=0, max=65535)] = 0,
    host: Annotated[str, typer.Option(help="Address to listen on. The default serves this machine only; another "
                                           "address lets other machines on that network open the page.")] = "127.0.0.1",
    no_browser: Annotated[bool, typer.Option("--no-browser", help="Print the address; do not open a browser.")] = False,
    seed: Annotated[int, typer.Option(help="Seed of the surface sampling and the renders.", min=0)] = 0,
) -> None:
    """Explore MESH live in the browser: move the lamp, change the material, the dome or the lamella
    orientation and watch the score map, the flash metrics and the picture follow; "recommend here"
    answers as recommend-orientation does. Ctrl-C stops it."""
    from labcut.explorer import ExploreSession, serve

    mesh = mesh_options.load(mesh_path)
    session = ExploreSession(mesh, material, scenario, quality, seed=seed)

    def ready(explorer: Any) -> None:
        console.print(f"labcut explore: serving {mesh_path.name} at {explorer.url} (Ctrl-C stops)", highlight=False, soft_wrap=True)
        sys.stdout.flush()
        if not no_browser:
            try:
                webbrowser.open(explorer.url, new=2)
            except webbrowser.Error:
                console.print("no browser found: open the address above", highlight=False)

    explorer = serve(session, host, port, ready)
    console.print("labcut explore: stopped", highlight=False)
    explorer.worker.join(STOP_SECONDS)
    if explorer.worker.is_alive():  # inside a render kernel, which Python cannot stop: end the process
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
