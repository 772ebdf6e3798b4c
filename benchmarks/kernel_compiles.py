"""Kernels Dr.Jit compiles for a question it has not seen (docs/performance.md, "Kernels compiled
anew for every new lamp").

    .venv/bin/python benchmarks/kernel_compiles.py

1. The score map's bin sums (``labcut.orientation.scoring._device_bins``) on the low oval's live
   problem: the median time of a call with the scatter-reduction's mode Dr.Jit picks (``Expand`` on
   the LLVM backend) and with plain atomics (``Direct``), warm.
2. Renders (96 px, 4 spp), in the diagram look and then the studio look, of three cabochons of
   new outlines, sizes, domes and places (drawn at random), then of the last one in three new
   materials: the kernels compiled (Dr.Jit's kernel history: neither in memory nor in its cache
   folder), their operations and their compile milliseconds, and the float literals by which a
   new stone's render kernel differs from the last stone's, where one was compiled.
3. The files in Dr.Jit's kernel cache folder (``~/.drjit``, or ``DRJIT_CACHE_DIR``).

    .venv/bin/python benchmarks/kernel_compiles.py --variants 8 [--plain-textures]

instead renders the same low oval (32 px, 4 spp) in the diagram and the studio look in 8 new
processes side by side and prints, per look, the distinct sets of render kernels (of more than
1,000 operations) they launched and how many processes launched each: one set if a scene always
makes the same kernels. ``--plain-textures``: the BSDF's textures made straight from numpy arrays,
as before ``labcut.rendering.textures.texture_data`` (in those processes only).
"""

from __future__ import annotations

import os
import random
import re
import statistics
import struct
import time
from collections import Counter
from pathlib import Path


def newly_compiled(history: list[dict]) -> list[dict]:
    """The kernels of Dr.Jit's kernel ``history`` that were compiled (not found in memory or in
    the cache folder)."""
    return [k for k in history if k.get("hash") and not k.get("cache_hit") and not k.get("cache_disk")]


def compiled(call) -> list[dict]:
    """The kernels ``call()`` compiled (:func:`newly_compiled`)."""
    import drjit as dr

    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # cleared
    try:
        call()
        return newly_compiled(dr.kernel_history())
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)


def bin_sums_by_mode() -> None:
    import drjit as dr

    import labcut
    from labcut.explorer.session import ExploreSession
    from labcut.orientation import scoring

    session = ExploreSession(labcut.Stone.load("meshes/oval-16x12-low.ply"), scenario="bench", quality="standard")
    session.view()
    problem = session.study().surface_scorer.problem
    real = dr.scatter_reduce
    try:
        for mode in ("Auto", "Direct"):
            dr.scatter_reduce = lambda *a, _m=getattr(dr.ReduceMode, mode), **k: real(*a, **{"mode": _m, **k})
            scoring._device_bins(problem, 612)  # compiled or read from the cache
            times = []
            for _ in range(15):
                t = time.perf_counter()
                scoring._device_bins(problem, 612)
                times.append(time.perf_counter() - t)
            print(f"bin sums, mode {mode}: median {1e3 * statistics.median(times):.1f} ms "
                  f"({problem.n_triples:,} triples, 612 x 612 grid)")
    finally:
        dr.scatter_reduce = real


def float_literals(kernel: dict) -> list[float]:
    """The float constants written into a kernel's LLVM code, in order (LLVM writes them as the
    hex of their double value)."""
    ir = kernel.get("ir")
    text = ir.getvalue() if hasattr(ir, "getvalue") else str(ir or "")
    return [struct.unpack(">d", bytes.fromhex(h))[0] for h in re.findall(r"float 0x([0-9A-Fa-f]{16})", text)]


