"""``labcut.compare_cuts``: cut specs, validation before work, the numbers of a comparison, and the
report files (JSON, CSV, HTML) — at draft quality with tiny renders, so it stays fast."""

from __future__ import annotations

import base64
import csv
import json
import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import labcut
from labcut.errors import LabcutWarning, MeshError, OutputError, ParameterError
from labcut.reports import compare as cmpmod
from labcut.orientation.misorientation import MISS_DIRECTIONS, ring
from labcut.reports.analysis import (
    compromise,
    per_view_flash,
    scorer_for,
    tilt_axes,
)
from labcut.reports.cuts import parse_cab_spec, resolve_cuts, unique_names

MESHES = Path(__file__).resolve().parents[1] / "meshes"
LOW = "cab:oval,16x12,low,res=64"
SCENARIOS = ["bench", "pendant"]


@pytest.fixture(scope="module")
def comparison():
    """3 cuts (a spec, a named Trimesh, the spec again) x 2 scenarios; the progress calls it made."""
    high = labcut.cabochon("oval", 16, 12, dome="high", resolution=64)
    high.metadata["name"] = "high"
    calls = []
    cmp = labcut.compare_cuts([LOW, high, LOW], scenarios=SCENARIOS, quality="draft", resolution=32, spp=4,
                              progress=lambda done, total: calls.append((done, total)))
    return cmp, calls


# ---------------------------------------------------------------------- cuts
@pytest.mark.parametrize(
    "spec, expected",
    [
        ("cab:oval,16x12,low", {"outline": "oval", "length": 16.0, "width": 12.0, "dome": "low"}),
        ("cab:round,12", {"outline": "round", "length": 12.0}),
        ("cab:round,12,high,profile=spherical", {"outline": "round", "length": 12.0, "dome": "high", "profile": "spherical"}),
        ("CAB:Oval,16×12,2.5,girdle=0.5,base=flat,res=64",
         {"outline": "oval", "length": 16.0, "width": 12.0, "dome": 2.5, "girdle": 0.5, "base": "flat", "resolution": 64}),
        ("cab:cushion,14x10,buff_top=0.5,corner=1", {"outline": "cushion", "length": 14.0, "width": 10.0, "buff_top": 0.5,
                                                    "corner_radius": 1.0}),
    ],
)
def test_cab_specs_parse(spec, expected):
    assert parse_cab_spec(spec) == expected


@pytest.mark.parametrize(
    "spec, fragment",
    [
        ("cab:oval", "needs at least an outline and a size"),
        ("cab:oval,16", "need LENGTHxWIDTH"),
        ("cab:oval,16x12x3", "LENGTHxWIDTH"),
        ("cab:oval,axb", "length must be a number"),
        ("cab:oval,16x12,flat", "dome must be low, medium, high or a number of mm in 'cab:oval,16x12,flat', got 'flat'"),
        ("cab:oval,16x12,low,sparkle=3", "unknown part 'sparkle=3'"),
        ("cab:oval,16x12,low,girdle=1,girdle=2", "given twice"),
        ("cab:oval,16x12,low,res=6.5", "whole number"),
        ("cab:oval,16x12,nan", "dome must be low, medium, high or a number of mm"),
        ("cab:oval,16x12,low,base=deep", "base must be low, medium, high or a number of mm"),
    ],
)
def test_bad_cab_specs_say_what_is_wrong(spec, fragment):
    with pytest.raises(ParameterError, match=re.escape(fragment)):
        parse_cab_spec(spec)


