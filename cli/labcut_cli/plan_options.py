"""The effect planner's options, shared by ``render``, ``recommend-orientation``,
``evaluate-orientation`` and ``compare`` (docs/planner.md): ``--plan``, ``--plan-only``,
``--estimator`` and ``--effect NAME=on|off``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Optional

import typer

from labcut.scene import ESTIMATORS, SWITCHABLE

Plan = Annotated[bool, typer.Option("--plan", help="Print the effect plan first: which effects are simulated, how, why, and the predicted time.")]
PlanOnly = Annotated[bool, typer.Option("--plan-only", help="Print the effect plan (and write it with --json) and exit without running.")]
Estimator = Annotated[str, typer.Option(
    "--estimator", help=f"Flash estimator: {', '.join(ESTIMATORS)} (auto: the planner chooses; samples: surface samples; "
                        "volume: surface samples with the light carried through the stone, mirrored below the surface and leaving elsewhere; "
                        "render: Mitsuba renders optimised with Dr.Jit gradients, carries light between the parts of a carving).")]
Effect = Annotated[Optional[list[str]], typer.Option(
    "--effect", help=f"Override the planner: NAME=on|off for {', '.join(x.replace('_', '-') for x in SWITCHABLE)} (repeatable).")]


@dataclass(frozen=True)
class PlanRequest:
    """The planner's options of a command: ``--estimator``, ``--effect`` (as given), ``--plan``, ``--plan-only``."""

    estimator: str = "auto"
    effect: Optional[list[str]] = None
    plan: bool = False
    plan_only: bool = False


def takes_plan_options(func: Any) -> Any:
    """Give a typer command ``--estimator``, ``--effect``, ``--plan`` and ``--plan-only`` once: the
    command declares ``plan_options: Any = None`` and receives a :class:`PlanRequest`."""
    from .groups import option_group

    return option_group("plan_options", (("estimator", Estimator, "auto"), ("effect", Effect, None), ("plan", Plan, False),
                                         ("plan_only", PlanOnly, False)), PlanRequest)(func)


def check(estimator: str, effect: list[str] | None) -> dict[str, bool]:
    """Validate ``--estimator`` and parse ``--effect`` before any work (one-line errors)."""
    from labcut.errors import ParameterError
    from labcut.scene import parse_effects

    if estimator not in ESTIMATORS:
        raise ParameterError(f"--estimator must be one of {', '.join(ESTIMATORS)}, got {estimator!r}")
    return parse_effects(effect)


def show(plan: Any, subject: str, *, to_stderr: bool = False) -> None:
    """Print the plan: one line per effect, then the estimator and the predicted seconds of each
    choice (recommend, evaluate: each estimator; compare: the samples' recommendation of the cut;
    render: the render, at the size the plan names)."""
    from rich.markup import escape

    from .root import console, err_console

    out = err_console if to_stderr else console
    out.print(f"[bold]Effect plan[/] ({plan.command}, {escape(subject)}):", highlight=False)
    for line in plan.lines():
        out.print("  " + escape(line), highlight=False, soft_wrap=True)


def finish_plan_only(plan: Any, json_path: str | None) -> None:
    """``--plan-only``: write the plan as the JSON (``{"plan": ...}``) when asked, then stop."""
    import json

    from .root import write_json

    data = {"plan": plan.to_dict()}
    if json_path == "-":
        typer.echo(json.dumps(data, indent=2, allow_nan=False))
    elif json_path is not None:
        write_json(json_path, data)
