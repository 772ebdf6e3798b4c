"""The layers hold: no module imports a layer above its own (docs/architecture.md).

    errors → backend, fileio → physics, colour → geometry, scene
           → orientation, rendering, plots (compute) → planner, timing, budgets (decide)
           → commands (recommend, evaluate, render, animate) → study → reports → batch
           → the CLI (labcut_cli)

A module may import its own layer and any below. Imports are read from the source
(every ``import`` and ``from ... import``, including those inside functions), so a lazy
import cannot hide a cycle. ``labcut/__init__.py`` is the facade and exempt.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "labcut"

LAYERS: list[tuple[str, ...]] = [
    ("labcut.errors", "labcut.validation", "labcut._exports"),
    ("labcut.backend", "labcut.fileio", "labcut.hugepages"),
    ("labcut.physics", "labcut.colour"),
    ("labcut.geometry", "labcut.scene"),
    # what computes and decides nothing: the flash problem, its kernels and scorer, the answer's
    # steps, the render estimator; the renderer (plans, scenes, passes), rays, plots
    ("labcut.orientation", "labcut.rendering", "labcut.plots"),
    # what decides: the effect planner, its predictions and their calibrations' runs
    ("labcut.planner",),
    # the commands: recommend, evaluate, render, animate, and the time budgets they fit into
    ("labcut.commands",),
    ("labcut.study",),
    ("labcut.reports", "labcut.rough"),
    ("labcut.batch", "labcut.explorer"),
]


#: a short name for each layer (docs/architecture.md and its figure)
LAYER_NAMES = ["errors · validation", "backend · fileio", "physics · colour", "geometry · scene",
               "orientation · rendering · plots", "planner", "commands · budgets", "study", "reports · rough", "batch · explorer"]


def layer_of(module: str) -> int | None:
    """The layer of a module: of the longest entry of :data:`LAYERS` that names it or a package above it."""
    best: tuple[int, int] | None = None  # (length of the entry, layer)
    for k, names in enumerate(LAYERS):
        for n in names:
            if (module == n or module.startswith(n + ".")) and (best is None or len(n) > best[0]):
                best = (len(n), k)
    return None if best is None else best[1]


def is_module(name: str) -> bool:
    """Whether ``name`` is a module or package of labcut's source tree."""
    rel = Path(*name.split("."))
    return (ROOT / rel.with_suffix(".py")).exists() or (ROOT / rel / "__init__.py").exists()


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports(path: Path) -> list[tuple[str, int]]:
    """(absolute module name, line) of every import in a source file."""
    tree = ast.parse(path.read_text(), str(path))
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            subs = [f"{target}.{alias.name}" for alias in node.names if is_module(f"{target}.{alias.name}")]
            # "from . import bsdf" imports the submodule (its package's facade is not what it uses);
            # "from .x import name" imports x
            out += [(sub, node.lineno) for sub in subs]
            if len(subs) < len(node.names):
                out.append((target, node.lineno))
    return out


SOURCES = sorted(p for p in PACKAGE.rglob("*.py") if p != PACKAGE / "__init__.py")


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_import_runs_up_the_layers(path):
    own = layer_of(module_name(path))
    assert own is not None, f"{module_name(path)} is in no layer: add it to LAYERS (and docs/architecture.md)"
    for target, line in imports(path):
        if target.startswith("labcut_cli"):
            pytest.fail(f"{path.relative_to(ROOT)}:{line} imports the CLI ({target})")
        k = layer_of(target)
        if k is not None and k > own:
            pytest.fail(f"{path.relative_to(ROOT)}:{line} imports {target} (layer {k}) from layer {own}")


def test_the_checker_sees_a_violation(tmp_path):
    """The contract test itself can fail: a physics module importing rendering is caught."""
    fake = PACKAGE / "physics" / "_layer_probe.py"
    assert not fake.exists()
    try:
        fake.write_text("from ..rendering import api\n")
        found = [t for t, _ in imports(fake) if (layer_of(t) or 0) > layer_of("labcut.physics")]
        assert found
    finally:
        fake.unlink()


def private_imports(path: Path) -> list[tuple[str, int]]:
    """``module.name`` and line of every private name (``_x``, not a dunder) a source file imports
    from another labcut module (``from .x import _helper``): a helper used across modules is public."""
    tree = ast.parse(path.read_text(), str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__") and (node.level or
                                                                                       (node.module or "").startswith("labcut")):
                    out.append((f"{node.module or '.'}.{alias.name}", node.lineno))
    return out


CLI_SOURCES = sorted((ROOT / "cli" / "labcut_cli").rglob("*.py"))


@pytest.mark.parametrize("path", SOURCES + CLI_SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_helper_crosses_modules(path):
    found = private_imports(path)
    assert not found, f"{path.relative_to(ROOT)} imports private names of other modules: {found}"


def test_the_private_import_checker_sees_one():
    fake = PACKAGE / "physics" / "_private_probe.py"
    assert not fake.exists()
    try:
        fake.write_text("def f():\n    from ..geometry.meshio import _secret\n    from .. import __version__\n")
        assert private_imports(fake) == [("geometry.meshio._secret", 2)]
    finally:
        fake.unlink()