def test_cuts_are_resolved_named_and_told_apart():
    mesh = labcut.cabochon("round", 10, dome="low", resolution=32)
    cuts = resolve_cuts([str(MESHES / "oval-16x12-low.ply"), "cab:round,10,low,res=32", ("mine", mesh),
                         str(MESHES / "oval-16x12-low.ply"), mesh, mesh])
    assert [c.name for c in cuts] == ["oval-16x12-low.ply", "cab:round,10,low,res=32", "mine", "oval-16x12-low.ply (2)",
                                      "mesh 5", "mesh 6"]
    assert [c.kind for c in cuts] == ["file", "cabochon", "mesh", "file", "mesh", "mesh"]
    assert cuts[1].design["dome_mm"] == pytest.approx(2.0) and cuts[1].design["height_mm"] == pytest.approx(2.0)
    assert unique_names(["a", "a (2)", "a"]) == ["a", "a (2)", "a (3)"]
    named = resolve_cuts({"low": "cab:oval,16x12,low,res=32", "high": "cab:oval,16x12,high,res=32"})
    assert [c.name for c in named] == ["low", "high"]


@pytest.mark.parametrize(
    "cuts, error, fragment",
    [
        (["cab:oval,16x12,low,res=32", "nowhere.ply"], MeshError, "cut 2 ('nowhere.ply'): mesh file 'nowhere.ply' does not exist"),
        (["cab:oval,16x12,low,res=32", "cab:ovl,16x12"], ParameterError, "cut 2 ('cab:ovl,16x12'): unknown outline 'ovl'"),
        (["cab:oval,16x12,low,res=32", "cab:oval,16x12,13"], ParameterError, "cut 2 ('cab:oval,16x12,13'): dome 13 mm is higher"),
        (["cab:oval,16x12,low,res=32", 42], ParameterError, "cut 2 ('int'): a cut must be a mesh path"),
        ([], ParameterError, "at least one cut"),
        ("cab:oval,16x12,low", ParameterError, "a list of cuts"),
        ([("  ", "cab:oval,16x12,low")], ParameterError, "cut 1: its name is empty"),
    ],
)
def test_a_bad_cut_among_several_is_named(cuts, error, fragment):
    with pytest.raises(error, match=re.escape(fragment)):
        resolve_cuts(cuts)


def test_broken_mesh_object_is_named():
    import trimesh

    open_box = trimesh.creation.box((5, 5, 5))
    open_box.update_faces(np.arange(len(open_box.faces)) > 0)  # one triangle missing: not watertight
    with pytest.raises(MeshError, match=r"cut 2 \('mesh 2'\): mesh 2 is not closed"):
        resolve_cuts(["cab:oval,16x12,low,res=32", open_box])


def test_file_warnings_name_the_cut(tmp_path):
    upside = labcut.cabochon("oval", 16, 12, dome="low", resolution=32)
    upside.apply_transform(np.diag([1.0, -1.0, -1.0, 1.0]))  # dome down
    upside.export(tmp_path / "flipped.ply")
    with pytest.warns(LabcutWarning, match=r"^flipped\.ply: flipped\.ply looks upside down"):
        cuts = resolve_cuts([str(tmp_path / "flipped.ply")])
    assert cuts[0].warnings and cuts[0].mesh.bounds[1][2] > 2.0  # turned face-up


def test_everything_is_checked_before_the_long_work(monkeypatch):
    """A bad cut, scenario, reference, quality or material fails at once: nothing is recommended."""
    from labcut.study import Study

    def boom(*a, **k):
        raise AssertionError("long work started before the inputs were checked")

    monkeypatch.setattr(Study, "recommend", boom)  # what run_comparison asks first of each cut
    good = ["cab:oval,16x12,low,res=32", "cab:oval,16x12,high,res=32"]
    cases = [
        ({"cuts": [good[0], "cab:oval,16x12,lo"]}, "cut 2 ('cab:oval,16x12,lo')"),
        ({"cuts": good, "scenarios": ["bench", "disco"]}, "disco"),
        ({"cuts": good, "scenarios": ["bench", "bench"]}, "scenario 'bench' is given twice"),
        ({"cuts": good, "reference": 2}, "reference 2 is out of range"),
        ({"cuts": good, "reference": "nope"}, "reference 'nope' is none of the cuts"),
        ({"cuts": good, "quality": "ultra"}, "quality must be one of"),
        ({"cuts": good, "material": "purple"}, "purple"),
        ({"cuts": good, "resolution": 4}, "render resolution"),
        ({"cuts": good, "spp": 0}, "samples per pixel"),
    ]
    for kwargs, fragment in cases:
        with pytest.raises(ParameterError, match=re.escape(fragment)):
            labcut.compare_cuts(**kwargs)


