"""Pictures of a rough plan: the rough, translucent, with its stones and the flash plane inside
from three views; each stone rendered with the lamella orientation the rough imposes; the front
of weight against flash; the slab question's curve. As one self-contained HTML page
(:func:`write_html`, checked in Chromium by ``tests/test_rough_browser.py``) and as one PNG
(:func:`write_png`). Views are orthographic, mm, in the rough's frame.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import atomic_output
from ..reports.figures import png, render_png
from ..reports.html import data_uri
from ..scene.directions import tilt_azimuth

#: (title, horizontal axis, vertical axis) of the three views, rough frame
VIEWS = (("from the top (x right, y back)", 0, 1), ("from the front (x right, z up)", 0, 2),
         ("from the right (y back, z up)", 1, 2))
#: render of each stone: pixels and samples per pixel
RENDER_RESOLUTION = 160
RENDER_SPP = 16
#: triangles drawn of the rough at most in each view (a scan is drawn by its hull's silhouette)
DRAWN_TRIANGLES = 20_000


def _silhouette(ax: Any, mesh: Any, i: int, j: int, **style: Any) -> None:
    from matplotlib.collections import PolyCollection

    tri = np.asarray(mesh.triangles)[:, :, [i, j]]
    if len(tri) > DRAWN_TRIANGLES:
        from scipy.spatial import ConvexHull

        pts = np.asarray(mesh.vertices)[:, [i, j]]
        tri = pts[ConvexHull(pts).vertices][None]
    ax.add_collection(PolyCollection(tri, **style))


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw_views(axes: Any, plan: Any) -> None:
    """The rough (grey, translucent), its stones (coloured, numbered) and the flash plane's trace
    (dashed, through the rough's centre, with the lamella normal's arrow) from the top, the front
    and the right, into three matplotlib axes."""
    colours = _pyplot().get_cmap("tab10")
    lo, hi = plan.rough.bounds
    centre = (lo + hi) / 2.0
    span = float(np.max(hi - lo))
    n = plan.lamella_normal
    for ax, (title, i, j) in zip(axes, VIEWS):
        _silhouette(ax, plan.rough.mesh, i, j, facecolor=(0.6, 0.6, 0.62, 0.08), edgecolor=(0.4, 0.4, 0.45, 0.15), linewidth=0.3)
        for k, s in enumerate(plan.stones):
            c = colours(k % 10)
            _silhouette(ax, s.mesh, i, j, facecolor=(*c[:3], 0.22), edgecolor="none")
            mid = np.asarray(s.mesh.bounds).mean(axis=0)
            ax.annotate(str(k + 1), (mid[i], mid[j]), ha="center", va="center", fontsize=11, weight="bold", color="black")
        d = np.array([n[i], n[j]])
        if np.linalg.norm(d) > 1e-6:
            d = d / np.linalg.norm(d)
            trace = np.array([-d[1], d[0]])
            pts = np.array([centre[[i, j]] - trace * span, centre[[i, j]] + trace * span])
            ax.plot(pts[:, 0], pts[:, 1], "--", color="#7a3fb0", linewidth=1.2)
            ax.annotate("", xy=centre[[i, j]] + d * 0.18 * span, xytext=centre[[i, j]],
                        arrowprops={"arrowstyle": "->", "color": "#7a3fb0", "linewidth": 1.5})
        ax.set_xlim(lo[i] - 0.05 * span, hi[i] + 0.05 * span)
        ax.set_ylim(lo[j] - 0.05 * span, hi[j] + 0.05 * span)
        ax.set_aspect("equal")
        ax.set_title(title + "; dashed: the flash plane", fontsize=9)
        ax.set_xlabel(f"{'xyz'[i]} (mm)")
        ax.set_ylabel(f"{'xyz'[j]} (mm)")


def draw_front(a: Any, b: Any, plan: Any) -> None:
    """Weight against flash ratio (the front over every cut and pose tried for one stone, the
    plan's stones marked) into ``a``; the slab question's curve (the longest stone that keeps at
    least each flash ratio) into ``b``."""
    cmap = _pyplot().get_cmap("tab10")
    front = plan.pareto
    a.plot([p["carats"] for p in front], [p["flash_ratio"] for p in front], "o-", color="#555", markersize=4,
           label="best flash at each weight (one stone)")
    for k, s in enumerate(plan.stones):
        a.plot([s.carats], [s.flash_ratio], "s", markersize=9, color=cmap(k % 10), label=f"stone {k + 1}")
    a.set_xlabel("weight (carats)")
    a.set_ylabel("flash ratio (of the cut's best)")
    a.set_ylim(0, 1.05)
    a.grid(alpha=0.3)
    a.legend(fontsize=8)
    a.set_title("weight against flash", fontsize=10)
    curve = [c for c in plan.tradeoff["curve"] if c["length_mm"] > 0]
    b.plot([c["length_mm"] for c in curve], [c["flash_ratio"] for c in curve], "o-", color="#7a3fb0")
    b.set_xlabel(f"longest {plan.tradeoff['cut']} that fits (mm)")
    b.set_ylabel("flash ratio kept at least")
    b.set_ylim(0, 1.05)
    b.grid(alpha=0.3)
    b.set_title("what a bigger stone costs in flash", fontsize=10)


def views_figure(plan: Any) -> Any:
    fig, axes = _pyplot().subplots(1, 3, figsize=(12.0, 4.2), constrained_layout=True)
    draw_views(axes, plan)
    return fig


def front_figure(plan: Any) -> Any:
    fig, (a, b) = _pyplot().subplots(1, 2, figsize=(11.0, 4.0), constrained_layout=True)
    draw_front(a, b, plan)
    return fig


def stone_renders(plan: Any) -> list[bytes]:
    """Each stone rendered (studio look, the plan's material and scenario, its main view) with the
    lamella normal the rough imposes, as PNG bytes."""
    from ..commands.render import render

    out = []
    for s in plan.stones:
        result = render(s.cut, _material(plan), s.lamella_normal_cut,
                        scenario=plan.scenario if plan.scenario is not None else plan.settings["scenario"],
                        resolution=RENDER_RESOLUTION, spp=RENDER_SPP,
                        check_flash=False)
        out.append(render_png(result.image, result.exposure))
    return out


def _material(plan: Any) -> Any:
    from ..physics.material import Labradorite

    return Labradorite.from_dict(plan.settings["material"])


def write_png(plan: Any, path: str | Path) -> Path:
    """The three views above the front and the curve, one PNG, written atomically."""
    plt = _pyplot()
    fig = plt.figure(figsize=(12.0, 8.6), constrained_layout=True)
    grid = fig.add_gridspec(2, 6)
    draw_views([fig.add_subplot(grid[0, 2 * k : 2 * k + 2]) for k in range(3)], plan)
    draw_front(fig.add_subplot(grid[1, 0:3]), fig.add_subplot(grid[1, 3:6]), plan)
    with atomic_output(path, (".png",)) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return Path(path)


_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<style>
body {{ font: 15px/1.45 system-ui, sans-serif; margin: 0 auto; max-width: 1180px; padding: 1rem; color: #222; }}
h1 {{ font-size: 1.4rem; }} h2 {{ font-size: 1.15rem; margin-top: 1.6rem; }}
img {{ max-width: 100%; height: auto; }}
table {{ border-collapse: collapse; width: 100%; font-size: 0.92rem; }}
th, td {{ border-bottom: 1px solid #ddd; padding: 0.3rem 0.45rem; text-align: right; }}
th:first-child, td:first-child {{ text-align: left; }}
.stones {{ display: grid; grid-template-columns: repeat(auto-fill, minmax(320px, 1fr)); gap: 1rem; }}
.stone {{ border: 1px solid #ddd; border-radius: 6px; padding: 0.6rem; }}
.stone img {{ width: 160px; float: right; margin-left: 0.5rem; }}
.stone ol {{ padding-left: 1.2rem; }} .note {{ color: #6a5a00; }}
.wide {{ overflow-x: auto; }}
@media print {{ .stone {{ break-inside: avoid; }} }}
</style></head><body>
<h1>{title}</h1>
<p>{summary}</p>
{notes}
<h2>The rough and its stones</h2>
<img src="{views}" alt="the rough from the top, the front and the right, with the stones and the flash plane">
<div class="wide"><table>
<tr><th>stone</th><th>size (mm)</th><th>carats</th><th>flash ratio</th><th>flash plane in the stone</th><th>off the cut's best</th><th>tolerance</th></tr>
{rows}
</table></div>
<h2>Workshop steps</h2>
<div class="stones">{stones}</div>
<h2>Weight against flash</h2>
<img src="{front}" alt="the front of weight against flash ratio, and the longest stone against the flash it keeps">
<p>{checks}</p>
<p>Made by labcut {version} in {seconds:.1f} s ({settings}).</p>
</body></html>
"""


def render_html(plan: Any, renders: bool = True) -> str:
    """The report page (self-contained: every picture inline)."""
    from .. import __version__

    esc = html.escape
    d = plan.to_dict()
    renders_png = stone_renders(plan) if renders else [None] * len(plan.stones)
    tilt, az = tilt_azimuth(plan.lamella_normal)
    rows, cards = [], []
    for s, image in zip(plan.stones, renders_png):
        mt, _ = tilt_azimuth(s.lamella_normal_cut)
        size = " x ".join(f"{x:.1f}" for x in s.size_mm)
        rows.append(f"<tr><td>{esc(s.name)}</td><td>{size}</td><td>{s.carats:.2f}</td><td>{s.flash_ratio:.0%}</td>"
                    f"<td>{mt:.1f}° from the base</td><td>{s.off_best_deg:.1f}°</td><td>±{s.tolerance_deg:.1f}°</td></tr>")
        img = (f'<img src="{data_uri(image)}" alt="{esc(s.name)} rendered with the lamella orientation the rough imposes">'
               if image is not None else "")
        steps = "".join(f"<li>{esc(t)}</li>" for t in s.workshop)
        cards.append(f'<div class="stone"><h3>{esc(s.name)}</h3>{img}<ol>{steps}</ol></div>')
    notes = "".join(f'<p class="note">{esc(n)}</p>' for n in plan.notes)
    c = plan.checks
    checks = (f"Checked with manifold3d: every stone inside the rough ({'yes' if c['inside'] else 'NO'}), "
              f"the stones apart ({'yes' if c['apart'] else 'NO'}); least clearance to the rough's surface "
              f"{min(x['clearance_mm'] for x in c['stones']):.2f} mm (margin {c['margin_mm']:g} mm).")
    settings = ", ".join(f"{k} {v}" for k, v in d["settings"].items() if k in ("quality", "rank", "scenario", "count", "margin_mm"))
    summary = (f"{esc(plan.rough.name)}: {plan.rough.carats:.1f} ct of rough, flash plane tilted {tilt:.1f}° from its top "
               f"face towards azimuth {az:.0f}°. {len(plan.stones)} stone(s), {d['carats']:.2f} ct in all: "
               f"{plan.yield_fraction:.0%} of the rough's weight.")
    return _PAGE.format(title=esc(f"labcut rough plan: {plan.rough.name}"), summary=summary, notes=notes,
                        views=data_uri(png(views_figure(plan))), rows="\n".join(rows), stones="\n".join(cards),
                        front=data_uri(png(front_figure(plan))), checks=checks, version=esc(__version__),
                        seconds=plan.seconds, settings=esc(settings))


def write_html(plan: Any, path: str | Path, renders: bool = True) -> Path:
    """Write the report page atomically; returns its path."""
    text = render_html(plan, renders)
    with atomic_output(path, (".html", ".htm")) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return Path(path)
