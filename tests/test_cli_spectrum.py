"""``labcut spectrum`` from the outside: tables, files, and one-line errors."""

from __future__ import annotations

import json

import pytest

from labcut import Labradorite


#: the CLI in this process (conftest's ``cli``): the spectrum's checks cost milliseconds, a new
#: interpreter a second; test_table_plot_and_json and the 80-column check run the console script
CLI_IN_PROCESS = True


def test_table_plot_and_json(tmp_path):
    from conftest import run_cli

    png, js = tmp_path / "s.png", tmp_path / "s.json"
    proc = run_cli("spectrum", "--preset", "green", "--angles", "0,20,40", "-o", str(png), "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    assert "peak λ" in proc.stdout and "530.0 nm" in proc.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    data = json.loads(js.read_text())
    assert [row["angle_deg"] for row in data["angles"]] == [0.0, 20.0, 40.0]
    assert abs(data["angles"][0]["peak_nm"] - 530.0) < 0.05
    assert Labradorite.from_dict(data["material"]) == Labradorite.preset("green")


def test_json_to_stdout_is_machine_readable(cli, tmp_path):
    proc = cli("spectrum", "--an", "52", "--json", "-", "--no-plot", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["material"]["name"] == "An52"
    assert not list(tmp_path.iterdir())


def test_explicit_layers_and_material_file(cli, tmp_path):
    proc = cli("spectrum", "--d-a", "90", "--d-b", "80", "--sigma-a", "10", "--pairs", "3000", "--json", str(tmp_path / "m.json"), "--no-plot")
    assert proc.returncode == 0, proc.stderr
    proc = cli("spectrum", "--material", str(tmp_path / "m.json"), "--json", "-", "--no-plot")
    whole = json.loads(proc.stdout)
    data = whole["material"]
    assert (data["d_a"], data["d_b"], data["sigma_a"], data["pairs"]) == (90.0, 80.0, 10.0, 3000)
    # the stack's depth, 3000 x 170 nm, and its flash depth (docs/physics.md "Depth")
    assert whole["depth"]["stack_depth_mm"] == pytest.approx(0.51)
    assert 0.2 < whole["depth"]["flash_depth_mm"] < 0.51 / 2 + 0.01


@pytest.mark.parametrize(
    "args",
    [
        ["--d-a", "-3"],
        ["--n-a", "1.0"],
        ["--peak", "nan"],
        ["--an", "70"],
        ["--preset", "purple"],
        ["--preset", "blue", "--peak", "470"],
        ["--angles", "0,95"],
        ["--angles", "zero"],
        ["--material", "/no/such/file.json"],
        ["--bogus-option"],
        ["--pairs", "many"],
        ["--peak", "250", "--sigma-a", "40", "--sigma-b", "40"],  # no period puts a peak there (was a ValueError)
    ],
)
def test_bad_input_is_one_line_and_exit_2(cli, tmp_path, args):
    proc = cli("spectrum", *args, "-o", str(tmp_path / "x.png"))
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and proc.stderr.startswith("error:")
    assert not (tmp_path / "x.png").exists()


def test_bad_output_paths_leave_nothing(cli, tmp_path):
    for out in (str(tmp_path / "missing" / "x.png"), str(tmp_path / "x.jpg"), str(tmp_path)):
        proc = cli("spectrum", "-o", out)
        assert proc.returncode == 2 and proc.stderr.startswith("error:")
    assert not list(tmp_path.iterdir())


def test_broken_material_file(cli, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    proc = cli("spectrum", "--material", str(bad), "--no-plot")
    assert proc.returncode == 2 and "not readable JSON" in proc.stderr
    bad.write_text(json.dumps({"d_a": -1}))
    proc = cli("spectrum", "--material", str(bad), "--no-plot")
    assert proc.returncode == 2 and "d_a" in proc.stderr


def test_help_and_version(cli):
    assert cli().returncode == 0
    proc = cli("--version")
    assert proc.returncode == 0 and "labcut" in proc.stdout


def test_outputs_get_the_usual_permissions(cli, tmp_path):
    import os
    import stat

    proc = cli("spectrum", "-o", str(tmp_path / "s.png"), "--json", str(tmp_path / "s.json"))
    assert proc.returncode == 0
    umask = os.umask(0)
    os.umask(umask)
    for name in ("s.png", "s.json"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~umask


# ---------------------------------------------------------------------- a flash outside the visible
@pytest.mark.parametrize("args", [
    ["--peak", "2000"],
    ["--an", "61"],
    ["--d-a", "600", "--d-b", "600"],
    ["--peak", "470", "--d-a", "600", "--d-b", "600"],
    ["--material", "FILE"],
])
def test_a_flash_outside_the_visible_is_accepted_with_one_warning(cli, tmp_path, args):
    """Every way of giving a material sets its period, and each gets the material's one
    warning line (stderr) and the same sentence in the JSON's warnings; exit status 0."""
    if args == ["--material", "FILE"]:
        (tmp_path / "dark.json").write_text(json.dumps({"material": {"d_a": 600.0, "d_b": 600.0}}))
        args = ["--material", str(tmp_path / "dark.json")]
    proc = cli("spectrum", *args, "--json", str(tmp_path / "s.json"))
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: ") and "Traceback" not in proc.stderr, proc.stderr
    assert "outside the visible range (380-780 nm)" in lines[0] and "infrared" in lines[0]
    assert json.loads((tmp_path / "s.json").read_text())["warnings"] == [lines[0][len("warning: "):]]


def test_a_visible_flash_has_no_warning(cli, tmp_path):
    """A base outside the visible that --d-a/--d-b bring back in does not warn either."""
    for args in (["--preset", "blue"], ["--peak", "2000", "--d-a", "80", "--d-b", "80"]):
        proc = cli("spectrum", *args, "--json", "-")
        assert proc.returncode == 0 and proc.stderr == "", proc.stderr
        assert json.loads(proc.stdout)["warnings"] == []


def test_a_purple_dominant_wavelength_is_explained(cli):
    """--peak 2000 shows a purple face-on (higher orders at 667 and 400 nm): its dominant λ is
    the complementary wavelength, marked c and explained, never a bare negative number."""
    proc = cli("spectrum", "--peak", "2000")
    assert proc.returncode == 0, proc.stderr
    assert "c 498.7 nm" in proc.stdout and "-498.7" not in proc.stdout
    assert "c: a purple" in proc.stdout and "complementary wavelength" in proc.stdout
    assert "c: a purple" not in cli("spectrum", "--preset", "green").stdout  # the caption only when needed
    row = json.loads(cli("spectrum", "--peak", "2000", "--json", "-").stdout)["angles"][0]
    assert row["hue"] == "purple" and row["complementary_nm"] == pytest.approx(498.7, abs=0.05)
    assert row["dominant_nm"] == pytest.approx(-row["complementary_nm"])  # the CIE number, kept
    row = json.loads(cli("spectrum", "--preset", "green", "--json", "-").stdout)["angles"][0]
    assert row["hue"] == "spectral" and row["complementary_nm"] is None


def test_the_table_is_readable_at_80_columns(tmp_path):
    """No column cut to an ellipsis in an 80-column terminal: the hex codes and every number whole."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    exe = Path(sys.executable).with_name("labcut")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "labcut_cli.app"]
    env = {**os.environ, "COLUMNS": "80", "NO_COLOR": "1"}
    proc = subprocess.run([*cmd, "spectrum", "--peak", "2000"], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "…" not in proc.stdout and max(len(line) for line in proc.stdout.splitlines()) <= 80
    for text in ("#ff1c93", "#ff0047", "#ffd200", "#006aff", "2000.0 nm", "1412.8 nm", "c 498.7 nm", "0.989", "0.62"):
        assert text in proc.stdout, proc.stdout
