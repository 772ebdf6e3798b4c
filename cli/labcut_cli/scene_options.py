"""Scene options shared by every command that scores or renders a stone: one vocabulary.

The help texts list the names of :mod:`labcut.scene`'s registries, the same names its
error messages and docs/scenarios.md use.
"""

from __future__ import annotations

from typing import Annotated, Any, Optional

import typer

from labcut.scene import LIGHTING, VIEWING
from labcut.scene import SCENARIOS

Scenario = Annotated[
    Optional[str],
    typer.Option(help=f"How the stone is lit, worn and seen: {SCENARIOS.choices()} (default: bench)."),
]
Lighting = Annotated[
    Optional[str],
    typer.Option(help=f"Replace the scenario's lights: {LIGHTING.choices()}."),
]
Viewing = Annotated[
    Optional[str],
    typer.Option(help=f"Replace the scenario's viewers: {VIEWING.choices()}."),
]


def resolve(scenario: str | None, lighting: str | None, viewing: str | None, quality: str = "standard") -> Any:
    """The :class:`labcut.Scenario` of a command's options (validated before any work starts)."""
    from labcut.scene import resolve_scene
    from labcut.scene import QUALITIES

    return resolve_scene(scenario, lighting, viewing, quality if quality in QUALITIES else "standard")
