"""CLI: ``labcut cabochon`` and ``labcut inspect``; errors exit 2 with one line, no traceback."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from labcut.geometry.meshio import load_mesh
from cli_run import run_in_process as run

ROOT = Path(__file__).resolve().parents[1]
LABCUT = Path(sys.executable).with_name("labcut")


def assert_one_line_error(code, err):
    assert code == 2, err
    assert "Traceback" not in err
    assert err.strip().startswith("error:")
    assert len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize(
    "args,dims",
    [
        (["--outline", "round", "--length", "10", "--dome", "high", "--profile", "spherical"], (10, 10, 5)),
        (["--outline", "oval", "--length", "16", "--width", "12", "--dome", "low"], (16, 12, 2.4)),
        (["--outline", "cushion", "--length", "12", "--width", "10", "--dome", "2", "--profile", "tallow"], (12, 10, 2)),
        (["--outline", "pear", "--length", "15", "--width", "10", "--dome", "medium"], (15, 10, 3.3)),
        (["--outline", "navette", "--length", "20", "--width", "8", "--dome", "low"], (20, 8, 1.6)),
        (["--outline", "rectangle", "--length", "14", "--width", "10", "--corner-radius", "1.5", "--dome", "2"], (14, 10, 2)),
        (["--outline", "oval", "--length", "16", "--width", "12", "--dome", "3", "--base", "1", "--girdle", "0.5"], (16, 12, 4.5)),
        (["--outline", "oval", "--length", "16", "--width", "12", "--dome", "3", "--buff-top", "0.5"], (16, 12, 3)),
    ],
)
def test_cabochon_every_kind(tmp_path, capsys, args, dims):
    out_path = tmp_path / "stone.ply"
    code, out, err = run(["cabochon", *args, "--resolution", "64", "-o", out_path], capsys)
    assert code == 0, err
    assert "dimensions" in out and "weight" in out and f"wrote {out_path}" in out.replace("\n", "")
    m = load_mesh(out_path)
    assert np.allclose(m.extents, dims, atol=0.01)
    assert m.metadata["labcut"]["repairs"] == []


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".off", ".glb", ".3mf"])
def test_cabochon_export_formats(tmp_path, capsys, suffix):
    out_path = tmp_path / f"cab{suffix}"
    code, _, err = run(["cabochon", "--outline", "oval", "--length", "8", "--width", "6", "--resolution", "32", "-o", out_path], capsys)
    assert code == 0, err
    assert np.allclose(load_mesh(out_path).extents, [8, 6, 0.33 * 6], atol=1e-4)


def test_cabochon_user_outline_files_and_json(tmp_path, capsys):
    square = [[0, 0], [10, 0], [10, 10], [0, 10]]
    csv = tmp_path / "outline.csv"
    csv.write_text("x,y\n" + "\n".join(f"{x},{y}" for x, y in square) + "\n")
    js = tmp_path / "outline.json"
    js.write_text(json.dumps({"points": square}))
    for src in (csv, js):
        out_path, summary = tmp_path / f"{src.stem}.stl", tmp_path / f"{src.stem}-{src.suffix[1:]}.json"
        code, _, err = run(["cabochon", "--outline", src, "--dome", "2", "-o", out_path, "--json", summary], capsys)
        assert code == 0, err
        data = json.loads(summary.read_text())
        assert data["volume_mm3"] == pytest.approx(100 * 2 / 3 * 2, rel=0.005)
        assert data["parameters"]["outline"] == "custom"
        assert data["convex"] is True and data["watertight"] is True
        assert data["output"] == str(out_path)


def test_inspect_reports_everything(tmp_path, capsys):
    cab = tmp_path / "cab.ply"
    assert run(["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "--dome", "low", "-o", cab], capsys)[0] == 0
    summary = tmp_path / "inspect.json"
    code, out, err = run(["inspect", cab, "--json", summary], capsys)
    assert code == 0, err
    for word in ("dimensions", "16.000 x 12.000 x 2.400", "volume", "ct", "triangles", "watertight", "convex", "repaired"):
        assert word in out, word
    data = json.loads(summary.read_text())
    assert 20000 <= data["triangles"] <= 50000
    assert data["weight_ct"] == pytest.approx(data["volume_mm3"] * 1e-3 * 2.705 / 0.2)
    assert data["load_report"]["convex"] is True


def test_inspect_shows_repairs_and_units(tmp_path, capsys):
    b = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    path = tmp_path / "inverted.obj"
    trimesh.Trimesh(b.vertices, b.faces[:, ::-1], process=False).export(path)
    summary = tmp_path / "s.json"
    code, out, err = run(["inspect", path, "--units", "cm", "--json", summary], capsys)
    assert code == 0, err
    assert "inverted all faces" in out
    data = json.loads(summary.read_text())
    assert data["volume_mm3"] == pytest.approx(6000.0)
    assert data["repairs"] and data["load_report"]["units"] == "cm"
    code, _, err = run(["inspect", path, "--no-repair"], capsys)
    assert_one_line_error(code, err)


@pytest.mark.parametrize(
    "argv",
    [
        ["cabochon", "--outline", "oval", "--length", "-16", "--width", "12"],
        ["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "--dome", "20"],
        ["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "--dome", "towering"],
        ["cabochon", "--outline", "hexagon", "--length", "16"],
        ["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "--profile", "gothic"],
        ["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "--resolution", "3"],
        ["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "-o", "{tmp}/cab.xyz"],
        ["cabochon", "--outline", "oval", "--length", "16", "--width", "12", "-o", "{tmp}/missing/cab.ply"],
        ["cabochon", "--outline", "{tmp}/bowtie.csv"],
        ["cabochon", "--length", "abc"],
        ["inspect", "{tmp}/nope.stl"],
        ["inspect", "{tmp}/empty.stl"],
        ["inspect", "{tmp}/truncated.stl"],
        ["inspect", "{tmp}/nan.ply"],
        ["inspect", "{tmp}/notamesh.ply"],
        ["inspect", "{tmp}/notes.txt"],
        ["inspect", "{tmp}/sheet.ply"],
    ],
)
def test_errors_exit_2_in_one_line(tmp_path, capsys, argv):
    _broken_files(tmp_path)
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, _, err = run(argv, capsys)
    assert_one_line_error(code, err)
    assert not list(tmp_path.glob("cab*")), "no output may be left behind"


def _broken_files(tmp: Path) -> None:
    (tmp / "empty.stl").write_bytes(b"")
    good = trimesh.creation.icosphere(subdivisions=1)
    data = trimesh.exchange.stl.export_stl(good)
    (tmp / "truncated.stl").write_bytes(data[: len(data) - 30])
    v = np.full_like(good.vertices, np.nan)
    trimesh.Trimesh(v, good.faces, process=False).export(tmp / "nan.ply")
    (tmp / "notamesh.ply").write_text("Dear cutter, this is a letter, not a mesh.\n")
    (tmp / "notes.txt").write_text("not a mesh")
    sheet = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    trimesh.Trimesh(sheet, [[0, 1, 2], [0, 2, 3]], process=False).export(tmp / "sheet.ply")
    (tmp / "bowtie.csv").write_text("0,0\n10,10\n10,0\n0,10\n")


@pytest.mark.skipif(not LABCUT.exists(), reason="console script not installed in this environment")
def test_console_script_errors_have_no_traceback(tmp_path):
    _broken_files(tmp_path)
    env = {**os.environ, "LABCUT_DEBUG": ""}
    env.pop("LABCUT_DEBUG")
    for argv in (["inspect", str(tmp_path / "truncated.stl")], ["cabochon", "--outline", "pear", "--length", "5", "--width", "9"]):
        proc = subprocess.run([str(LABCUT), *argv], capture_output=True, text=True, env=env, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert "Traceback" not in proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    ok = subprocess.run(
        [str(LABCUT), "cabochon", "--outline", "oval", "--length", "16", "--width", "12", "--dome", "low", "-o", str(tmp_path / "c.ply")],
        capture_output=True, text=True, env=env, timeout=120,
    )
    assert ok.returncode == 0, ok.stderr
    assert (tmp_path / "c.ply").exists()
