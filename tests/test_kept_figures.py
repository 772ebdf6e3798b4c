"""Figures a CLI call would otherwise compute in every process, kept in labcut's user cache.

The scene's peak (the flash threshold's reference: a simplex search over face directions) and
the planner's depth exposure of a stone (its thickness rays and a pass over every face) are the
same in every process that asks the same question; each new process read them back instead of
spending about a tenth of a second each on them. A stale figure would be a silent wrong answer,
so every input that shapes one is part of its key, and a damaged entry is measured again with a
warning.
"""

from __future__ import annotations

import json

import pytest

import labcut
from labcut import fileio
from labcut.orientation import radiance, volume
from labcut.scene import Lights

LAB = labcut.Labradorite()


def _new_process(monkeypatch):
    """Forget what this process kept (as a new CLI call starts): only the cache files remain."""
    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    monkeypatch.setattr(radiance, "_PEAKS", {})


def _counted(monkeypatch, module, name):
    calls = []
    real = getattr(module, name)
    monkeypatch.setattr(module, name, lambda *a, **k: calls.append(a) or real(*a, **k))
    return calls


def test_the_scene_peak_is_read_back_the_same_in_a_new_process(monkeypatch, fresh_user_cache):
    calls = _counted(monkeypatch, radiance, "_scene_peak")
    first = radiance.scene_peak(LAB, Lights.preset("room", "draft"))
    assert len(calls) == 1 and (fresh_user_cache / "scene-peaks.json").exists()
    _new_process(monkeypatch)
    again = radiance.scene_peak(LAB, Lights.preset("room", "draft"))
    assert len(calls) == 1 and again == first  # read back, to the last bit
    # another material, other lights: searched
    radiance.scene_peak(labcut.Labradorite.preset("gold"), Lights.preset("room", "draft"))
    radiance.scene_peak(LAB, Lights.lamp([0.3, 0.0, 1.0], 5.0, 1.0, 7))
    assert len(calls) == 3


def test_the_scene_peaks_key_holds_the_version_and_the_code(monkeypatch, fresh_user_cache):
    calls = _counted(monkeypatch, radiance, "_scene_peak")
    radiance.scene_peak(LAB, Lights.preset("room", "draft"))
    _new_process(monkeypatch)
    monkeypatch.setattr(labcut, "__version__", "0.0.0-other")
    radiance.scene_peak(LAB, Lights.preset("room", "draft"))
    assert len(calls) == 2
    _new_process(monkeypatch)
    monkeypatch.setattr(fileio, "code_hash", lambda *paths: "edited")
    radiance.scene_peak(LAB, Lights.preset("room", "draft"))
    assert len(calls) == 3


@pytest.mark.parametrize("bad", ["0.5", 0.0, 1.5, None, True, float("nan")])
def test_a_damaged_scene_peak_is_searched_again_with_a_warning(monkeypatch, fresh_user_cache, bad):
    calls = _counted(monkeypatch, radiance, "_scene_peak")
    first = radiance.scene_peak(LAB, Lights.preset("room", "draft"))
    path = fresh_user_cache / "scene-peaks.json"
    held = json.loads(path.read_text())
    (key,) = held
    path.write_text(json.dumps({key: {"peak": bad}}))
    _new_process(monkeypatch)
    with pytest.warns(labcut.LabcutWarning, match="scene-peaks.json is damaged"):
        assert radiance.scene_peak(LAB, Lights.preset("room", "draft")) == first
    assert len(calls) == 2 and json.loads(path.read_text())[key] == {"peak": first}  # written over


def _stone(path="meshes/oval-16x12-low.ply"):
    return labcut.load_mesh(path)  # a new mesh object: nothing kept with it


def test_the_depth_exposure_is_read_back_the_same_in_a_new_process(monkeypatch, fresh_user_cache):
    calls = _counted(monkeypatch, volume, "convex_thickness")
    first = volume.depth_exposure(_stone(), LAB)
    assert len(calls) == 1 and (fresh_user_cache / "depth-exposure.json").exists()
    _new_process(monkeypatch)
    again = volume.depth_exposure(_stone(), LAB)
    assert again == first and len(calls) == 1
    assert all(type(again[k]) is float for k in again)


