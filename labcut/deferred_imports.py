"""trimesh without the import time of the libraries it only sometimes uses.

``import trimesh`` imports scipy.spatial, scipy.sparse, scipy.optimize and networkx at the top
of its modules (``from scipy.spatial import cKDTree`` and the like, each in a ``try``), which is
0.3-0.5 s of every labcut process on 2 cores, most of a CLI call's import time, although a
recommendation for a convex cabochon uses only ``scipy.sparse.csgraph`` (for smooth shading) and
none of the others. :func:`install` (run by ``import labcut``) makes the *first* ``import
trimesh`` of the process bind those names to stand-ins instead:

- a stand-in module (:class:`_StubModule`) for each such library, whose attributes are
- :class:`_Deferred` objects: on first use (a call or an attribute) each imports the real library,
  puts the real objects in place of every stand-in of that library in trimesh's modules (so
  later calls are trimesh's own, at full speed), and forwards the use;
- an exception class that no code raises for an exception name (``QhullError``): trimesh catches
  it only around a call of that library, and that call has swapped the real class in before the
  ``except`` clause is read.

Only trimesh's own imports get stand-ins, and only while a process runs one Python thread: a
library that trimesh's import chain brings in, and anything but trimesh that reaches a stand-in
(through ``sys.modules`` while trimesh imports, or a module stand-in trimesh kept), gets the
real library, imported there and then.
After the import the stand-ins leave ``sys.modules`` (and their parent packages), so every
other ``import scipy.spatial``, labcut's own or a user's, gets the real library. Nothing changes
when trimesh or one of the libraries was imported before labcut (then it is the real thing),
for a trimesh release outside :data:`TESTED_TRIMESH`, or with ``LABCUT_EAGER_IMPORTS=1`` (a
switch for debugging). What differs from a plain import: a library that is installed but fails
to import fails at its first use rather than making trimesh drop the feature at import (the
same ImportError either way). ``tests/test_deferred_imports.py``
checks that the libraries stay unloaded, that each stand-in resolves to the real object, and that
trimesh's functions that use them give the same answers.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import os
import sys
import threading
import types
from typing import Any

#: libraries (with their submodules) that trimesh imports at the top of its modules but labcut
#: needs only on some paths; each is deferred only when it is installed and not yet imported
DEFERRED = ("scipy.spatial", "scipy.sparse", "scipy.optimize", "scipy.ndimage", "networkx")

#: trimesh releases whose imports this module has been checked against (tests/test_deferred_imports.py)
TESTED_TRIMESH = ("4.", "5.")

_lock = threading.RLock()
_stubs: dict[str, "_StubModule"] = {}  # module name -> its stand-in, while unresolved
_resolved: set[str] = set()  # roots (entries of DEFERRED) whose real library has been put in place
_state: dict[str, Any] = {"installed": False, "window": None}  # window: the ident of the thread importing trimesh


def _root(name: str) -> str | None:
    for root in DEFERRED:
        if name == root or name.startswith(root + "."):
            return root
    return None


def _is_exception_name(name: str) -> bool:
    return name.endswith(("Error", "Exception", "Warning"))


class _Deferred:
    """A name ``attr`` of the library module ``module``, imported when first used."""

    __slots__ = ("_module", "_attr", "__weakref__")

    def __init__(self, module: str, attr: str) -> None:
        object.__setattr__(self, "_module", module)
        object.__setattr__(self, "_attr", attr)

    def _target(self) -> Any:
        return _resolve_name(object.__getattribute__(self, "_module"), object.__getattribute__(self, "_attr"))

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self._target()(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._target(), name)

    def __instancecheck__(self, obj: Any) -> bool:  # isinstance(x, cKDTree) before the swap
        return isinstance(obj, self._target())

    def __subclasscheck__(self, cls: Any) -> bool:
        return issubclass(cls, self._target())

    def __repr__(self) -> str:
        return f"<deferred {object.__getattribute__(self, '_module')}.{object.__getattribute__(self, '_attr')}>"


class _StubModule(types.ModuleType):
    """Stand-in of a deferred library module during trimesh's import: every public name is a
    :class:`_Deferred` (or, for an exception name, a placeholder class)."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.__path__: list[str] = []  # a package, so ``import scipy.sparse.csgraph`` finds its own stand-in
        self._labcut_names: dict[str, Any] = {}

    def __getattr__(self, name: str) -> Any:
        if name == "_labcut_names":
            raise AttributeError(name)
        if not (_in_window() and _asked_by_trimesh(self.__name__)):
            # anyone but trimesh's import (another library, a later use of a module stand-in trimesh
            # kept, ``import networkx as nx``, a Cython cimport's ``__pyx_capi__``): the real thing
            return getattr(_resolve_module(self.__name__), name)
        if name.startswith("__"):
            raise AttributeError(name)  # the import system's probes while trimesh imports
        names = self.__dict__["_labcut_names"]
        if name not in names:
            if _is_exception_name(name):
                names[name] = type(name, (Exception,), {"__module__": __name__, "_labcut_deferred": (self.__name__, name)})
            else:
                names[name] = _Deferred(self.__name__, name)
        return names[name]