# ---------------------------------------------------------------------- the numbers
def test_names_ranks_and_reference(comparison):
    cmp, _ = comparison
    names = [c.name for c in cmp.cuts]
    assert names == [LOW, "high", f"{LOW} (2)"]
    assert cmp.reference == 0 and cmp.reference_cut.name == LOW
    for s in SCENARIOS:
        low, high, again = (c.scenarios[s] for c in cmp.cuts)
        assert low.energy == again.energy  # the same cut twice: the same numbers, a shared rank
        assert (low.rank, again.rank) == (1, 1) and high.rank == 3 and high.energy < low.energy
        assert low.normalised["flash_energy"] == 1.0 and again.normalised["flash_energy"] == 1.0
        assert high.normalised["flash_energy"] == pytest.approx(high.energy / low.energy, rel=1e-12)
        assert high.normalised["tolerance_deg"] == pytest.approx(high.recommendation.tolerance_deg / low.recommendation.tolerance_deg)
    assert [c.rank for c in cmp.ranked()] == [1, 1, 3]
    assert cmp.cuts[0].overall_score == 1.0 and cmp.cuts[1].overall_score < 1.0


def test_progress_counts_cuts_times_scenarios(comparison):
    _, calls = comparison
    assert calls[0] == (0, 6) and calls[-1] == (6, 6)
    assert [d for d, _ in calls] == list(range(7)) and {t for _, t in calls} == {6}


def test_competition_ranks():
    assert cmpmod.competition_ranks([3.0, 5.0, 5.0, 1.0]) == [3, 1, 1, 4]


def test_own_scorer_scores_as_the_recommendation(comparison):
    cmp, _ = comparison
    r = cmp.cuts[1].scenarios["pendant"]
    scorer = scorer_for(cmp.cuts[1].cut.mesh, cmp.material, r.scenario, "draft")
    # the same samples and weights: equal up to float32 summation order
    assert scorer.energy_map(r.recommendation.normal[None, :])[0] == pytest.approx(r.recommendation.score, rel=1e-4)


def test_misorientation_curve_meets_the_tolerance(comparison):
    cmp, _ = comparison
    for c in cmp.cuts[:2]:
        for s in SCENARIOS:
            r = c.scenarios[s]
            mc = r.misorientation
            assert mc.miss_deg[0] == 0 and mc.mean[0] == pytest.approx(1.0, abs=1e-6) and mc.worst[0] == pytest.approx(1.0, abs=1e-6)
            assert np.all(mc.worst <= mc.mean + 1e-12)
            # the worst direction first drops below 90 % where the recommendation's tolerance ends
            first = int(np.argmax(mc.worst < 0.9))
            assert mc.miss_deg[first - 1] - 0.06 <= r.recommendation.tolerance_deg <= mc.miss_deg[first] + 0.06


def test_ring_is_the_tolerance_search_ring():
    centre = np.array([0.1, -0.2, 1.0]) / np.linalg.norm([0.1, -0.2, 1.0])
    pts = ring(centre, 5.0)
    assert pts.shape == (MISS_DIRECTIONS, 3) and np.allclose(np.linalg.norm(pts, axis=1), 1.0)
    assert np.allclose(np.degrees(np.arccos(pts @ centre)), 5.0)


