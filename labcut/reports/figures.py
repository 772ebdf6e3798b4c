"""The figures of a comparison report, as PNG bytes (matplotlib, Agg; PIL for the renders).

Every figure of one scenario draws all cuts on the same axes or scale, each cut in the same
colour throughout the report (:func:`cut_colours`). Angles in degrees, flash values in units
of ``L_ref`` (DESIGN.md §4), wavelengths in nm; lamella normals in the mesh frame.
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

DPI = 110
#: hue range (nm) shown by the flash-colour maps when the flash spans less
WAVELENGTH_SPAN_NM = 40.0
GAP_PX = 4
#: score maps zoom to where a cut keeps at least this share of its best
ZOOM_KEEP = 0.3


def nm_range(lo: float | None, hi: float | None) -> str:
    """``481–486 nm``; one decimal when the range is narrower than 2 nm."""
    if lo is None or hi is None:
        return ""
    fmt = ".1f" if hi - lo < 2.0 else ".0f"
    return f"{lo:{fmt}}–{hi:{fmt}} nm"


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def png(fig: Any) -> bytes:
    """A matplotlib figure as PNG bytes (the figure is closed)."""
    plt = _plt()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    plt.close(fig)
    return buf.getvalue()


def image_png(rgb: np.ndarray) -> bytes:
    """An sRGB image in [0, 1] (H x W x 3) as 8-bit PNG bytes."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)), "RGB").save(buf, format="PNG")
    return buf.getvalue()


def cut_colours(n: int) -> list[Any]:
    """One colour per cut, the same in every figure."""
    plt = _plt()
    cmap = plt.get_cmap("tab10" if n <= 10 else "tab20")
    return [cmap(i % cmap.N) for i in range(n)]


def short(name: str, limit: int = 28) -> str:
    """A cut's name shortened for a legend."""
    return name if len(name) <= limit else name[: limit - 1] + "…"


# ---------------------------------------------------------------------- renders
def render_png(image: np.ndarray, exposure: float) -> bytes:
    """A linear render tonemapped with the scenario's shared ``exposure``."""
    from ..rendering.images import tonemap

    return image_png(tonemap(image, exposure))


def strip_png(frames: list[np.ndarray], exposure: float) -> bytes:
    """The frames of a rocking strip side by side (white gaps), one exposure."""
    from ..rendering.images import tonemap

    h = frames[0].shape[0]
    gap = np.ones((h, GAP_PX, 3))
    parts: list[np.ndarray] = []
    for i, f in enumerate(frames):
        if i:
            parts.append(gap)
        parts.append(tonemap(f, exposure))
    return image_png(np.concatenate(parts, axis=1))


