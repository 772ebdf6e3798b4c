"""Plot of a material's reflectance spectrum at several internal angles."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..colour import tables
from ..fileio import atomic_output
from ..physics.material import Labradorite
from ..physics.summary import check_angles


def _describe(material: Labradorite) -> str:
    head = f"{material.name}: " if material.name else ""
    return (
        f"{head}d = {material.d_a:.1f} + {material.d_b:.1f} nm, "
        f"σ = {material.sigma_a:.0f}/{material.sigma_b:.0f} nm, N = {material.pairs}"
    )


def plot_spectrum(material: Labradorite, angles_deg: Any, path: str | os.PathLike[str]) -> None:
    """Write a PNG of R(λ) over 360-830 nm at each internal angle, with flash swatches.

    Each curve is drawn in the flash colour at that angle and labelled with its hex code and
    dominant wavelength (a purple's complementary wavelength, named as such); a strip of
    swatches along the bottom shows the colours side by side.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    angles = check_angles(angles_deg)
    wl = tables().wavelengths
    fig, (ax, strip) = plt.subplots(
        2, 1, figsize=(8.0, 5.6), gridspec_kw={"height_ratios": [5, 1]}, constrained_layout=True
    )
    for i, angle in enumerate(angles):
        c = math.cos(math.radians(float(angle)))
        r = material.reflectance(wl, c)
        colour = material.flash_colour(c)
        shade = np.asarray(colour.srgb) * 0.85  # a little darker so light hues read on white
        hue = (f"purple, complementary λc {colour.complementary_wavelength_nm:.0f} nm" if colour.hue == "purple"
               else f"λd {colour.dominant_wavelength_nm:.0f} nm" if colour.hue else "grey")
        ax.plot(wl, r, color=shade, lw=2.0, label=f"{angle:g}°  ({colour.hex}, {hue})")
        strip.add_patch(plt.Rectangle((i, 0), 0.92, 1, color=colour.srgb))
        strip.text(i + 0.46, -0.25, f"{angle:g}°", ha="center", va="top", fontsize=9)
    ax.set_xlim(wl[0], wl[-1])
    ax.set_ylim(0.0, max(1e-3, float(np.max([material.reflectance(wl, math.cos(math.radians(a))) for a in angles]))) * 1.08)
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("lamella-stack reflectance R")
    ax.set_title(_describe(material), fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(title="angle to lamella normal (inside the stone)", fontsize=8, title_fontsize=8)
    strip.set_xlim(-0.1, len(angles))
    strip.set_ylim(-0.6, 1.0)
    strip.axis("off")
    strip.set_title("flash colour (D65, brightest channel = 1)", fontsize=9)
    with atomic_output(path, (".png",)) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