def test_compromise_is_the_best_mean_of_relative_energies(comparison):
    cmp, _ = comparison
    c = cmp.cuts[1]
    recs = [c.scenarios[s].recommendation for s in SCENARIOS]
    scorers = [scorer_for(c.cut.mesh, cmp.material, c.scenarios[s].scenario, "draft") for s in SCENARIOS]
    cp = c.compromise
    assert cp.score == pytest.approx(np.mean(list(cp.relative.values())), rel=1e-9)
    for s, rel in cp.relative.items():
        assert 0.0 < rel <= 1.0 + 1e-3
        assert rel == pytest.approx(c.scenarios[s].compromise_relative)
        # metrics sum the triples, the relative energy comes from the binned map: equal to ~1e-4
        assert c.scenarios[s].compromise_metrics.flash_energy == pytest.approx(rel * c.scenarios[s].recommendation.score, rel=1e-3)

    bases = [sc.energy_map(r.normal[None, :])[0] for sc, r in zip(scorers, recs)]

    def mean_rel(normals):
        return np.mean([sc.energy_map(normals) / b for sc, b in zip(scorers, bases)], axis=0)

    # no orientation on a fine cap around it, nor either scenario's own optimum, does better
    dense = np.concatenate([ring(cp.normal, a, 24) for a in np.arange(0.25, 8.01, 0.25)])
    others = np.array([r.normal for r in recs])
    assert mean_rel(dense).max() <= cp.score * (1 + 2e-3)
    assert mean_rel(others).max() <= cp.score * (1 + 1e-9)
    # (the two searches find the same side's edge by separate root-finds: equal to about 1e-7 degrees)
    assert cp.tolerance_deg <= min(cp.tolerance_by_axis.values()) + 1e-6
    one = compromise(scorers[:1], ["x"], [recs[0].normal], "draft")
    assert np.allclose(one.normal, recs[0].normal) and one.score == 1.0


def test_per_view_flash_agrees_with_the_scorer():
    from labcut.orientation.problem import build_problem
    from labcut.orientation.scoring import Scorer
    from labcut.scene import Scenario

    mesh = labcut.cabochon("oval", 16, 12, dome="medium", resolution=48)
    problem = build_problem(mesh, labcut.Labradorite(), quality="draft", n_points=800,
                            settings=Scenario.preset("display", "draft").settings())
    normal = np.array([0.05, -0.2, 1.0]) / np.linalg.norm([0.05, -0.2, 1.0])
    energy, area = per_view_flash(problem, normal)
    pv = Scorer(problem).metrics(normal).per_view
    assert np.allclose(energy, pv["flash_energy"], rtol=2e-4, atol=1e-7)
    assert np.allclose(area, pv["flash_area"], atol=2e-3)


def test_tilt_curve(comparison):
    cmp, _ = comparison
    for s in SCENARIOS:
        for c in cmp.cuts[:2]:
            tc = c.scenarios[s].tilt
            i = int(np.argmin(np.abs(tc.angles_deg)))
            assert tc.angles_deg[i] == 0.0 and tc.angles_deg[0] == -30.0 and tc.angles_deg[-1] == 30.0
            assert tc.flash_energy["front_back"][i] == tc.flash_energy["side_to_side"][i]  # both: the rest pose
            assert np.nanmax(tc.flash_energy["front_back"]) > 0.0
    sc = cmp.scenarios[1]  # pendant: front-back about world X, side-to-side about the vertical
    axes = tilt_axes(sc)
    assert np.allclose(axes["front_back"], [1, 0, 0]) and np.allclose(axes["side_to_side"], [0, 0, 1])
    bench = tilt_axes(cmp.scenarios[0])  # the cutter looks 10° from the vertical, from the front
    assert np.allclose(bench["front_back"], [1, 0, 0]) and bench["side_to_side"][1] > 0.98


def test_tilt_curve_at_rest_is_the_main_view_alone(comparison):
    """The curve's 0° value is the flash of the main view in the rest pose (not the rocking mean)."""
    from labcut.orientation.problem import build_problem
    from labcut.reports.analysis import TILT_POINTS
    from labcut.scene import Views

    cmp, _ = comparison
    r = cmp.cuts[0].scenarios["bench"]
    st = r.scenario.main_setting()
    single = build_problem(cmp.cuts[0].cut.mesh, cmp.material, quality="draft", n_points=TILT_POINTS["draft"],
                           settings=[st.__class__(st.lights, Views([st.views.main]), 1.0, st.pose)])
    energy, _ = per_view_flash(single, r.recommendation.normal)
    assert r.tilt.at_rest() == pytest.approx(float(energy[0]), rel=1e-9)


