"""``labcut recommend-orientation`` / ``evaluate-orientation`` end to end."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

MESHES = Path(__file__).resolve().parents[1] / "meshes"
OVAL = str(MESHES / "oval-16x12-low.ply")


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


def test_recommend_writes_json_render_and_map(cli, tmp_path):
    js, png, mp = tmp_path / "r.json", tmp_path / "r.png", tmp_path / "m.png"
    proc = cli("recommend-orientation", OVAL, "--preset", "green", "--lighting", "spot", "--quality", "draft",
               "--json", str(js), "--render", str(png), "--map", str(mp), "--spp", "4")
    assert proc.returncode == 0, proc.stderr
    assert "tilt the lamella plane" in proc.stdout and "front" in proc.stdout and "±" in proc.stdout
    data = json.loads(js.read_text())
    assert set(["normal", "tilt_deg", "azimuth_deg", "score", "metrics", "tolerance_deg", "runners_up", "map"]) <= set(data)
    assert 5.0 < data["tilt_deg"] < 16.0
    for f in (png, mp):
        assert f.read_bytes()[:4] == b"\x89PNG"


def test_recommend_json_to_stdout(cli):
    proc = cli("recommend-orientation", OVAL, "--quality", "draft", "--optimizer", "gradient", "--max-tilt", "10", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["optimizer"] == "gradient" and data["tilt_deg"] <= 10.0


def test_evaluate_orientation(cli):
    proc = cli("evaluate-orientation", OVAL, "--normal", "0,0,1", "--quality", "draft", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert 0.0 < data["metrics"]["flash_area"] <= 1.0 and data["metrics"]["flash_energy"] > 0
    assert data["tilt_deg"] == 0.0 and "flash_energy" not in data  # recommend-orientation's layout


def test_evaluate_and_recommend_put_their_metrics_in_one_place(cli):
    ev = json.loads(cli("evaluate-orientation", OVAL, "--quality", "draft", "--json", "-").stdout)
    rec = json.loads(cli("recommend-orientation", OVAL, "--quality", "draft", "--json", "-").stdout)
    shared = {"normal", "tilt_deg", "azimuth_deg", "metrics", "metric_definitions", "mesh", "estimator", "plan", "frame"}
    assert shared <= set(ev) and shared <= set(rec)
    assert set(ev["metrics"]) == set(rec["metrics"])


@pytest.mark.parametrize(("args", "start"), [
    (["--max-tilt", "0"], "error: --max-tilt must lie in (0, 90]"),
    (["--tilt-axis", "0,0,1"], "error: --tilt-axis must be horizontal"),
    (["--quality", "ultra"], "error: --quality must be one of"),
    (["--objective", "sparkle"], "error: --objective must be one of"),
])
def test_library_errors_name_the_option(cli, args, start):
    """The library's ParameterError names its parameter; the CLI calls it by its option."""
    proc = cli("recommend-orientation", OVAL, *args, "--json", "-")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines()[-1].startswith(start), proc.stderr


def test_parameter_error_renamed_keeps_the_rest_of_the_message():
    from labcut.errors import ParameterError
    from labcut.validation import check_number

    with pytest.raises(ParameterError) as info:
        check_number(-1, "time budget", 0.0, low_open=True, unit="s")
    assert info.value.parameter == "time budget"
    renamed = info.value.renamed({"time budget": "--time-budget"})
    assert str(renamed) == "--time-budget must be greater than 0 s, got -1"
    assert info.value.renamed({"seed": "--seed"}) is info.value
    assert ParameterError("seed x", parameter="spp").parameter is None  # a name the message does not begin with


@pytest.mark.parametrize(
    "args",
    [
        ["--lighting", "disco"],
        ["--viewing", "upside-down"],
        ["--objective", "sparkle"],
        ["--optimizer", "magic"],
        ["--max-tilt", "0"],
        ["--tilt-axis", "0,0,1"],
        ["--quality", "ultra"],
        ["--preset", "purple"],
    ],
)
def test_bad_input_one_line_exit_2_and_no_partial_files(cli, tmp_path, args):
    outs = [tmp_path / "r.json", tmp_path / "r.png", tmp_path / "m.png"]
    proc = cli("recommend-orientation", OVAL, *args, "--json", str(outs[0]), "--render", str(outs[1]), "--map", str(outs[2]))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("error:") and "Traceback" not in proc.stderr
    assert not any(p.exists() for p in outs)


def test_unreadable_mesh_and_zero_normal(cli, tmp_path):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat garbage\n")
    proc = cli("recommend-orientation", str(bad), "--json", str(tmp_path / "r.json"))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and not (tmp_path / "r.json").exists()
    proc = cli("evaluate-orientation", OVAL, "--normal", "0,0,0")
    assert proc.returncode == 2 and "zero" in proc.stderr


