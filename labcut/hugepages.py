"""Transparent huge pages and numpy: whether this machine's kernel makes a process wait for them.

numpy asks the kernel for transparent huge pages (``madvise(MADV_HUGEPAGE)``) for the memory of
every array of 4 MiB or more. What a page fault in that memory then costs is the kernel's choice,
its ``defrag`` policy (``/sys/kernel/mm/transparent_hugepage/defrag``): under ``always``,
``madvise`` and ``defer+madvise`` a fault in advised memory that finds no free huge page
reclaims and compacts memory on the spot before it returns, which on a machine whose memory is
fragmented (a long-running host, a virtual machine whose host takes freed memory back) can take
longer than the work the memory was for. Under ``defer`` and ``never`` nothing waits.

labcut changes nothing in a process that imports it. The ``labcut`` command's own process turns
numpy's request off where the kernel stalls (:func:`stalls`; :func:`numpy_off_for_this_process`,
called by the CLI's entry point) for the commands that run once and end: their big arrays are
new, and the kernel has no free huge page to give them without compacting. A process that answers
for minutes keeps the advice (``labcut explore``: its answers run on memory the last answer
freed, where huge pages come without a stall and save the faults of 4 KiB pages). A variable
``NUMPY_MADVISE_HUGEPAGE`` the user has set is left as set. A program that calls the library can
choose for itself by setting ``NUMPY_MADVISE_HUGEPAGE=0`` before numpy is imported. What each
choice costs here: docs/performance.md, "Huge pages".
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["DEFRAG_FILE", "NUMPY_VARIABLE", "STALLING", "defrag_policy", "numpy_off_for_this_process", "stalls"]

#: the kernel's transparent huge page defrag policy (Linux)
DEFRAG_FILE = Path("/sys/kernel/mm/transparent_hugepage/defrag")
#: the policies under which a fault in memory advised for huge pages compacts memory on the spot
STALLING = ("always", "madvise", "defer+madvise")
#: numpy's switch, read when numpy is imported (``0``: no huge page advice)
NUMPY_VARIABLE = "NUMPY_MADVISE_HUGEPAGE"


def defrag_policy(path: Path | str = DEFRAG_FILE) -> str | None:
    """The kernel's chosen defrag policy (the bracketed word of ``path``, e.g. ``madvise`` in
    ``always defer defer+madvise [madvise] never``), or None where the file cannot be read (no
    transparent huge pages, not Linux) or holds no bracketed word."""
    try:
        text = Path(path).read_text(encoding="ascii", errors="replace")
    except OSError:
        return None
    for word in text.split():
        if len(word) > 2 and word[0] == "[" and word[-1] == "]":
            return word[1:-1]
    return None


def stalls(path: Path | str = DEFRAG_FILE) -> bool:
    """Whether a page fault in memory advised for huge pages may wait for the kernel to compact
    memory (:data:`STALLING`)."""
    return defrag_policy(path) in STALLING


def numpy_off_for_this_process(path: Path | str = DEFRAG_FILE) -> bool:
    """Turn numpy's huge page advice off for the arrays this process makes from now on, where the
    kernel stalls on it and the user has not set ``NUMPY_MADVISE_HUGEPAGE``; True when turned off.
    For a process that is labcut's own (the ``labcut`` command): a library call never makes it."""
    if NUMPY_VARIABLE in os.environ or not stalls(path):
        return False
    import numpy as np

    switch = getattr(getattr(getattr(np, "_core", None), "multiarray", None), "_set_madvise_hugepage", None)
    if switch is None:  # a numpy without the switch: its default stays
        return False
    switch(False)
    return True

