"""Reproduce the figures of Weidlich & Wilkie 2009 with labcut; write labelled contact sheets.

    .venv/bin/python examples/paper_figures.py [--out docs/gallery] [--quick] [--only fig07 fig08 ...] [--page PATH]

A full run (no ``--only``) also writes the whole gallery page, each image beside its caption
(default: ``<out>.md`` next to the folder, so ``--out docs/gallery`` rewrites docs/gallery.md;
the page's text is the template :data:`PAGE` below, with this run's measured exposures).

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
import os
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
#: what this run measured, for the page (the studio series fills it)
FACTS: dict[str, str] = {}


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
    from labcut.commands.animate import animate

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
        FACTS[f"{name.replace('-', '_')}_normal"] = "(" + ", ".join(f"{x:+.3f}" for x in r.normal) + ")"
        FACTS["studio_ev"] = f"{res_.exposure_ev:+.2f}"
        FACTS["studio_size"] = f"{res} x {res} px, {spp} spp"
    frames, ares, aspp = (3, 32, 4) if s.quick else (24, 200, 16)
    anim = animate(stones[0][1], blue, rec.normal, motion="rock", frames=frames, scenario=rec.scenario, spp=aspp,
                   resolution=ares)
    for suffix in (".webp", ".gif"):
        anim.save(out / f"studio-oval-rock{suffix}")
        FACTS[f"rock_{suffix[1:]}"] = f"{(out / f'studio-oval-rock{suffix}').stat().st_size / 1000:.0f} kB"
    FACTS["rock"] = f"{frames} frames at {ares} x {ares} px, {aspp} spp each"
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


# ---------------------------------------------------------------------- the page
COMMAND = ".venv/bin/python examples/paper_figures.py --out docs/gallery"

#: docs/gallery.md: (heading, introduction, [(image, alt text, caption)]); {key}s are :data:`FACTS`
PAGE: list[tuple[str, str, list[tuple[str, str, str]]]] = [
    ("Fig. 6 / 11: the zoning lookup table", "", [
        ("fig06-lut.png", "LUT",
         "The two zoning presets (docs/zoning.md). Top: the flash colour at normal incidence of the parameter set the "
         "LUT gives for each noise value x; black bars are the unblended ranges, the rest is blended linearly in the "
         "parameters (`smooth`) or switched at the middle of the gap (`sharp`: here the ranges touch). Bottom: a slice "
         "of the baked, equalised noise grid mapped through the LUT. No rendering is involved."),
    ]),
    ("Fig. 7: anorthite content", "", [
        ("fig07-anorthite.png", "anorthite series",
         "The top face of `meshes/cube-10.ply`, lamellae parallel to it, diffuse sky (`lighting=\"sky\"`), viewed "
         "face-up and cropped to the face, for `Labradorite.from_anorthite(46 … 60)`. As in the paper the dominant "
         "colour moves to longer wavelengths with the anorthite content (thicker lamellae): blue, cyan, green, gold, "
         "orange, red (first-order peaks at 447, 492, 537, 582, 627 and 673 nm); at An58 and An60 the peak (718, "
         "763 nm) leaves the visible range and the colour fades to a reddish grey. Labels: the lamella period and the "
         "CIE dominant wavelength of the flash at normal incidence."),
    ]),
    ("Fig. 8: thickness variance", "", [
        ("fig08-variance.png", "variance series",
         "The same cube top for a material peaking at 500 nm with σa = 1, 10, 20, 30, 40, 50, 80 nm and σb = 16 nm "
         "(the paper's values). The hue stays put and the colour desaturates to grey as the stack becomes irregular; "
         "the labels give the excitation purity of the flash colour."),
    ]),
    ("Fig. 9 and 10: smooth and sharp colour zoning", "", [
        ("fig09-10-zoning.png", "zoning",
         "The `smooth` and `sharp` zoning presets (blue, green and gold parameter sets, "
         "`Zoning.preset(name, scale_mm=3.5)`) on the cube top and on `meshes/sphere-10.ply` seen from above under the "
         "sky. Both presets use the same noise seed, so the zones sit in the same places: `smooth` (2 octaves, wide "
         "blended ranges) gives soft transitions like the paper's Labradorite (Fig. 9), `sharp` (5 octaves, no blended "
         "ranges) ragged, hard-edged zones like its Spectrolite (Fig. 10). On the sphere only the cap whose surface is "
         "near the lamella plane flashes."),
    ]),
    ("Fig. 12: zoned cabochons", "", [
        ("fig12-cabochons.png", "cabochons",
         "`meshes/oval-16x12-medium.ply`, `oval-16x12-high.ply` and `round-12-high.ply` with zoning (`scale_mm=4`, "
         "seed 3), lamellae parallel to the base, sky light, seen 20° from the top. As the paper notes for its Fig. 12, "
         "curved stones show the zones over a smaller, less intense area than flat cube faces: the flash covers the "
         "part of the dome that is close to parallel to the lamellae."),
    ]),
    ("Fig. 13: the biplane carving, two lamella orientations", "", [
        ("fig13-biplane.png", "biplane",
         "`meshes/carving-biplane.ply` (non-convex: path traced, 3 bounces), blue material, studio lighting, seen from "
         "40° tilt. Left: lamellae parallel to the wings, which flash. Right: lamellae tilted 55° toward the front: "
         "the wings are grey and the flash moves to the fuselage side, tail and wheels. As the paper says, no change "
         "of lighting or view moves the flash of one orientation to where the other one has it; choosing the "
         "orientation for a carving is what `labcut.recommend_orientation` is for."),
    ]),
    ("Studio presentation renders",
     "What a designer would show a client: the studio look (docs/rendering.md, \"The studio look\"); `--only studio` "
     "renders just these images (the page is rewritten by a full run only). `RenderResult.save` writes them, with "
     "the AgX curve and the exposure metered from the lights, the same {studio_ev} EV for all: the stones' brightness "
     "differences are real. Each stone is blue labradorite at the lamella orientation `labcut.recommend_orientation` "
     "picks at draft quality under the `bench` scenario, seen from the bench's main viewer, {studio_size}, denoised.", [
        ("studio-oval-zoned.png", "zoned oval",
         "`meshes/oval-16x12-low.ply`, lamella normal {studio_oval_zoned_normal} (parallel to the base: the "
         "recommendation), with the `smooth` colour zoning on the blue material (`Zoning.preset(\"smooth\", blue, "
         "scale_mm=4, seed=3)`): blue, green and gold zones under the lamp, the lamp's near-white mirror image at the "
         "top of the dome, dark inclusions, the dark rim where the dome turns away from the lamp, and the soft contact "
         "shadow on the grey table."),
        ("studio-biplane.png", "biplane",
         "`meshes/carving-biplane.ply` (non-convex: path traced), lamella normal {studio_biplane_normal} (tilted a few "
         "degrees towards the front): the wings flash blue, the fuselage (its surfaces far from the lamella plane) "
         "stays the dark grey-green body with the tent's reflections along it."),
        ("studio-srb.png", "SRB",
         "The faceted design `meshes/designs/SRB.asc` (a standard round brilliant, 10 mm), lamella normal "
         "{studio_srb_normal} (tilted a few degrees towards the front): the table facet and the crown facets near it "
         "flash, the steeper crown facets show the dark body and mirror the tent and the lamp."),
        ("studio-oval-rock.webp", "rocking oval",
         "The oval (no zoning) rocked ±30° front-to-back under the fixed lamp, {rock}, one exposure for every frame: "
         "the flash fills the dome at rest, goes out as the stone tilts away (a thin band lingers at the rim facing "
         "the lamp) and comes back, as it does in the hand; the lamp's highlight moves to the dome's edge. Animated "
         "WebP ({rock_webp}); the same as a GIF: [studio-oval-rock.gif]({gif}) ({rock_gif})."),
    ]),
]

HEADER = """# Gallery: the paper's figures, rendered by labcut