def test_empty_lighting_file(cli, tmp_path):
    (tmp_path / "empty.json").write_text(json.dumps({"directions": []}))
    proc = cli("recommend-orientation", OVAL, "--lighting", str(tmp_path / "empty.json"))
    assert proc.returncode == 2 and "error:" in proc.stderr


def test_tilt_axis_with_map_and_all_outputs(cli, tmp_path):
    outs = [tmp_path / "r.json", tmp_path / "m.png", tmp_path / "r.png"]
    proc = cli("recommend-orientation", OVAL, "--quality", "draft", "--tilt-axis", "1,0,0", "--lighting", "spot",
               "--json", str(outs[0]), "--map", str(outs[1]), "--render", str(outs[2]), "--spp", "1")
    assert proc.returncode == 0, proc.stderr
    assert all(p.exists() for p in outs)
    assert abs(json.loads(outs[0].read_text())["normal"][0]) < 1e-6


@pytest.mark.parametrize("args, fragment", [(["--seed", "-1"], "seed"), (["--lighting", "EMPTY"], "[x, y, z]")])
def test_messages_keep_their_text(cli, tmp_path, args, fragment):
    (tmp_path / "empty.json").write_text(json.dumps({"directions": []}))
    args = [str(tmp_path / "empty.json") if a == "EMPTY" else a for a in args]
    proc = cli("recommend-orientation", OVAL, *args)
    assert proc.returncode == 2 and fragment in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_evaluate_by_tilt_and_azimuth_matches_the_normal(cli):
    """``evaluate-orientation --tilt T --azimuth A`` is the normal (sin T cos A, sin T sin A, cos T)."""
    import math

    t, a = 12.0, 250.0
    n = [math.sin(math.radians(t)) * math.cos(math.radians(a)), math.sin(math.radians(t)) * math.sin(math.radians(a)),
         math.cos(math.radians(t))]
    by_angles = json.loads(cli("evaluate-orientation", OVAL, "--tilt", str(t), "--azimuth", str(a), "--quality", "draft",
                               "--json", "-").stdout)
    by_normal = json.loads(cli("evaluate-orientation", OVAL, "--normal", ",".join(map(repr, n)), "--quality", "draft",
                               "--json", "-").stdout)
    assert by_angles["normal"] == pytest.approx(n, abs=1e-12)
    assert by_angles["metrics"]["flash_energy"] == pytest.approx(by_normal["metrics"]["flash_energy"], rel=1e-9)
    assert by_angles["tilt_deg"] == pytest.approx(t) and by_angles["azimuth_deg"] == pytest.approx(a)
    for args, words in ((["--tilt", "5"], "--tilt and --azimuth together"),
                        (["--normal", "0,0,1", "--tilt", "5", "--azimuth", "0"], "not both"),
                        (["--tilt", "95", "--azimuth", "0"], "--tilt must lie in [0, 90]")):
        proc = cli("evaluate-orientation", OVAL, *args, "--quality", "draft", "--json", "-")
        assert proc.returncode == 2 and words in proc.stderr, proc.stderr


def test_evaluate_orientation_api_takes_tilt_and_azimuth():
    import labcut

    import math

    mesh = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
    by_angles = labcut.evaluate_orientation(mesh, tilt=20.0, azimuth=90.0, quality="draft")
    by_normal = labcut.evaluate_orientation(mesh, [0.0, math.sin(math.radians(20)), math.cos(math.radians(20))],
                                            quality="draft")
    assert by_angles.flash_energy == pytest.approx(by_normal.flash_energy, rel=1e-9)
    with pytest.raises(labcut.ParameterError, match="both tilt and azimuth"):
        labcut.evaluate_orientation(mesh, tilt=20.0, quality="draft")


def test_two_outputs_on_one_path_are_refused_before_any_work(cli, tmp_path):
    """--render and --map on one file: the render would silently replace the map (issue 34)."""
    out = tmp_path / "x.png"
    proc = cli("recommend-orientation", OVAL, "--quality", "draft", "--render", str(out), "--map", str(out))
    assert proc.returncode == 2
    assert "--render and --map name the same file" in proc.stderr.strip().splitlines()[-1]
    assert not out.exists()


def test_a_zero_tilt_axis_says_zero():
    from labcut.errors import ParameterError
    from labcut.orientation.optimize import Constraint

    with pytest.raises(ParameterError, match="tilt axis must not be the zero vector"):
        Constraint(tilt_axis=(0.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="must be horizontal"):
        Constraint(tilt_axis=(0.0, 0.0, 2.0))


def test_scenario_and_direction_sets_print_in_one_line():
    import labcut

    sc = labcut.Scenario.preset("pendant", "draft")
    text = repr(sc)
    assert "\n" not in text and len(text) < 200 and "array" not in text
    assert text.startswith("Scenario('pendant', Lights(") and f"{len(sc.lights)} directions" in text
    assert repr(labcut.Lights([[0, 0, 1]])) == "Lights('custom', 1 direction, towards (0.00, 0.00, 1.00))"
