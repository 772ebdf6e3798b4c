"""The explorer's answer timed in one process, without the server (issue 35): ``ExploreSession.view``
after a lamp or material change, with the process's user and system CPU time and minor page faults
over each answer (``resource.getrusage``).

    .venv/bin/python benchmarks/explore_inprocess.py [--stone meshes/oval-16x12-low.ply] [--quality standard]
        [--pictures] [--no-huge-pages] [--fresh-cache] [--random-lamps] [--domes]

Six new lamps, then three materials (two presets and a flash peak), each one the session has not
seen. ``--pictures``: the preview and the refined picture of each state drawn before the next
change, as the server draws them (the memory they free is what the next answer's arrays land on);
the preview, drawn right after the answer as the server draws it, is timed too ("preview ms").
``--no-huge-pages``: numpy asked not to request transparent huge pages for its big arrays (this
benchmark's process only: the library changes no numpy setting, and ``labcut explore`` keeps
numpy's default: docs/performance.md, "Huge pages"), to see what they add to the system time. ``--fresh-cache``: labcut's user cache in a new empty folder, so that every material (and
lamp) is one the machine has never seen and its reflectance tables are built in the answer. ``perf record -g .venv/bin/python benchmarks/explore_inprocess.py --pictures`` shows
where the system time goes (``clear_page_erms``: the kernel clearing fresh pages).
``--random-lamps``: the six lamps' elevations drawn at random (40-85°, a new draw each run), as a
user's slider gives them: a lamp no earlier run has seen gives new bin counts, and the columns
"kernels compiled" and "compile ms" (Dr.Jit's kernel history) show what of the answer was LLVM
compiling kernels that Dr.Jit's cache did not hold.
``--domes``: then three oval cabochons of new dome heights (drawn at random, 1.5-5.5 mm, a new draw
each run), each a stone of a new size, with ``--pictures`` their previews' kernels compiled too
("preview kernels"): a render of a new size had compiled its render kernel again before renders
placed every stone in its render frame (docs/performance.md, "Renders in the stone's frame").
The figures of docs/explore.md ("What the wall times above hold") and docs/performance.md ("fresh
memory") come from this command.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import time

from kernel_compiles import compiled  # this folder's helper: the kernels a call compiled

LAMPS = (61.3, 47.9, 74.2, 55.1, 66.6, 81.2)
MATERIALS = ({"material": "green"}, {"material": "gold"}, {"material": "peak", "peak_nm": 503.0})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--stone", default="meshes/oval-16x12-low.ply")
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--pictures", action="store_true", help="draw each state's pictures before the next change")
    parser.add_argument("--no-huge-pages", action="store_true", help="numpy without transparent huge pages (this process)")
    parser.add_argument("--fresh-cache", action="store_true",
                        help="labcut's user cache in a new empty folder (this process): every material is one the "
                             "machine has never seen, its reflectance tables built in the answer")
    parser.add_argument("--random-lamps", action="store_true",
                        help="the lamps' elevations drawn at random (40-85 deg), new to the machine's kernel cache")
    parser.add_argument("--domes", action="store_true",
                        help="then three oval cabochons of new dome heights (1.5-5.5 mm, drawn at random): new stone sizes")
    args = parser.parse_args()
    lamps = LAMPS
    if args.random_lamps:
        import random

        lamps = tuple(round(random.uniform(40.0, 85.0), 4) for _ in LAMPS)
    if args.fresh_cache:
        import os
        import tempfile

        os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="labcut-explore-cache-")
    if args.no_huge_pages:
        import numpy as np

        np._core.multiarray._set_madvise_hugepage(False)

    import labcut
    from labcut.explorer.session import ExploreSession

    session = ExploreSession(labcut.Stone.load(args.stone), scenario="bench", quality=args.quality)
    session.view()
    rows = []
    if args.pictures:
        session.preview()
    changes = [("lamp", {"lamp_elevation": e}) for e in lamps] + [("material", m) for m in MATERIALS]
    if args.domes:
        import random

        changes += [("dome", {"outline": "oval", "dome": round(random.uniform(1.5, 5.5), 3)}) for _ in range(3)]
    for kind, change in changes:
        if args.pictures:  # the rest of the last state's pictures (its preview is timed below)
            session.planned_estimator()
            list(session.refine())
        session.set(change)
        before = resource.getrusage(resource.RUSAGE_SELF)
        t = time.perf_counter()
        built = compiled(session.view)  # the answer, and the kernels it compiled
        wall = time.perf_counter() - t
        after = resource.getrusage(resource.RUSAGE_SELF)
        preview, preview_built = float("nan"), []
        if args.pictures:  # as the server does: the answer, then the state's first picture
            t = time.perf_counter()
            preview_built = compiled(session.preview)
            preview = 1000 * (time.perf_counter() - t)
        rows.append((kind, change, 1000 * wall, 1000 * (after.ru_utime - before.ru_utime),
                     1000 * (after.ru_stime - before.ru_stime), after.ru_minflt - before.ru_minflt,
                     len(built), sum(float(k.get("backend_time", 0.0)) for k in built), preview, len(preview_built)))
    print(f"{args.stone}, {args.quality}, {'pictures between changes' if args.pictures else 'no pictures'}"
          f"{', numpy without huge pages' if args.no_huge_pages else ''}"
          f"{', a new cache folder (every material never seen)' if args.fresh_cache else ''}\n")
    print("| change | wall ms | user CPU ms | system CPU ms | minor page faults | kernels compiled | compile ms | preview ms "
          "| preview kernels |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for kind, change, wall, user, system, faults, built, compile_ms, preview, preview_built in rows:
        print(f"| {kind} {change} | {wall:.0f} | {user:.0f} | {system:.0f} | {faults} | {built} | {compile_ms:.0f} | "
              f"{'-' if preview != preview else f'{preview:.0f}'} | {preview_built if args.pictures else '-'} |")
    for kind in ("lamp", "material") + (("dome",) if args.domes else ()):
        walls = [r[2] for r in rows if r[0] == kind]
        print(f"\n{kind}: median {statistics.median(walls):.0f} ms, range {min(walls):.0f}-{max(walls):.0f} ms")
        if args.pictures:
            previews = [r[8] for r in rows if r[0] == kind]
            print(f"{kind} preview: median {statistics.median(previews):.0f} ms, range {min(previews):.0f}-{max(previews):.0f} ms")


if __name__ == "__main__":
    main()
