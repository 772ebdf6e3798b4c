"""The live view's metrics with numpy's BLAS on its own threads against one thread (issue 35).

    .venv/bin/python benchmarks/explore_blas.py [--stone meshes/oval-16x12-low.ply] [--pairs 15]

``ExploreSession.view`` runs inside :func:`labcut.backend.serial_blas`. This times the part that
decides it, the metrics of the current normal and their bootstrap error (``Scorer.metrics`` and
``sampling_error``), alternately with OpenBLAS's threads and on one thread, and prints both
medians and the machine's load (the gap grows with the load: OpenBLAS's threads wait on cores
Dr.Jit's pool holds).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from labcut.backend import serial_blas
from labcut.explorer.session import ExploreSession
from labcut.orientation.uncertainty import sampling_error


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--stone", default="meshes/oval-16x12-low.ply")
    parser.add_argument("--pairs", type=int, default=15)
    args = parser.parse_args()
    session = ExploreSession(args.stone, quality="standard")
    session.view()
    scorer, normal = session.study().surface_scorer, session.normal()

    def once() -> float:
        t = time.perf_counter()
        sampling_error(scorer.problem, normal, seed=0)
        scorer.metrics(normal)
        return (time.perf_counter() - t) * 1000.0

    threaded, serial = [], []
    for _ in range(args.pairs):
        threaded.append(once())
        with serial_blas():
            serial.append(once())
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"{args.stone}: metrics and bootstrap, median of {args.pairs}: BLAS threads {statistics.median(threaded):.1f} ms, "
          f"one thread {statistics.median(serial):.1f} ms (load average {load})")


if __name__ == "__main__":
    main()
