"""The public API is one list per namespace, and the CLI goes through it.

The CLI (``cli/labcut_cli``) imports labcut only from :data:`PUBLIC` namespaces and only the
names in their ``__all__``: the library's internal modules can move without the CLI noticing.
Each package's lazy public names point into the package itself (a string cannot hide an
import that runs up a layer), and every listed name resolves.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: the namespaces a front end may import from (docs/architecture.md, "The public API")
PUBLIC = ("labcut", "labcut.errors", "labcut.fileio", "labcut.hugepages", "labcut.validation", "labcut.planner", "labcut.scene",
          "labcut.geometry", "labcut.physics", "labcut.orientation", "labcut.rendering", "labcut.plots",
          "labcut.commands", "labcut.reports", "labcut.rough", "labcut.batch", "labcut.explorer")


def cli_imports() -> list[tuple[str, str, str, int]]:
    """(file, module, name, line) of every labcut import in the CLI's source (name "" for ``import m``)."""
    out = []
    for path in sorted((ROOT / "cli" / "labcut_cli").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").split(".")[0] == "labcut":
                out += [(path.name, node.module, a.name, node.lineno) for a in node.names]
            elif isinstance(node, ast.Import):
                out += [(path.name, a.name, "", node.lineno) for a in node.names if a.name.split(".")[0] == "labcut"]
    return out


def test_the_cli_imports_only_public_names():
    found = cli_imports()
    assert len(found) > 50  # the parse saw the CLI's imports
    bad = []
    for file, module, name, line in found:
        if module not in PUBLIC:
            bad.append(f"{file}:{line} imports from the internal module {module}")
        elif name and name != "__version__" and name not in importlib.import_module(module).__all__:
            bad.append(f"{file}:{line} imports {name}, not in {module}.__all__")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("namespace", PUBLIC)
def test_every_public_name_resolves(namespace):
    module = importlib.import_module(namespace)
    assert module.__all__ and len(set(module.__all__)) == len(module.__all__)
    for name in module.__all__:
        assert getattr(module, name) is not None, name
    assert set(module.__all__) <= set(dir(module))


@pytest.mark.parametrize("namespace", [n for n in PUBLIC if (ROOT / Path(*n.split("."))).is_dir() and n != "labcut"])
def test_lazy_names_point_into_their_own_package(namespace):
    module = importlib.import_module(namespace)
    targets = getattr(module, "_EXPORTS", {})
    for name, target in targets.items():
        assert target.startswith("."), f"{namespace}.{name} -> {target} leaves the package"
        value = getattr(module, name)
        owner = getattr(value, "__module__", None)
        if owner is not None and not isinstance(value, type(module)):
            assert owner.startswith(namespace), f"{namespace}.{name} comes from {owner}"


@pytest.mark.parametrize("namespace", [n for n in PUBLIC if (ROOT / Path(*n.split("."))).is_dir()])
def test_no_public_name_is_shadowed_by_a_module(namespace):
    """A listed name that is also a module of the package would turn into that module once the
    module is imported (``labcut.geometry.cabochon``): the name's value would depend on what ran before."""
    import pkgutil

    module = importlib.import_module(namespace)
    modules = {m.name for m in pkgutil.iter_modules(module.__path__)}
    for name in module.__all__:
        if name in modules:
            assert isinstance(getattr(module, name), type(module)), f"{namespace}.{name} is both a name and a module"


def test_a_lazy_name_is_what_its_module_holds_and_unknown_names_fail(monkeypatch):
    """A package's name is looked up in its module at each access (never a stale copy: a test that
    patches the module, and undoes it, leaves the package as it was)."""
    import labcut.commands as commands
    import labcut.commands.render as module
    import labcut.geometry as geometry
    from labcut.geometry import meshio

    assert geometry.load_mesh is meshio.load_mesh
    with monkeypatch.context() as m:
        m.setattr(module, "render_checked", "patched")
        assert commands.render_checked == "patched"
    assert commands.render_checked is module.render_checked and callable(commands.render_checked)
    assert "load_mesh" not in vars(geometry)
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        geometry.nothing_here  # noqa: B018
