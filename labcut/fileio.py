"""Output files that are never left half-written.

Every file labcut writes (PNG, EXR, JSON, meshes) goes through :func:`atomic_output`:
the writer fills a temporary file next to the target, which replaces the target
only once the writer has finished without error. A failure leaves no partial file.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from .errors import CacheWarning, LabcutError, OutputError, ParameterError

__all__ = ["atomic_output", "cache_path", "cached_array", "cache_problem", "cached_arrays", "distinct_outputs", "calibration", "check_output_path", "check_outputs", "code_hash", "compute_platform", "read_cache", "read_json", "write_cache"]


def check_output_path(path: str | os.PathLike[str], suffixes: tuple[str, ...] | None = None, *, probe: bool = True) -> Path:
    """Validate an output path before any work: its folder exists, its suffix is allowed (when
    ``suffixes`` is given), an existing target is a regular file, and (``probe``) a file can really be
    created in its folder, so a read-only or virtual folder (``/proc``) fails now, not after the work.
    """
    out = Path(path)
    if out.name == "" or out.is_dir():
        raise ParameterError(f"output path {str(path)!r} is a folder, not a file name")
    if not out.parent.exists() and str(out.parent) != "":
        raise ParameterError(f"output folder {str(out.parent)!r} does not exist")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        raise ParameterError(f"output file {out.name!r} must end in one of {', '.join(suffixes)}")
    if out.exists() and not out.is_file():  # a device or a pipe: replacing it would remove it
        raise ParameterError(f"output path {str(path)!r} exists and is not a regular file")
    if probe:
        try:
            fd, name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=".probe", dir=out.parent or ".")
        except OSError as exc:
            raise OutputError(f"cannot write {str(out)!r}: {exc.strerror or exc}") from None
        os.close(fd)
        os.unlink(name)
    return out


def check_outputs(outputs: dict[str, tuple[Any, tuple[str, ...] | None]],
                  inputs: dict[str, Any] | None = None) -> None:
    """Check every output of a call before its work starts: each path as :func:`check_output_path`
    does, none named twice (:func:`distinct_outputs`) and none the same file as an input.

    ``outputs``: ``{option: (path or None, allowed suffixes)}``; ``"-"`` (standard output) and None
    are skipped. ``inputs``: ``{option or argument name: path or None}``, the files the call reads.
    """
    distinct_outputs({option: path for option, (path, _) in outputs.items()})
    read = {_same_file_key(p): name for name, p in (inputs or {}).items() if p is not None and str(p) != "-"}
    for option, (path, suffixes) in outputs.items():
        if path is None or str(path) == "-":
            continue
        if _same_file_key(path) in read:
            raise ParameterError(f"{option} {path} is also the input {read[_same_file_key(path)]}: writing it would "
                                 "replace what is being read; give the output its own path")
        try:
            check_output_path(path, suffixes)
        except ParameterError as exc:  # name the option: a command may write several files
            raise ParameterError(f"{option}: {exc}") from None


def _same_file_key(path: Any) -> Path:
    """A key under which two spellings of one file compare equal (relative, ``~``, symbolic links)."""
    return Path(os.path.realpath(os.path.expanduser(str(path))))


def distinct_outputs(outputs: dict[str, Any]) -> None:
    """Raise :class:`~labcut.errors.ParameterError` when two of ``outputs`` (``{option: path or
    None}``; ``"-"``, standard output, is never a file) name the same file: one would silently
    replace the other."""
    seen: dict[Path, str] = {}
    for option, path in outputs.items():
        if path is None or str(path) == "-":
            continue
        key = _same_file_key(path)
        if key in seen:
            raise ParameterError(f"{seen[key]} and {option} name the same file ({path}): give each output its own path")
        seen[key] = option


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], suffixes: tuple[str, ...] | None = None) -> Iterator[Path]:
    """Yield a temporary path with the target's suffix; move it onto ``path`` on success.

    A writer that fails with an I/O error (``OSError``, or the ``RuntimeError`` Mitsuba raises)
    becomes an :class:`~labcut.errors.OutputError` whose one-line message names ``path``, the
    user's file, never the temporary one.

    >>> with atomic_output("plot.png") as tmp:
    ...     figure.savefig(tmp)
    """
    out = check_output_path(path, suffixes, probe=False)
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=out.suffix, dir=out.parent or ".")
    except OSError as exc:
        raise OutputError(f"cannot write {str(out)!r}: {exc.strerror or exc}") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600: give the file the usual permissions
        os.replace(tmp, out)
    except LabcutError:
        raise
    except (OSError, RuntimeError) as exc:
        detail = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        detail = " ".join(detail.replace(str(tmp), str(out)).replace(tmp.name, out.name).split())
        raise OutputError(f"cannot write {str(out)!r}: {detail}") from None
    finally:
        if tmp.exists():
            tmp.unlink()


def read_json(path: str | os.PathLike[str], what: str) -> Any:
    """Parse a JSON file; a missing or unreadable file is a one-line :class:`ParameterError`
    that names ``what`` the file was meant to be (e.g. "material file")."""
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ParameterError(f"{what} {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ParameterError(f"{what} {str(path)!r} is not readable JSON ({str(exc).splitlines()[0]})") from None


def cache_path(name: str) -> Path:
    """A file in labcut's user cache folder (beside Dr.Jit's kernel cache): calibrations and
    measurements kept between runs (``platformdirs.user_cache_dir("labcut")``)."""
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("labcut")) / name


#: the cache problems this process has warned of (:func:`cache_problem`): each once
_CACHE_WARNED: set[str] = set()


def cache_problem(path: str | os.PathLike[str], detail: str, *, unwritable: bool = False) -> None:
    """Warn, once per process for each file (each folder, ``unwritable``), that labcut's user cache
    is damaged or cannot be written: the cache is only ever a saving, so the work goes on (what the
    file held is computed again; what could not be written is computed again next run), and one
    :class:`~labcut.errors.CacheWarning` (a :class:`~labcut.errors.LabcutWarning`) says so."""
    import warnings

    where = Path(path).parent if unwritable else Path(path)
    if str(where) in _CACHE_WARNED:
        return
    _CACHE_WARNED.add(str(where))
    detail = " ".join(str(detail).split())
    if unwritable:
        text = (f"labcut's cache folder {where} cannot be written ({detail}): nothing is kept for the next run, "
                "which computes it again")
    else:
        text = f"labcut's cache file {where} is damaged ({detail}): ignored, and what it held is computed again"
    warnings.warn(text, CacheWarning, stacklevel=3)


def read_cache(path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The JSON object a cache file holds, or None when it is missing (then the caller measures
    again); a file that cannot be read or holds no JSON object is None too, with one warning
    (:func:`cache_problem`)."""
    p = Path(path)
    if not p.exists():
        return None
    try:
        data = json.loads(p.read_text())
    except (OSError, ValueError) as exc:
        cache_problem(p, exc.strerror if isinstance(exc, OSError) and exc.strerror else "not JSON")
        return None
    if not isinstance(data, dict):
        cache_problem(p, "not a JSON object")
        return None
    return data


