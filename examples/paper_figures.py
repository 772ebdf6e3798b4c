"""Reproduce the figures of Weidlich & Wilkie 2009 with labcut; write labelled contact sheets.

    .venv/bin/python examples/paper_figures.py [--out docs/gallery] [--quick] [--only fig07 fig08 ...]

Series (one PNG each, see docs/gallery.md):

* fig06-lut      the zoning lookup table (paper Fig. 6/11): flash colour along the LUT's x,
                 and a slice of the baked noise mapped through it (no rendering)
* fig07-anorthite  cube tops, An46..An60 (``Labradorite.from_anorthite``), diffuse sky, close-up
* fig08-variance   cube tops, sigma_a = 1, 10, 20, 30, 40, 50, 80 nm, sigma_b = 16 nm
* fig09-10-zoning  smooth (Fig. 9) and sharp (Fig. 10) colour zoning on a cube top and a sphere
* fig12-cabochons  zoned oval and round cabochons
* fig13-biplane    the biplane carving with two lamella orientations
* studio           presentation renders (studio look): the zoned oval, the biplane and the SRB
                 design at their recommended orientations, and the oval rocking (WebP and GIF)

Each panel of the paper's series is a linear RGB render; a series shares one exposure (so brightness differences
are real) and is tonemapped with labcut's hue-preserving curve. ``--quick`` renders tiny
images (a smoke test). The studio series is written by ``RenderResult.save`` (AgX tone
curve, exposure metered from the lights). Defaults take about 2-3 minutes on 2 CPU cores (LLVM).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import labcut  # noqa: E402
from labcut import Labradorite  # noqa: E402
from labcut.rendering.images import auto_exposure, tonemap  # noqa: E402
from labcut.rendering.zoning import Zoning  # noqa: E402

MESHES = ROOT / "meshes"
UP = (0.0, 0.0, 1.0)


class Settings:
    def __init__(self, quick: bool) -> None:
        self.quick = quick
        self.res = 48 if quick else 224  # cube close-ups are cropped to ~45 % of this
        self.res_wide = 48 if quick else 200
        self.res_big = 48 if quick else 300
        self.spp = 8 if quick else 64
        self.spp_path = 4 if quick else 32


def mesh(name: str):
    return labcut.load_mesh(MESHES / f"{name}.ply")


def crop(img: np.ndarray, frac: float) -> np.ndarray:
    """Centre crop keeping ``frac`` of each side (the cube's top face fills ~53 % of a face-up frame)."""
    h, w = img.shape[:2]
    ch, cw = max(4, int(h * frac)), max(4, int(w * frac))
    y, x = (h - ch) // 2, (w - cw) // 2
    return img[y : y + ch, x : x + cw]


def shade(panels: list[np.ndarray], exposure: float | None = None) -> list[np.ndarray]:
    """Tonemap a series with one shared exposure (auto: from all panels together)."""
    if exposure is None:
        stacked = np.concatenate([p.reshape(-1, 3) for p in panels])[None]
        exposure = auto_exposure(stacked, percentile=99.0, target=1.6)
    return [tonemap(p, exposure) for p in panels]


def sheet(panels: list[np.ndarray], labels: list[str], title: str, path: Path, cols: int | None = None, panel_in: float = 1.55) -> None:
    """A labelled contact sheet of display-ready panels."""
    n = len(panels)
    cols = cols or n
    rows = (n + cols - 1) // cols
    aspect = panels[0].shape[0] / panels[0].shape[1]
    fig, axes = plt.subplots(rows, cols, figsize=(panel_in * cols, panel_in * aspect * rows + 0.55 + 0.3 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, img, label in zip(axes.ravel(), panels, labels):
        ax.imshow(np.clip(img, 0, 1), interpolation="nearest")
        ax.set_title(label, fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def render(m, material, normal=UP, **kw) -> np.ndarray:
    kw.setdefault("seed", 1)
    return labcut.render(m, material, normal, **kw).image


# ---------------------------------------------------------------------- series
def fig06_lut(s: Settings, out: Path) -> None:
    """The LUT of both zoning presets as colour along x, and a noise slice mapped through it."""
    from labcut.colour import colour_of_spectrum, tables

    xs = np.linspace(0.0, 1.0, 161)
    fig, axes = plt.subplots(2, 2, figsize=(9.0, 5.2), gridspec_kw={"height_ratios": [1, 3.2]})
    for col, name in enumerate(("smooth", "sharp")):
        z = Zoning.preset(name)
        params = z.parameters(xs)
        shared = z.shared
        colours = []
        from labcut.physics.lamella import Stack, stack_reflectance

        for d_a, d_b, s_a, s_b, pairs in params:
            r = stack_reflectance(tables().wavelengths, 1.0, Stack(shared["n_a"], shared["n_b"], d_a, d_b, s_a, s_b, pairs, shared["n_surface"]))
            colours.append(colour_of_spectrum(r).srgb)
        bar = np.array(colours)[None].repeat(12, axis=0)
        ax = axes[0, col]
        ax.imshow(bar, extent=(0, 1, 0, 0.12), aspect="auto")
        for lo, hi, k in z.ranges:
            ax.axvspan(lo, hi, ymin=0.0, ymax=0.18, color="k", alpha=0.6)
            ax.text(0.5 * (lo + hi), 0.135, z.materials[k].name, ha="center", va="bottom", fontsize=7)
        ax.set_ylim(0, 0.18)
        ax.set_yticks([])
        ax.set_xlabel("noise value x  (black: unblended ranges)", fontsize=8)
        ax.set_title(f"'{name}' preset: flash colour (normal incidence) along the LUT", fontsize=9)
        ax.tick_params(labelsize=7)
        baked = z.bake([[-10, -10, 0], [10, 10, 10]])
        x = baked.grid[baked.grid.shape[0] // 2]
        idx = np.clip(np.round(x * (len(xs) - 1)).astype(int), 0, len(xs) - 1)
        axes[1, col].imshow(np.array(colours)[idx], origin="lower", extent=(-10, 10, -10, 10))
        axes[1, col].set_title(f"noise slice z = 5 mm through the LUT ({z.octaves} octaves, {z.scale_mm:g} mm)", fontsize=8)
        axes[1, col].tick_params(labelsize=7)
        axes[1, col].set_xlabel("x (mm)", fontsize=7)
    fig.suptitle("Colour zoning lookup table (paper Fig. 6 and 11): parameter sets blended along the noise value", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(out / "fig06-lut.png", dpi=90)
    plt.close(fig)


def fig07_anorthite(s: Settings, out: Path) -> None:
    cube = mesh("cube-10")
    ans = [46, 48, 50, 52, 54, 56, 58, 60]
    panels, labels = [], []
    for an in ans:
        lab = Labradorite.from_anorthite(an)
        img = render(cube, lab, lighting="sky", view="face-up", resolution=s.res, spp=s.spp)
        panels.append(crop(img, 0.45))
        dom = lab.dominant_wavelength()
        labels.append(f"An{an}  (period {lab.period_nm:.0f} nm)\ndominant {abs(dom):.0f} nm{'c' if dom < 0 else ''}")
    sheet(shade(panels), labels, "Fig. 7 — cube tops with increasing anorthite content (diffuse sky, face-up close-up)", out / "fig07-anorthite.png")


def fig08_variance(s: Settings, out: Path) -> None:
    cube = mesh("cube-10")
    base = Labradorite.from_peak_wavelength(500.0)
    panels, labels = [], []
    for sa in (1, 10, 20, 30, 40, 50, 80):
        lab = base.replace(sigma_a=float(sa), sigma_b=16.0)
        img = render(cube, lab, lighting="sky", view="face-up", resolution=s.res, spp=s.spp)
        panels.append(crop(img, 0.45))
        fc = lab.flash_colour()
        labels.append(f"σa = {sa} nm\npurity {fc.purity:.2f}")
    sheet(shade(panels), labels, "Fig. 8 — cube tops with increasing lamella thickness spread σa (σb = 16 nm, peak 500 nm)", out / "fig08-variance.png")


def fig09_10_zoning(s: Settings, out: Path) -> None:
    cube, sphere = mesh("cube-10"), mesh("sphere-10")
    panels, labels = [], []
    for name in ("smooth", "sharp"):
        z = Zoning.preset(name, scale_mm=3.5)  # zones a few mm across, to suit 10 mm stones
        img = render(cube, Labradorite(), lighting="sky", view="face-up", resolution=s.res, spp=s.spp, zoning=z)
        panels.append(crop(img, 0.45))
        labels.append(f"{name} (Fig. {9 if name == 'smooth' else 10}): cube top")
        img = render(sphere, Labradorite(), lighting="sky", view="face-up", resolution=s.res_wide, spp=s.spp, zoning=z)
        panels.append(crop(img, 0.8))
        labels.append(f"{name}: sphere, face-up")
    sheet(shade(panels), labels, "Fig. 9 / 10 — smooth and sharp colour zoning (blue, green, gold sets; sky light)", out / "fig09-10-zoning.png", panel_in=2.2)


def fig12_cabochons(s: Settings, out: Path) -> None:
    panels, labels = [], []
    for mesh_name, zname in (("oval-16x12-medium", "smooth"), ("oval-16x12-high", "sharp"), ("round-12-high", "smooth"), ("round-12-high", "sharp")):
        m = mesh(mesh_name)
        z = Zoning.preset(zname, scale_mm=4.0, seed=3)
        img = render(m, Labradorite(), lighting="sky", view=(20.0, 270.0), resolution=s.res_wide, spp=s.spp, zoning=z)
        panels.append(img)
        labels.append(f"{mesh_name}\n{zname} zoning")
    sheet(shade(panels), labels, "Fig. 12 — zoned cabochons (lamellae parallel to the base, sky light, 20° tilt)", out / "fig12-cabochons.png", panel_in=2.3)


def fig13_biplane(s: Settings, out: Path) -> None:
    plane = mesh("carving-biplane")
    lab = Labradorite.preset("blue")
    normals = {"lamellae ∥ wings (normal +Z)": (0.0, 0.0, 1.0), "lamellae tilted 55° toward the front": (0.0, -0.82, 0.57)}
    panels, labels = [], []
    for label, n in normals.items():
        img = render(plane, lab, n, lighting="studio", view=(40.0, 250.0), resolution=s.res_big, spp=s.spp_path)
        panels.append(img)
        labels.append(label)
    sheet(shade(panels), labels, "Fig. 13 — the biplane carving, two lamella orientations (studio light, path traced)", out / "fig13-biplane.png", panel_in=3.2)


def studio(s: Settings, out: Path) -> None:
    """Presentation renders in the studio look (docs/gallery.md "Studio presentation renders"):
    each stone at the lamella orientation ``recommend_orientation`` picks (draft quality) under
    the ``bench`` scenario, rendered from its main view; and a rocking animation of the oval."""
    from labcut.rendering.animate import animate

    blue = Labradorite.preset("blue")
    res, spp = (48, 8) if s.quick else (360, 64)
    stones = [
        ("studio-oval-zoned", mesh("oval-16x12-low"), Zoning.preset("smooth", blue, scale_mm=4.0, seed=3)),
        ("studio-biplane", mesh("carving-biplane"), None),
        ("studio-srb", labcut.load_mesh(MESHES / "designs" / "SRB.asc"), None),
    ]
    rec = None
    for name, m, zoning in stones:
        r = labcut.recommend_orientation(m, blue, scenario="bench", quality="draft")
        rec = rec or r
        res_ = labcut.render(m, blue, r.normal, scenario=r.scenario, spp=spp, resolution=res, look="studio", zoning=zoning,
                             output=out / f"{name}.png")
        print(f"  {name}: normal ({', '.join(f'{x:+.3f}' for x in r.normal)}) = {r.description}; "
              f"{res_.seconds:.1f} s; exposure {res_.exposure_ev:+.2f} EV", flush=True)
    frames, ares, aspp = (3, 32, 4) if s.quick else (24, 200, 16)
    anim = animate(stones[0][1], blue, rec.normal, motion="rock", frames=frames, scenario=rec.scenario, spp=aspp,
                   resolution=ares)
    for suffix in (".webp", ".gif"):
        anim.save(out / f"studio-oval-rock{suffix}")
    print(f"  studio-oval-rock: {frames} frames, {anim.seconds:.1f} s, exposure {anim.exposure_ev:+.2f} EV for all", flush=True)


SERIES = {
    "fig06": fig06_lut,
    "fig07": fig07_anorthite,
    "fig08": fig08_variance,
    "fig09-10": fig09_10_zoning,
    "fig12": fig12_cabochons,
    "fig13": fig13_biplane,
    "studio": studio,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "gallery", help="output folder (default docs/gallery)")
    parser.add_argument("--quick", action="store_true", help="tiny, noisy images: a smoke test")
    parser.add_argument("--only", nargs="*", choices=sorted(SERIES), help="render only these series")
    args = parser.parse_args(argv)
    settings = Settings(args.quick)
    args.out.mkdir(parents=True, exist_ok=True)
    total = time.perf_counter()
    for key in args.only or SERIES:
        start = time.perf_counter()
        SERIES[key](settings, args.out)
        print(f"{key:10s} {time.perf_counter() - start:6.1f} s", flush=True)
    print(f"all        {time.perf_counter() - total:6.1f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
