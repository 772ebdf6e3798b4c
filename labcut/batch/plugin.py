"""Dask plugins that set up each worker of a batch.

:class:`LabcutWorkerPlugin` (every worker, when it joins): imports labcut and the modules a row
needs (so the first row does not pay for them), selects the Mitsuba variant renders use, and
sets Dr.Jit's thread count so that the workers of one machine share its cores instead of each
starting a thread per core: ``cores // workers on that machine`` (at least 1), or a number given.

:class:`NodeKernelCache` (a nanny plugin, for a cluster the user started): gives each machine its
own Dr.Jit kernel cache folder, ``<user cache>/labcut/drjit-nodes/<host name>`` unless one is
given, and restarts the workers once so that Dr.Jit, which reads ``DRJIT_CACHE_DIR`` when it is
first imported, uses it. A home folder shared by all machines (NFS) would otherwise have every
node write one folder. An embedded ``LocalCluster`` runs on the driver's machine and gets the
driver's cache folder in its workers' environment instead (no restart).
"""

from __future__ import annotations

import importlib
import os
import socket
from typing import Any

from distributed.diagnostics.plugin import NannyPlugin, WorkerPlugin

PLUGIN_NAME = "labcut-batch"
CACHE_PLUGIN_NAME = "labcut-kernel-cache"


def node_cache_dir(root: str | None = None) -> str:
    """This machine's kernel cache folder: ``root/<host name>`` (default root: the user's
    labcut cache, ``~/.cache/labcut/drjit-nodes`` on Linux)."""
    if root is None:
        from platformdirs import user_cache_dir

        root = os.path.join(user_cache_dir("labcut"), "drjit-nodes")
    return os.path.join(root, socket.gethostname())


def cores() -> int:
    """CPU cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - macOS
        return max(1, os.cpu_count() or 1)


class LabcutWorkerPlugin(WorkerPlugin):
    """Set up a worker for batch rows (module docstring).

    ``threads``: Dr.Jit threads per worker; None: this machine's cores divided by
    ``workers_per_host[host]`` (the number of the batch's workers on that host, counted by the
    driver; 1 for a host it did not see). ``mode``: the Mitsuba colour mode renders use.
    ``warm``: modules to import at set-up (the driver names the one holding its row function), so
    a worker's first row does not pay for them."""

    name = PLUGIN_NAME

    def __init__(self, threads: int | None = None, workers_per_host: dict[str, int] | None = None, mode: str = "rgb",
                 warm: tuple[str, ...] = ()) -> None:
        self.threads = threads
        self.workers_per_host = dict(workers_per_host or {})
        self.mode = mode
        self.warm = tuple(warm)

    def thread_count(self, host: str) -> int:
        if self.threads is not None:
            return max(1, int(self.threads))
        return max(1, cores() // max(1, int(self.workers_per_host.get(host, 1))))

    def setup(self, worker: Any) -> None:
        import time

        start = time.perf_counter()
        import drjit as dr

        import labcut  # noqa: F401  (backend checks, the BSDF)
        import labcut.geometry.meshio  # noqa: F401
        import labcut.orientation.recommend  # noqa: F401
        from labcut.backend import set_variant

        for name in self.warm:  # the driver's row function and what it imports
            importlib.import_module(name)

        host = worker.address.split("://")[-1].rsplit(":", 1)[0]
        threads = self.thread_count(host)
        dr.set_thread_count(threads)
        variant = set_variant(self.mode)
        worker.labcut_setup = {  # read back by the driver (worker_info)
            "host": socket.gethostname(), "threads": threads, "variant": variant,
            "kernel_cache": os.environ.get("DRJIT_CACHE_DIR"), "setup_seconds": time.perf_counter() - start,
            # Dask's nanny default, 65536, slows rows down (labcut.batch.runner.TRIM_KEY); None: glibc's own
            "malloc_trim_threshold": os.environ.get("MALLOC_TRIM_THRESHOLD_"),
        }


class NodeKernelCache(NannyPlugin):
    """Give every machine its own Dr.Jit kernel cache folder (module docstring); ``root``: the
    folder holding one sub-folder per host name (default :func:`node_cache_dir`'s)."""

    name = CACHE_PLUGIN_NAME
    restart = True

    def __init__(self, root: str | None = None) -> None:
        self.root = root

    def setup(self, nanny: Any) -> None:
        folder = node_cache_dir(self.root)
        os.makedirs(folder, exist_ok=True)
        nanny.env["DRJIT_CACHE_DIR"] = folder


def worker_info(dask_worker: Any) -> dict[str, Any]:
    """What :class:`LabcutWorkerPlugin` set on a worker (run with ``client.run``)."""
    return dict(getattr(dask_worker, "labcut_setup", {}) or {})


__all__ = ["LabcutWorkerPlugin", "NodeKernelCache", "cores", "node_cache_dir", "worker_info"]
