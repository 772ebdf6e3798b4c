"""Rough planning against the plans a cutter would make without labcut (docs/rough.md).

For the bundled roughs and ``--nodules`` random convex nodules with random flash planes (seeded),
one stone and two stones planned by ``labcut.plan_rough`` (rank value), against

* the naive plan: the largest default cabochon laid flat on the rough's largest face, the flash
  plane ignored (every outline and dome, turned every 7.5° on that face);
* the largest stone with the flash ignored: ``plan_rough(..., rank="weight")``;

each stone's flash ratio measured on the stone (its own recommendation and evaluation). Then the
time of one standard plan of a rough of about 200 k triangles (the convex nodule, subdivided).

    .venv/bin/python benchmarks/rough_yield.py --quality draft --nodules 20 --out docs/rough-benchmark.md
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import trimesh

import labcut
from labcut.rough.candidates import build_models
from labcut.rough.pose import axial_upper, rotation_of
from labcut.rough.search import Region, exact_placement
from labcut.rough.shape import load_rough
from labcut.scene.directions import direction

ROUGHS = Path(__file__).resolve().parents[1] / "meshes" / "rough"


def nodule(seed: int) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(300, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    radii = rng.uniform(9.0, 22.0, size=3)
    return trimesh.convex.convex_hull(d * radii * rng.uniform(0.9, 1.1, size=(300, 1)))


def naive(rough_in, n: np.ndarray, quality: str, margin: float = 0.5) -> tuple[float, float, float]:
    """(yield, flash ratio, carats) of the largest default cabochon laid flat on the rough's largest face."""
    rough = load_rough(rough_in)
    mesh = rough.mesh
    facets = mesh.facets
    if len(facets):
        k = int(np.argmax(mesh.facets_area))
        face_n = mesh.facets_normal[k]
    else:
        face_n = mesh.face_normals[int(np.argmax(mesh.area_faces))]
    region = Region(np.concatenate([rough.planes[:, :3], rough.planes[:, 3:] - margin], axis=1))
    models = build_models(None, None, "bench", quality)
    best = None
    for model in models:
        for psi in np.arange(24) * (math.pi / 24):
            rot = rotation_of(-face_n, psi)  # the stone's top points into the rough: its base on the face
            p = exact_placement(model, rot, region, 0.0)
            if p is not None and (best is None or p.carats > best.carats):
                best = p
    cut = best.model.mesh.copy()
    cut.apply_scale(best.scale)
    study = labcut.Study(cut, None, "bench", quality)
    m = axial_upper(best.rotation.T @ n)
    flash = study.evaluate(m / np.linalg.norm(m)).flash_energy / study.recommend().score
    return float(cut.volume / rough.volume_mm3), float(flash), float(best.carats)


