"""Exact ensemble means of the lamella stack's reflectance: the reference data of the physics tests.

    .venv/bin/python benchmarks/tmm_ensemble.py                     # ~15-20 min on 2 cores
    .venv/bin/python benchmarks/tmm_ensemble.py --realisations 64   # a quick look

For every material preset (blue, green, gold, red) and internal angle to the lamella
normal of 0, 20, 30, 45, 60 and 70° (in the bulk stone, n = 1.56), the mean of R_s and
R_p over ``--realisations`` random stacks (Gaussian thicknesses; benchmarks/tmm.py:
Snell and exact Fresnel in every layer, all multiple reflections) on 380-780 nm in 5 nm
steps, with the standard error of each mean. Written to benchmarks/data/tmm-ensemble.json,
which tests/test_physics_tmm.py compares labcut's closed form against, and which
benchmarks/physics_accuracy.py turns into the tables of docs/physics-accuracy.md.
Deterministic for a seed.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import tmm  # noqa: E402

import labcut  # noqa: E402
from labcut.fileio import atomic_output  # noqa: E402

PRESETS = ("blue", "green", "gold", "red")
ANGLES = (0.0, 20.0, 30.0, 45.0, 60.0, 70.0)
WAVELENGTHS = np.arange(380.0, 781.0, 5.0)
OUT = Path(__file__).resolve().parent / "data" / "tmm-ensemble.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=600)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    cases = []
    t0 = time.perf_counter()
    for k, preset in enumerate(PRESETS):
        lab = labcut.Labradorite.preset(preset)
        for j, theta in enumerate(ANGLES):
            entry = {"preset": preset, "theta_deg": theta}
            for pol in ("s", "p"):
                mean, se = tmm.ensemble_mean(WAVELENGTHS, theta, lab, pol, args.realisations, seed=args.seed + 100 * k + j)
                entry[f"R_{pol}"] = [round(float(x), 7) for x in mean]
                entry[f"se_{pol}"] = [round(float(x), 7) for x in se]
            cases.append(entry)
            print(f"{preset} {theta:4.0f}°  peak R_s {max(entry['R_s']):.4f}  R_p {max(entry['R_p']):.4f}  "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    data = {
        "command": "benchmarks/tmm_ensemble.py " + " ".join(sys.argv[1:]),
        "realisations": args.realisations,
        "seed": args.seed,
        "n_surface": labcut.Labradorite().n_surface,
        "wavelengths_nm": WAVELENGTHS.tolist(),
        "materials": {p: labcut.Labradorite.preset(p).to_dict() for p in PRESETS},
        "cases": cases,
    }
    with atomic_output(args.out, (".json",)) as tmp:
        tmp.write_text(json.dumps(data) + "\n")
    print(f"wrote {args.out} ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