def write_cache(path: str | os.PathLike[str], data: dict[str, Any]) -> None:
    """Write a cache file atomically; a cache folder that cannot be written is no error (measured
    again next time), with one warning (:func:`cache_problem`)."""
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path, (".json",)) as tmp:
            tmp.write_text(json.dumps(data, indent=1) + "\n")
    except (OSError, LabcutError) as exc:
        cache_problem(path, getattr(exc, "strerror", None) or str(exc), unwritable=True)


#: calibrations measured or read in this process: ``(file name, key) -> value``
_CALIBRATIONS: dict[tuple[str, str], dict[str, Any]] = {}
#: each calibration file (by path) as this process read it: read once, read again only to merge before a write
_STORES: dict[str, dict[str, Any]] = {}


def instrumented() -> bool:
    """Whether Python runs a profiler or a tracer in this thread (``sys.getprofile()`` or
    ``sys.gettrace()``: cProfile, coverage, a debugger): timings measured now say what the
    instrumentation costs, not what this machine does."""
    import sys

    return sys.getprofile() is not None or sys.gettrace() is not None


#: the calibration files whose timing this process measured under a profiler or tracer and did not keep
_UNKEPT_WARNED: set[str] = set()


def _unkept(path: Path) -> None:
    """Warn, once per file and process, that a timing measured under instrumentation is not kept."""
    import warnings

    if str(path) in _UNKEPT_WARNED:
        return
    _UNKEPT_WARNED.add(str(path))
    warnings.warn(f"labcut timed this machine under a profiler or tracer: the timing is used in this process but "
                  f"not kept in {path} (it would mislead the next run's predictions)", CacheWarning, stacklevel=4)