class _StubLoader(importlib.abc.Loader):
    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        stub = _StubModule(spec.name)
        _stubs[spec.name] = stub
        return stub

    def exec_module(self, module: types.ModuleType) -> None:
        return None


class _WindowFinder(importlib.abc.MetaPathFinder):
    """Hands out stand-ins for the deferred libraries while trimesh imports, and wraps the first
    ``import trimesh`` in that window."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if fullname == "trimesh" and _state["window"] is None and "trimesh" not in sys.modules:
            spec = importlib.machinery.PathFinder.find_spec(fullname, path)
            if spec is None or spec.loader is None or threading.active_count() > 1 or not _tested_trimesh():
                return None  # with other threads running, a plain import: none can meet a stand-in
            spec.loader = _TrimeshLoader(spec.loader)
            return spec
        if not _in_window() or not _asked_by_trimesh(fullname):
            return None
        root = _root(fullname)
        if root is None or root in _resolved or (root in sys.modules and not isinstance(sys.modules[root], _StubModule)):
            return None
        if fullname == root and not _installed(root):
            return None  # not installed: trimesh's own ImportError handling, as without labcut
        return importlib.machinery.ModuleSpec(fullname, _StubLoader(), is_package=True)


def _in_window() -> bool:
    """Whether this thread is importing trimesh now."""
    return _state["window"] == threading.get_ident()


def _asked_by_trimesh(fullname: str) -> bool:
    """Whether the import of ``fullname`` under way comes from one of trimesh's modules: the first
    frame up the stack outside the import machinery and outside ``fullname``'s parent packages
    (``from scipy import spatial`` goes through scipy's lazy ``__getattr__``)."""
    parents = {fullname.rsplit(".", k)[0] for k in range(1, fullname.count(".") + 1)}
    frame = sys._getframe(2)
    while frame is not None:
        code = frame.f_code.co_filename
        name = frame.f_globals.get("__name__", "")
        if not (code.startswith("<frozen importlib") or name in ("importlib", __name__) or name in parents):
            return name == "trimesh" or name.startswith("trimesh.")
        frame = frame.f_back
    return False


def _tested_trimesh() -> bool:
    try:
        from importlib.metadata import version

        return version("trimesh").startswith(TESTED_TRIMESH)
    except Exception:  # noqa: BLE001 - no metadata: do not defer
        return False


def _installed(name: str) -> bool:
    parent, _, leaf = name.rpartition(".")
    try:
        if parent:
            base = importlib.import_module(parent)  # scipy itself: light
            return importlib.machinery.PathFinder.find_spec(name, getattr(base, "__path__", None)) is not None
        return importlib.machinery.PathFinder.find_spec(name) is not None
    except Exception:  # noqa: BLE001 - cannot tell: do not defer
        return False


class _TrimeshLoader(importlib.abc.Loader):
    """trimesh's own loader, run with the stand-ins handed out; they leave ``sys.modules`` after."""

    def __init__(self, inner: importlib.abc.Loader) -> None:
        self._inner = inner

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> Any:
        return self._inner.create_module(spec)

    def exec_module(self, module: types.ModuleType) -> None:
        module.__loader__ = self._inner
        if module.__spec__ is not None:
            module.__spec__.loader = self._inner
        # no lock held here: another thread's imports are not this window's (:func:`_in_window`),
        # and another thread's ``import trimesh`` waits on the import system's own module lock
        _state["window"] = threading.get_ident()
        try:
            self._inner.exec_module(module)
        finally:
            _state["window"] = None
            with _lock:
                for name in list(_stubs):
                    _unlist(name)


def _unlist(name: str) -> None:
    """Take the stand-in ``name`` out of ``sys.modules`` and out of its parent package."""
    stub = _stubs.get(name)
    if sys.modules.get(name) is stub and stub is not None:
        del sys.modules[name]
    parent, _, leaf = name.rpartition(".")
    owner = sys.modules.get(parent) if parent else None
    if owner is not None and stub is not None and owner.__dict__.get(leaf) is stub:
        delattr(owner, leaf)


def _resolve_module(module: str) -> types.ModuleType:
    """The real library module ``module``, after its library is put in place in trimesh."""
    root = _root(module)
    with _lock:
        if root is not None and root not in _resolved:
            _resolve_root(root)
    return importlib.import_module(module)


def _resolve_name(module: str, attr: str) -> Any:
    """The real ``module.attr``, after the real library of ``module`` is put in place in trimesh."""
    real = _resolve_module(module)
    try:
        return getattr(real, attr)
    except AttributeError:
        try:
            return importlib.import_module(f"{module}.{attr}")  # ``from scipy.sparse import csgraph``
        except ModuleNotFoundError:
            raise ImportError(f"cannot import name {attr!r} from {module!r}") from None


def _resolve_root(root: str) -> None:
    """Import the real ``root`` library and swap it in for its stand-ins in trimesh's modules."""
    mine = {n: s for n, s in _stubs.items() if _root(n) == root}
    for name in mine:
        _unlist(name)
    _resolved.add(root)
    replacements: dict[int, Any] = {}
    for name, stub in mine.items():
        real = importlib.import_module(name)
        replacements[id(stub)] = real
        for attr, value in stub.__dict__["_labcut_names"].items():
            try:
                replacements[id(value)] = getattr(real, attr)
            except AttributeError:
                try:
                    replacements[id(value)] = importlib.import_module(f"{name}.{attr}")
                except ImportError:
                    continue  # the real library lacks it: the stand-in keeps raising as trimesh's wrapper would
        del _stubs[name]
    if not replacements:
        return
    spaces = []
    for mod_name, mod in list(sys.modules.items()):
        if (mod_name == "trimesh" or mod_name.startswith("trimesh.")) and isinstance(getattr(mod, "__dict__", None), dict):
            spaces.append(mod.__dict__)
    # exception classes first: a thread that meets a real function already swapped in finds its
    # real exception class there too (``except QhullError`` around ``ConvexHull``)
    for exceptions_first in (True, False):
        for space in spaces:
            for key, value in list(space.items()):
                real = replacements.get(id(value))
                if real is not None and _is_exception_class(real) == exceptions_first:
                    space[key] = real
    for space in spaces:  # annotations trimesh evaluated at import (``-> cKDTree``), for whoever reads them
        for value in list(space.values()):
            kind = type(value)  # the real type: trimesh's ExceptionWrapper raises on any attribute
            if kind is types.FunctionType:
                _swap_annotations(value.__annotations__, replacements)
            elif issubclass(kind, type) and value.__module__ == space.get("__name__"):
                _swap_annotations(vars(value).get("__annotations__"), replacements)
                for member in list(vars(value).values()):
                    for fn in (member, getattr(member, "fget", None), getattr(member, "__func__", None)) if not isinstance(member, _Deferred) else ():
                        if type(fn) is types.FunctionType:
                            _swap_annotations(fn.__annotations__, replacements)


def _is_exception_class(value: Any) -> bool:
    return isinstance(value, type) and issubclass(value, BaseException)


def _swap_annotations(notes: Any, replacements: dict[int, Any]) -> None:
    if isinstance(notes, dict):
        for key, value in list(notes.items()):
            real = replacements.get(id(value))
            if real is not None:
                notes[key] = real


def pending() -> list[str]:
    """The deferred libraries whose stand-ins are still in trimesh's modules (each is swapped
    out at its first use through trimesh, whether or not something else imported it meanwhile)."""
    return sorted({r for r in (_root(n) for n in _stubs) if r is not None and r not in _resolved})


def install() -> None:
    """Defer the libraries of :data:`DEFERRED` in the first ``import trimesh`` of the process
    (idempotent; nothing when trimesh is already imported or ``LABCUT_EAGER_IMPORTS=1``)."""
    if _state["installed"] or "trimesh" in sys.modules or os.environ.get("LABCUT_EAGER_IMPORTS", "") not in ("", "0"):
        return
    _state["installed"] = True
    sys.meta_path.insert(0, _WindowFinder())
