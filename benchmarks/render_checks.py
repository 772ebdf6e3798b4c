"""Render-level checks behind numbers quoted in docs/rendering.md.

    .venv/bin/python benchmarks/render_checks.py [--out docs/render-checks.md]

1. Gradient of a rendered image's mean with respect to the lamella normal (x component):
   Dr.Jit AD through the ``prb`` integrator vs central finite differences (same seed),
   rgb and spectral, with the delta surface lobe left out (as gradient renders should)
   and, to show why, with it left in.
2. Polarizer at Brewster's angle: mean surface glare and schiller through a linear
   polarizer at 0° and 90° (slab, diffuse sky).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import labcut  # noqa: F401  (configures Dr.Jit before it is imported)
import drjit as dr
import mitsuba as mi
import numpy as np

from labcut.rendering.api import build_scene
from labcut.scene import resolve_scene

ROOT = Path(__file__).resolve().parents[1]


def gradient_vs_fd(mode: str, lobes: tuple[str, ...], spp: int = 256, h: float = 0.01) -> tuple[float, float]:
    cab = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("green", spread_deg=6.0)
    scene, _ = build_scene(cab, lab, [0.12, -0.05, 1.0], resolve_scene(lighting="sky").main_setting(), "face-up", 48, mode, lobes=lobes, integrator="prb")
    params = mi.traverse(scene)
    key = next(k for k in params.keys() if k.endswith("normal") and "bsdf" in k)
    m0 = np.array([params[key].x[0], params[key].y[0], params[key].z[0]], dtype=np.float64)

    def set_normal(m) -> None:
        params[key] = mi.Vector3f(*[float(x) for x in m])
        params.update()

    set_normal(m0)
    dr.enable_grad(params[key])
    params.update()
    dr.backward(dr.mean(mi.render(scene, params, spp=spp, seed=7), axis=None))
    ad = float(np.array(dr.grad(params[key]).x).ravel()[0])
    dr.disable_grad(params[key])
    values = []
    for sign in (1.0, -1.0):
        set_normal(m0 + [sign * h, 0.0, 0.0])
        values.append(float(np.array(mi.render(scene, params, spp=spp, seed=7)).mean()))
    return ad, (values[0] - values[1]) / (2 * h)


def polarizer() -> dict[str, tuple[float, float]]:
    slab = labcut.load_mesh(ROOT / "meshes" / "slab-20x20x3.ply")
    lab = labcut.Labradorite.preset("gold")
    brewster = math.degrees(math.atan(lab.n_surface))
    out = {}
    for lobe in ("surface", "schiller"):
        vals = []
        for angle in (0.0, 90.0):
            r = labcut.render(slab, lab, (0, 0, 1), lighting="sky", view=(brewster, 270.0), resolution=24, spp=16,
                              polarizer_deg=angle, lobes=(lobe,))
            vals.append(float(r.image[8:16, 8:16].mean()))
        out[lobe] = (vals[0], vals[1])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "render-checks.md"))
    args = parser.parse_args()
    lines = ["# Render checks", "", "Made by `.venv/bin/python benchmarks/render_checks.py`.", "",
             "## Gradient of the image mean with respect to the lamella normal (x component)", "",
             "Bundled oval cabochon, green labradorite with 6° spread, diffuse sky, 48², 256 spp, seed 7, "
             "finite-difference step 0.01.", "",
             "| variant | lobes | AD (prb) | central FD | relative difference |", "|---|---|---|---|---|"]
    for mode in ("rgb", "spectral"):
        for lobes in (("schiller", "body"), ("surface", "schiller", "body")):
            ad, fd = gradient_vs_fd(mode, lobes)
            lines.append(f"| {mode} | {', '.join(lobes)} | {ad:.5f} | {fd:.5f} | {abs(ad - fd) / abs(fd):.1%} |")
            print(lines[-1])
    pol = polarizer()
    from labcut.colour import reflectance_luminance

    import numpy as np

    lab = labcut.Labradorite.preset("gold")
    sb = math.sin(math.atan(lab.n_surface)) / lab.n_surface
    b = np.array([0.0, -sb, math.sqrt(1.0 - sb * sb)])
    cos_l = float(b[2])
    at_mirror = float(reflectance_luminance(lab, cos_l, polarization="p") / reflectance_luminance(lab, cos_l, polarization="s"))
    rng = np.random.default_rng(0)
    sp = math.radians(lab.spread_deg)
    h = np.stack([rng.normal(0, sp, 200_000), rng.normal(0, sp, 200_000), np.ones(200_000)], axis=1)
    c = np.abs(h @ b) / np.linalg.norm(h, axis=1)
    grid = np.linspace(0.6, 1.0, 401)
    y = {p: np.interp(c, grid, reflectance_luminance(lab, grid, polarization=p)).mean() for p in "sp"}
    predicted = float(y["p"] / y["s"])
    lines += ["", "## Linear polarizer at Brewster's angle", "",
              "Slab, lamellae parallel to the face, gold labradorite, overcast sky, viewed at Brewster's angle from "
              "the front; polarizer 0° passes s (the image's horizontal), 90° passes p. The glare is pure s. The "
              "schiller is reflected at 32.6° inside the stone, where the stack reflects s more than p: "
              f"Y(R_p)/Y(R_s) = {at_mirror:.4f} at the mirror angle and {predicted:.4f} averaged over the lamella lobe "
              f"({lab.spread_deg:g}° spread; Monte Carlo over orientations) from `Labradorite.reflectance(..., polarization=)`. "
              "The first release modelled the schiller as unpolarised (ratio 1.0000).", "",
              "| lobe | polarizer 0° | polarizer 90° | ratio 90°/0° |", "|---|---|---|---|"]
    for lobe, (a, b) in pol.items():
        lines.append(f"| {lobe} | {a:.5f} | {b:.6f} | {b / a:.4f} |")
        print(lines[-1])
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
