"""Transparent huge pages and numpy: whether numpy's huge page advice decides, and turning it off.

numpy asks the kernel for transparent huge pages (``madvise(MADV_HUGEPAGE)``) for the memory of
every array of 4 MiB or more. The advice decides where the kernel's transparent huge pages are
enabled on ``madvise`` (``/sys/kernel/mm/transparent_hugepage/enabled``); under ``always`` big
mappings get huge pages with or without it (the advice then only lets a fault compact memory), and
under ``never`` none do. A huge page is a whole free 2 MiB block, and where the process has none of
its own the first touch of one may wait: a kernel whose memory is fragmented compacts memory for
it (its ``defrag`` policy), and a virtual machine that reports its free 2 MiB blocks to its host
(free page reporting, a ``page_reporting_order`` of 9) gets blocks the host has taken back and must
back again as the block is cleared. 4 KiB pages come from memory the kernel has at hand.

labcut changes nothing in a process that imports it. The ``labcut`` command's own process turns
numpy's advice off where it decides (:func:`advice_taken`; :func:`numpy_off_for_this_process`,
called by the CLI's entry point) for the commands that run once and end: their big arrays are new,
every one of them a first touch. A process that answers for minutes keeps the advice (``labcut
explore``: its answers run on memory the last answer freed, where huge pages come without a wait
and save the faults of 4 KiB pages). A variable ``NUMPY_MADVISE_HUGEPAGE`` the user has set is
left as set. A program that calls the library can choose for itself by setting
``NUMPY_MADVISE_HUGEPAGE=0`` before numpy is imported. What each choice costs on this project's
machine: docs/performance.md, "Huge pages".
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

__all__ = ["ENABLED_FILE", "NUMPY_VARIABLE", "TAKEN", "advice_taken", "numpy_advice", "numpy_off_for_this_process",
           "thp_policy"]

#: whether the kernel's transparent huge pages are on (Linux)
ENABLED_FILE = Path("/sys/kernel/mm/transparent_hugepage/enabled")
#: the settings under which numpy's advice decides whether its arrays get huge pages
TAKEN = ("madvise",)
#: numpy's switch, read when numpy is imported (``0``: no huge page advice)
NUMPY_VARIABLE = "NUMPY_MADVISE_HUGEPAGE"


def thp_policy(path: Path | str = ENABLED_FILE) -> str | None:
    """The kernel's chosen setting (the bracketed word of ``path``, e.g. ``madvise`` in
    ``always [madvise] never``), or None where the file cannot be read (no transparent huge pages,
    not Linux) or holds no bracketed word."""
    try:
        text = Path(path).read_text(encoding="ascii", errors="replace")
    except OSError:
        return None
    for word in text.split():
        if len(word) > 2 and word[0] == "[" and word[-1] == "]":
            return word[1:-1]
    return None


def advice_taken(path: Path | str = ENABLED_FILE) -> bool:
    """Whether numpy's advice decides if its arrays get huge pages (:data:`TAKEN`)."""
    return thp_policy(path) in TAKEN


def _numpy_switch() -> Any:
    """numpy's ``_set_madvise_hugepage`` (``numpy._core.multiarray`` from numpy 2, ``numpy.core``
    before), or None where this numpy has none."""
    import numpy as np

    core = getattr(np, "_core", None) or getattr(np, "core", None)
    return getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)


def numpy_advice() -> bool | None:
    """Whether numpy asks for huge pages for the arrays this process makes now; None where this
    numpy cannot say."""
    switch = _numpy_switch()
    if switch is None:
        return None
    now = switch(True)
    switch(now)
    return bool(now)


def numpy_off_for_this_process(path: Path | str = ENABLED_FILE) -> bool:
    """Turn numpy's huge page advice off for the arrays this process makes from now on, where it
    decides (:func:`advice_taken`) and the user has not set ``NUMPY_MADVISE_HUGEPAGE``; True when
    turned off.
    For a process that is labcut's own (the ``labcut`` command): a library call never makes it."""
    if NUMPY_VARIABLE in os.environ or not advice_taken(path):
        return False
    switch = _numpy_switch()
    if switch is None:  # a numpy without the switch: its default stays
        return False
    switch(False)
    return True
