"""``labcut compare`` end to end: outputs, tables, bad input (one line, exit 2, nothing written) and
all-or-nothing writing."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


MESHES = Path(__file__).resolve().parents[1] / "meshes"
OVAL = str(MESHES / "oval-16x12-low.ply")
TINY = ["--quality", "draft", "--resolution", "16", "--spp", "1"]


def test_compare_writes_html_json_csv_and_prints_the_ranking(cli, tmp_path):
    html, js, cs = tmp_path / "r.html", tmp_path / "r.json", tmp_path / "r.csv"
    proc = cli("compare", OVAL, "cab:oval,16x12,high,res=64", OVAL, "--scenario", "bench", "--preset", "green", *TINY,
               "--html", str(html), "--json", str(js), "--csv", str(cs))
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "Ranked by flash (reference: oval-16x12-low.ply)" in out and "oval-16x12-low.ply (2)" in out
    assert "Scenario bench" in out and "tie for the most flash" in out
    assert "report written to" in out and "comparing" in proc.stderr  # the progress bar is on stderr
    data = json.loads(js.read_text())
    assert [c["name"] for c in data["cuts"]] == ["oval-16x12-low.ply", "cab:oval,16x12,high,res=64", "oval-16x12-low.ply (2)"]
    assert data["material"]["name"] == "green" and [s["name"] for s in data["scenarios"]] == ["bench"]
    assert [c["rank"] for c in data["cuts"]] == [1, 3, 1]
    assert [c["tied"] for c in data["cuts"]] == [True, False, True]  # one stone twice: a tie, said so
    assert data["verdict"].startswith("oval-16x12-low.ply and oval-16x12-low.ply (2) tie for the most flash over bench")
    rows = list(csv.DictReader(cs.open()))
    assert {r["cut"] for r in rows} >= {c["name"] for c in data["cuts"]}
    text = html.read_text()
    assert text.startswith("<!DOCTYPE html>") and "oval-16x12-low.ply (2)" in text


def test_json_to_stdout_and_reference_by_name(cli):
    proc = cli("compare", "cab:oval,16x12,low,res=48", "cab:oval,16x12,medium,res=48", "--reference", "cab:oval,16x12,medium,res=48",
               *TINY, "--json", "-")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)  # nothing but the JSON on stdout
    assert data["reference"] == {"index": 1, "name": "cab:oval,16x12,medium,res=48"}
    assert data["cuts"][1]["scenarios"]["bench"]["normalised"]["flash_energy"] == 1.0


@pytest.mark.parametrize(
    "args, fragment",
    [
        ([OVAL, "cab:oval,16x12,lo"], "cut 2 ('cab:oval,16x12,lo'): dome must be low, medium, high or a number of mm"),
        ([OVAL, "missing.stl", "cab:oval,16x12,low"], "cut 2 ('missing.stl'): mesh file 'missing.stl' does not exist"),
        ([OVAL, "--scenario", "disco"], "disco"),
        ([OVAL, "--scenario", "ring", "--scenario", "ring"], "scenario 'ring' is given twice"),
        ([OVAL, OVAL, "--reference", "3"], "--reference is a cut's position (1 to 2, the order of the CUTs) or its name, got '3'"),
        ([OVAL, "--reference", "0"], "--reference is a cut's position (1 to 1"),
        ([OVAL, "--reference", "round"], "reference 'round' is none of the cuts"),
        ([OVAL, "--quality", "ultra"], "quality must be one of draft, standard, high, got 'ultra'"),
        ([OVAL, "--preset", "purple"], "purple"),
        ([OVAL, "--units", "furlong"], "furlong"),
        ([OVAL, "--resolution", "4"], "render resolution"),
        ([OVAL, "--html", "{out}/r.txt"], "must end in one of .html, .htm"),
        ([OVAL, "--csv", "{out}/r.json"], "--json and --csv name the same file"),
        ([OVAL, "--csv", "{out}/r.txt"], "must end in one of .csv"),
        ([OVAL, "--html", "/proc/r.html"], "cannot write '/proc/r.html'"),
        ([OVAL, "--html", "{out}/nowhere/r.html"], "does not exist"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_nothing_is_written(cli, tmp_path, args, fragment):
    args = [a.replace("{out}", str(tmp_path)) for a in args]
    outs = {"--html": tmp_path / "r.html", "--json": tmp_path / "r.json", "--csv": tmp_path / "r.csv"}
    extra = [x for flag, path in outs.items() if flag not in args for x in (flag, str(path))]
    proc = cli("compare", *args, *extra)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and fragment in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr and "comparing" not in proc.stderr  # refused before the work
    assert [p.name for p in tmp_path.iterdir()] == []


def test_outputs_are_all_or_nothing(tmp_path, monkeypatch, capsys):
    """The CSV fails after the HTML and JSON were written: those are removed again, exit 2."""
    from labcut_cli.app import main

    from labcut.errors import OutputError
    from labcut.reports.compare import Comparison

    def fail(self, path):
        raise OutputError(f"cannot write {str(path)!r}: No space left on device")

    monkeypatch.setattr(Comparison, "save_csv", fail)
    outs = [tmp_path / "r.html", tmp_path / "r.json", tmp_path / "r.csv"]
    with pytest.raises(SystemExit) as exit_:
        main(["compare", "cab:round,10,low,res=32", *TINY, "--html", str(outs[0]), "--json", str(outs[1]), "--csv", str(outs[2])])
    assert exit_.value.code == 2
    assert "No space left on device" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