# ---------------------------------------------------------------------- score maps
def score_maps(cmp: Any, scenario: str) -> bytes:
    """Per cut, the flash energy over lamella orientations (score / best) as a polar map: radius
    the tilt from +Z, angle the azimuth (+X right, +Y up in the panel: the back, or the top of an
    upright stone); star the optimum with its 90 % tolerance circle, cross the compromise."""
    plt = _plt()
    from matplotlib.tri import Triangulation

    from ..scene.directions import tilt_azimuth

    cuts = cmp.cuts
    cols = min(len(cuts), 3)
    rows = math.ceil(len(cuts) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols + 0.9, 3.0 * rows + 0.5), squeeze=False, constrained_layout=True)
    # one zoom for every panel: where any cut keeps >= 30 % of its best (and the compromise)
    lim = 15.0
    for c in cuts:
        rec = c.scenarios[scenario].recommendation
        t = np.degrees(np.arccos(np.clip(rec.map_normals[:, 2], -1, 1)))
        s = rec.map_scores / max(rec.score, 1e-30)
        if np.any(s >= ZOOM_KEEP):
            lim = max(lim, 1.2 * float(t[s >= ZOOM_KEEP].max()) + 3.0)
        lim = max(lim, 1.2 * tilt_azimuth(c.compromise.normal)[0] + 3.0)
    lim = min(lim, 90.0)
    levels = np.linspace(0.0, 1.0, 21)
    cs = None
    for k, c in enumerate(cuts):
        ax = axes[k // cols][k % cols]
        rec = c.scenarios[scenario].recommendation
        n = rec.map_normals
        s = np.clip(rec.map_scores / max(rec.score, 1e-30), 0.0, 1.0)
        t = np.degrees(np.arccos(np.clip(n[:, 2], -1, 1)))
        az = np.arctan2(n[:, 1], n[:, 0])
        x, y = t * np.cos(az), t * np.sin(az)
        near = t <= lim * 1.05
        if near.sum() >= 3 and np.ptp(x[near]) > 0 and np.ptp(y[near]) > 0:
            cs = ax.tricontourf(Triangulation(x[near], y[near]), s[near], levels=levels, cmap="magma")
        for ring in range(10, int(lim) + 1, 10):
            ax.add_patch(plt.Circle((0, 0), ring, fill=False, color="white", lw=0.5, alpha=0.5))
        bt, ba = rec.tilt_deg, rec.azimuth_deg
        bx, by = bt * math.cos(math.radians(ba)), bt * math.sin(math.radians(ba))
        ax.add_patch(plt.Circle((bx, by), rec.tolerance_deg, fill=False, color="cyan", lw=1.2))
        ax.plot(bx, by, "c*", ms=10)
        ct, ca = tilt_azimuth(c.compromise.normal)
        if len(cmp.scenarios) > 1:
            ax.plot(ct * math.cos(math.radians(ca)), ct * math.sin(math.radians(ca)), "wx", ms=8, mew=2)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_facecolor("black")
        ax.set_title(f"{short(c.name)}\nbest {bt:.1f}° @ {ba:.0f}°, ±{rec.tolerance_deg:.1f}°", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("tilt towards +X (right), °", fontsize=7)
        ax.set_ylabel("tilt towards +Y, °", fontsize=7)
    for k in range(len(cuts), rows * cols):
        axes[k // cols][k % cols].axis("off")
    if cs is not None:
        fig.colorbar(cs, ax=axes, shrink=0.8, label="flash energy / best")
    return png(fig)


# ---------------------------------------------------------------------- curves
def tilt_curves(cmp: Any, scenario: str) -> bytes:
    """Flash energy seen by the main viewer against the stone's tilt from its rest pose, front-to-back
    and side-to-side, one line per cut (each at its best orientation); the scenario's own rocking
    range shaded, the rocking strip's frames marked."""
    plt = _plt()
    colours = cut_colours(len(cmp.cuts))
    fig, axes = plt.subplots(1, 2, figsize=(8.0, 3.2), sharey=True, constrained_layout=True)
    titles = {"front_back": "front-to-back (+: far/top edge towards the viewer)",
              "side_to_side": "side-to-side (+: right edge turns away)"}
    strip = cmp.render.get("strip_angles_deg", [])
    for ax, key in zip(axes, ("front_back", "side_to_side")):
        sc = next(s for s in cmp.scenarios if s.name == scenario)
        amp = sc.rock_deg if key == "front_back" else sc.sway_deg
        if amp > 0:
            ax.axvspan(-amp, amp, color="0.9", label=f"scenario rocks ±{amp:g}°")
        for c, col in zip(cmp.cuts, colours):
            tc = c.scenarios[scenario].tilt
            ax.plot(tc.angles_deg, tc.flash_energy[key], color=col, lw=1.8, marker="o", ms=3, label=short(c.name))
            if key == "front_back":
                ys = np.interp(strip, tc.angles_deg, np.nan_to_num(tc.flash_energy[key]))
                ax.plot(strip, ys, ls="none", marker="s", mfc="none", mec=col, ms=7)
        ax.axvline(0.0, color="0.5", lw=0.8)
        ax.set_title(titles[key], fontsize=9)
        ax.set_xlabel("tilt of the stone from its rest pose, degrees", fontsize=8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    axes[0].set_ylabel("flash energy (main viewer), L_ref", fontsize=8)
    axes[0].set_ylim(bottom=0)
    axes[1].legend(fontsize=7, loc="upper right")
    return png(fig)


def misorientation_curves(cmp: Any, scenario: str) -> bytes:
    """Flash energy relative to the optimum when the cutter misses it by an angle: mean (solid) and
    worst (dashed) over directions around it, one colour per cut; the 90 % line and each cut's
    tolerance marked."""
    plt = _plt()
    colours = cut_colours(len(cmp.cuts))
    fig, ax = plt.subplots(figsize=(6.4, 3.3), constrained_layout=True)
    for c, col in zip(cmp.cuts, colours):
        mc = c.scenarios[scenario].misorientation
        ax.plot(mc.miss_deg, mc.mean, color=col, lw=1.8, label=f"{short(c.name)} (±{mc.tolerance_deg:.1f}°)")
        ax.plot(mc.miss_deg, mc.worst, color=col, lw=1.2, ls="--")
        ax.axvline(mc.tolerance_deg, color=col, lw=0.8, ls=":")
    ax.axhline(0.9, color="0.4", lw=0.8)
    ax.text(0.2, 0.905, "90 %", fontsize=7, color="0.3", va="bottom")
    ax.set_xlabel("miss: angle between the lamella normal cut and the optimum, degrees", fontsize=8)
    ax.set_ylabel("flash energy / at the optimum", fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_xlim(left=0)
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=8)
    ax.legend(fontsize=7, loc="lower left", title="solid: mean, dashed: worst direction", title_fontsize=7)
    return png(fig)


# ---------------------------------------------------------------------- flash colour
def wavelength_range(cmp: Any) -> tuple[float, float]:
    """One wavelength scale (nm) for every flash-colour map of the report: the 2nd-98th
    percentiles of all flashing pixels' dominant wavelengths, at least :data:`WAVELENGTH_SPAN_NM` wide."""
    values = []
    for c in cmp.cuts:
        for r in c.scenarios.values():
            if r.colour is None:
                continue
            lam = r.colour.wavelength_nm
            sel = np.isfinite(lam) & (lam > 0) & (r.colour.level >= (1.0 if r.colour.stats["basis"] == "flash" else 0.0))
            values.append(lam[sel])
    allv = np.concatenate(values) if values else np.array([])
    if allv.size == 0:
        return 450.0, 650.0
    lo, hi = np.percentile(allv, [2, 98])
    mid, half = 0.5 * (lo + hi), max(0.5 * (hi - lo), 0.5 * WAVELENGTH_SPAN_NM)
    return float(mid - half), float(mid + half)


def spectral_colormap(lo: float, hi: float) -> Any:
    """A matplotlib colour map over wavelengths ``lo``-``hi`` nm painting each wavelength in its own
    colour (:func:`labcut.colour.spectral_srgb`), for the colour bars of flash-colour figures."""
    from matplotlib.colors import ListedColormap

    from ..colour import spectral_srgb

    return ListedColormap(spectral_srgb(np.linspace(lo, hi, 256)), name="labcut-spectral")


def colour_map_rgba(fm: Any, lo: float, hi: float) -> np.ndarray:
    """The RGBA picture of a flash-colour map: flashing pixels in the colour of their dominant
    wavelength (:func:`labcut.colour.spectral_srgb`: a 477 nm flash is blue),
    pixels below the threshold in the same colours faded by their level, the rest of the stone
    grey, background transparent."""
    from ..colour import spectral_srgb

    lam = fm.wavelength_nm
    coloured = np.concatenate([spectral_srgb(np.clip(np.nan_to_num(lam, nan=lo), lo, hi)),
                               np.ones(lam.shape + (1,))], axis=-1)
    grey = np.array([0.78, 0.78, 0.78, 1.0])
    alpha = np.clip(fm.level, 0.0, 1.0)[..., None] ** 0.5
    alpha = np.where(fm.level[..., None] >= 1.0, 1.0, 0.6 * alpha)
    hue = np.isfinite(lam) & (lam > 0)
    purple = np.isfinite(lam) & (lam < 0)
    coloured[purple] = np.array([0.8, 0.1, 0.8, 1.0])
    out = np.where((hue | purple)[..., None], alpha * coloured + (1 - alpha) * grey, grey)
    out[..., 3] = np.where(fm.mask, 1.0, 0.0)
    return out


def colour_maps(cmp: Any, scenario: str) -> bytes:
    """Per cut, the dominant wavelength of the flash over the stone as the main viewer sees it,
    each pixel in that wavelength's own colour, one wavelength scale for the whole report; faded where the schiller stays below the
    threshold, grey where there is none; magenta for purples."""
    plt = _plt()
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    lo, hi = wavelength_range(cmp)
    cuts = cmp.cuts
    cols = min(len(cuts), 4)
    rows = math.ceil(len(cuts) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(2.4 * cols + 1.0, 2.6 * rows + 0.3), squeeze=False, constrained_layout=True)
    for k, c in enumerate(cuts):
        ax = axes[k // cols][k % cols]
        fm = c.scenarios[scenario].colour
        ax.imshow(colour_map_rgba(fm, lo, hi), interpolation="nearest")
        st = fm.stats
        nm = st.get("dominant_wavelength_nm")

        text = "no hue" if nm is None else f"{nm:.0f} nm ({nm_range(st['p10_nm'], st['p90_nm'])})"
        est = st.get("estimator_flash_area")
        said = "" if est is None else f" (est. {est:.0%})"
        what = f"flash {st['flash_fraction']:.0%}{said}" if st["basis"] == "flash" else f"no flash: faint schiller{said}"
        ax.set_title(f"{short(c.name)}\n{text}\n{what}", fontsize=7.5)
        ax.axis("off")
    for k in range(len(cuts), rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.colorbar(ScalarMappable(Normalize(lo, hi), spectral_colormap(lo, hi)), ax=axes, shrink=0.85,
                 label="dominant λ, nm (its own colour)")
    return png(fig)


# ---------------------------------------------------------------------- design parameters
DESIGN_PARAMETERS = {"length_mm": "length (X), mm", "width_mm": "width (Y), mm", "height_mm": "height (Z), mm"}


def design_layout(cmp: Any) -> dict[str, Any]:
    """How the cuts spread over their design parameters (:data:`DESIGN_PARAMETERS`, rounded to
    0.01 mm): ``kind`` ``"heatmap"`` (two parameters vary and place every cut in its own cell),
    ``"line"`` (one parameter, or two that do not), or ``"none"`` (all cuts measure the same),
    with ``x``/``y`` the parameters and ``why`` a sentence for the page."""
    values = {p: [round(float(c.cut.design[p]), 2) for c in cmp.cuts] for p in DESIGN_PARAMETERS}
    varying = [p for p in DESIGN_PARAMETERS if len(set(values[p])) > 1]
    if not varying:
        return {"kind": "none", "x": None, "y": None, "values": values,
                "why": "all cuts measure the same (length, width, height): there is no design parameter to chart"}
    pairs = [(p, q) for i, p in enumerate(varying) for q in varying[i + 1:]]
    for p, q in pairs:
        cells = list(zip(values[p], values[q]))
        if len(set(cells)) == len(cells):
            return {"kind": "heatmap", "x": p, "y": q, "values": values,
                    "why": f"the cuts differ in {DESIGN_PARAMETERS[p]} and {DESIGN_PARAMETERS[q]}"}
    x = max(varying, key=lambda p: len(set(values[p])))
    return {"kind": "line", "x": x, "y": None, "values": values, "why": f"the cuts differ in {DESIGN_PARAMETERS[x]}"}


def design_chart(cmp: Any) -> bytes | None:
    """Flash energy at each cut's best orientation, normalised to the reference cut, over the
    design parameters: a heat map over two (cells annotated with the value and the tolerance),
    else against one; one panel per scenario. None when the cuts do not differ."""
    layout = design_layout(cmp)
    if layout["kind"] == "none":
        return None
    plt = _plt()
    names = cmp.scenario_names
    fig, axes = plt.subplots(1, len(names), figsize=(3.6 * len(names) + 0.6, 3.2), squeeze=False, constrained_layout=True)
    vals = layout["values"]
    for ax, scen in zip(axes[0], names):
        z = [c.scenarios[scen].normalised.get("flash_energy") for c in cmp.cuts]
        z = np.array([np.nan if v is None else v for v in z])
        tol = [c.scenarios[scen].recommendation.tolerance_deg for c in cmp.cuts]
        if layout["kind"] == "heatmap":
            xs, ys = sorted(set(vals[layout["x"]])), sorted(set(vals[layout["y"]]))
            grid = np.full((len(ys), len(xs)), np.nan)
            for k in range(len(cmp.cuts)):
                i, j = ys.index(vals[layout["y"]][k]), xs.index(vals[layout["x"]][k])
                grid[i, j] = z[k]
                ax.text(j, i, f"{z[k]:.2f}\n±{tol[k]:.1f}°", ha="center", va="center", fontsize=7,
                        color="white" if np.nan_to_num(z[k]) < 0.6 * np.nanmax(z) else "black")
            im = ax.imshow(np.ma.masked_invalid(grid), origin="lower", cmap="viridis", aspect="auto")
            ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs], fontsize=7)
            ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys], fontsize=7)
            ax.set_ylabel(DESIGN_PARAMETERS[layout["y"]], fontsize=8)
            fig.colorbar(im, ax=ax, shrink=0.85, label="flash energy / reference")
        else:
            x = np.array(vals[layout["x"]])
            order = np.argsort(x, kind="stable")
            ax.plot(x[order], z[order], "-o", color="#2b6cb0", ms=5)
            for k in range(len(cmp.cuts)):
                ax.annotate(f"±{tol[k]:.1f}°", (x[k], z[k]), textcoords="offset points", xytext=(4, 4), fontsize=6.5)
            ax.set_ylabel("flash energy / reference", fontsize=8)
            ax.set_ylim(bottom=0)
            ax.grid(alpha=0.3)
        ax.set_xlabel(DESIGN_PARAMETERS[layout["x"]], fontsize=8)
        ax.set_title(f"scenario {scen}", fontsize=9)
        ax.tick_params(labelsize=7)
    return png(fig)
