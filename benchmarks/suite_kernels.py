"""A pytest plugin for ``benchmarks/suite_cold.py``: the Dr.Jit kernels each test compiled.

Loaded with ``-p suite_kernels`` (``benchmarks`` on ``PYTHONPATH``) in every xdist worker, it
turns on Dr.Jit's kernel history around each test (set-up, call and teardown) and keeps, for every
kernel the test compiled (found neither in memory nor in the cache folder), its hash, operation
count and LLVM compile milliseconds. Each worker writes its list to
``$SUITE_KERNELS_DIR/kernels-<pid>.json`` when the session ends. Kernels compiled by the CLI's
own processes (console-script tests) are not seen.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from kernel_compiles import newly_compiled  # benchmarks/ is on the path of the runs that load this plugin

_RECORDS: list[dict] = []


def _compiled(nodeid: str) -> None:
    import drjit as dr

    for k in newly_compiled(dr.kernel_history()):
        _RECORDS.append({"test": nodeid, "hash": k["hash"], "ops": int(k.get("operation_count", 0)),
                         "compile_ms": float(k.get("backend_time", 0.0)) + float(k.get("codegen_time", 0.0))})


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    import drjit as dr

    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # cleared: what follows is this test's
    yield
    _compiled(item.nodeid)


def pytest_sessionfinish(session):
    folder = os.environ.get("SUITE_KERNELS_DIR")
    if folder:
        Path(folder, f"kernels-{os.getpid()}.json").write_text(json.dumps(_RECORDS))
