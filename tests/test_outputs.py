"""Every output checked before any work, and the answer written before any figure (issue 34, point 2).

Each output path of a command is checked first: its folder can really hold a new file (a probe
file, so ``/proc`` or a read-only mount fails at once), it is no device, no two outputs name one
file, and no output is a file the command reads. Figures (score map, render, report) come after
the answer (table, JSON, CSV), so a failing figure leaves the answer written.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import labcut
from labcut.errors import OutputError, ParameterError
from labcut.fileio import check_output_path, check_outputs
from cli_run import run_in_process as _run

ROOT = Path(__file__).resolve().parents[1]
OVAL = ROOT / "meshes" / "oval-16x12-low.ply"


# ----------------------------------------------------------------------------- the library's checks
def test_a_folder_that_cannot_hold_a_file_fails_before_the_work():
    with pytest.raises(OutputError) as info:
        check_output_path("/proc/report.html", (".html",))
    assert "/proc/report.html" in str(info.value) and "\n" not in str(info.value)


def test_the_probe_leaves_nothing_behind(tmp_path):
    check_output_path(tmp_path / "a.json", (".json",))
    assert list(tmp_path.iterdir()) == []


def test_a_device_is_never_replaced():
    with pytest.raises(ParameterError, match="not a regular file"):
        check_output_path("/dev/null")


def test_an_output_may_not_be_an_input(tmp_path):
    src = tmp_path / "m.json"
    src.write_text("{}")
    with pytest.raises(ParameterError) as info:
        check_outputs({"--json": (tmp_path / "sub" / ".." / "m.json", (".json",))}, inputs={"--material": src})
    assert "--json" in str(info.value) and "--material" in str(info.value)
    with pytest.raises(ParameterError, match="--json and --map name the same file"):
        check_outputs({"--json": (tmp_path / "a.png", None), "--map": (str(tmp_path / "a.png"), None)})
    check_outputs({"--json": ("-", (".json",)), "--map": (None, (".png",))}, inputs={"MESH": src})  # stdout, unset: fine


def test_a_symbolic_link_to_an_input_is_that_input(tmp_path):
    src = tmp_path / "stone.ply"
    src.write_bytes(OVAL.read_bytes())
    (tmp_path / "link.ply").symlink_to(src)
    with pytest.raises(ParameterError, match="is also the input"):
        check_outputs({"--output": (tmp_path / "link.ply", (".ply",))}, inputs={"MESH": src})


# ----------------------------------------------------------------------------- every command, before its work
def test_compare_to_an_unwritable_report_fails_before_comparing(capsys, monkeypatch):
    import labcut.reports as reports

    def never(*args, **kwargs):
        raise AssertionError("the comparison ran before its report path was checked")

    monkeypatch.setattr(reports, "run_comparison", never, raising=False)
    monkeypatch.setattr(reports, "plan_comparison", never, raising=False)
    code, out, err = _run(["compare", OVAL, "--html", "/proc/x.html", "--quality", "draft"], capsys)
    assert code == 2 and "cannot write '/proc/x.html'" in err.strip().splitlines()[-1]


@pytest.mark.parametrize("argv", [
    ["recommend-orientation", "{mesh}", "--material", "{mat}", "--json", "{mat}"],
    ["evaluate-orientation", "{mesh}", "--material", "{mat}", "--json", "{mat}"],
    ["render", "{mesh}", "--output", "{mesh}"],
    ["inspect", "{mesh}", "--json", "{mat}", "--material", "{mat}"],
    ["compare", "{mesh}", "{mesh}@14", "--csv", "{mesh}"],
    ["rough", "{mesh}", "--lamella", "0,0,1", "--png", "{mesh}"],
    ["cabochon", "--outline", "{outline}", "--output", "{outline}"],
    ["spectrum", "--material", "{mat}", "--json", "{mat}"],
    ["batch", "{outline}", "--out", "{mesh}.parquet", "--json", "{outline}"],
])
def test_no_command_overwrites_what_it_reads(argv, tmp_path, capsys):
    mesh, mat, outline = tmp_path / "stone.ply", tmp_path / "mat.json", tmp_path / "outline.csv"
    mesh.write_bytes(OVAL.read_bytes())
    mat.write_text(json.dumps(labcut.Labradorite().to_dict()))
    outline.write_text("0,0\n10,0\n10,6\n0,6\n")
    before = {p: p.read_bytes() for p in (mesh, mat, outline)}
    if argv[0] == "inspect":  # inspect takes no material: its JSON may not be its mesh either
        argv = ["inspect", "{mesh}", "--json", "{mesh}.json"]
        (tmp_path / "stone.ply.json").symlink_to(mesh)
    args = [a.format(mesh=mesh, mat=mat, outline=outline) for a in argv]
    code, out, err = _run(args, capsys)
    assert code == 2, err
    line = err.strip().splitlines()[-1]
    assert line.startswith("error:") and "is also the input" in line, line
    assert {p: p.read_bytes() for p in before} == before


def test_an_output_that_is_also_the_input_is_named(tmp_path, capsys):
    mat = tmp_path / "m.json"
    mat.write_text(json.dumps(labcut.Labradorite().to_dict()))
    code, out, err = _run(["recommend-orientation", OVAL, "--material", mat, "--json", mat], capsys)
    assert code == 2 and f"--json {mat} is also the input --material {mat}" in err


# ----------------------------------------------------------------------------- the answer before the figures
def test_a_failing_score_map_leaves_the_answer(tmp_path, capsys, monkeypatch):
    import labcut.plots.scoremap as scoremap

    def broken(*args, **kwargs):
        raise OutputError("cannot write the map: disk full")

    monkeypatch.setattr(scoremap, "plot_score_map", broken)
    js, mp = tmp_path / "r.json", tmp_path / "m.png"
    code, out, err = _run(["recommend-orientation", OVAL, "--quality", "draft", "--json", js, "--map", mp], capsys)
    assert code == 2 and "disk full" in err.strip().splitlines()[-1]
    assert json.loads(js.read_text())["normal"] and not mp.exists()
    assert "Recommendation for" in out and f"the answer above stands in {js}; the score map {mp} was not written" in err


def test_a_failing_report_leaves_the_comparisons_answer(tmp_path, capsys, monkeypatch):
    from labcut.reports.compare import Comparison

    def broken(self, path):
        raise OutputError("cannot write the report: disk full")

    monkeypatch.setattr(Comparison, "save_html", broken)
    js, csv, html = tmp_path / "c.json", tmp_path / "c.csv", tmp_path / "c.html"
    code, out, err = _run(["compare", OVAL, "--quality", "draft", "--json", js, "--csv", csv, "--html", html], capsys)
    assert code == 2 and "disk full" in err.strip().splitlines()[-1]
    assert json.loads(js.read_text())["cuts"] and csv.read_text().strip() and not html.exists()
    assert "the report" in err and "was not written" in err
