"""``labcut render`` end to end."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

MESH = str(Path(__file__).resolve().parents[1] / "meshes" / "oval-16x12-low.ply")


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


def test_render_png_exr_and_plan_json(cli, tmp_path):
    png, js = tmp_path / "r.png", tmp_path / "r.json"
    proc = cli("render", MESH, "-o", str(png), "--normal", "0.1,0,1", "--preset", "gold", "--spp", "4", "--resolution", "64", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    assert png.read_bytes()[:4] == b"\x89PNG"
    data = json.loads(js.read_text())
    assert data["plan"]["integrator"] == "direct" and data["plan"]["variant"].endswith("_ad_rgb")
    assert abs(sum(x * x for x in data["normal"]) - 1.0) < 1e-9
    proc = cli("render", MESH, "-o", str(tmp_path / "r.exr"), "--spp", "2", "--resolution", "32", "--mode", "spectral", "--view", "30,270")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "r.exr").read_bytes()[:4] == b"\x76\x2f\x31\x01"  # OpenEXR magic


def test_the_normal_by_its_tilt_and_azimuth(cli, tmp_path):
    """``--tilt`` and ``--azimuth``, the angles recommend- and evaluate-orientation print, give the
    normal their direction does (the picture and the JSON the same as ``--normal``'s)."""
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    common = ["--spp", "2", "--resolution", "32", "--look", "diagram"]
    proc = cli("render", MESH, "-o", str(a), "--tilt", "30", "--azimuth", "90", "--json", str(tmp_path / "a.json"), *common)
    assert proc.returncode == 0, proc.stderr
    proc = cli("render", MESH, "-o", str(b), "--normal", "0,0.5,0.8660254037844386", "--json", str(tmp_path / "b.json"), *common)
    assert proc.returncode == 0, proc.stderr
    got, want = (json.loads((tmp_path / f"{x}.json").read_text())["normal"] for x in "ab")
    assert got == pytest.approx(want, abs=1e-12) and got == pytest.approx([0.0, 0.5, 0.8660254037844386], abs=1e-12)
    assert a.read_bytes() == b.read_bytes()


@pytest.mark.parametrize(
    "args",
    [
        ["--tilt", "10"],
        ["--tilt", "95", "--azimuth", "0"],
        ["--normal", "0,0,1", "--tilt", "10", "--azimuth", "0"],
        ["--normal", "0,0,0"],
        ["--normal", "nan,0,1"],
        ["--normal", "1,2"],
        ["--lighting", "disco"],
        ["--view", "100,0"],
        ["--mode", "hyper"],
        ["--spp", "0"],
        ["--preset", "purple"],
        ["--lighting", "/no/such/sky.exr"],
    ],
)
def test_bad_input_one_line_exit_2_no_file(cli, tmp_path, args):
    out = tmp_path / "bad.png"
    proc = cli("render", MESH, "-o", str(out), "--resolution", "16", *args)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("error:") and "Traceback" not in proc.stderr
    assert not out.exists()


def test_unreadable_mesh(cli, tmp_path):
    bad = tmp_path / "broken.stl"
    bad.write_bytes(b"solid nothing here")
    proc = cli("render", str(bad), "-o", str(tmp_path / "x.png"))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    proc = cli("render", str(tmp_path / "missing.ply"), "-o", str(tmp_path / "x.png"))
    assert proc.returncode == 2
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("args", [["--polarizer", "nan"], ["--polarizer", "inf"], ["--exposure", "-1"], ["--exposure", "nan"]])
def test_bad_polarizer_or_exposure(cli, tmp_path, args):
    out = tmp_path / "x.png"
    proc = cli("render", MESH, "-o", str(out), "--resolution", "16", "--spp", "1", *args)
    assert proc.returncode == 2 and proc.stderr.startswith("error:") and not out.exists()
