"""Option groups: a set of typer options declared once and handed to a command as one value.

A command declares one parameter (``material: Any = None``) where the group's options belong;
:func:`option_group` puts the options there in the signature typer reads, and calls the command
with the value ``build(**options)`` instead (built, and so checked, before the command's body
runs: a bad value is the usual one-line error). ``labcut_cli.materials.takes_material`` and
``labcut_cli.meshes.takes_mesh_options`` are the groups.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Sequence
from typing import Any


def option_group(param: str, options: Sequence[tuple[str, Any, Any]], build: Callable[..., Any]) -> Callable[[Any], Any]:
    """A decorator: replace the command parameter ``param`` by ``options`` ((name, typer annotation,
    default) each) and pass the command ``param=build(**values of the options)``."""

    def decorate(func: Any) -> Any:
        sig = inspect.signature(func, eval_str=True)  # real annotations: typer reads the Options in them
        if param not in sig.parameters:
            raise TypeError(f"{func.__name__} must declare a {param!r} parameter for its option group")
        params: list[inspect.Parameter] = []
        for name, p in sig.parameters.items():
            if name == param:
                params += [inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=d, annotation=a)
                           for n, a, d in options]
            else:
                params.append(p)

        @functools.wraps(func)
        def command(*args: Any, **kwargs: Any) -> Any:
            values = {n: kwargs.pop(n, d) for n, _, d in options}
            return func(*args, **{param: build(**values)}, **kwargs)

        annotations = {k: v for k, v in getattr(func, "__annotations__", {}).items() if k != param}
        annotations.update({n: a for n, a, _ in options})
        command.__annotations__ = annotations
        command.__signature__ = sig.replace(parameters=params)  # type: ignore[attr-defined]
        return command

    return decorate
