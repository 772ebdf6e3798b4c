"""Lazy public names of a package: each is imported from its module on first access.

A package's ``__init__`` declares its public names as ``{name: "module:attribute"}`` with
modules of its own package; :func:`lazy_exports` gives it the module ``__getattr__``,
``__dir__`` and ``__all__`` (PEP 562). ``import labcut.scene`` or ``from labcut.geometry
import load_mesh`` then loads only what is used, and the public API of each package is one
list that a test checks the CLI against (``tests/test_public_api.py``).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, names: Mapping[str, str],
                 eager: tuple[str, ...] = ()) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """``(__getattr__, __dir__, __all__)`` of ``package`` whose lazy public ``names`` map to
    ``"module:attribute"`` (a module of ``package`` given relative, as ``".summary:check_angles"``,
    or absolute; no attribute: the module itself). ``eager``: public names the package defines
    itself (they join ``__all__``). A name is looked up in its module at every access, not copied
    into the package: what the module holds (a replaced or patched function too) is what the
    package gives."""
    targets = dict(names)

    def __getattr__(name: str) -> Any:
        target = targets.get(name)
        if target is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module_name, _, attr = target.partition(":")
        module = importlib.import_module(module_name, package if module_name.startswith(".") else None)
        return getattr(module, attr) if attr else module

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(targets))

    return __getattr__, __dir__, sorted([*eager, *targets])
