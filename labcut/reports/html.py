"""The comparison report as one self-contained HTML page (jinja2 template ``templates/compare.html.j2``).

Images are embedded as ``data:`` PNGs; there is no script and nothing is fetched (a
Content-Security-Policy of ``default-src 'none'`` says so to the browser). The layout reflows
on a phone (tables scroll sideways, figures shrink) and prints on A4 (print CSS: one scenario
per page, no figure split).
"""

from __future__ import annotations

import base64
import os
from pathlib import Path
from typing import Any

from . import figures as fg

#: what the report's numbers mean (its JSON's ``metric_definitions``, the page's last section)
COMPARE_DEFINITIONS = {
    "flash_energy": "mean schiller radiance over the whole visible stone, in units of L_ref (a flat face, lamellae "
                    "parallel, lit and seen along its normal by one light of the same total irradiance); mean over the "
                    "scenario's viewers and poses. The ranking metric.",
    "flash_area": "share of the visible stone (projected area) whose schiller reaches the flash threshold tau x P x L_ref "
                  "(tau = 0.1; P the brightest schiller the scenario's light can give, scene_peak); mean over viewers",
    "flash_intensity": "mean schiller radiance / L_ref over the part that flashes (0 where none does); mean over viewers",
    "coverage": "share (weight) of the viewers that see a flash on more than 5 % of the stone",
    "energy_in_flash": "the part of the flash energy in the flashing regions: sum over views of weight x area x intensity",
    "energy_below_threshold": "the part of the flash energy in schiller fainter than tau x P x L_ref",
    "tolerance_deg": "how far (degrees) the lamella normal may miss the optimum in any direction and keep 90 % of the "
                     "flash energy; front_back_deg / left_right_deg: the same, missing only towards the front/back "
                     "(±Y) or the sides (±X) of the stone",
    "normalised": "a cut's value divided by the reference cut's under the same scenario, each at its own best "
                  "orientation (1 = as good as the reference; empty where the reference's value is 0)",
    "rank": "per scenario: order by flash energy at each cut's own best orientation (1 = most); overall: order by "
            "overall_score. A cut's rank is 1 + the number of cuts better than it beyond the error bars (the difference "
            "larger than the two bars added in quadrature): cuts within each other's error bars share a rank, a tie "
            "(tied: true; '=1' in tables)",
    "error_bars": "every ± beside a score is its error bar: with about 95 % confidence the score converged at high "
                  "sampling lies that close (flash_energy_error, overall_score_error; the recommendation's "
                  "uncertainty.score_rel relative). Two scores closer than their bars are not told apart: a tie",
    "verdict": "the comparison in words: the cut that flashes most, the cuts tied for it, or that no cut shows flash "
               "(none reaches tau x P x L_ref at its best orientation) and what to try; scenario_verdicts per scenario",
    "overall_score": "mean over the scenarios of a cut's flash energy at its compromise orientation divided by the "
                     "reference cut's at its own compromise orientation",
    "compromise": "one lamella orientation per cut for all chosen scenarios: the normal maximising the mean over "
                  "scenarios of flash energy / that scenario's best; relative_to_best: energy at the compromise / "
                  "energy at the scenario's own optimum",
    "weight_ct": "carat weight at labradorite's density 2.705 g/cm³ (1 ct = 0.2 g); weight_ct_range: at 2.69-2.72 g/cm³",
    "tilt_curve": "flash energy (and area) seen by the scenario's main viewer when the stone, cut at its best "
                  "orientation, is tilted from its rest pose by the angle on the x axis, lights and viewer fixed: "
                  "front_back about the horizontal axis across the line of sight (+: the far or top edge comes towards "
                  "the viewer), side_to_side about the picture's vertical (+: the right edge turns away)",
    "score_map": "flash energy at lamella normals over the hemisphere (tilt from +Z, azimuth from +X towards +Y), "
                 "divided by the best",
    "dominant_wavelength_nm": "dominant wavelength (CIE 15) of the flash as the main viewer sees it, from a render of the "
                              "schiller alone: the luminance-weighted median over the pixels that flash (or, where none "
                              "does, over the faint schiller); p10_nm / p90_nm the 10th / 90th percentiles; negative "
                              "values are purples' complementary wavelengths",
    "flash_fraction": "share of the stone's pixels whose schiller radiance reaches tau x P x L_ref (the lights summed exactly "
                      "from the render's camera: the flash mask): the main view's flash area as the picture shows it, "
                      "beside the estimator's (est.) for the same view at rest",
    "estimator_flash_area": "the surface-sample estimator's flash area of the main view at rest (the tilt curve at 0°)",
    "exposure": "the multiplier every render and rocking-strip frame is tonemapped with: the bench reference, one for "
                "all cuts and all scenarios, so brightness differences between their pictures are real",
}

