"""Backend selection: which Mitsuba variant labcut runs on, and start-up checks.

* CUDA (``cuda_ad_*``) when a CUDA device works, else LLVM (``llvm_ad_*``); the
  environment variable ``LABCUT_BACKEND=llvm|cuda`` forces one.
* The colour mode (mono / rgb / spectral, optionally polarized) is the caller's
  choice: labcut never pays for spectral or polarized transport unless asked.
* Dr.Jit 1.5's LLVM backend aborts on libLLVM 14-16 (DESIGN.md §6). Dr.Jit loads
  ``DRJIT_LIBLLVM_PATH`` when the user sets it, else the newest libLLVM in the
  system's library folders (:data:`DRJIT_LLVM_GLOBS`, Dr.Jit's own search). At import,
  :func:`check_llvm` finds the library Dr.Jit will load and stops with
  :class:`~labcut.errors.LLVMVersionError` naming the fix when it is older than 17
  (and no CUDA device runs instead). labcut sets no environment variable: Dr.Jit's
  kernel cache is Dr.Jit's own (``~/.drjit``, or ``DRJIT_CACHE_DIR`` when set).

The check must run before ``drjit`` is imported, so this module imports neither
drjit nor mitsuba at import time.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import glob
import os
import re
from collections.abc import Callable, Iterator
from typing import Any, Generic, TypeVar

from .errors import BackendError, LLVMVersionError, ParameterError

MIN_LLVM = 17
MODES = ("mono", "rgb", "spectral")

#: where Dr.Jit 1.5 itself looks for libLLVM when ``DRJIT_LIBLLVM_PATH`` is unset (the pattern
#: compiled into libdrjit-core: ``/usr/lib/{x86_64-linux-gnu,aarch64-linux-gnu,wsl/lib}/libLLVM*.so.*``,
#: then ``libLLVM.so`` through the loader); it loads the newest
DRJIT_LLVM_GLOBS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so.*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so.*",
    "/usr/lib/wsl/lib/libLLVM*.so.*",
)
#: other folders where a libLLVM may be installed that Dr.Jit does not search: one found there is
#: named in the error, to be handed over with ``DRJIT_LIBLLVM_PATH``
OTHER_LLVM_GLOBS = (
    "/usr/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
    "/opt/homebrew/opt/llvm/lib/libLLVM*.dylib",
)
_LLVM_FIX = (
    "install Debian's libllvm19 ('sudo apt-get update && sudo apt-get install -y libllvm19', "
    "or run 'make setup'), or point DRJIT_LIBLLVM_PATH at a libLLVM >= 17"
)


def _llvm_major(path: str) -> int | None:
    """Major version encoded in a libLLVM file name (libLLVM-19.so, libLLVM.so.19.1)."""
    m = re.match(r"^libLLVM(?:-|\.so\.)?(\d+)", os.path.basename(path))
    return int(m.group(1)) if m else None


def _newest(patterns: tuple[str, ...]) -> tuple[int, str] | None:
    found: list[tuple[int, str]] = []
    for pattern in patterns:
        for path in glob.glob(pattern):
            major = _llvm_major(path)
            if major is not None:
                found.append((major, path))
    return max(found) if found else None


def find_libllvm() -> tuple[int, str] | None:
    """The libLLVM Dr.Jit will load, as ``(major, path)``, or None.

    ``DRJIT_LIBLLVM_PATH``, when the user sets it, is the only candidate; else the newest in
    :data:`DRJIT_LLVM_GLOBS`.
    """
    forced = os.environ.get("DRJIT_LIBLLVM_PATH")
    if forced:
        major = _llvm_major(forced)
        return (major if major is not None else MIN_LLVM, forced) if os.path.exists(forced) else None
    return _newest(DRJIT_LLVM_GLOBS)


#: the CUDA driver's library names, tried in turn by :func:`_cuda_driver_present`
_CUDA_DRIVER_NAMES = ("libcuda.so.1", "libcuda.so", "nvcuda.dll", "libcuda.dylib")


@functools.lru_cache(maxsize=1)
def _cuda_driver_present() -> bool:
    """Whether the CUDA driver library loads: the loader's own search, as Dr.Jit's, rather than
    ``ctypes.util.find_library``, which runs ``ldconfig -p`` and ``gcc`` as subprocesses at every
    start of a machine without CUDA."""
    for name in _CUDA_DRIVER_NAMES:
        try:
            ctypes.CDLL(name)
        except OSError:
            continue
        return True
    return False


def check_llvm() -> None:
    """Raise :class:`LLVMVersionError` when Dr.Jit's LLVM backend would abort.

    Cheap (a file-name scan); run at import. A machine with a CUDA driver passes,
    since labcut then runs on CUDA.
    """
    best = find_libllvm()
    if best is not None and best[0] >= MIN_LLVM:
        return
    if _cuda_driver_present():
        return
    have = f"libLLVM {best[0]}" if best else "no libLLVM"
    elsewhere = None if os.environ.get("DRJIT_LIBLLVM_PATH") else _newest(OTHER_LLVM_GLOBS)
    if elsewhere is not None and elsewhere[0] >= MIN_LLVM:
        raise LLVMVersionError(f"Dr.Jit 1.5 needs libLLVM >= {MIN_LLVM} but finds {have} in its own search; "
                               f"{elsewhere[1]} is libLLVM {elsewhere[0]}: set DRJIT_LIBLLVM_PATH={elsewhere[1]}")
    raise LLVMVersionError(f"Dr.Jit 1.5 needs libLLVM >= {MIN_LLVM} but this machine has {have}: {_LLVM_FIX}")


@functools.lru_cache(maxsize=1)
def device() -> str:
    """``"cuda"`` when a CUDA device works (or LABCUT_BACKEND=cuda), else ``"llvm"``."""
    forced = os.environ.get("LABCUT_BACKEND", "").strip().lower()
    if forced not in ("", "cuda", "llvm"):
        raise BackendError(f"LABCUT_BACKEND must be 'cuda' or 'llvm', not {forced!r}")
    import drjit as dr

    if forced != "llvm" and _cuda_driver_present():
        try:
            if dr.has_backend(dr.JitBackend.CUDA):
                return "cuda"
        except Exception:  # a broken driver is the same as none
            pass
        if forced == "cuda":
            raise BackendError("LABCUT_BACKEND=cuda but no CUDA device works on this machine")
    elif forced == "cuda":
        raise BackendError("LABCUT_BACKEND=cuda but no CUDA driver is installed")
    version = tuple(dr.detail.llvm_version())
    if version[0] < MIN_LLVM:
        raise LLVMVersionError(
            f"Dr.Jit loaded libLLVM {'.'.join(map(str, version))}, but needs >= {MIN_LLVM}: {_LLVM_FIX}"
        )
    return "llvm"


def variant_name(mode: str = "rgb", polarized: bool = False) -> str:
    """The Mitsuba variant for a colour mode on this machine, e.g. ``llvm_ad_rgb``."""
    if mode not in MODES:
        raise ParameterError(f"colour mode must be one of {', '.join(MODES)}, not {mode!r}")
    if polarized and mode == "rgb":
        raise ParameterError("polarized rendering needs mode 'mono' or 'spectral' (Mitsuba has no polarized rgb)")
    return f"{device()}_ad_{mode}" + ("_polarized" if polarized else "")


def set_variant(mode: str = "rgb", polarized: bool = False) -> str:
    """Select the Mitsuba variant for ``mode`` (CUDA if it works, else LLVM) and return its name."""
    import mitsuba as mi

    name = variant_name(mode, polarized)
    if mi.variant() != name:
        mi.set_variant(name)
    return name


def ad_types() -> tuple[Any, Any]:
    """``(drjit, types)``: Dr.Jit and its AD array types of the backend in use (``drjit.cuda.ad``
    when CUDA works, else ``drjit.llvm.ad``; :func:`device`)."""
    import drjit as dr

    return dr, (dr.cuda.ad if device() == "cuda" else dr.llvm.ad)


@functools.lru_cache(maxsize=1)
def _blas_controller() -> Any:
    """threadpoolctl's view of the BLAS libraries loaded (made once: it walks the loaded
    libraries), or None where threadpoolctl cannot load."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - a dependency of labcut
        return None
    return ThreadpoolController()


