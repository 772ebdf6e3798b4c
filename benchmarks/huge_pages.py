"""numpy's huge page advice on this machine (labcut.hugepages; docs/performance.md, "Huge pages").

    .venv/bin/python benchmarks/huge_pages.py [--stone meshes/designs/SRB.asc] [--size 10] [--runs 2]

Each run is a new process with a new, empty labcut cache folder (as a first call on a machine
would be), once with numpy's huge page advice on (``NUMPY_MADVISE_HUGEPAGE=1``) and once off
(``=0``), in turn: a standard recommendation of the stone, then two high-quality ones. For each
call it prints the wall time and the process's user and system CPU time and minor page faults
over it. Printed first: whether the kernel acts on the advice (its transparent huge pages) and
the order of the free blocks a virtual machine reports to its host (9: 2 MiB, a huge page).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
import labcut
stone, size = sys.argv[1], sys.argv[2]
mesh = labcut.load_mesh(stone, size=float(size)) if size != "-" else labcut.load_mesh(stone)
rows = []
for label, quality in (("standard", "standard"), ("high, first", "high"), ("high, second", "high")):
    a = resource.getrusage(resource.RUSAGE_SELF)
    t = time.perf_counter()
    labcut.recommend_orientation(mesh, "blue", quality=quality)
    wall = time.perf_counter() - t
    b = resource.getrusage(resource.RUSAGE_SELF)
    rows.append([label, wall, b.ru_utime - a.ru_utime, b.ru_stime - a.ru_stime, b.ru_minflt - a.ru_minflt])
print(json.dumps(rows))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--stone", default="meshes/designs/SRB.asc")
    parser.add_argument("--size", default="10", help="girdle size in mm for a design ('-': as loaded)")
    parser.add_argument("--runs", type=int, default=2)
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    from labcut.hugepages import ENABLED_FILE, advice_taken, thp_policy

    reporting = Path("/sys/module/page_reporting/parameters/page_reporting_order")
    order = reporting.read_text().strip() if reporting.exists() else "none"
    print(f"transparent huge pages: {thp_policy()} ({ENABLED_FILE}); numpy's advice taken: {advice_taken()}; "
          f"free page reporting order: {order}\n")
    print("| numpy's advice | call | wall s | user s | system s | minor faults |")
    print("|---|---|---:|---:|---:|---:|")
    base = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "NUMPY_MADVISE_HUGEPAGE")}
    for _ in range(args.runs):
        for advice in ("1", "0"):
            with tempfile.TemporaryDirectory(prefix="labcut-hugepages-") as cache:
                env = {**base, "NUMPY_MADVISE_HUGEPAGE": advice, "XDG_CACHE_HOME": cache}
                out = subprocess.run([sys.executable, "-c", CHILD, args.stone, args.size], env=env, cwd=ROOT,
                                     capture_output=True, text=True, check=True)
            for label, wall, user, system, faults in json.loads(out.stdout.strip().splitlines()[-1]):
                print(f"| {'on' if advice == '1' else 'off'} | {label} | {wall:.2f} | {user:.2f} | {system:.2f} | {faults} |",
                      flush=True)


if __name__ == "__main__":
    main()
