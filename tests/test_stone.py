"""labcut.Stone: one typed, immutable object for what labcut knows about a stone (issue 31 §1)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import MeshError
from labcut.geometry import stone as stone_module
from labcut.geometry.stone import Provenance, Stone

ROOT = Path(__file__).resolve().parents[1]
OVAL = ROOT / "meshes" / "oval-16x12-low.ply"
BIPLANE = ROOT / "meshes" / "carving-biplane.ply"


def record_reads(path: Path) -> list[str]:
    """Places in a source file that read a mesh's ``metadata["labcut"]`` record."""
    tree = ast.parse(path.read_text(), str(path))
    out = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Load)
                and isinstance(node.value, ast.Attribute) and node.value.attr == "metadata"
                and isinstance(node.slice, ast.Constant) and node.slice.value == "labcut"):
            out.append(f"{path.name}:{node.lineno}")
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr in ("get", "setdefault", "pop") and node.args
              and isinstance(node.args[0], ast.Constant) and node.args[0].value == "labcut"):
            out.append(f"{path.name}:{node.lineno}")
    return out


def test_only_the_stone_reads_the_mesh_record():
    files = [p for d in ("labcut", "cli") for p in sorted((ROOT / d).rglob("*.py"))]
    found = [hit for p in files if p != ROOT / "labcut" / "geometry" / "stone.py" for hit in record_reads(p)]
    assert found == []


def test_the_record_rule_sees_reads(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('a = mesh.metadata["labcut"]\nb = (mesh.metadata or {}).get("labcut", {})\n'
                     'mesh.metadata["labcut"] = {}\nc = mesh.metadata.setdefault("labcut", {})\n')
    assert record_reads(probe) == ["probe.py:1", "probe.py:2", "probe.py:4"]  # the write on line 3 is a loader's


@pytest.fixture(scope="module")
def oval():
    return Stone.load(OVAL)


def test_a_loaded_stone_has_typed_facts(oval):
    assert oval.kind == "loaded" and oval.convex is True and oval.faceted is False
    assert isinstance(oval.provenance, Provenance)
    assert oval.provenance.source.endswith("oval-16x12-low.ply") and oval.provenance.units == "mm"
    assert oval.provenance.up_axis == "+Z" and oval.provenance.bodies == 1
    assert isinstance(oval.provenance.repairs, tuple) and oval.shading_angle_deg == 30.0
    biplane = Stone.load(BIPLANE)
    assert biplane.convex is False
    cab = Stone.of(labcut.cabochon(outline="oval", length=16, width=12, dome="low"))
    assert cab.kind == "cabochon" and cab.convex and cab.shape["outline"] == "oval"
    design = Stone.load(ROOT / "meshes" / "designs" / "SRB.asc", size=8.0)
    assert design.faceted and design.shading_angle_deg == 0.5 and design.design["facets"] > 0
    assert design.provenance_dict()["design"]["name"]
    assert "face_names" not in design.provenance_dict()["design"]


def test_a_stone_is_immutable_and_replace_makes_another(oval):
    with pytest.raises(AttributeError, match="immutable"):
        oval.convex = False
    with pytest.raises(TypeError):
        oval.record["convex"] = False  # a read-only view
    other = oval.replace(convex=False)
    assert other.convex is False and oval.convex is True and other.mesh is not oval.mesh
    assert Stone.of(other.mesh) is other and Stone.of(oval.mesh) is oval
    assert other.mesh.metadata["labcut"]["convex"] is False  # the trimesh a user holds agrees


def test_of_wraps_once_and_follows_the_mesh():
    mesh = labcut.load_mesh(OVAL)
    first = Stone.of(mesh)
    assert Stone.of(mesh) is first and Stone.of(first) is first
    given = Stone(mesh, convex=False)  # a stone made with other facts is the one later calls see
    assert Stone.of(mesh) is given and not Stone.of(mesh).convex
    mesh.metadata["labcut"]["convex"] = True  # the record edited by hand: read again
    assert Stone.of(mesh) is not given and Stone.of(mesh).convex
    again = Stone.of(mesh)
    mesh.vertices = mesh.vertices * 1.1  # new geometry: a new stone, its derived geometry made anew
    assert Stone.of(mesh) is not again
    with pytest.raises(MeshError, match="trimesh.Trimesh or a labcut.Stone"):
        Stone.of("oval.ply")
    with pytest.raises(MeshError):
        Stone([[0, 0, 0]])


def test_derived_geometry_is_made_once_per_stone(oval, monkeypatch):
    calls = []
    real = stone_module.draw_samples
    monkeypatch.setattr(stone_module, "draw_samples", lambda *a, **k: calls.append(a[1:3]) or real(*a, **k))
    fresh = Stone(oval.mesh.copy())
    a = fresh.surface_samples(500, 3)
    assert fresh.surface_samples(500, 3) is a and calls == [(500, 3)]
    fresh.surface_samples(500, 4)
    assert calls == [(500, 3), (500, 4)]
    assert fresh.face_areas is fresh.face_areas
    np.testing.assert_array_equal(fresh.face_areas, oval.mesh.area_faces)
    assert fresh.smooth_split() is fresh.smooth_split(30.0)
    assert a.convex is True and a.points.shape == (500, 3)


def test_every_api_takes_a_stone_or_its_mesh(oval):
    mesh = labcut.load_mesh(OVAL)
    by_stone = labcut.recommend_orientation(oval, quality="draft", scenario="bench")
    by_mesh = labcut.recommend_orientation(mesh, quality="draft", scenario="bench")
    np.testing.assert_array_equal(by_stone.normal, by_mesh.normal)
    assert by_stone.mesh == by_mesh.mesh  # the same provenance block
    ev = labcut.evaluate_orientation(oval, by_stone.normal, quality="draft", scenario="bench")
    assert ev == labcut.evaluate_orientation(mesh, by_stone.normal, quality="draft", scenario="bench")
    img = labcut.render(oval, labcut.Labradorite(), by_stone.normal, resolution=16, spp=1, check_flash=False)
    assert img.image.shape[:2] == (16, 16)
    plan = labcut.plan_effects(oval, labcut.Labradorite(), scenario="bench", predict=False)
    assert plan.estimator == "samples"
    from labcut.geometry.inspect import summarize

    assert summarize(oval).convex is True


def test_a_stone_pickles_with_its_mesh():
    """A batch row's mesh travels to a Dask worker with the stone kept in its cache."""
    import pickle

    mesh = labcut.load_mesh(OVAL)
    made = Stone(mesh, convex=False)
    made.surface_samples(200, 0)  # derived geometry is not pickled: made again where needed
    back = pickle.loads(pickle.dumps(mesh))
    assert Stone.of(back).convex is False and Stone.of(back).mesh is back
    copy = pickle.loads(pickle.dumps(made))
    assert copy.convex is False and copy.provenance == made.provenance and dict(copy.record) == dict(made.record)
    np.testing.assert_array_equal(copy.surface_samples(200, 0).points, made.surface_samples(200, 0).points)