@contextlib.contextmanager
def serial_blas() -> Iterator[None]:
    """numpy's BLAS on one thread for the block: labcut's host work beside its Dr.Jit kernels.

    Dr.Jit's LLVM backend keeps a pool of worker threads on every core; OpenBLAS's own threads,
    woken for each of the small products a recommendation makes (the error bars' replicates, the
    facing tests), contend with them on few cores (the cost is measured by ``benchmarks/recommend_stages.py``,
    docs/performance.md). It also fixes the order of the products' sums, so a question's answer
    is the same bits whoever calls it (``tests/test_golden_answers.py``, ``tests/test_study.py``). The
    previous thread counts come back on leaving the block; nested blocks are fine."""
    controller = _blas_controller()
    if controller is None or not controller.select(user_api="blas").lib_controllers:
        yield
        return
    with controller.limit(limits=1, user_api="blas"):
        yield


F = TypeVar("F", bound=Callable[..., Any])


def with_serial_blas(func: F) -> F:
    """``func`` run inside :func:`serial_blas` (the public entry points that mix kernels and
    host products: a recommendation, an evaluation)."""
    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with serial_blas():
            return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


T = TypeVar("T")


class Launched(Generic[T]):
    """A result of Dr.Jit kernels already launched: Dr.Jit's LLVM launches return at once and the
    kernels run on its threads while the caller goes on (an optimiser's steps in numpy, the host's
    bootstrap); :attr:`value` waits for them the first time it is read, and keeps what they gave.

    >>> Launched.ready(3).value
    3
    """

    __slots__ = ("_read", "_value", "_done")

    def __init__(self, read: Callable[[], T]) -> None:
        self._read = read
        self._done = False
        self._value: Any = None

    @classmethod
    def ready(cls, value: T) -> Launched[T]:
        """A result already made (a call the kernels did not take)."""
        out: Launched[T] = cls(lambda: value)
        out._value, out._done, out._read = value, True, None
        return out

    @property
    def value(self) -> T:
        """The result, waited for once."""
        if not self._done:
            self._value, self._done, self._read = self._read(), True, None
        return self._value

    def __repr__(self) -> str:
        return f"Launched({'ready' if self._done else 'running'})"
