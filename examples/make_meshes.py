"""Regenerate the bundled stone meshes in ``meshes/`` (and ``meshes/README.md``).

    python examples/make_meshes.py            # writes into meshes/
    python examples/make_meshes.py OUT_DIR    # writes somewhere else

Deterministic: the builders use no randomness, and the files are binary PLY
(little-endian, no timestamps), so running it twice gives byte-identical files.
All meshes are in mm in the labcut frame (DESIGN.md §3: +Z face-up, base on z = 0).
"""

from __future__ import annotations

import sys
from pathlib import Path

from labcut.fileio import atomic_output
from labcut.geometry import carvings
from labcut.geometry.cabochon import cabochon
from labcut.geometry.inspect import summarize
from labcut.geometry.meshio import save_mesh

ROOT = Path(__file__).resolve().parents[1]

# (file name, what it is, Python call, CLI command or None, builder)
STONES = [
    ("oval-16x12-low.ply", "oval cabochon, low elliptic dome (the benchmark stone)",
     'labcut.cabochon("oval", 16, 12, dome="low")',
     "labcut cabochon --outline oval --length 16 --width 12 --dome low -o meshes/oval-16x12-low.ply",
     lambda: cabochon("oval", 16, 12, dome="low")),
    ("oval-16x12-medium.ply", "oval cabochon, medium elliptic dome",
     'labcut.cabochon("oval", 16, 12, dome="medium")',
     "labcut cabochon --outline oval --length 16 --width 12 --dome medium -o meshes/oval-16x12-medium.ply",
     lambda: cabochon("oval", 16, 12, dome="medium")),
    ("oval-16x12-high.ply", "oval cabochon, high elliptic dome",
     'labcut.cabochon("oval", 16, 12, dome="high")',
     "labcut cabochon --outline oval --length 16 --width 12 --dome high -o meshes/oval-16x12-high.ply",
     lambda: cabochon("oval", 16, 12, dome="high")),
    ("round-12-low.ply", "round cabochon, low elliptic dome",
     'labcut.cabochon("round", 12, dome="low")',
     "labcut cabochon --outline round --length 12 --dome low -o meshes/round-12-low.ply",
     lambda: cabochon("round", 12, dome="low")),
    ("round-12-medium.ply", "round cabochon, medium elliptic dome",
     'labcut.cabochon("round", 12, dome="medium")',
     "labcut cabochon --outline round --length 12 --dome medium -o meshes/round-12-medium.ply",
     lambda: cabochon("round", 12, dome="medium")),
    ("round-12-high.ply", "round cabochon, high spherical dome (a hemisphere)",
     'labcut.cabochon("round", 12, dome="high", profile="spherical")',
     "labcut cabochon --outline round --length 12 --dome high --profile spherical -o meshes/round-12-high.ply",
     lambda: cabochon("round", 12, dome="high", profile="spherical")),
    ("double-cabochon-oval-16x12.ply", "double cabochon: 3.5 mm crown, 0.5 mm girdle, 1.5 mm domed base",
     'labcut.cabochon("oval", 16, 12, dome=3.5, girdle=0.5, base=1.5)',
     "labcut cabochon --outline oval --length 16 --width 12 --dome 3.5 --girdle 0.5 --base 1.5 "
     "-o meshes/double-cabochon-oval-16x12.ply",
     lambda: cabochon("oval", 16, 12, dome=3.5, girdle=0.5, base=1.5)),
    ("buff-top-oval-16x12.ply", "buff-top: medium dome with a flat table over half the outline",
     'labcut.cabochon("oval", 16, 12, dome="medium", buff_top=0.5)',
     "labcut cabochon --outline oval --length 16 --width 12 --dome medium --buff-top 0.5 "
     "-o meshes/buff-top-oval-16x12.ply",
     lambda: cabochon("oval", 16, 12, dome="medium", buff_top=0.5)),
    ("slab-20x20x3.ply", "flat polished slab",
     "labcut.geometry.carvings.slab(20, 20, 3)", None, lambda: carvings.slab(20, 20, 3)),
    ("cube-10.ply", "cube", "labcut.geometry.carvings.cube(10)", None, lambda: carvings.cube(10)),
    ("sphere-10.ply", "sphere (bead)", "labcut.geometry.carvings.sphere(10)", None, lambda: carvings.sphere(10)),
    ("step-cut-12x10.ply", "faceted step (emerald) cut: 3 crown steps, table, 3 pavilion steps, keel",
     "labcut.geometry.carvings.step_cut(12, 10)", None, lambda: carvings.step_cut(12, 10)),
    ("carving-biplane.ply", "non-convex CSG carving: biplane (fuselage, two wings, struts, tail, propeller, wheels)",
     "labcut.geometry.carvings.biplane(30)", None, lambda: carvings.biplane(30)),
]


def main(out_dir: Path | None = None) -> None:
    """Write every mesh of :data:`STONES` and the README into ``out_dir``."""
    out = Path(out_dir) if out_dir is not None else ROOT / "meshes"
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, what, call, cli, build in STONES:
        mesh = build()
        save_mesh(mesh, out / name)
        s = summarize(mesh, name)
        convex = "yes" if mesh.metadata["labcut"]["convex"] else "no"
        rows.append(
            f"| `{name}` | {what} | {s.length_mm:.2f} x {s.width_mm:.2f} x {s.height_mm:.2f} "
            f"| {s.volume_mm3:.2f} | {s.weight_ct:.2f} | {s.triangles} | {convex} |"
        )
        print(f"{name}: {s.triangles} triangles, {s.volume_mm3:.2f} mm^3")
    commands = []
    for name, _, call, cli, _ in STONES:
        commands.append(f"- `{name}`: `{call}`" + (f"  \n  CLI: `{cli}`" if cli else ""))
    readme = "\n".join(
        [
            "# Bundled stone meshes",
            "",
            "Binary PLY, millimetres, labcut frame (DESIGN.md §3): +Z face-up, the lowest point",
            "on z = 0, centred on the Z axis. Every file is watertight with outward normals and",
            "loads with `labcut.load_mesh` without repairs. Weights use labradorite's density",
            "2.705 g/cm³ (midpoint of 2.69–2.72).",
            "",
            "Regenerate them all (deterministic, byte-identical output):",
            "",
            "    .venv/bin/python examples/make_meshes.py",
            "",
            "| file | stone | L x W x H (mm) | volume (mm³) | weight (ct) | triangles | convex |",
            "|---|---|---|---|---|---|---|",
            *rows,
            "",
            "## How each file is made",
            "",
            *commands,
            "",
            "## Roughs (`meshes/rough/`)",
            "",
            "Made by `.venv/bin/python tools/make_roughs.py` (deterministic), for `labcut rough` (docs/rough.md):",
            "",
            "- `slab-40x30x6.ply`: a sawn slab 40 x 30 x 6 mm spanning [0, 40] x [0, 30] x [0, 6];",
            "- `nodule-convex.ply`: a convex nodule about 46 x 32 x 23 mm, the convex hull of 400 points on an",
            "  ellipsoid pushed in and out by up to 12 % (seed 7);",
            "- `nodule-dented.ply`: a non-convex nodule about 44 x 34 x 26 mm, such a hull (seed 11) with a bite",
            "  of an 11 mm sphere taken out of one side (manifold3d difference).",
            "",
        ]
    )
    with atomic_output(out / "README.md", (".md",)) as tmp:
        tmp.write_text(readme)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else None)
