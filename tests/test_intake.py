"""Mesh intake a new user can trust (issue 9, items 1-3, 10, 11): up axis, units, size, render
camera at any size, provenance, validation of meshes that did not come through load_mesh."""

from __future__ import annotations

import json
import math
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import labcut
from labcut.errors import LabcutWarning, MeshError, ParameterError
from labcut.geometry.meshio import UNITS, load_mesh, save_mesh
from labcut.geometry.orient import UP_ROTATIONS, detect_up_axis, up_rotation


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


MESHES = Path(__file__).resolve().parents[1] / "meshes"
OVAL = MESHES / "oval-16x12-low.ply"


@pytest.fixture(scope="module")
def oval():
    return load_mesh(OVAL)


def export(mesh, path, up="+Z", unit_mm=1.0):
    """Write ``mesh`` (labcut frame, mm) as a file whose face-up side is ``up`` and whose unit is
    ``unit_mm`` mm, the way another program would: raw coordinates, no labcut conventions."""
    out = mesh.copy()
    out.metadata = {}
    transform = np.eye(4)
    transform[:3, :3] = up_rotation(up).T / unit_mm  # labcut -> file: the inverse of the intake rotation
    out.apply_transform(transform)
    out.export(path)
    return path


def quiet_load(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LabcutWarning)
        return load_mesh(*args, **kwargs)


# ----------------------------------------------------------------------------- 1. up axis
@pytest.mark.parametrize("up", list(UP_ROTATIONS))
def test_every_up_axis_is_found_from_the_flat_base(tmp_path, oval, up):
    path = export(oval, tmp_path / "stone.stl", up)
    m = quiet_load(path)
    meta = m.metadata["labcut"]
    assert meta["up_axis"] == up and meta["up_axis_source"].startswith("shape: a flat base")
    assert np.allclose(m.bounds, oval.bounds, atol=1e-4)  # the same stone, the same frame
    assert np.allclose(np.asarray(meta["rotation"]), up_rotation(up))
    assert bool(meta["warnings"]) == (up != "+Z")


def test_dome_down_file_warns_and_is_scored_on_its_dome(tmp_path, oval):
    path = export(oval, tmp_path / "down.stl", "-Z")
    with pytest.warns(LabcutWarning, match="upside down"):
        m = load_mesh(path)
    assert m.metadata["labcut"]["up_axis"] == "-Z"
    # the flat base is at the bottom again: the lowest 1 % of the stone is the full outline
    low = m.vertices[m.vertices[:, 2] < 0.01]
    assert np.ptp(low[:, 0]) == pytest.approx(16.0, abs=0.05)
    # keeping the file's orientation on purpose is possible, and warned about
    with pytest.warns(LabcutWarning, match="shape says -Z"):
        kept = load_mesh(path, up_axis="+Z")
    assert kept.metadata["labcut"]["up_axis"] == "+Z"
    assert np.ptp(kept.vertices[kept.vertices[:, 2] < 0.01][:, 0]) < 2.0  # lying on its dome


def test_y_up_gltf_is_upright_and_in_mm_without_a_warning(tmp_path, oval):
    path = export(oval, tmp_path / "stone.glb", "+Y", unit_mm=1000.0)  # glTF: metres, +Y up
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        m = load_mesh(path)
    meta = m.metadata["labcut"]
    assert (meta["units"], meta["units_source"], meta["up_axis"]) == ("m", "file", "+Y")
    assert np.allclose(m.bounds, oval.bounds, atol=1e-4)


def test_own_gltf_export_is_metres_y_up_and_round_trips(tmp_path):
    for stone in (labcut.cabochon("oval", 16, 12, dome="low", resolution=48), trimesh.creation.icosphere(2, 5.0)):
        path = save_mesh(stone, tmp_path / "out.glb")
        raw = trimesh.load(path, process=False, force="mesh")
        ext = np.ptp(raw.vertices, axis=0)
        # other tools see metres, +Y up: the stone's height is along Y
        assert ext.max() == pytest.approx(np.ptp(stone.vertices, axis=0).max() / 1000.0, rel=1e-6)
        assert ext[1] == pytest.approx(np.ptp(stone.vertices[:, 2]) / 1000.0, rel=1e-6)
        back = load_mesh(path)
        assert np.allclose(np.ptp(back.vertices, axis=0), np.ptp(stone.vertices, axis=0), atol=1e-4)