This page and every image on it are written by one command (edit the template, `PAGE` in
`examples/paper_figures.py`, not this file):

```sh
{command}
```

({minutes:.0f} min on {cores} CPU cores, Mitsuba LLVM; `--quick` makes tiny smoke-test images, `--only fig07 fig08`
re-renders some series without rewriting the page.)

Renders that reproduce the result figures of Weidlich & Wilkie 2009 with the `labradorite` BSDF and labcut's
bundled meshes, then presentation renders in the studio look. Each sheet of the paper's figures is one series
(RGB variant); its panels share one exposure, so differences in brightness are real, and are tonemapped with
labcut's hue-preserving curve (`labcut.rendering.images.tonemap`). Renders include all three lobes (surface glare,
schiller, grey body) unless noted. The paper's images are gamut-mapped spectral renders; ours are linear-sRGB
renders whose reflectance tables come from the same spectral model, so the hues agree but the exact saturation
does not.
"""


def write_page(out: Path, page: Path, seconds: float) -> None:
    """Write the gallery page (:data:`PAGE`): each image in a table row beside its caption."""
    rel = Path(os.path.relpath(out.resolve(), page.parent.resolve())).as_posix()
    facts = dict(FACTS, gif=f"{rel}/studio-oval-rock.gif")
    lines = [HEADER.format(command=COMMAND, minutes=max(1.0, seconds / 60.0), cores=os.cpu_count())]
    for heading, intro, images in PAGE:
        lines += [f"## {heading}", ""]
        if intro:
            lines += [intro.format(**facts), ""]
        lines += ["| image | what it shows |", "|---|---|"]
        for name, alt, caption in images:
            assert (out / name).exists(), f"{out / name} missing"
            lines.append(f"| ![{alt}]({rel}/{name}) | {caption.format(**facts)} |")
        lines.append("")
    page.write_text("\n".join(lines))
    print(f"page       -> {page}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "gallery", help="output folder (default docs/gallery)")
    parser.add_argument("--quick", action="store_true", help="tiny, noisy images: a smoke test")
    parser.add_argument("--only", nargs="*", choices=sorted(SERIES), help="render only these series (the page is not rewritten)")
    parser.add_argument("--page", type=Path, default=None, help="the gallery page a full run writes (default: <out>.md)")
    args = parser.parse_args(argv)
    settings = Settings(args.quick)
    args.out.mkdir(parents=True, exist_ok=True)
    total = time.perf_counter()
    for key in args.only or SERIES:
        start = time.perf_counter()
        SERIES[key](settings, args.out)
        print(f"{key:10s} {time.perf_counter() - start:6.1f} s", flush=True)
    print(f"all        {time.perf_counter() - total:6.1f} s -> {args.out}")
    if not args.only:
        write_page(args.out, args.page or args.out.with_name(args.out.name + ".md"), time.perf_counter() - total)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