TEMPLATE = "compare.html.j2"


def data_uri(png: bytes) -> str:
    """A PNG as a ``data:`` URI."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _pct(v: float | None) -> str:
    return "–" if v is None else f"{v:.1%}"


def _num(v: float | None, fmt: str = ".3f") -> str:
    return "–" if v is None else format(v, fmt)


def rank_label(rank: int, tied: bool) -> str:
    """A rank for a table: ``2``, or ``=2`` when another cut shares it (a tie within the error bars)."""
    return f"={rank}" if tied else str(rank)


def _times(v: float | None) -> str:
    return "–" if v is None else f"×{v:.2f}"


def _scenario_rows(cmp: Any, name: str) -> list[dict[str, Any]]:
    rows = []
    for c in cmp.cuts:
        r = c.scenarios[name]
        rec, m, nz = r.recommendation, r.recommendation.metrics, r.normalised
        st = r.colour.stats if r.colour is not None else {}
        rows.append({
            "rank": rank_label(r.rank, r.tied), "name": c.name, "reference": c is cmp.reference_cut,
            "description": rec.description, "workshop": rec.workshop.get("text", ""),
            "angles": f"{rec.tilt_deg:.1f}° / {rec.azimuth_deg:.0f}°",
            "tolerance": f"±{rec.tolerance_deg:.1f}°", "tolerance_x": _times(nz.get("tolerance_deg")),
            "front_back": f"±{rec.tolerance_by_axis['front_back_deg']:.1f}°",
            "left_right": f"±{rec.tolerance_by_axis['left_right_deg']:.1f}°",
            "energy": f"{m.flash_energy:.4f} ± {r.energy_error:.4f}", "energy_x": _times(nz.get("flash_energy")),
            "area": _pct(m.flash_area) + ("" if m.flash_area_mm2 is None else f", {m.flash_area_mm2:.3g} mm²"),
            "area_x": _times(nz.get("flash_area")),
            "intensity": f"{m.flash_intensity:.3f}", "intensity_x": _times(nz.get("flash_intensity")),
            "coverage": _pct(m.coverage), "coverage_x": _times(nz.get("coverage")),
            "weight": f"{c.summary.weight_ct:.2f} ct",
            "colour_nm": "–" if st.get("dominant_wavelength_nm") is None else f"{st['dominant_wavelength_nm']:.0f} nm",
            "colour_range": fg.nm_range(st.get("p10_nm"), st.get("p90_nm")),
            "colour_hex": st.get("mean_hex"), "colour_basis": st.get("basis"),
            "no_flash": m.flash_area == 0.0, "rest_area": _pct(r.tilt.at_rest("flash_area")),
        })
    return rows


def context(cmp: Any) -> dict[str, Any]:
    """Everything the template shows: formatted tables and figures as data URIs."""
    from .. import __version__
    from ..orientation.recommend import FRAME, METRIC_DEFINITIONS

    names = cmp.scenario_names
    summary = []
    for c in cmp.ranked():
        summary.append({
            "rank": rank_label(c.rank, c.tied), "name": c.name, "reference": c is cmp.reference_cut,
            "weight": f"{c.summary.weight_ct:.2f}",
            "overall": f"{c.overall_score:.2f} ± {c.overall_error:.2f}", "compromise": c.compromise_description,
            "compromise_tolerance": f"±{c.compromise.tolerance_deg:.1f}°",
            "scenarios": [{"rank": rank_label(c.scenarios[n].rank, c.scenarios[n].tied),
                           "energy": f"{c.scenarios[n].energy:.4f} ± {c.scenarios[n].energy_error:.4f}",
                           "energy_x": _times(c.scenarios[n].normalised.get("flash_energy")),
                           "tolerance": f"±{c.scenarios[n].recommendation.tolerance_deg:.1f}°"} for n in names],
        })
    scenarios = []
    for sc in cmp.scenarios:
        n = sc.name
        exposure = cmp.exposures[n]
        scenarios.append({
            "name": n, "description": sc.description, "lighting": sc.lights.name, "viewing": sc.views.name,
            "rock": sc.rock_deg, "sway": sc.sway_deg, "poses": len(sc.poses()), "exposure": f"{exposure:.3g}",
            "plus_y": "its top, the bail end, as this scenario wears it upright" if sc.worn_upright else "its back",
            "rows": _scenario_rows(cmp, n), "verdict": cmp.scenario_verdict(n), "any_flash": cmp.flashes(n),
            "renders": [{"name": c.name, "rank": c.scenarios[n].rank, "note": c.scenarios[n].recommendation.metrics.flash_area == 0.0,
                         "rest_area": _pct(c.scenarios[n].tilt.at_rest("flash_area")),
                         "src": data_uri(fg.render_png(c.scenarios[n].renders.main, exposure))} for c in cmp.cuts],
            "view": cmp.cuts[0].scenarios[n].renders.view,
            "strips": [{"name": c.name, "src": data_uri(fg.strip_png(c.scenarios[n].renders.strip, exposure))} for c in cmp.cuts],
            "strip_angles": ", ".join(f"{a:+g}°" for a in cmp.render["strip_angles_deg"]),
            "score_maps": data_uri(fg.score_maps(cmp, n)),
            "tilt": data_uri(fg.tilt_curves(cmp, n)),
            "tilt_notes": sorted({note for c in cmp.cuts for note in c.scenarios[n].tilt.notes}),
            "misorientation": data_uri(fg.misorientation_curves(cmp, n)),
            "colour": data_uri(fg.colour_maps(cmp, n)),
        })
    compromise = []
    for c in cmp.cuts:
        compromise.append({
            "name": c.name, "description": c.compromise_description, "workshop": c.compromise_workshop.get("text", ""),
            "tolerance": f"±{c.compromise.tolerance_deg:.1f}°",
            "front_back": f"±{c.compromise.tolerance_by_axis['front_back_deg']:.1f}°",
            "left_right": f"±{c.compromise.tolerance_by_axis['left_right_deg']:.1f}°",
            "score": f"{c.compromise.score:.1%}",
            "scenarios": [{"relative": f"{c.scenarios[n].compromise_relative:.0%}",
                           "energy": f"{c.scenarios[n].compromise_metrics.flash_energy:.4f}",
                           "area": _pct(c.scenarios[n].compromise_metrics.flash_area)} for n in names],
        })
    layout = fg.design_layout(cmp)
    design = fg.design_chart(cmp)
    cuts = [{"name": c.name, "kind": c.cut.kind, "source": c.cut.source or "a mesh given in Python",
             "dims": f"{c.summary.length_mm:.2f} × {c.summary.width_mm:.2f} × {c.summary.height_mm:.2f} mm",
             "weight": f"{c.summary.weight_ct:.2f} ct ({c.summary.weight_ct_range[0]:.2f}–{c.summary.weight_ct_range[1]:.2f})",
             "warnings": c.cut.warnings, "repairs": c.summary.repairs} for c in cmp.cuts]
    definitions = {**METRIC_DEFINITIONS, **COMPARE_DEFINITIONS}
    lab = cmp.material
    return {
        "title": f"Cut comparison: {len(cmp.cuts)} cut{'s' if len(cmp.cuts) != 1 else ''} × "
                 f"{len(names)} scenario{'s' if len(names) != 1 else ''}",
        "names": names, "summary": summary, "verdict": cmp.verdict, "ties": any(c.tied for c in cmp.cuts)
        or any(c.scenarios[n].tied for c in cmp.cuts for n in names), "scenarios": scenarios, "compromise": compromise,
        "many_scenarios": len(names) > 1, "sides_note": cmp.sides_note, "cuts": cuts, "reference": cmp.reference_cut.name,
        "material": {"name": lab.name or "default", "peak": f"{lab.peak_wavelength():.0f}",
                     "swatch": lab.flash_colour().hex, "params": lab.to_dict()},
        "quality": cmp.quality, "render": cmp.render, "seconds": f"{cmp.seconds:.1f}", "version": __version__,
        "design": None if design is None else data_uri(design), "design_why": layout["why"], "design_kind": layout["kind"],
        "definitions": sorted(definitions.items()), "frame": FRAME,
    }


def render_html(cmp: Any) -> str:
    """The report page as a string."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("labcut.reports", "templates"),
        autoescape=jinja2.select_autoescape(default=True, default_for_string=True),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    return env.get_template(TEMPLATE).render(**context(cmp))


def write_report(cmp: Any, path: str | os.PathLike[str]) -> Path:
    """Write the page to ``path`` (.html/.htm), atomically."""
    from ..fileio import atomic_output, check_output_path

    check_output_path(path, (".html", ".htm"))
    text = render_html(cmp)
    with atomic_output(path, (".html", ".htm")) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