def test_the_depth_exposures_key_holds_the_geometry_the_material_and_the_sampling(monkeypatch, fresh_user_cache):
    calls = _counted(monkeypatch, volume, "convex_thickness")
    volume.depth_exposure(_stone(), LAB)
    moved = _stone()
    moved.vertices[5] += [0.0, 0.0, 1e-9]  # one vertex, a nanometre
    volume.depth_exposure(moved, LAB)
    assert len(calls) == 2
    thinner = LAB.replace(pairs=LAB.pairs // 2)  # a shallower stack
    volume.depth_exposure(_stone(), thinner)
    assert len(calls) == 3
    monkeypatch.setattr(volume, "EXPOSURE_POINTS", 300)
    volume.depth_exposure(_stone(), LAB)
    assert len(calls) == 4
    monkeypatch.setattr(volume, "EXPOSURE_SAMPLING", "random")  # the samples placed otherwise
    volume.depth_exposure(_stone(), LAB)
    assert len(calls) == 5
    monkeypatch.setattr(labcut, "__version__", "0.0.0-other")
    volume.depth_exposure(_stone(), LAB)
    assert len(calls) == 6
    # the surface samples' code is in the key: a changed draw_samples measures again
    hashed = []
    real_hash = fileio.code_hash
    monkeypatch.setattr(fileio, "code_hash", lambda *paths: hashed.append([str(p) for p in paths]) or real_hash(*paths))
    _new_process(monkeypatch)
    volume.depth_exposure(_stone(), LAB)
    assert any(p.endswith("geometry/surface.py") for p in hashed[-1])
    # a stone declared non-convex is measured by rays, under its own key
    _new_process(monkeypatch)
    stone = labcut.Stone(_stone(), convex=False)
    assert volume.depth_exposure(stone, LAB)["thin_share"] == pytest.approx(volume.depth_exposure(_stone(), LAB)["thin_share"], abs=0.01)
    assert len(calls) == 6


def test_a_stones_depth_geometry_serves_every_material(monkeypatch, fresh_user_cache):
    """The thicknesses behind the samples and the normals' turn rates are the stone's, whatever the
    material: a stone asked about three stacks casts its thickness rays once (a new flash peak in
    the explorer cast them anew), and each answer is the one a stone that never saw another
    material gives."""
    calls = _counted(monkeypatch, volume, "convex_thickness")
    turns = _counted(monkeypatch, volume, "corner_normals")
    stone = labcut.Stone.of(_stone())
    materials = [LAB, LAB.replace(pairs=LAB.pairs // 3), labcut.Labradorite.from_peak_wavelength(612.0)]
    answers = [volume.depth_exposure(stone, m) for m in materials]
    assert len(calls) == 1 and len(turns) == 1
    # deeper stacks: more of the surface thinner than them, more of the normal's turn across the flash depth
    ordered = sorted(answers, key=lambda a: a["stack_depth_mm"])
    assert [a["thin_share"] for a in ordered] == sorted(a["thin_share"] for a in ordered)
    assert ordered[0]["thin_share"] < ordered[-1]["thin_share"] and ordered[0]["turn_deg"] < ordered[-1]["turn_deg"]
    for m, a in zip(materials, answers):
        _new_process(monkeypatch)
        monkeypatch.setattr(fileio, "code_hash", lambda *paths: "another round")  # not read back from the cache
        assert volume.depth_exposure(labcut.Stone.of(_stone()), m) == a
    assert len(calls) == 4


def test_a_damaged_depth_exposure_is_measured_again_with_a_warning(monkeypatch, fresh_user_cache):
    first = volume.depth_exposure(_stone(), LAB)
    path = fresh_user_cache / "depth-exposure.json"
    (key,) = json.loads(path.read_text())
    for bad in ({**first, "thin_share": "0.1"}, {"thin_share": 0.1}, [1, 2], {**first, "turn_deg": float("inf")}):
        path.write_text(json.dumps({key: bad}))
        _new_process(monkeypatch)
        monkeypatch.setattr(fileio, "_CACHE_WARNED", set())
        with pytest.warns(labcut.LabcutWarning, match="depth-exposure.json is damaged"):
            assert volume.depth_exposure(_stone(), LAB) == first