def row(name: str, rough, n: np.ndarray, quality: str) -> dict[str, float]:
    out: dict[str, float] = {}
    t = time.monotonic()
    one = labcut.plan_rough(rough, n, quality=quality)
    out["one_s"] = time.monotonic() - t
    out["one_yield"], out["one_flash"] = one.yield_fraction, one.stones[0].flash_ratio
    t = time.monotonic()
    two = labcut.plan_rough(rough, n, quality=quality, count=2)
    out["two_s"] = time.monotonic() - t
    out["two_yield"] = two.yield_fraction
    out["two_flash"] = float(np.mean([s.flash_ratio for s in two.stones]))
    out["two_count"] = len(two.stones)
    bright = labcut.plan_rough(rough, n, quality=quality, rank="weight", min_flash=0.9)
    out["bright_yield"], out["bright_flash"] = bright.yield_fraction, bright.stones[0].flash_ratio
    heavy = labcut.plan_rough(rough, n, quality=quality, rank="weight")
    out["weight_yield"], out["weight_flash"] = heavy.yield_fraction, heavy.stones[0].flash_ratio
    out["naive_yield"], out["naive_flash"], naive_ct = naive(rough, n, quality)
    # the plan's front (one stone, every cut and pose tried) at the naive plan's weight
    at_weight = [p["flash_ratio"] for p in one.pareto if p["carats"] >= naive_ct * 0.999]
    out["front_flash_at_naive_weight"] = max(at_weight) if at_weight else float("nan")
    print(f"{name}: " + ", ".join(f"{k} {v:.3f}" for k, v in out.items()), flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", default="draft")
    ap.add_argument("--nodules", type=int, default=20)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    rng = np.random.default_rng(2026)
    rows: list[tuple[str, dict[str, float]]] = []
    for f in ("slab-40x30x6.ply", "nodule-convex.ply", "nodule-dented.ply"):
        rows.append((f, row(f, ROUGHS / f, direction(30.0, 60.0), args.quality)))
    for k in range(args.nodules):
        n = direction(float(np.degrees(np.arccos(rng.uniform(0, 1)))), float(rng.uniform(0, 360)))
        rows.append((f"nodule {k}", row(f"nodule {k}", nodule(100 + k), n, args.quality)))
    big = load_rough(ROUGHS / "nodule-convex.ply").mesh
    while len(big.faces) < 200_000:
        big = big.subdivide()
    t = time.monotonic()
    labcut.plan_rough(big, direction(30.0, 60.0), quality="standard")
    big_s = time.monotonic() - t
    print(f"standard plan of a {len(big.faces)}-triangle rough: {big_s:.1f} s")
    randoms = [r for name, r in rows if name.startswith("nodule ")]
    keys = list(randoms[0])
    lines = ["| rough | one stone: yield, flash | two stones: yield, mean flash | heaviest at flash >= 0.9: yield, flash | flash ignored: yield, flash | naive: yield, flash | the front's flash at the naive weight | seconds (one, two) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, r in rows[:3] + [("random nodules (mean)", {k: float(np.nanmean([x[k] for x in randoms])) for k in keys})]:
        lines.append(f"| {name} | {r['one_yield']:.0%}, {r['one_flash']:.2f} | {r['two_yield']:.0%}, {r['two_flash']:.2f} | "
                     f"{r['bright_yield']:.0%}, {r['bright_flash']:.2f} | "
                     f"{r['weight_yield']:.0%}, {r['weight_flash']:.2f} | {r['naive_yield']:.0%}, {r['naive_flash']:.2f} | "
                     f"{r['front_flash_at_naive_weight']:.2f} | {r['one_s']:.1f}, {r['two_s']:.1f} |")
    share = np.mean([r["one_flash"] >= 0.9 for r in randoms])
    lines.append(f"Random nodules: heaviest stone at flash >= 0.9 reached 30 % of the rough in "
                 f"{np.mean([r['bright_yield'] >= 0.3 for r in randoms]):.0%} of them; two stones reached 45 % in "
                 f"{np.mean([r['two_yield'] >= 0.45 for r in randoms]):.0%}; at the naive plan's weight the front's flash beat "
                 f"the naive plan's in {np.mean([np.nan_to_num(r['front_flash_at_naive_weight'], nan=-1) > r['naive_flash'] for r in randoms]):.0%}.")
    lines.append("")
    lines.append(f"Random nodules: one stone reached flash ratio >= 0.9 in {share:.0%} of them; the plan's flash beat the "
                 f"naive plan's in {np.mean([r['one_flash'] > r['naive_flash'] for r in randoms]):.0%}, at "
                 f"{np.mean([r['one_yield'] / max(r['naive_yield'], 1e-9) for r in randoms]):.2f}x its yield (mean).")
    lines.append(f"A standard plan of the convex nodule subdivided to {len(big.faces)} triangles: {big_s:.1f} s.")
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(f"<!-- made by: .venv/bin/python benchmarks/rough_yield.py --quality {args.quality} "
                            f"--nodules {args.nodules} --out {args.out} -->\n\n{text}\n")


if __name__ == "__main__":
    main()