@pytest.mark.parametrize("name", ["step-cut-12x10.ply", "double-cabochon-oval-16x12.ply", "buff-top-oval-16x12.ply"])
@pytest.mark.parametrize("up", ["-Z", "+Y", "-X"])
def test_tables_and_domes_say_which_side_is_up(name, up):
    m = trimesh.load(MESHES / name, process=False)
    v = m.vertices @ up_rotation(up)  # file coordinates of a stone whose face-up side is `up`
    assert detect_up_axis(v, m.faces, convex=True).axis == up


@pytest.mark.parametrize("path", sorted(MESHES.glob("*.ply")), ids=lambda p: p.name)
def test_bundled_meshes_stay_as_they_are(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        m = load_mesh(path)
    assert m.metadata["labcut"]["up_axis"] == "+Z" and m.metadata["labcut"]["warnings"] == []


def test_shapes_that_do_not_say_keep_the_file_convention(tmp_path):
    box = trimesh.creation.box(extents=(10.0, 8.0, 6.0))
    box.export(tmp_path / "box.stl")
    meta = load_mesh(tmp_path / "box.stl").metadata["labcut"]
    assert meta["up_axis"] == "+Z" and meta["up_axis_source"].startswith("convention")


def test_cli_up_axis_and_warning(cli, tmp_path, oval):
    path = export(oval, tmp_path / "down.ply", "-Z")
    proc = cli("evaluate-orientation", str(path), "--quality", "draft", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    assert "warning:" in proc.stderr and "upside down" in proc.stderr
    data = json.loads(proc.stdout)
    assert data["mesh"]["up_axis"] == "-Z" and data["mesh"]["warnings"]
    proc = cli("evaluate-orientation", str(path), "--up-axis", "-Z", "--quality", "draft", "--json", "-")
    assert proc.returncode == 0 and "warning:" not in proc.stderr
    for cmd in (["inspect"], ["render", "-o", str(tmp_path / "x.png")], ["recommend-orientation"]):
        proc = cli(*cmd, str(path), "--up-axis", "sideways")
        assert proc.returncode == 2 and proc.stderr.startswith("error:") and "up axis" in proc.stderr
        assert not (tmp_path / "x.png").exists()


# a property (issue 9, "What must hold"): any axis-aligned up axis and any unit, exported and
# loaded with up_axis="auto" and the right units, gives the same recommendation in the stone's frame
@settings(max_examples=6)
@given(up=st.sampled_from(sorted(UP_ROTATIONS)), unit=st.sampled_from(["mm", "cm", "m", "in", "um"]),
       suffix=st.sampled_from([".ply", ".stl", ".obj"]))
def test_recommendation_is_independent_of_up_axis_and_units(tmp_path_factory, up, unit, suffix):
    ref = _reference()
    tmp = tmp_path_factory.mktemp("prop")
    path = export(ref["mesh"], tmp / f"stone{suffix}", up, unit_mm=UNITS[unit])
    m = quiet_load(path, units=unit, up_axis="auto")
    assert np.allclose(m.bounds, ref["mesh"].bounds, atol=1e-4 * max(1.0, UNITS[unit]))
    rec = labcut.recommend_orientation(m, quality="draft", lighting="spot", viewing="face-up")
    # the loaded mesh is in the stone's own frame: compare normals directly (axial)
    angle = math.degrees(math.acos(min(1.0, abs(float(rec.normal @ ref["rec"].normal)))))
    assert angle < 1.0, (up, unit, suffix, rec.normal, ref["rec"].normal)


_REF: dict = {}


def _reference() -> dict:
    if not _REF:
        mesh = quiet_load(OVAL, up_axis="+Z")  # the stone's own frame, whatever auto would say
        _REF.update(mesh=mesh, rec=labcut.recommend_orientation(mesh, quality="draft", lighting="spot", viewing="face-up"))
    return _REF


# ----------------------------------------------------------------------------- 2. units
def test_units_declared_by_3mf_are_honoured(tmp_path, oval):
    path = save_mesh(oval, tmp_path / "stone.3mf")
    assert load_mesh(path).metadata["labcut"]["units_source"] == "file"
    # the same numbers declared in centimetres are ten times larger
    cm = tmp_path / "cm.3mf"
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(cm, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename.lower().endswith(".model"):
                assert b'unit="millimeter"' in data
                data = data.replace(b'unit="millimeter"', b'unit="centimeter"')
            zout.writestr(item, data)
    m = load_mesh(cm, units="auto")
    assert m.metadata["labcut"]["units"] == "cm"
    assert np.allclose(m.extents, 10 * np.asarray(oval.extents), rtol=1e-5)
    # a given unit overrides the file's, with a note
    given_mm = load_mesh(cm, units="mm")
    assert np.allclose(given_mm.extents, oval.extents, rtol=1e-5)
    assert any("declares cm" in n for n in given_mm.metadata["labcut"]["notes"])


@pytest.mark.parametrize("unit_mm, units, hint", [(1000.0, "auto", "--units m"), (1.0, "m", "--units mm"),
                                                  (1e-3, "mm", "--units um")])
def test_a_stone_outside_half_a_mm_to_half_a_metre_is_refused(tmp_path, oval, unit_mm, units, hint):
    path = export(oval, tmp_path / "stone.ply", "+Z", unit_mm=unit_mm)
    with pytest.raises(ParameterError) as info:
        load_mesh(path, units=units)
    assert hint in str(info.value) and "\n" not in str(info.value)


def test_units_on_every_command_that_reads_a_mesh(cli_main, tmp_path, oval):
    path = export(oval, tmp_path / "metres.ply", "+Z", unit_mm=1000.0)
    out = tmp_path / "x.png"
    commands = [["inspect"], ["evaluate-orientation", "--quality", "draft"], ["recommend-orientation", "--quality", "draft"],
                ["render", "-o", str(out), "--resolution", "16", "--spp", "1"]]
    for cmd in commands:
        proc = cli_main(cmd[0], str(path), *cmd[1:])
        assert proc.returncode == 2 and "--units m" in proc.stderr, (cmd, proc.stderr)
        assert not out.exists()
    for cmd in commands:
        proc = cli_main(cmd[0], str(path), *cmd[1:], "--units", "m")
        assert proc.returncode == 0, (cmd, proc.stderr)
    proc = cli_main("evaluate-orientation", str(path), "--units", "furlong")
    assert proc.returncode == 2 and "unknown units" in proc.stderr


# issue 34 (1): a file without a unit, in inches or centimetres, loads 25.4 or 10 times too small
# but inside the 0.5-500 mm the size check accepts; it is warned about, with the --units that fits
def _scaled(length_mm):
    """The reference oval (16 x 12 mm) scaled to ``length_mm`` long, in mm."""
    m = quiet_load(OVAL, up_axis="+Z")
    m.apply_scale(length_mm / 16.0)
    return m


@pytest.mark.parametrize("length", [16.0, 20.0])
@pytest.mark.parametrize("unit", ["in", "cm"])
def test_a_stone_in_inches_or_centimetres_without_units_is_warned(tmp_path, unit, length):
    path = export(_scaled(length), tmp_path / "oval.ply", "+Z", unit_mm=UNITS[unit])
    with pytest.warns(LabcutWarning, match=f"pass --units {unit} \\(units='{unit}'\\) for {length:g} mm") as caught:
        m = load_mesh(path)
    msg = str(caught[0].message)
    assert "oval.ply is" in msg and "the default: the file does not say" in msg and "\n" not in msg
    assert m.metadata["labcut"]["warnings"] == [msg]
    # the unit it names loads the stone at its size, without a warning; so does --units mm, on purpose
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        assert max(load_mesh(path, units=unit).extents) == pytest.approx(length, rel=1e-5)
        assert max(load_mesh(path, units="mm").extents) == pytest.approx(length / UNITS[unit], rel=1e-5)


@pytest.mark.parametrize("length", [3.0, 4.0, 6.0, 60.0])
def test_small_real_stones_in_mm_are_not_warned(tmp_path, length):
    path = export(_scaled(length), tmp_path / "cab.stl", "+Z")
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        m = load_mesh(path)
    assert m.metadata["labcut"]["warnings"] == [] and max(m.extents) == pytest.approx(length, rel=1e-5)


# a property: a stone of a realistic size written in inches (5-60 mm) or centimetres (5-24 mm: a
# larger one reads 2.5 mm or more, the size of a real small stone) with no unit in the file is
# warned about (or, under 12.7 mm in inches, refused) naming the unit it is in, and that unit loads it
# at its size
@settings(max_examples=10)
@given(case=st.one_of(st.tuples(st.just("in"), st.floats(5.0, 60.0)), st.tuples(st.just("cm"), st.floats(5.5, 24.0))),
       suffix=st.sampled_from([".ply", ".stl", ".obj"]))
def test_a_stone_in_inches_or_centimetres_is_caught_without_units(tmp_path_factory, case, suffix):
    unit, length = case
    path = export(_scaled(length), tmp_path_factory.mktemp("units") / f"stone{suffix}", "+Z", unit_mm=UNITS[unit])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LabcutWarning)
        try:
            load_mesh(path)
            said = " ".join(str(w.message) for w in caught if issubclass(w.category, LabcutWarning))
        except ParameterError as exc:  # under 0.5 mm read in mm: a stone under 12.7 mm in inches
            said = str(exc)
            assert unit == "in" and length < 12.8
    assert f"--units {unit} (units='{unit}')" in said, (unit, length, said)
    m = quiet_load(path, units=unit)
    assert max(m.extents) == pytest.approx(length, rel=1e-5)
    assert m.metadata["labcut"]["warnings"] == []


def test_a_huge_or_tiny_units_factor_reads_in_a_short_message(tmp_path):
    for factor, size in ((1e300, "1.6e+301"), (1e-300, "1.6e-299"), (1e5, "1.6e+06")):
        with pytest.raises(ParameterError) as info:
            load_mesh(OVAL, units=factor)
        msg = str(info.value)
        assert f"is {size} mm across" in msg and len(msg) < 250, msg


def test_cli_warns_of_inches_and_keeps_errors_short(cli, tmp_path, oval):
    path = export(oval, tmp_path / "inches.stl", "+Z", unit_mm=UNITS["in"])
    proc = cli("inspect", str(path))
    assert proc.returncode == 0, proc.stderr
    assert "warning:" in proc.stderr and "--units in" in proc.stderr and "16 mm" in proc.stderr
    proc = cli("inspect", str(path), "--units", "in")
    assert proc.returncode == 0 and "warning:" not in proc.stderr and "16.000 x 12.000" in proc.stdout
    proc = cli("inspect", str(path), "--units", "mm")  # the user says so: no warning
    assert proc.returncode == 0 and "warning:" not in proc.stderr
    proc = cli("inspect", str(OVAL), "--units", "1e300")
    assert proc.returncode == 2 and "1.6e+301 mm across" in proc.stderr and len(proc.stderr) < 300, proc.stderr


# ----------------------------------------------------------------------------- 3. render camera
@pytest.mark.parametrize("scale", [1e-2, 1.0, 400.0])  # 0.16 mm to 6.4 m: near/far from the bounds
def test_any_size_renders_a_stone_not_a_flat_image(scale):
    cab = labcut.cabochon("oval", 16, 12, dome="low", resolution=48)
    cab.apply_scale(scale)
    img = labcut.render(cab, labcut.Labradorite(), (0, 0, 1), view="face-up", spp=2, resolution=24, check_flash=False).image
    lum = img.mean(axis=-1)
    assert np.all(np.isfinite(img)) and lum.std() > 0.05 * lum.max() > 0
    # the stone fills the middle, not the corners
    assert lum[10:14, 10:14].mean() > 2 * lum[:3, :3].mean()


# ----------------------------------------------------------------------------- 10. provenance
def test_provenance_in_json_and_repairs_shown(cli_main, tmp_path):
    box = trimesh.creation.box(extents=(10.0, 8.0, 3.0))
    path = tmp_path / "inverted.obj"
    trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False).export(path)
    js = tmp_path / "rec.json"
    proc = cli_main("recommend-orientation", str(path), "--quality", "draft", "--json", str(js), "--units", "cm")
    assert proc.returncode == 0, proc.stderr
    assert "repaired" in proc.stdout and "inverted all faces" in proc.stdout
    mesh = json.loads(js.read_text())["mesh"]
    assert mesh["path"] == str(path) and mesh["units"] == "cm" and mesh["up_axis"] == "+Z"
    assert mesh["bodies"] == 1 and any("inverted" in r for r in mesh["repairs"])
    assert mesh["dimensions_mm"] == pytest.approx([100.0, 80.0, 30.0])
    rj = tmp_path / "render.json"
    proc = cli_main("render", str(path), "--units", "cm", "-o", str(tmp_path / "r.png"), "--resolution", "16", "--spp", "1",
               "--json", str(rj))
    assert proc.returncode == 0, proc.stderr
    assert "inverted all faces" in proc.stdout
    assert json.loads(rj.read_text())["mesh"]["repairs"] == mesh["repairs"]


# ----------------------------------------------------------------------------- 11. API validation
def _broken_meshes():
    box = trimesh.creation.box(extents=(10.0, 8.0, 3.0))
    nan = box.copy()
    nan.vertices[0] = np.nan
    open_shell = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)
    inward = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    return {"nan": nan, "open": open_shell, "inward": inward, "not a mesh": "stone.stl"}


