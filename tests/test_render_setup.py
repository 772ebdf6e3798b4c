"""RenderRequest and Motion: a render request validated once, carried as it is (issue 16 §1)."""

from __future__ import annotations

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.rendering import api
from labcut.rendering.request import Motion, RenderRequest


@pytest.fixture(scope="module")
def cab():
    return labcut.cabochon("oval", 10, 8, resolution=32)


def test_build_holds_the_request():
    s = RenderRequest.build("red", "ring", view="face-up", spp=8, resolution=24, look="studio", seed=3)
    assert s.material.name == "red" and s.scenario.name == "ring" and s.spp == 8 and s.resolution == 24
    assert [c.name for c in s.cameras] == ["face-up"] and s.look == "studio" and s.plan_denoise
    assert s.to_dict()["views"] == ["face-up"] and "RenderRequest('red'" in repr(s)
    assert RenderRequest.build().spp == 64 and not RenderRequest.build().plan_denoise
    assert RenderRequest.build(time_budget=2).time_budget == 2.0


@pytest.mark.parametrize("kwargs, words", [
    ({"mode": "infrared"}, "mode must be one of"),
    ({"spp": 0}, "spp must"),
    ({"spp": 2.5}, "spp must"),
    ({"spp": 4, "time_budget": 1.0}, "not both"),
    ({"time_budget": -1}, "time budget"),
    ({"resolution": 4}, "resolution"),
    ({"polarizer_deg": float("nan")}, "polarizer angle"),
    ({"mode": "mono", "denoise": True}, "denoising needs"),
    ({"lobes": ("sparkle",)}, "lobes must"),
    ({"view": "upside-down"}, "unknown view"),
    ({"look": "glamour"}, "look must"),
    ({"exposure": 0.0}, "exposure"),
    ({"seed": -1}, "seed"),
    ({"max_depth": 0}, "max_depth"),
])
def test_build_refuses_bad_requests(kwargs, words):
    with pytest.raises(ParameterError, match=words):
        RenderRequest.build(**kwargs)


def test_render_takes_the_setup_as_it_is(cab, monkeypatch):
    loose = labcut.render(cab, "blue", (0.1, 0.0, 1.0), scenario="ring", spp=2, resolution=16, seed=4, check_flash=False)
    setup = RenderRequest.build("blue", "ring", spp=2, resolution=16, seed=4)
    built = []
    real = RenderRequest.build
    monkeypatch.setattr(RenderRequest, "build", classmethod(lambda cls, *a, **k: built.append(1) or real(*a, **k)))
    held = labcut.render(cab, lamella_normal=(0.1, 0.0, 1.0), setup=setup, check_flash=False)
    assert not built  # given a setup, render checks nothing again
    assert np.allclose(loose.image, held.image, rtol=1e-4, atol=1e-6) and held.spp == 2 and held.scenario["name"] == "ring"
    with pytest.raises(ParameterError, match="already holds the render request; do not also pass spp"):
        labcut.render(cab, setup=setup, spp=4)
    with pytest.raises(ParameterError, match="already holds.*material"):
        labcut.render(cab, "red", setup=setup)
    with pytest.raises(ParameterError, match="must be a labcut RenderRequest"):
        labcut.render(cab, setup={"spp": 2})


def test_motion_angles_and_checks():
    assert Motion.build("rock", frames=4).angles_deg == pytest.approx([0.0, 30.0, 0.0, -30.0], abs=1e-12)
    assert Motion.build(" Turntable ", frames=3).angles_deg == pytest.approx([0.0, 120.0, 240.0])
    for kwargs, words in (({"motion": "spin"}, "motion must"), ({"frames": 1}, "frames must"),
                          ({"amplitude_deg": 75}, "rock amplitude"), ({"fps": 0.5}, "fps must")):
        with pytest.raises(ParameterError, match=words):
            Motion.build(**kwargs)


def test_animate_refuses_what_the_motion_or_setup_holds(cab):
    from labcut.commands.animate import animate

    with pytest.raises(ParameterError, match="holds its frames"):
        animate(cab, motion=Motion.build("rock", frames=4), frames=8)
    with pytest.raises(ParameterError, match="already holds the render request; do not also pass spp"):
        animate(cab, setup=RenderRequest.build(spp=2, resolution=16), spp=4)


def _main(*args: str) -> int:
    from labcut_cli.app import main

    with pytest.raises(SystemExit) as exit_:
        main(list(args))
    return int(exit_.value.code or 0)


def test_cli_builds_the_setup_once_before_the_mesh(tmp_path, monkeypatch, capsys):
    from labcut.geometry import meshio

    mesh = tmp_path / "cab.stl"
    labcut.cabochon("oval", 10, 8, resolution=32).export(mesh)
    built = []
    real = RenderRequest.build
    monkeypatch.setattr(RenderRequest, "build", classmethod(lambda cls, *a, **k: built.append(1) or real(*a, **k)))
    out = tmp_path / "a.png"
    assert _main("render", str(mesh), "-o", str(out), "--spp", "2", "--resolution", "16", "--look", "diagram") == 0
    assert built == [1] and out.is_file()
    # a bad option fails before the mesh is read, named as the option
    loads = []
    monkeypatch.setattr(meshio, "load_mesh", lambda *a, **k: loads.append(1))
    for args, words in ((["--spp", "4", "--time-budget", "1"], "--spp or --time-budget: give one, not both"),
                        (["--mode", "infrared"], "mode must be one of"),
                        (["--mode", "mono", "--denoise"], "denoising needs")):
        capsys.readouterr()
        assert _main("render", str(mesh), "-o", str(tmp_path / "b.png"), *args) == 2
        err = capsys.readouterr().err
        assert words in err and len(err.strip().splitlines()) == 1, err
    assert not loads and not (tmp_path / "b.png").exists()


def test_a_missing_denoiser_fails_before_any_work(monkeypatch):
    from labcut.errors import BackendError
    from labcut.rendering import denoise

    monkeypatch.setattr(denoise, "available", lambda: False)
    with pytest.raises(BackendError, match="pyoidn"):
        RenderRequest.build(look="studio")
    assert RenderRequest.build(look="studio", denoise=False).look == "studio"  # denoise off needs no pyoidn