def test_tilt_curve_is_the_tilted_scenario(comparison):
    """Each point of the curve is the flash of the main viewer in the scenario turned by that angle about
    the world axis (pendant: side to side about the vertical, not about the stone's own face normal)."""
    from labcut.orientation.problem import build_problem
    from labcut.reports.analysis import TILT_POINTS
    from labcut.scene import Scenario, Views
    from labcut.scene.directions import rotation

    cmp, _ = comparison
    r = cmp.cuts[1].scenarios["pendant"]
    sc, tc = r.scenario, r.tilt
    for key in ("front_back", "side_to_side"):
        for angle in (-20.0, 10.0):
            turned = Scenario(sc.name, rotation(tilt_axes(sc)[key], angle) @ sc.pose, sc.lights, sc.views, 0.0, 0.0, "", "draft")
            st = turned.main_setting()
            problem = build_problem(cmp.cuts[1].cut.mesh, cmp.material, quality="draft", n_points=TILT_POINTS["draft"],
                                    settings=[st.__class__(st.lights, Views([st.views.main]), 1.0, st.pose)])
            energy, _ = per_view_flash(problem, r.recommendation.normal)
            i = int(np.flatnonzero(tc.angles_deg == angle)[0])
            assert tc.flash_energy[key][i] == pytest.approx(float(energy[0]), rel=1e-9), (key, angle)


def test_one_exposure_for_every_cut_and_scenario(comparison):
    from labcut.rendering.exposure import reference_exposure

    cmp, _ = comparison
    assert len(SCENARIOS) > 1
    for s in SCENARIOS:
        assert cmp.exposures[s] == reference_exposure(None)  # the bench's: a dimmer scenario looks dimmer
        r = cmp.cuts[0].scenarios[s].renders
        assert r.main.shape == (32, 32, 3) and len(r.strip) == len(cmp.render["strip_angles_deg"])
        assert r.strip[cmp.render["strip_angles_deg"].index(0.0)] is r.main


def test_turning_the_camera_is_tilting_the_stone():
    """A rocking-strip frame (camera and lights turned about the stone) is the render of the tilted pose."""
    from labcut.reports.renders import StoneScene
    from labcut.scene import Scenario
    from labcut.scene.directions import rotation

    mesh = labcut.cabochon("oval", 16, 12, dome="low", resolution=64)
    lab = labcut.Labradorite()
    normal = np.array([0.0, -0.08, 1.0])
    for name in ("bench", "pendant"):
        sc = Scenario.preset(name, "draft")
        axis = tilt_axes(sc)["front_back"]
        scene = StoneScene(mesh, lab, normal, sc, 48)
        rest = scene.render(64, 1)
        scene.tilt(axis, 15.0)
        turned = scene.render(64, 1)
        tilted = Scenario(sc.name, rotation(axis, 15.0) @ sc.pose, sc.lights, sc.views, 0.0, 0.0, "", "draft")
        fresh = labcut.render(mesh, lab, normal, scenario=tilted, spp=64, resolution=48, check_flash=False).image
        assert abs(turned.mean() - fresh.mean()) < 0.03 * fresh.mean()
        assert abs(turned.mean() - rest.mean()) > 0.05 * rest.mean()  # and the tilt shows
        # pixel by pixel: turned about the stone's centre (a turn about another point shifts the picture)
        assert np.abs(turned - fresh).mean() < 0.25 * np.abs(rest - fresh).mean()
        scene.turn(np.eye(3))
        assert np.allclose(scene.render(64, 1), rest, atol=1e-4)  # back at rest (film accumulation: ~1e-7)


