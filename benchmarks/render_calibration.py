"""The render command's calibration (``labcut.planner.render_command_timing``, issue 36): what it
costs a machine the first time a look and colour mode are rendered, and how well it predicts.

    .venv/bin/python benchmarks/render_calibration.py [--look studio] [--mode rgb] [--sizes 96x4,256x4,256x32]

Calibrates twice, warm (each calibration warms its own kernels first): with labcut's sizes
(``labcut.planner._RENDER_CAL``) and with ``--sizes`` (default: the sizes before 2026-12-05,
96² px at 4 spp, 256² at 4 and at 32), printing each's seconds and its fit (fixed seconds,
seconds per sample, seconds per pixel); then renders the bundled low oval at 512² px and 64 spp,
256² and 16 spp, and 768² and 16 spp (``labcut.planner.render_once``, after a warm-up) and prints
each measured time beside the two calibrations' predictions. docs/performance.md, "The render
command's calibration", holds its figures.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--look", default="studio", choices=("diagram", "studio"))
    parser.add_argument("--mode", default="rgb", choices=("rgb", "spectral", "mono"))
    parser.add_argument("--sizes", default="96x4,256x4,256x32", help="the other calibration's sizes, PXxSPP,...")
    args = parser.parse_args()
    os.chdir(Path(__file__).resolve().parents[1])

    import labcut
    from labcut import planner
    from labcut.physics.material import Labradorite
    from labcut.scene.directions import normalize_normal

    other = tuple(tuple(int(x) for x in s.split("x")) for s in args.sizes.split(","))
    ours = planner._RENDER_CAL
    fits = {}
    for name, sizes in (("labcut's", ours), ("--sizes", other)):
        planner._RENDER_CAL = sizes  # this process only: the calibration the sizes give
        try:
            planner.render_command_timing(args.mode, False, "direct", args.look, refresh=True)  # warm: its kernels
            t = time.perf_counter()
            fits[name] = planner.render_command_timing(args.mode, False, "direct", args.look, refresh=True)
            took = time.perf_counter() - t
        finally:
            planner._RENDER_CAL = ours
        fixed, per_sample, per_pixel = fits[name]
        print(f"{name} sizes {sizes}: calibration {took:.2f} s; fixed {fixed:.3g} s, {per_sample:.3g} s a sample, "
              f"{per_pixel:.3g} s a pixel")
    planner.render_command_timing(args.mode, False, "direct", args.look, refresh=True)  # the user cache as labcut keeps it
    oval = labcut.load_mesh("meshes/oval-16x12-low.ply")
    request = dict(scenario="bench", mode=args.mode, look=args.look)
    normal = normalize_normal((0.05, 0.02, 1.0))
    print(f"\n{args.look} look, {args.mode}: the low oval")
    print("| render | measured | predicted, labcut's sizes | predicted, --sizes |")
    print("|---|---:|---:|---:|")
    for res, spp in ((512, 64), (256, 16), (768, 16)):
        planner.render_once(oval, Labradorite(), normal, res, spp, request)  # warm
        t = time.perf_counter()
        planner.render_once(oval, Labradorite(), normal, res, spp, request)
        measured = time.perf_counter() - t
        pred = [f[0] + f[1] * res * res * spp + f[2] * res * res for f in (fits["labcut's"], fits["--sizes"])]
        print(f"| {res}² px, {spp} spp | {measured:.2f} s | {pred[0]:.2f} s | {pred[1]:.2f} s |")


if __name__ == "__main__":
    main()
