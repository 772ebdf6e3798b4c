"""Answers the ``labcut`` command remembers: the same question asked again is read back, not computed.

A recommendation asked a second time with the same inputs (``labcut recommend-orientation``) is
printed from the entry its first call left in labcut's user cache folder (``answers/``), without
loading the mesh: the warm call then costs the command's imports, not trimesh's and SciPy's nor the
work (docs/performance.md, "The warm command").

An entry is keyed by everything that shapes the answer:

- the command and this module's :data:`FORMAT`;
- labcut's version and its code: the bytes of every module of ``labcut`` and ``labcut_cli``, so an
  edited checkout never reads what its old code answered;
- the installed distributions (the ``*.dist-info`` names on ``sys.path``: every library's version)
  and what runs the kernels (:func:`labcut.fileio.compute_platform`: the Dr.Jit backend with its
  libLLVM or CUDA version);
- the mesh file's name and bytes and the options it is read with (units, up axis, size);
- the whole question, as its pickle (material, scenario with its lights, views and poses, quality,
  objective, constraint, seed, estimator, effects, zoning), and the command's other options that
  shape the answer (the optimiser, the scenario variants).

Calls whose answer depends on this machine's speed (a time budget) or that make pictures or plans
(``--render``, ``--map``, ``--plan``, ``--plan-only``) are neither read nor remembered;
``--recompute`` computes the answer and remembers it anew; ``LABCUT_ANSWERS=off`` in the
environment switches the store off (the test suite does, so that every test computes).

An entry holds the JSON document the command wrote, the mesh's provenance facts and the warning and
note lines the call printed, so a remembered answer prints as the computed one did. A damaged entry
is computed again with one warning; a folder that cannot be written only costs the next call's
time (:func:`labcut.fileio.cache_problem`). The newest :data:`KEEP` entries are kept.
"""

from __future__ import annotations

import contextlib
import gzip
import hashlib
import json
import os
import pickle
import time
from pathlib import Path
from typing import Any

#: the entries' layout and key recipe: a change here makes every earlier entry unread
FORMAT = "labcut answers 1"
#: how many entries the folder keeps (the most recently used)
KEEP = 256
#: the environment variable that switches the store off (``off``, ``0``, ``no`` or ``false``)
SWITCH = "LABCUT_ANSWERS"
#: mesh formats whose file may name others it is read with (a glTF's buffers and images): not
#: remembered, as the key holds the named file's bytes alone
SPREAD_FORMATS = (".gltf",)


def enabled() -> bool:
    """Whether answers are read and remembered (:data:`SWITCH` not set to off)."""
    return os.environ.get(SWITCH, "").strip().lower() not in ("off", "0", "no", "false")


def folder() -> Path:
    """The store's folder in labcut's user cache."""
    from labcut.fileio import cache_path

    return cache_path("answers")


def _code() -> str:
    """A hash of the bytes of every module of labcut and of this command-line package
    (:func:`labcut.fileio.code_hash`)."""
    import labcut
    from labcut.fileio import code_hash

    import labcut_cli

    return code_hash(*(f for package in (labcut, labcut_cli)
                       for f in sorted(Path(package.__file__).resolve().parent.rglob("*.py"))))


def _distributions() -> list[str]:
    """The ``*.dist-info`` names in every folder of ``sys.path`` (each installed distribution's name
    and version: an upgraded library changes them), folder by folder."""
    import sys

    names = []
    for entry in sys.path:
        try:
            found = sorted(p for p in os.listdir(entry or ".") if p.endswith(".dist-info"))
        except OSError:
            continue
        names += [f"{entry}:{p}" for p in found]
    return names


def file_state(path: Path) -> tuple[int, int] | None:
    """A mesh file's size and modification time (ns): the same before the load and after it, or
    the file changed while it was read and its answer is not remembered under the bytes hashed."""
    try:
        st = Path(path).stat()
    except OSError:
        return None
    return st.st_size, st.st_mtime_ns