def test_flash_colour_agrees_with_the_physics_and_the_estimator():
    """Dominant wavelength of the flash near the material's own colour; flashing pixels ~ flash area."""
    from labcut.colour import dominant_wavelength
    from labcut.orientation.radiance import reference_radiance
    from labcut.rendering.scene import RENDER_IRRADIANCE
    from labcut.reports.analysis import tilt_curve
    from labcut.reports.flashcolour import (
        dominant_wavelengths,
        flash_colour_map,
        linear_srgb_to_xyz,
    )
    from labcut.reports.renders import render_cut
    from labcut.scene import Scenario

    rng = np.random.default_rng(3)
    rgb = rng.random((200, 3))
    ours = dominant_wavelengths(rgb)
    ref = np.array([dominant_wavelength(linear_srgb_to_xyz(c))[0] for c in rgb])
    assert np.allclose(ours, ref, rtol=0, atol=1e-6, equal_nan=True)
    assert np.isnan(dominant_wavelengths(np.array([[0.3, 0.3, 0.3]]))[0])  # grey: no hue

    mesh = labcut.cabochon("oval", 16, 12, dome="low", resolution=64)
    for preset in ("blue", "gold"):
        lab = labcut.Labradorite.preset(preset)
        sc = Scenario.preset("bench", "draft")
        rec = labcut.recommend_orientation(mesh, lab, scenario=sc, quality="draft")
        r = render_cut(mesh, lab, rec.normal, sc, tilt_axes(sc)["front_back"], 64, 32, (0.0,))
        fm = flash_colour_map(r.schiller, r.mask, 0.1 * reference_radiance(lab, RENDER_IRRADIANCE))
        expected = lab.flash_colour(cos_theta=1.0).dominant_wavelength_nm
        assert fm.stats["basis"] == "flash" and abs(fm.stats["dominant_wavelength_nm"] - expected) < 6.0
        area = tilt_curve(mesh, lab, rec.normal, sc, "draft").at_rest("flash_area")
        assert abs(fm.stats["flash_fraction"] - area) < 0.08


# ---------------------------------------------------------------------- JSON, CSV, HTML
def test_json_holds_the_report(comparison, tmp_path):
    cmp, _ = comparison
    path = cmp.save_json(tmp_path / "c.json")
    data = json.loads(path.read_text())
    assert data == json.loads(json.dumps(cmp.to_dict(), allow_nan=False))
    assert data["kind"] == "labcut.compare" and data["reference"] == {"index": 0, "name": LOW}
    assert [c["name"] for c in data["cuts"]] == [c.name for c in cmp.cuts]
    c = data["cuts"][1]
    assert c["weight_ct"] == pytest.approx(cmp.cuts[1].summary.weight_ct)
    s = c["scenarios"]["pendant"]
    for key in ("rank", "best", "normalised", "tilt_curve", "misorientation", "flash_colour", "render", "compromise"):
        assert key in s
    for key in ("description", "workshop", "tolerance_deg", "tolerance_by_axis", "metrics", "map"):
        assert key in s["best"]
    assert len(s["tilt_curve"]["flash_energy"]["front_back"]) == len(s["tilt_curve"]["angles_deg"])
    assert s["render"]["exposure"] == cmp.exposures["pendant"]
    assert {"flash_energy", "tilt_curve", "misorientation", "dominant_wavelength_nm", "overall_score"} <= set(data["metric_definitions"])
    assert data["summary"][0]["rank"] == 1 and set(data["summary"][0]["scenarios"]) == set(SCENARIOS)