def calibration(name: str, key: str, measure: Any, *, check: Any = None, refresh: bool = False,
                keep: int = 64, timed: bool = False) -> dict[str, Any]:
    """A measurement of this machine (or a slow value it computes the same every time), made once
    and kept: the value of ``key`` in this process,
    else in the user cache file ``name`` (:func:`cache_path`; up to ``keep`` keys per file, the
    newest kept), else ``measure()`` (a JSON-able dict), stored under ``key``. ``key`` names what
    the value depends on (versions, CPU count, the layout): a changed key measures again. ``check``:
    optional ``check(value)`` raising KeyError/TypeError/ValueError for a stored value that is not
    what is kept under ``key`` (a damaged entry: measured again, with one warning for the file). ``refresh`` measures again whatever is kept.
    ``timed``: the value is a timing of this machine; measured under a profiler or tracer
    (:func:`instrumented`) it is used in this process but not written to the file (one warning)."""
    return calibrations(name, [key], lambda missing: [measure()], check=check, refresh=refresh, keep=keep,
                        timed=timed)[0]


def calibrations(name: str, keys: Sequence[str], measure: Any, *, check: Any = None, refresh: bool = False,
                 keep: int = 64, timed: bool = False) -> list[dict[str, Any]]:
    """:func:`calibration` of several keys of one file at once: the values of ``keys`` (in order),
    those kept in this process or in the file as they are, the others from one call
    ``measure(missing_keys)`` (a list of JSON-able dicts, one per missing key, in order), stored with
    one write of the file. A plan asks one value per pose of its scene: measured together they
    share the work, and the file is written once, not once per pose."""
    path = cache_path(name)
    stored = _STORES.get(str(path))
    if stored is None:  # a file of many keys (a plan asks one per pose) is read once per process
        stored = _STORES[str(path)] = read_cache(path) or {}
    values: dict[str, dict[str, Any]] = {}
    for key in keys:
        memo = (name, key)
        if memo in _CALIBRATIONS and not refresh:
            values[key] = _CALIBRATIONS[memo]
            continue
        value = None if refresh else stored.get(key)
        if isinstance(value, dict):
            try:
                if check is not None:
                    check(value)
            except (KeyError, TypeError, ValueError, IndexError):
                cache_problem(path, f"its entry {key[:60]!r} is not what labcut keeps there")
                value = None
        elif value is not None:
            cache_problem(path, f"its entry {key[:60]!r} is not what labcut keeps there")
            value = None
        if value is not None:
            values[key] = value
    missing = list(dict.fromkeys(k for k in keys if k not in values))
    if missing:
        before = instrumented()  # a profiler or tracer on before the measurement or after it
        measured = [dict(v) for v in measure(missing)]
        if len(measured) != len(missing):
            raise ValueError(f"measure gave {len(measured)} values for {len(missing)} keys of {name}")
        values.update(zip(missing, measured))
        if timed and (before or instrumented()):  # this process only
            _unkept(path)
        else:
            stored = read_cache(path) or {}  # what other processes wrote since, kept
            for key, value in zip(missing, measured):
                stored.pop(key, None)
                stored[key] = value
            stored = _STORES[str(path)] = dict(list(stored.items())[-keep:])
            write_cache(path, stored)
    for key in keys:
        _CALIBRATIONS[(name, key)] = values[key]
    return [values[key] for key in keys]