def key(command: str, mesh_path: Path, mesh_options: Any, question: Any, **options: Any) -> str | None:
    """The store's key of ``command`` asked of the mesh file ``mesh_path`` (read with
    ``mesh_options``) with ``question`` (a :class:`~labcut.orientation.FlashQuestion`) and the
    command's other ``options`` that shape its answer; None where the mesh file cannot be read (the
    command's load then says why) or a part of the question cannot be pickled (not remembered)."""
    import labcut
    from labcut.fileio import compute_platform

    path = Path(mesh_path)
    if path.suffix.lower() in SPREAD_FORMATS:
        return None
    try:
        if not path.is_file():  # a folder, a pipe, a device: the load says what it is (a pipe is never read here)
            return None
        digest = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
        mesh_digest = digest.digest()
        asked = pickle.dumps((mesh_options, question, sorted(options.items())), protocol=5)
    except (OSError, pickle.PicklingError, TypeError, AttributeError, RecursionError):
        return None
    h = hashlib.sha256()
    h.update(FORMAT.encode())
    h.update(command.encode())
    h.update(labcut.__version__.encode())
    h.update(_code().encode())
    h.update("\n".join(_distributions()).encode())
    h.update(compute_platform().encode())
    h.update(path.name.encode())
    h.update(mesh_digest)
    h.update(asked)
    return h.hexdigest()[:40]


def entry_path(key_: str) -> Path:
    """The file of the entry stored under ``key_``."""
    return folder() / f"{key_}.json.gz"


def read(key_: str) -> dict[str, Any] | None:
    """The entry stored under ``key_``, or None (none, or damaged: one warning, then computed again)."""
    from labcut.fileio import cache_problem

    path = entry_path(key_)
    try:
        raw = path.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # none stored (or no folder: said when written)
        return None
    except OSError as exc:
        cache_problem(path, exc.strerror or str(exc))
        return None
    try:
        entry = json.loads(gzip.decompress(raw))
    except Exception:  # noqa: BLE001 - zlib.error, EOFError, ValueError, RecursionError: damaged either way
        cache_problem(path, "not a remembered answer")
        return None
    if not _well_formed(entry):
        cache_problem(path, "not a remembered answer")
        return None
    with contextlib.suppress(OSError):
        os.utime(path)  # used: the newest entries are the ones kept
    return entry


def _well_formed(entry: Any) -> bool:
    """An entry as :func:`remember` writes it (its answer's own fields are checked when read back)."""
    if not (isinstance(entry, dict) and entry.get("format") == FORMAT and isinstance(entry.get("answer"), dict)):
        return False
    messages = entry.get("messages")
    return (isinstance(entry.get("computed"), str) and isinstance(entry.get("seconds"), (int, float))
            and isinstance(entry.get("provenance"), dict) and isinstance(messages, list)
            and all(isinstance(m, list) and len(m) == 2 and m[0] in ("warning", "note") and isinstance(m[1], str)
                    for m in messages))


def remember(key_: str, answer: dict[str, Any], provenance: dict[str, Any], messages: list[tuple[str, str]],
             seconds: float) -> None:
    """Store an answer (the command's JSON document), the mesh's provenance facts and the lines the
    call printed (``(kind, text)``: ``warning`` or ``note``); ``seconds``: what the call took."""
    from labcut.errors import LabcutError
    from labcut.fileio import atomic_output, cache_problem

    entry = {"format": FORMAT, "computed": time.strftime("%Y-%m-%d %H:%M"), "seconds": float(seconds),
             "answer": answer, "provenance": provenance, "messages": [list(m) for m in messages]}
    path = entry_path(key_)
    try:
        data = gzip.compress(json.dumps(entry, allow_nan=False).encode(), compresslevel=5)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path, (".gz",)) as tmp:
            tmp.write_bytes(data)
    except (OSError, ValueError, TypeError, LabcutError) as exc:
        cache_problem(path, getattr(exc, "strerror", None) or str(exc), unwritable=True)
        return
    _prune(path.parent)


def _prune(where: Path) -> None:
    """Keep the :data:`KEEP` most recently used entries."""
    try:
        entries = [(p.stat().st_mtime, p) for p in where.glob("*.json.gz")]
    except OSError:
        return
    if len(entries) <= KEEP:
        return
    for _, p in sorted(entries)[: len(entries) - KEEP]:
        with contextlib.suppress(OSError):
            p.unlink(missing_ok=True)
