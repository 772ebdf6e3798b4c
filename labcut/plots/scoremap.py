"""Polar map of a flash objective over the hemisphere of lamella normals."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..fileio import atomic_output


def plot_score_map(rec: Any, path: str | os.PathLike[str], title: str | None = None) -> None:
    """Write a PNG: score vs lamella-normal tilt (radius, degrees) and azimuth (angle),
    with the recommendation, its tolerance circle and the runners-up marked.

    Azimuth 0° is +X (the stone's right), 90° is +Y (back), 270° is -Y (front).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    from ..scene.directions import tilt_azimuth

    n = rec.map_normals
    s = rec.map_scores / max(float(rec.score), 1e-30)
    axis = rec.settings.get("tilt_axis") if isinstance(getattr(rec, "settings", None), dict) else None
    if axis is not None:
        _plot_axis_scores(rec, np.asarray(axis, dtype=np.float64), n, s, path, title)
        return
    tilt = np.degrees(np.arccos(np.clip(n[:, 2], -1, 1)))
    az = np.arctan2(n[:, 1], n[:, 0])
    x, y = tilt * np.cos(az), tilt * np.sin(az)
    fig, ax = plt.subplots(figsize=(6.4, 5.6), constrained_layout=True)
    if len(n) >= 3 and np.ptp(x) > 0 and np.ptp(y) > 0:
        tri = Triangulation(x, y)
        cs = ax.tricontourf(tri, s, levels=np.linspace(0, max(1.0, float(s.max())), 21), cmap="magma")
        fig.colorbar(cs, ax=ax, label=f"{rec.objective} / best")
    else:
        ax.scatter(x, y, c=s, cmap="magma")
    # zoom to where the score lives (>= 2 % of the best), with a margin; never below 15°
    lit = tilt[s >= 0.02] if np.any(s >= 0.02) else tilt
    lim = float(min(tilt.max() if len(tilt) else 90.0, max(15.0, 1.3 * float(lit.max()) + 3.0)))
    step = 5 if lim <= 35 else 15
    for ring in range(step, int(lim) + 1, step):
        ax.add_patch(plt.Circle((0, 0), ring, fill=False, color="white", lw=0.5, alpha=0.5))
        ax.text(ring * math.cos(math.radians(45)), ring * math.sin(math.radians(45)), f"{ring}°", color="white", fontsize=7)
    bt, ba = tilt_azimuth(rec.normal)
    bx, by = bt * math.cos(math.radians(ba)), bt * math.sin(math.radians(ba))
    ax.add_patch(plt.Circle((bx, by), rec.tolerance_deg, fill=False, color="cyan", lw=1.5, label=f"90 % tolerance ±{rec.tolerance_deg:.1f}°"))
    ax.plot(bx, by, "c*", ms=14, label=f"best: tilt {bt:.1f}°, azimuth {ba:.0f}°")
    for i, r in enumerate(rec.runners_up):
        rx, ry = r["tilt_deg"] * math.cos(math.radians(r["azimuth_deg"])), r["tilt_deg"] * math.sin(math.radians(r["azimuth_deg"]))
        ax.plot(rx, ry, "wo", ms=7, mfc="none")
        ax.text(rx, ry, f" {i + 2}", color="white", fontsize=8)
    ax.set_aspect("equal")
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_xlabel("tilt towards right (+X), degrees")
    ax.set_ylabel("tilt towards back (+Y), degrees")
    ax.set_title(title or "flash score over lamella orientations (front of the stone at the bottom)", fontsize=9)
    ax.legend(loc="lower right", fontsize=7)
    with atomic_output(path, (".png",)) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def _plot_axis_scores(rec: Any, axis: np.ndarray, normals: np.ndarray, s: np.ndarray, path: Any, title: str | None) -> None:
    """With a fixed tilt axis the map is one-dimensional: score vs tilt angle about the axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    z = np.array([0.0, 0.0, 1.0])

    def angle(m: np.ndarray) -> float:
        return math.degrees(math.atan2(float(np.cross(z, m) @ axis), float(m @ z)))

    x = np.array([angle(m) for m in normals])
    order = np.argsort(x)
    best = angle(np.asarray(rec.normal))
    fig, ax = plt.subplots(figsize=(6.4, 3.8), constrained_layout=True)
    ax.plot(x[order], s[order], color="#2b6cb0", lw=2)
    ax.axvspan(best - rec.tolerance_deg, best + rec.tolerance_deg, color="cyan", alpha=0.25, label=f"90 % tolerance ±{rec.tolerance_deg:.1f}°")
    ax.axvline(best, color="c", lw=1.5, label=f"best: {best:+.1f}° about the axis")
    ax.set_xlabel(f"tilt of the lamella normal about the axis ({axis[0]:+.2f}, {axis[1]:+.2f}, {axis[2]:+.2f}), degrees")
    ax.set_ylabel(f"{rec.objective} / best")
    ax.set_ylim(0, max(1.05, float(s.max()) * 1.05))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or "flash score vs tilt about the fixed axis", fontsize=9)
    with atomic_output(path, (".png",)) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
