"""The effect planner's pilot renders of a carving's inter-reflection, timed (docs/performance.md,
"Pilot renders one scene at a time").

For each scenario, :func:`labcut.orientation.render_objective.interreflection_share` of the bundled
biplane as :func:`labcut.planner.measured_interreflection` calls it (its pilot poses, resolution and
samples), in this process: a first call (the kernels of a new process: compiled, or read from
Dr.Jit's cache) and the best of ``--repeat`` more, with the renders and the share each gave. The
same script run with another checkout's labcut (``PYTHONPATH=/tmp/old:/tmp/old/cli``) gives the
figures before a change.

    .venv/bin/python benchmarks/pilot_renders.py [--scenarios ring,pendant,outdoor] [--repeat 2]
"""

from __future__ import annotations

import argparse
import gc
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", default="ring,pendant,outdoor")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()

    import labcut
    from labcut import planner
    from labcut.orientation.render_objective import interreflection_share
    from labcut.scene import resolve_scene

    mesh = labcut.load_mesh(ROOT / "meshes" / "carving-biplane.ply")
    print(f"labcut from {Path(labcut.__file__).parent}")
    print("| scenario | poses | views | first call | best of the next | share |")
    print("|---|---|---|---|---|---|")
    for name in args.scenarios.split(","):
        settings = resolve_scene(name, None, None, planner.PILOT_QUALITY).settings()
        if len(settings) > planner.PILOT_POSES:  # as measured_interreflection thins a rocking hand's poses
            settings = settings[:: -(-len(settings) // planner.PILOT_POSES)]
        times, share = [], None
        for _ in range(1 + args.repeat):
            gc.collect()
            start = time.perf_counter()
            share = interreflection_share(planner.pilot_mesh(mesh), labcut.Labradorite(), settings,
                                          resolution=planner.PILOT_RESOLUTION, spp=planner.PILOT_SPP)
            times.append(time.perf_counter() - start)
        views = sum(len(s.views.directions) for s in settings)
        print(f"| {name} | {len(settings)} | {views} | {times[0]:.2f} s | {min(times[1:]):.2f} s | {share:.5f} |")


if __name__ == "__main__":
    main()
