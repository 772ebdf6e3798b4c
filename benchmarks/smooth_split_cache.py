"""The smooth-shaded split of a stone: built by trimesh against read back from labcut's user
cache (best of 5 each; a cache folder of its own under /tmp, so nothing of the user's is touched).

    .venv/bin/python benchmarks/smooth_split_cache.py [MESH ...]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import labcut
from labcut import fileio
from labcut.geometry.surface import SMOOTH_ANGLE_DEG, smooth_split

ROOT = Path(__file__).resolve().parents[1]


def best(fn, repeat: int = 5) -> float:
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def main() -> None:
    paths = sys.argv[1:] or [str(ROOT / "meshes" / "oval-16x12-low.ply"), str(ROOT / "meshes" / "carving-biplane.ply")]
    folder = Path(tempfile.mkdtemp(prefix="labcut-split-"))
    fileio.cache_path = lambda name: folder / name  # this process only: a cache of its own
    print("| mesh | triangles | built by trimesh (ms) | read back from the cache (ms) |")
    print("|---|---|---|---|")
    for p in paths:
        mesh = labcut.load_mesh(p)
        built = best(lambda: smooth_split(mesh, SMOOTH_ANGLE_DEG, cache=False))
        smooth_split(mesh, SMOOTH_ANGLE_DEG)  # writes the entry
        read = best(lambda: smooth_split(mesh, SMOOTH_ANGLE_DEG))
        print(f"| {Path(p).name} | {len(mesh.faces)} | {1000 * built:.1f} | {1000 * read:.1f} |")


if __name__ == "__main__":
    main()