def cached_array(name: str, key: str, build: Any, *, shape: tuple[int, ...], dtype: Any) -> Any:
    """``build()`` (a numpy array of ``shape`` and ``dtype``), kept in labcut's user cache folder
    (:func:`cache_path`, ``tables/``) under a file named by ``name`` and a hash of ``key``: a
    later process reads it back (the same array, bit for bit) instead of building it again.
    ``key`` names everything the array depends on (versions, a hash of the code that computes
    it, the parameters): a changed key builds again. A file that is missing, unreadable or of
    another shape or dtype is built again; a cache folder that cannot be written is no error
    (built again next time)."""
    import hashlib

    import numpy as np

    digest = hashlib.blake2b(key.encode(), digest_size=12).hexdigest()
    path = cache_path("tables") / f"{name}-{digest}.npy"
    want = np.dtype(dtype)
    if path.exists():
        try:
            value = np.load(path, allow_pickle=False)
            if value.shape == tuple(shape) and value.dtype == want:
                return value
            cache_problem(path, f"holds {value.dtype}{value.shape}, not {want}{tuple(shape)}")
        except (OSError, ValueError, EOFError) as exc:
            cache_problem(path, getattr(exc, "strerror", None) or "not a NumPy array")
    value = np.asarray(build())
    if value.shape != tuple(shape) or value.dtype != want:
        raise ValueError(f"cached_array {name!r}: built {value.dtype}{value.shape}, expected {want}{tuple(shape)}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path, (".npy",)) as tmp:
            np.save(tmp, value, allow_pickle=False)
    except (OSError, LabcutError) as exc:
        cache_problem(path, getattr(exc, "strerror", None) or str(exc), unwritable=True)
    return value


def cached_arrays(name: str, key: str, build: Any) -> dict[str, Any]:
    """``build()`` (a dict of numpy arrays, none of them objects), kept in labcut's user cache
    folder (:func:`cache_path`, ``tables/``) as one ``.npz`` named by ``name`` and a hash of
    ``key``: a later process reads the same arrays back, bit for bit. ``key`` names everything
    the arrays depend on (labcut's and the libraries' versions, the input's bytes, the
    parameters). A file that is missing, unreadable or holds other names is built again; a cache
    folder that cannot be written is no error (built again next time)."""
    import hashlib
    import zipfile

    import numpy as np

    digest = hashlib.blake2b(key.encode(), digest_size=16).hexdigest()
    path = cache_path("tables") / f"{name}-{digest}.npz"
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as held:
                stored = {k: held[k] for k in held.files}
            held_key = stored.pop("__key__", None)
            if held_key is not None and str(held_key) == key and "__names__" in stored:
                names = [str(n) for n in stored.pop("__names__")]
                if sorted(names) == sorted(stored):
                    return stored
            if held_key is None or "__names__" not in stored:
                cache_problem(path, "not labcut's arrays")
            # another key in the same file (a hash collision) or other names: built again, quietly
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:
            cache_problem(path, getattr(exc, "strerror", None) or "not a NumPy archive")
    value = {k: np.asarray(v) for k, v in build().items()}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path, (".npz",)) as tmp, open(tmp, "wb") as out:
            np.savez(out, __key__=np.array(key), __names__=np.array(sorted(value)), **value)
    except (OSError, LabcutError) as exc:
        cache_problem(path, getattr(exc, "strerror", None) or str(exc), unwritable=True)
    return value


def compute_platform() -> str:
    """What computes labcut's kernels here, for cache keys: the Dr.Jit backend (``cuda`` or
    ``llvm``, :func:`labcut.backend.device`) with the libLLVM version, or the CUDA version and the
    device's compute capability; the backend's name alone where it cannot say."""
    import drjit as dr

    from .backend import device

    name = device()
    try:
        if name == "cuda":
            return f"cuda {dr.detail.cuda_version()} {dr.detail.cuda_compute_capability()}"
        return f"llvm {dr.detail.llvm_version()}"
    except Exception:  # noqa: BLE001 - a backend that cannot say: its name alone
        return name


def code_hash(*paths: str | os.PathLike[str]) -> str:
    """A short hash of the bytes of the given files (a folder: its ``*.py`` files), for cache keys:
    an edited module changes it, so what it computes is computed again."""
    import hashlib

    h = hashlib.blake2b(digest_size=12)
    for p in paths:
        p = Path(p)
        for f in sorted(p.glob("*.py")) if p.is_dir() else [p]:
            h.update(f.name.encode())
            h.update(f.read_bytes())
    return h.hexdigest()