@pytest.mark.parametrize("kind", list(_broken_meshes()))
def test_api_refuses_meshes_that_did_not_come_through_load_mesh(kind):
    mesh = _broken_meshes()[kind]
    lab = labcut.Labradorite()
    calls = [
        lambda: labcut.recommend_orientation(mesh, lab, quality="draft"),
        lambda: labcut.evaluate_orientation(mesh, (0, 0, 1), lab, quality="draft"),
        lambda: labcut.render(mesh, lab, (0, 0, 1), spp=1, resolution=8),
    ]
    for call in calls:
        with pytest.raises(MeshError) as info:
            call()
        assert "\n" not in str(info.value)


def test_convexity_is_the_same_built_or_reloaded(tmp_path):
    t = np.linspace(0.0, 2.0 * np.pi, 7, endpoint=False)
    outlines = [np.c_[10 * np.cos(t), 8 * np.sin(t)], np.array([[0, 0], [10, 0], [5, 8]], float), "oval"]
    for outline in outlines:
        for dome in ("low", "high"):
            built = labcut.cabochon(outline, 16 if isinstance(outline, str) else None,
                                    12 if isinstance(outline, str) else None, dome=dome, resolution=64)
            for suffix in (".ply", ".stl"):
                back = load_mesh(save_mesh(built, tmp_path / f"c{suffix}"))
                assert back.metadata["labcut"]["convex"] == built.metadata["labcut"]["convex"] is True


# ----------------------------------------------------------------------------- 12. progress of long loads
def test_load_reports_progress():
    stages = []
    load_mesh(OVAL, progress=lambda stage, fraction: stages.append((stage, fraction)))
    fractions = [f for _, f in stages]
    assert len(stages) >= 4 and fractions == sorted(fractions) and fractions[-1] == 1.0
    assert any("reading" in s for s, _ in stages) and any("repair" in s for s, _ in stages)