def test_csv_holds_every_number_of_the_json(comparison, tmp_path):
    cmp, _ = comparison
    path = cmp.save_csv(tmp_path / "c.csv")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == list(cmpmod.CSV_COLUMNS)
    assert len(rows) == len(cmp.rows())
    data = cmp.to_dict()

    def one(cut, scen, orient, qty, x=""):
        hit = [r for r in rows if (r["cut"], r["scenario"], r["orientation"], r["quantity"], r["x"]) == (cut, scen, orient, qty, x)]
        assert len(hit) == 1, (cut, scen, orient, qty, x)
        return float(hit[0]["value"])

    for c in data["cuts"]:
        n = c["name"]
        assert one(n, "", "", "weight_ct") == c["weight_ct"]
        assert one(n, "", "compromise", "tilt_deg") == c["compromise"]["tilt_deg"]
        for scen, s in c["scenarios"].items():
            assert one(n, scen, "best", "flash_energy") == s["best"]["metrics"]["flash_energy"]
            assert one(n, scen, "best", "tolerance_front_back_deg") == s["best"]["tolerance_by_axis"]["front_back_deg"]
            assert one(n, scen, "best", "flash_energy_normalised") == s["normalised"]["flash_energy"]
            assert one(n, scen, "compromise", "relative_to_best") == c["compromise"]["relative_to_best"][scen]
            tc = s["tilt_curve"]
            for a, v in zip(tc["angles_deg"], tc["flash_energy"]["side_to_side"]):
                assert one(n, scen, "best", "tilt_flash_energy_side_to_side", repr(float(a))) == v
            mc = s["misorientation"]
            assert one(n, scen, "best", "misorientation_worst_relative", repr(float(mc["miss_deg"][-1]))) == mc["worst_relative"][-1]
            maps = [r for r in rows if r["cut"] == n and r["scenario"] == scen and r["quantity"] == "score_map_flash_energy"]
            assert [float(r["value"]) for r in maps] == s["best"]["map"]["score"]
    # nothing but numbers in the value column
    assert all(math.isfinite(float(r["value"])) for r in rows)


def test_html_is_self_contained(comparison, tmp_path):
    cmp, _ = comparison
    path = cmp.save_html(tmp_path / "report.html")
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and "<script" not in text.lower()
    assert not re.search(r"(src|href)\s*=\s*\"(https?:|//|file:)", text) and "url(" not in text
    assert "default-src 'none'" in text and "@media print" in text and 'name="viewport"' in text
    srcs = re.findall(r'<img src="([^"]+)"', text)
    # per scenario: a render and a strip per cut, score maps, tilt, misorientation, colour maps; the design chart
    assert len(srcs) == len(SCENARIOS) * (2 * len(cmp.cuts) + 4) + 1
    for src in srcs:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    for c in cmp.cuts:
        assert c.name in text
    for heading in ("Ranked summary", "Scenario <em>bench</em>", "Scenario <em>pendant</em>", "One orientation for all scenarios",
                    "Design parameters", "Definitions", "Tilt performance", "Misorientation", "Flash colour", "Rocking strip",
                    "Score map"):
        assert heading in text
    assert text.index("Ranked summary") < text.index("Scenario <em>bench</em>") < text.index('id="definitions"')


def test_html_escapes_names(tmp_path):
    mesh = labcut.cabochon("round", 10, dome="low", resolution=32)
    cmp = labcut.compare_cuts([("<b>bold</b> & co", mesh)], quality="draft", resolution=16, spp=1)
    text = cmp.save_html(tmp_path / "r.html").read_text()
    assert "<b>bold</b>" not in text and "&lt;b&gt;bold&lt;/b&gt; &amp; co" in text
    assert "With one scenario the compromise is the best orientation itself" in text


