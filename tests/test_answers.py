"""Answers a new user can trust (issue 9, items 4-9 and 12): no meaningless optimum, honest
exposure, the answer before the render, metrics that add up, parallel within tolerance,
workshop terms, and the small ones."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

import labcut
from labcut.errors import OutputError, ParameterError
from labcut.fileio import atomic_output
from labcut.geometry.meshio import load_mesh
from labcut.orientation.recommend import energy_parts
from labcut.rendering.images import read_png_metadata, shared_exposure
from cli_run import run_in_process as _run_in_process


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


ROOT = Path(__file__).resolve().parents[1]
OVAL = ROOT / "meshes" / "oval-16x12-low.ply"
LAB = labcut.Labradorite()


@pytest.fixture(scope="module")
def oval():
    return load_mesh(OVAL)


@pytest.fixture(scope="module")
def spot_rec(oval):
    return labcut.recommend_orientation(oval, LAB, lighting="spot", viewing="face-up", quality="draft")


# ----------------------------------------------------------------------------- 4. no meaningless answers
#: a stone lit only from behind and below its horizon, seen from in front just above it: the light reaches
#: only the back of the dome, which the viewer sees at grazing, so no orientation flashes (the threshold
#: is the scene's own, τ P: under an even sky or a ceiling a stone does flash, test_radiance.py)
BACKLIT = {"directions": [[0.0, 0.998, -0.06]]}
GRAZING = {"directions": [[0.0, -0.99, 0.14]]}


@pytest.mark.parametrize("objective", ["area", "intensity", "balanced"])
def test_threshold_objectives_without_any_flash_are_an_error(oval, objective):
    lights, views = labcut.Lights(**BACKLIT), labcut.Views(**GRAZING)
    with pytest.raises(ParameterError) as info:
        labcut.recommend_orientation(oval, LAB, lighting=lights, viewing=views, objective=objective, quality="draft")
    msg = str(info.value)
    assert "--objective energy" in msg and "objective='energy'" in msg and "\n" not in msg
    assert "the brightest schiller its light can give" in msg
    # energy still ranks orientations under the same light
    rec = labcut.recommend_orientation(oval, LAB, lighting=lights, viewing=views, quality="draft")
    assert rec.score > 0 and rec.metrics.flash_area == 0.0
    # the same stone under an even sky, by the scene's own threshold, flashes
    sky = labcut.recommend_orientation(oval, LAB, lighting="sky", viewing="face-up", objective="area", quality="draft")
    assert sky.score > 0.05


def test_cli_no_flash_objective_exit_2_no_files(cli, tmp_path):
    js = tmp_path / "r.json"
    (tmp_path / "back.json").write_text(json.dumps(BACKLIT))
    (tmp_path / "grazing.json").write_text(json.dumps(GRAZING))
    proc = cli("recommend-orientation", str(OVAL), "--lighting", str(tmp_path / "back.json"), "--viewing",
               str(tmp_path / "grazing.json"), "--objective", "area", "--quality", "draft", "--json", str(js))
    assert proc.returncode == 2 and "--objective energy" in proc.stderr and "±0.0°" not in proc.stdout
    assert proc.stderr.strip().splitlines()[-1].startswith("error:") and not js.exists()


# ----------------------------------------------------------------------------- 5. exposure
def test_render_records_its_exposure(cli, tmp_path):
    png, js = tmp_path / "r.png", tmp_path / "r.json"
    proc = cli("render", str(OVAL), "-o", str(png), "--resolution", "16", "--spp", "1", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(js.read_text())
    meta = read_png_metadata(png)
    assert data["exposure_mode"] == meta["exposure_mode"] == "reference"
    assert float(meta["exposure"]) == pytest.approx(data["exposure"]) == pytest.approx(data["exposure_reference"])
    assert data["exposure"] > 0
    assert data["exposure_vs_reference_ev"] == 0.0 and "reference exposure" in proc.stdout
    proc = cli("render", str(OVAL), "-o", str(png), "--resolution", "16", "--spp", "1", "--exposure", "2.5", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    assert json.loads(js.read_text())["exposure"] == 2.5 and read_png_metadata(png)["exposure_mode"] == "given"
    assert float(read_png_metadata(png)["exposure"]) == 2.5
    for bad in ("bright", "0", "nan"):
        proc = cli("render", str(OVAL), "-o", str(tmp_path / "bad.png"), "--exposure", bad)
        assert proc.returncode == 2 and "--exposure" in proc.stderr and not (tmp_path / "bad.png").exists()


def test_a_series_shares_one_exposure_and_says_where_there_is_no_flash(oval, tmp_path):
    result = labcut.render(oval, LAB, (0.0, 0.5, 1.0), view="orbit", spp=1, resolution=16, exposure="auto")
    h, w = result.image.shape[:2]
    tiles = [result.image[r:r + h // 2, c:c + w // 4] for r in (0, h // 2) for c in range(0, w, w // 4)]
    assert len(tiles) == 8 and result.exposure == pytest.approx(shared_exposure(tiles))
    assert result.exposure_mode == "auto" and result.exposure_vs_reference_ev > 1.0  # the orbit's views are dim
    # the optimiser's estimator per tile: some orbit views see no flash at this orientation, and say so
    assert [f["view"] for f in result.flash] == result.views
    dark = [f["view"] for f in result.flash if f["flash"] is False]
    assert dark and any("no flash" in n and dark[0] in n for n in result.notes)
    result.save(tmp_path / "orbit.png")
    assert float(read_png_metadata(tmp_path / "orbit.png")["exposure"]) == pytest.approx(result.exposure)


def test_cli_says_when_the_view_shows_no_flash(cli, tmp_path):
    # lamellae standing on edge: nothing mirrors the lamp into the viewer
    js = tmp_path / "r.json"
    proc = cli("render", str(OVAL), "-n", "1,0,0.02", "--lighting", "spot", "--viewing", "face-up", "-o", str(tmp_path / "r.png"),
               "--resolution", "16", "--spp", "1", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    assert "no flash" in proc.stdout
    data = json.loads(js.read_text())
    assert data["flash_by_view"][0]["flash"] is False and data["notes"]


# ----------------------------------------------------------------------------- 6. the answer first


def test_a_failing_render_leaves_the_answer(tmp_path, capsys, monkeypatch):
    import labcut.commands.render as api

    def broken(*args, **kwargs):
        raise labcut.BackendError("the renderer ran out of memory")

    monkeypatch.setattr(api, "render", broken)
    monkeypatch.setattr(api, "render_checked", broken)  # what the CLI calls with its checked RenderRequest
    monkeypatch.setattr(labcut, "render", broken, raising=False)
    js, png, mp = tmp_path / "r.json", tmp_path / "r.png", tmp_path / "m.png"
    code, out, err = _run_in_process(["recommend-orientation", OVAL, "--quality", "draft", "--json", js, "--render", png,
                                      "--map", mp], capsys)
    assert code == 2 and "out of memory" in err.strip().splitlines()[-1]
    assert "tilt the lamella plane" in out or "parallel to the base" in out  # printed before the render
    data = json.loads(js.read_text())
    assert data["normal"] and data["render"]["status"].startswith("pending")
    assert mp.exists() and not png.exists()
    assert "answer above stands" in err
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_ctrl_c_during_the_render_leaves_the_answer(tmp_path):
    js, png = tmp_path / "r.json", tmp_path / "r.png"
    exe = Path(sys.executable).with_name("labcut")
    env = {**os.environ, "NO_COLOR": "1"}
    proc = subprocess.Popen([str(exe), "recommend-orientation", str(OVAL), "--quality", "draft", "--json", str(js),
                             "--render", str(png), "--spp", "100000", "--resolution", "256", "--yes"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            # a user's Ctrl-C: the child handles SIGINT as a terminal's process would, even
                            # where the test runner (xdist workers, CI shells) starts children with it ignored
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while not js.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.2)
    assert js.exists(), proc.communicate()[1]
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert json.loads(js.read_text())["normal"]
    assert not png.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_write_errors_name_the_users_path(tmp_path):
    target = tmp_path / "render.png"
    with pytest.raises(OutputError) as info:
        with atomic_output(target) as tmp:
            raise OSError(28, "No space left on device", str(tmp))
    assert str(target) in str(info.value) and ".render." not in str(info.value)
    with pytest.raises(OutputError) as info:
        with atomic_output(target) as tmp:
            raise RuntimeError(f"Bitmap::write(): could not open \"{tmp}\"")
    assert str(target) in str(info.value) and tmp.name not in str(info.value)
    assert not list(tmp_path.iterdir())


# ----------------------------------------------------------------------------- 7. metrics that add up
def test_energy_is_its_flashing_part_plus_the_faint_part(spot_rec, oval):
    data = spot_rec.to_dict()["metrics"]
    pv = spot_rec.metrics.per_view
    in_flash = float(np.dot(pv["weight"], np.asarray(pv["flash_area"]) * np.asarray(pv["flash_intensity"])))
    assert data["energy_in_flash"] == pytest.approx(in_flash, rel=1e-12)
    assert data["energy_in_flash"] + data["energy_below_threshold"] == pytest.approx(data["flash_energy"], rel=1e-12)
    assert data["energy_below_threshold"] >= 0
    # the same for evaluate_orientation's metrics
    m = labcut.evaluate_orientation(oval, (0, 0, 1), LAB, lighting="overhead", viewing="above", quality="draft")
    a, b = energy_parts(m)
    assert a + b == pytest.approx(m.flash_energy) and a <= m.flash_energy


def test_the_table_numbers_add_up(spot_rec):
    from labcut_cli.recommend import _metrics_table

    console = Console(width=400, record=True, color_system=None)
    console.print(_metrics_table("t", spot_rec.metrics))
    text = console.export_text()
    row = next(line for line in text.splitlines() if "flash energy" in line)
    energy = float(re.search(r"│\s*([0-9.]+)\s*│", row).group(1))
    parts = re.search(r"= ([0-9.]+) in the flashes .* \+ ([0-9.]+) fainter", row)
    assert parts, row
    assert float(parts.group(1)) + float(parts.group(2)) == pytest.approx(energy, abs=1e-9)
    assert float(parts.group(1)) == pytest.approx(energy_parts(spot_rec.metrics)[0], abs=6e-5)
    # aggregates are view means: the table must not claim energy = area x intensity of the aggregates
    m = spot_rec.metrics
    assert "area x intensity" not in row.replace("(area x intensity, view by view)", "")
    assert abs(m.flash_area * m.flash_intensity - m.flash_energy) > 1e-4  # why the claim was wrong


# ----------------------------------------------------------------------------- 8. tilt inside its tolerance
def test_a_tilt_inside_its_own_tolerance_is_parallel_to_the_base(oval):
    rec = labcut.recommend_orientation(oval, LAB, quality="draft")  # bench: a broad optimum a few degrees off
    assert rec.tilt_deg >= 0.5  # the optimum itself is tilted ...
    scorer_pole = labcut.evaluate_orientation(oval, (0, 0, 1), LAB, quality="draft").flash_energy
    assert scorer_pole >= 0.9 * rec.score  # ... but the base scores as well
    assert rec.parallel_within_deg is not None and rec.parallel_within_deg > 0
    assert rec.description.startswith("keep the lamella plane parallel to the base (any tilt within ±")
    assert f"±{rec.parallel_within_deg:.1f}°" in rec.description
    data = rec.to_dict()
    assert data["parallel_to_base"] is True and data["workshop"]["raise_deg"] == 0.0


def test_a_real_tilt_stays_an_instruction(spot_rec):
    assert spot_rec.parallel_within_deg is None and spot_rec.description.startswith("tilt the lamella plane")


# ----------------------------------------------------------------------------- 9. workshop terms
def test_workshop_raise_edge_degrees_and_mm(spot_rec, oval):
    shop = spot_rec.to_dict()["workshop"]
    assert shop["raise_edge"] == "front (-Y)" and shop["raise_deg"] == pytest.approx(spot_rec.tilt_deg)
    assert shop["span_mm"] == pytest.approx(12.0, abs=0.2)  # the oval's width: front to back
    assert shop["raise_mm"] == pytest.approx(shop["span_mm"] * math.sin(math.radians(spot_rec.tilt_deg)))
    assert "saw or dop" in shop["text"] and f"{shop['raise_mm']:.2f} mm" in shop["text"]
    # geometry: with the flash (lamella) plane levelled, the base rises towards the raised edge by raise_mm
    m = spot_rec.normal
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(m, z)
    s, c = np.linalg.norm(axis), float(m @ z)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    level = np.eye(3) + k + k @ k * ((1 - c) / s**2)  # rotation taking m to +Z
    base = np.asarray(oval.vertices)[np.abs(oval.vertices[:, 2]) < 1e-6]
    u = np.array([math.cos(math.radians(shop["edge_azimuth_deg"])), math.sin(math.radians(shop["edge_azimuth_deg"])), 0.0])
    front, back = base[np.argmax(base @ u)], base[np.argmin(base @ u)]
    rise = float((level @ front)[2] - (level @ back)[2])
    assert rise == pytest.approx(shop["raise_mm"], rel=0.005) and rise > 0


def test_workshop_in_the_table_and_named_as_worn(cli):
    proc = cli("recommend-orientation", str(OVAL), "--scenario", "pendant", "--quality", "draft", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    shop = json.loads(proc.stdout)["workshop"]
    assert shop["raise_edge"].startswith("top") or shop["raise_edge"].startswith("bottom") or shop["raise_deg"] == 0.0
    proc = cli("recommend-orientation", str(OVAL), "--lighting", "spot", "--viewing", "face-up", "--quality", "draft")
    assert proc.returncode == 0, proc.stderr
    flat = " ".join(proc.stdout.split())
    assert "when sawing or dopping" in flat and "front" in flat and " mm" in flat


# ----------------------------------------------------------------------------- 12. small ones
def test_spectrum_writes_nothing_unless_asked(cli, tmp_path):
    proc = cli("spectrum", "--json", "-", cwd=tmp_path)
    assert proc.returncode == 0 and json.loads(proc.stdout)["angles"]
    proc = cli("spectrum", cwd=tmp_path)
    assert proc.returncode == 0
    assert not list(tmp_path.iterdir())


def test_render_needs_an_explicit_output(cli, tmp_path):
    proc = cli("render", str(OVAL), "--resolution", "16", "--spp", "1", cwd=tmp_path)
    assert proc.returncode == 2 and "--output" in proc.stderr and not list(tmp_path.iterdir())


def test_material_file_refuses_booleans(cli, tmp_path):
    with pytest.raises(ParameterError, match="pairs"):
        labcut.Labradorite.from_dict({"pairs": True})
    (tmp_path / "m.json").write_text(json.dumps({"pairs": True}))
    for cmd in (["spectrum"], ["evaluate-orientation", str(OVAL)]):
        proc = cli(*cmd, "--material", str(tmp_path / "m.json"))
        assert proc.returncode == 2 and "pairs" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_layer_flags_and_a_recommendations_material(cli, tmp_path):
    rec = tmp_path / "rec.json"
    proc = cli("recommend-orientation", str(OVAL), "--quality", "draft", "--preset", "gold", "--d-a", "95", "--sigma-b", "12",
               "--n-surface", "1.57", "--json", str(rec))
    assert proc.returncode == 0, proc.stderr
    material = json.loads(rec.read_text())["settings"]["material"]
    assert (material["d_a"], material["sigma_b"], material["n_surface"]) == (95.0, 12.0, 1.57)
    proc = cli("evaluate-orientation", str(OVAL), "--quality", "draft", "--material", str(rec), "--pairs", "4000", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    used = json.loads(proc.stdout)["material"]
    assert used["d_a"] == 95.0 and used["pairs"] == 4000 and used["sigma_b"] == 12.0
    rj = tmp_path / "r.json"
    proc = cli("render", str(OVAL), "--material", str(rec), "-o", str(tmp_path / "r.png"), "--resolution", "16", "--spp", "1",
               "--json", str(rj))
    assert proc.returncode == 0, proc.stderr
    assert json.loads(rj.read_text())["material"] == material


def test_an_oval():
    with pytest.raises(ParameterError, match="^an oval cabochon needs its length"):
        labcut.cabochon("oval", width=12)
    with pytest.raises(ParameterError, match="for an elliptic profile"):
        labcut.cabochon("oval", 16, 12, dome=20.0)


def test_azimuth_convention_is_documented(spot_rec, cli):
    frame = spot_rec.to_dict()["frame"]
    assert "from +X (right) towards +Y (back)" in frame["azimuth_deg"] and "270 front" in frame["azimuth_deg"]
    readme = (ROOT / "README.md").read_text()
    assert re.search(r"azimuth.{0,80}from \+X", readme, re.S)
    help_text = " ".join(cli("recommend-orientation", "--help").stdout.split())
    assert "270° front" in help_text


def test_readme_api_snippet_runs_as_written(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## Python API\n\n```python\n(.*?)```", text, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["img"].image.shape[-1] == 3 and namespace["rec"].normal[2] > 0
    # the snippet ends by stopping the explorer it started: one left running would render (and so
    # switch Mitsuba's variant, the process's) under the next test on this worker
    ex = namespace["ex"]
    assert not ex.worker.is_alive() and not ex._thread.is_alive()
