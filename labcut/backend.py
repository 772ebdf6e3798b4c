"""Backend selection: which Mitsuba variant labcut runs on, and start-up checks.

* CUDA (``cuda_ad_*``) when a CUDA device works, else LLVM (``llvm_ad_*``); the
  environment variable ``LABCUT_BACKEND=llvm|cuda`` forces one.
* The colour mode (mono / rgb / spectral, optionally polarized) is the caller's
  choice: labcut never pays for spectral or polarized transport unless asked.
* Dr.Jit 1.5's LLVM backend aborts on libLLVM 14-16 (DESIGN.md §6). At import,
  :func:`configure_environment` points Dr.Jit at the newest libLLVM >= 17 and
  :func:`check_llvm` stops with :class:`~labcut.errors.LLVMVersionError` naming
  the fix when there is none (and no CUDA device to run on instead).
* Dr.Jit's on-disk kernel cache lives in a per-user cache directory
  (``~/.cache/labcut/drjit`` on Linux) unless ``DRJIT_CACHE_DIR`` is set.

Both environment variables must be set before ``drjit`` is imported, so this
module imports neither drjit nor mitsuba at import time.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import glob
import os
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

from .errors import BackendError, LLVMVersionError, ParameterError

MIN_LLVM = 17
MODES = ("mono", "rgb", "spectral")

_LLVM_GLOBS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
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


def find_libllvm() -> tuple[int, str] | None:
    """Newest libLLVM on the system as ``(major, path)``, or None.

    ``DRJIT_LIBLLVM_PATH``, when set by the user, is taken as the only candidate.
    """
    forced = os.environ.get("DRJIT_LIBLLVM_PATH")
    if forced and os.environ.get("_LABCUT_SET_LIBLLVM") != forced:
        major = _llvm_major(forced)
        return (major if major is not None else MIN_LLVM, forced) if os.path.exists(forced) else None
    found: list[tuple[int, str]] = []
    for pattern in _LLVM_GLOBS:
        for path in glob.glob(pattern):
            major = _llvm_major(path)
            if major is not None:
                found.append((major, path))
    return max(found) if found else None


#: the CUDA driver's library names, tried in turn by :func:`_cuda_driver_present`
_CUDA_DRIVER_NAMES = ("libcuda.so.1", "libcuda.so", "nvcuda.dll", "libcuda.dylib")


@functools.lru_cache(maxsize=1)
def _cuda_driver_present() -> bool:
    """Whether the CUDA driver library loads: the loader's own search, as Dr.Jit's, which takes
    microseconds where ``ctypes.util.find_library`` runs ``ldconfig -p`` and ``gcc`` (10-20 ms
    and two subprocesses at every start of a machine without CUDA)."""
    for name in _CUDA_DRIVER_NAMES:
        try:
            ctypes.CDLL(name)
        except OSError:
            continue
        return True
    return False


def configure_environment() -> None:
    """Set Dr.Jit's kernel cache and libLLVM before drjit is imported (idempotent)."""
    if "DRJIT_CACHE_DIR" not in os.environ:
        from platformdirs import user_cache_dir

        cache = Path(user_cache_dir("labcut")) / "drjit"
        try:
            cache.mkdir(parents=True, exist_ok=True)
            os.environ["DRJIT_CACHE_DIR"] = str(cache)
        except OSError:
            pass  # read-only home: Dr.Jit falls back to its own default
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        best = find_libllvm()
        if best is not None and best[0] >= MIN_LLVM:
            os.environ["DRJIT_LIBLLVM_PATH"] = best[1]
            os.environ["_LABCUT_SET_LIBLLVM"] = best[1]


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
    libraries, about 3 ms), or None where threadpoolctl cannot load."""
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
    facing tests), contend with them, and a standard recommendation on 2 cores took 10-20 ms
    longer with them than without (``benchmarks/recommend_stages.py``, docs/performance.md). The
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