def test_report_is_written_atomically(comparison, tmp_path, monkeypatch):
    cmp, _ = comparison
    with pytest.raises(ParameterError, match="does not exist"):
        cmp.save_html(tmp_path / "missing" / "r.html")
    with pytest.raises(ParameterError, match="must end in"):
        cmp.save_html(tmp_path / "r.txt")
    target = tmp_path / "r.html"
    target.write_text("old report")
    from labcut.reports import html

    def broken_writer(self, *a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_text", broken_writer)
    with pytest.raises(OutputError, match="cannot write .*r.html.*No space left"):
        html.write_report(cmp, target)
    monkeypatch.undo()
    assert target.read_text() == "old report" and sorted(p.name for p in tmp_path.iterdir()) == ["r.html"]


def test_design_layout():
    from labcut.reports.figures import design_layout

    def fake(*dims):
        return SimpleNamespace(cuts=[SimpleNamespace(cut=SimpleNamespace(design={"length_mm": l, "width_mm": w, "height_mm": h}))
                                     for l, w, h in dims])

    grid = design_layout(fake((16, 12, 2.4), (16, 12, 4.0), (14, 10, 2.4), (14, 10, 4.0)))
    assert grid["kind"] == "heatmap" and (grid["x"], grid["y"]) == ("length_mm", "height_mm")
    assert design_layout(fake((16, 12, 2.4), (16, 12, 4.0), (16, 12, 6.0)))["kind"] == "line"
    assert design_layout(fake((16, 12, 2.4), (16, 12, 2.4)))["kind"] == "none"
    # every pair of parameters leaves two cuts in one cell: a line over the first one
    same_cell = design_layout(fake((16, 12, 2.4), (14, 10, 2.4), (14, 10, 4.0), (14, 10, 4.0)))
    assert same_cell["kind"] == "line" and same_cell["x"] == "length_mm"


def test_size_sets_the_girdle_width_of_designs_only():
    """``size`` sizes the GemCad designs among the cuts and leaves meshes as they are; without a
    design among them it is a one-line error."""
    from labcut.errors import ParameterError
    from labcut.reports.compare import plan_comparison

    meshes = Path(__file__).resolve().parents[1] / "meshes"
    plan = plan_comparison([meshes / "designs" / "SRB.asc", meshes / "oval-16x12-low.ply"], None, ["bench"], size=8,
                           quality="draft")
    assert plan.cuts[0].design["width_mm"] == pytest.approx(8.0)
    assert plan.cuts[1].design["length_mm"] == pytest.approx(16.0, abs=0.01)
    with pytest.raises(ParameterError, match="no cut is one"):
        plan_comparison([meshes / "oval-16x12-low.ply"], None, ["bench"], size=8)


def test_a_comparison_answers_as_recommend_orientation_and_builds_each_problem_once(monkeypatch):
    """Each cut and scenario's recommendation is recommend_orientation's to the last bit, and its
    flash problem serves the curves and the compromise (one build per cut and scenario)."""
    from labcut.study import Study

    built = []

    original = Study.scorer.fget

    def counting(self):
        if self._scorer is None:
            built.append(1)
        return original(self)

    monkeypatch.setattr(Study, "scorer", property(counting))
    cmp = labcut.compare_cuts(["cab:oval,16x12,low,res=32", "cab:round,10,high,res=32"], scenarios=["bench", "pendant"],
                              quality="draft", resolution=16, spp=1)
    assert len(built) == 4
    mesh = labcut.cabochon("oval", 16, 12, dome="low", resolution=32)
    rec = labcut.recommend_orientation(mesh, scenario="pendant", quality="draft")
    got = cmp.cuts[0].scenarios["pendant"].recommendation
    assert np.array_equal(got.normal, rec.normal) and got.score == rec.score


def test_the_flash_colour_maps_flash_is_the_estimators(comparison):
    # the map's flashing pixels are the flash mask's (lights summed exactly from the render's
    # camera): their share is the main view's flash area the estimator finds at rest
    cmp, _ = comparison
    for c in cmp.cuts:
        for s in SCENARIOS:
            r = c.scenarios[s]
            st = r.colour.stats
            assert st["estimator_flash_area"] == pytest.approx(float(r.tilt.flash_area["front_back"][
                int(np.argmin(np.abs(r.tilt.angles_deg)))]))
            assert st["flash_fraction"] == pytest.approx(st["estimator_flash_area"], abs=0.04), (c.name, s)
            h, w = r.renders.schiller.shape[:2]
            flashing = r.renders.mask & (r.renders.flash.ratio_at(h, w) >= r.renders.flash.threshold)
            assert st["flash_pixels"] == int(flashing.sum())