def renders_of_new_stones() -> None:
    import numpy as np
    import trimesh

    import labcut

    rng = random.Random()
    cab = None
    for look in ("diagram", "studio"):
        last: dict[int, list[float]] = {}  # the last stone's compiled kernels: operations -> their float literals
        for _ in range(3):
            outline = rng.choice(("oval", "round", "cushion", "pear"))
            length = round(rng.uniform(8.0, 30.0), 3)
            width = length if outline == "round" else round(length * rng.uniform(0.6, 0.9), 3)
            dome = rng.choice(("low", "medium", "high"))
            shift = [round(rng.uniform(-50.0, 50.0), 2) for _ in range(3)]  # where the stone lies in its file
            made = labcut.cabochon(outline, length, width, dome=dome)
            cab = trimesh.Trimesh(np.asarray(made.vertices) + shift, np.asarray(made.faces), process=False)
            built = compiled(lambda: labcut.render(cab, "blue", resolution=96, spp=4, look=look, check_flash=False))
            big = [k for k in built if k["operation_count"] > 100]  # not the mesh copies (their alignment varies)
            print(f"{look} render of a new {outline} {length} x {width} mm cabochon, {dome} dome, at {shift}: "
                  f"{len(built)} kernel(s) compiled ({len(big)} of more than 100 operations), "
                  f"{sum(k['operation_count'] for k in built)} operations, {sum(k['backend_time'] for k in built):.0f} ms")
            now = {k["operation_count"]: float_literals(k) for k in big}
            for ops, values in now.items():
                if ops in last:  # the literals each has and the other lacks (its callables may come in another order)
                    gone, new = Counter(last[ops]) - Counter(values), Counter(values) - Counter(last[ops])
                    print(f"  its {ops}-operation kernel against the last stone's: float literals "
                          f"{', '.join(f'{v:.4g}' for v in sorted(gone.elements())) or 'none'} -> "
                          f"{', '.join(f'{v:.4g}' for v in sorted(new.elements())) or 'none'}")
            last = now
    for _ in range(3):
        peak = round(rng.uniform(450.0, 600.0), 2)
        built = compiled(lambda: labcut.render(cab, labcut.Labradorite.from_peak_wavelength(peak), resolution=96, spp=4))
        print(f"the same cabochon in a new material ({peak} nm): {len(built)} kernel(s) compiled, "
              f"{sum(k['backend_time'] for k in built):.0f} ms")


#: one process of ``--variants``: the render kernels of the same scene in each look, as JSON
VARIANT = r"""
import json, sys
import drjit as dr, mitsuba as mi, numpy as np
import labcut
if sys.argv[1] == "plain":  # the textures as before texture_data: straight from numpy
    from labcut.rendering import bsdf, zoning_kernel
    plain = lambda values: mi.TensorXf(np.ascontiguousarray(values, dtype=np.float32))
    bsdf.texture_data = zoning_kernel.texture_data = plain
oval = labcut.load_mesh("meshes/oval-16x12-low.ply")
out = {}
for look in ("diagram", "studio"):
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()
        labcut.render(oval, "blue", np.array([0.1, 0.0, 1.0]), resolution=32, spp=4, look=look, check_flash=False)
        out[look] = sorted(k["hash"][:8] for k in dr.kernel_history()
                           if k.get("type") == dr.KernelType.JIT and k["operation_count"] > 1000)
print(json.dumps(out))
"""


def variants(n: int, plain: bool) -> None:
    import json
    import subprocess
    import sys

    procs = [subprocess.Popen([sys.executable, "-c", VARIANT, "plain" if plain else "owned"], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True) for _ in range(n)]
    runs = [json.loads(p.communicate()[0].strip().splitlines()[-1]) for p in procs]
    print(f"{n} new processes side by side, the same low oval, textures "
          f"{'straight from numpy' if plain else 'through texture_data'}:")
    for look in ("diagram", "studio"):
        sets = Counter(" ".join(r[look]) for r in runs)
        print(f"  {look}: {len(sets)} distinct set(s) of render kernels: "
              + "; ".join(f"{k} in {c}" for k, c in sets.most_common()))


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--variants", type=int, default=0, help="render one scene in this many new processes")
    parser.add_argument("--plain-textures", action="store_true", help="with --variants: textures straight from numpy")
    args = parser.parse_args()
    os.chdir(Path(__file__).resolve().parents[1])
    if args.variants:
        variants(args.variants, args.plain_textures)
        return
    bin_sums_by_mode()
    renders_of_new_stones()
    folder = Path(os.environ.get("DRJIT_CACHE_DIR", Path.home() / ".drjit"))
    files = list(folder.glob("*")) if folder.is_dir() else []
    print(f"Dr.Jit's kernel cache {folder}: {len(files):,} files, {sum(f.stat().st_size for f in files) / 2**20:.0f} MiB")


if __name__ == "__main__":
    main()
