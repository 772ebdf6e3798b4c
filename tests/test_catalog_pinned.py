"""labcut.batch.catalog pinned by mutation testing (issue 37; docs/testing.md, "labcut/batch/catalog.py").

Every legal form the catalogue documents (module docstring, docs/batch.md): the columns and
their defaults, CSV and YAML (list, defaults, rows, grid), units, quoting, comments, a BOM; each
column's effect on the row's call (``recommend_kwargs``, ``load_mesh``) and on its key (the key
recomputed by hand from the inputs the docstring lists); every error as the one line it is, word
for word. No cluster, no recommendation: the whole file runs in a few seconds.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import warnings
from pathlib import Path

import pytest

import labcut
from labcut.batch import catalog as cat_mod
from labcut.batch.catalog import (COLUMNS, MAX_REPORTED_ROWS, Catalog, CatalogError, Defaults, Row, check_row,
                                  read_catalog)
from labcut.errors import LabcutError, LabcutWarning, ParameterError
from labcut.geometry.stone import Stone
from labcut.physics.material import Labradorite

BACKLIT = {"name": "backlit", "lighting": {"directions": [[0.0, 0.998, -0.06]]},
           "viewing": {"directions": [[0.0, -0.99, 0.14]]}}


@pytest.fixture
def folder(catalogue_folder: Path) -> Path:
    """A catalogue folder: a 10 mm cube, a step cut, the SRB design, a scenario file, a material file."""
    tmp_path = catalogue_folder
    (tmp_path / "backlit.json").write_text(json.dumps(BACKLIT))
    (tmp_path / "gold.json").write_text(json.dumps(Labradorite.preset("gold").to_dict()))
    shutil.copy(tmp_path / "gold.json", tmp_path / "Gold.JSON")
    return tmp_path


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def one(folder: Path, text: str, name: str = "c.csv", **kw) -> Row:
    rows = read_catalog(write(folder / name, text), **kw).rows
    assert len(rows) == 1
    return rows[0]


def error(catalog, **kw) -> CatalogError:
    with pytest.raises(CatalogError) as info:
        read_catalog(catalog, **kw)
    return info.value


def label(path: Path) -> str:
    return f"catalogue {str(path)!r}"


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def key_of(inputs: dict) -> str:
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()[:20]


# ---------------------------------------------------------------------- the constants and small types
def test_the_documented_columns_and_limits():
    assert COLUMNS == ("name", "cut", "material", "scenario", "quality", "objective", "seed", "units", "up_axis",
                       "size", "max_tilt")
    assert cat_mod.DESIGN_SUFFIXES == (".asc", ".gem") and cat_mod.CATALOG_SUFFIXES == (".csv", ".yaml", ".yml")
    assert cat_mod.KEY_CHARS == 20 and MAX_REPORTED_ROWS == 20 and cat_mod._NAMED_ROWS == 5
    assert Defaults() == Defaults(material=None, scenario="bench", quality="standard", objective="energy", seed=0)


def test_catalog_error_problems_and_kind():
    e = CatalogError("one line")
    assert str(e) == "one line" and e.problems == ("one line",)
    assert CatalogError("head", problems=["a", "b"]).problems == ("a", "b")
    assert CatalogError("head", problems=iter([])).problems == ("head",)
    assert isinstance(e, ParameterError) and isinstance(e, LabcutError) and isinstance(e, ValueError)


def test_catalog_len_and_label(folder):
    assert len(Catalog(None)) == 0 and Catalog(None).label == "catalogue" and Catalog(None).rows == []
    assert Catalog(Path("x/c.csv")).label == str(Path("x/c.csv"))
    cat = read_catalog(write(folder / "c.csv", "cut,seed\nm/cube.ply,0\nm/cube.ply,1\n"))
    assert len(cat) == 2 and cat.path == folder / "c.csv" and cat.label == str(folder / "c.csv")
    assert read_catalog(cat) is cat  # a checked Catalog is returned as is


def test_fail_is_one_line():
    e = cat_mod._fail("catalogue 'x'", "a\n  b   c\t d")
    assert isinstance(e, CatalogError) and str(e) == "catalogue 'x': a b c d"


# ---------------------------------------------------------------------- one row: every column
def test_a_row_of_defaults_by_hand(folder):
    """Only the cut given: every other field is the documented default, and the key is the SHA-256
    of the documented inputs."""
    row = one(folder, "cut\nm/cube.ply\n")
    mesh = folder / "m" / "cube.ply"
    assert (row.index, row.name, row.cut, row.kind, row.path) == (1, "cube.ply", "m/cube.ply", "file", str(mesh.resolve()))
    assert row.material == Labradorite() and row.material_label == "default"
    assert (row.scenario, row.quality, row.objective, row.seed) == ("bench", "standard", "energy", 0)
    assert (row.units, row.up_axis, row.size, row.max_tilt, row.cab) == ("auto", "auto", None, 90.0, None)
    assert isinstance(row.max_tilt, float)
    inputs = {"labcut": labcut.__version__, "cut": {"file_sha256": sha(mesh), "suffix": ".ply"},
              "material": Labradorite().to_dict(), "scenario": {"name": "bench"}, "quality": "standard",
              "objective": "energy", "seed": 0, "units": "auto", "up_axis": "auto", "size": None, "max_tilt": 90.0}
    assert row.key == key_of(inputs) and len(row.key) == 20
    assert row.recommend_kwargs() == {"material": row.material, "scenario": "bench", "quality": "standard",
                                      "objective": "energy", "seed": 0, "max_tilt": 90.0}


def test_every_column_given_reaches_the_row_its_call_and_its_key(folder):
    text = ("Name , CUT,material,scenario,quality,objective,seed,units,up_axis,max_tilt\n"
            " my cube , m/cube.ply , Gold , Ring , HIGH , Area , 3 , CM , -y , 45.5 \n")
    row = one(folder, text)
    mesh = folder / "m" / "cube.ply"
    assert (row.name, row.cut, row.kind) == ("my cube", "m/cube.ply", "file")
    assert row.material == Labradorite.preset("gold") and row.material_label == "gold"
    assert (row.scenario, row.quality, row.objective, row.seed) == ("ring", "high", "area", 3)
    assert (row.units, row.up_axis, row.size, row.max_tilt) == ("cm", "-Y", None, 45.5)
    assert row.recommend_kwargs() == {"material": Labradorite.preset("gold"), "scenario": "ring", "quality": "high",
                                      "objective": "area", "seed": 3, "max_tilt": 45.5}
    inputs = {"labcut": labcut.__version__, "cut": {"file_sha256": sha(mesh), "suffix": ".ply"},
              "material": Labradorite.preset("gold").to_dict(), "scenario": {"name": "ring"}, "quality": "high",
              "objective": "area", "seed": 3, "units": "cm", "up_axis": "-Y", "size": None, "max_tilt": 45.5}
    assert row.key == key_of(inputs)
    d = row.to_dict()
    assert d == {"row": 1, "name": "my cube", "cut": "m/cube.ply", "kind": "file", "path": str(mesh.resolve()),
                 "material": "gold", "material_parameters": Labradorite.preset("gold").to_dict(), "scenario": "ring",
                 "quality": "high", "objective": "area", "seed": 3, "units": "cm", "up_axis": "-Y", "size": None,
                 "max_tilt": 45.5, "key": row.key}


@pytest.mark.parametrize("column, a, b", [
    ("material", "blue", "gold"), ("material", "505", "506"), ("scenario", "bench", "ring"),
    ("quality", "draft", "high"), ("objective", "energy", "balanced"), ("seed", "0", "1"),
    ("units", "mm", "cm"), ("units", "auto", "mm"), ("up_axis", "+z", "-z"), ("max_tilt", "30", "31"),
])
def test_each_setting_is_a_new_key(folder, column, a, b):
    first = one(folder, f"cut,{column}\nm/cube.ply,{a}\n", "a.csv")
    second = one(folder, f"cut,{column}\nm/cube.ply,{b}\n", "b.csv")
    assert first.key != second.key


def test_name_defaults_and_labels(folder):
    cat = read_catalog([{"cut": "m/cube.ply"}, {"cut": "m/SRB.asc"}, {"cut": " cab:round,8,low,res=32 "},
                        {"cut": "m/step.ply", "name": "named"}, {"cut": "m/step.ply", "name": 7, "seed": 1}], base=folder)
    assert [r.name for r in cat.rows] == ["cube.ply", "SRB.asc", "cab:round,8,low,res=32", "named", "7"]
    assert [r.cut for r in cat.rows] == ["m/cube.ply", "m/SRB.asc", "cab:round,8,low,res=32", "m/step.ply", "m/step.ply"]
    assert [r.index for r in cat.rows] == [1, 2, 3, 4, 5]
    # a file or design given with spaces around it (YAML, Python rows) is named without them, as a cabochon is
    spaced = read_catalog([{"cut": " m/SRB.asc "}, {"cut": "\tm/cube.ply"}], base=folder)
    assert [r.name for r in spaced.rows] == ["SRB.asc", "cube.ply"]


# ---------------------------------------------------------------------- cut: files, designs, cabochons
def test_a_design_takes_size_and_loads_at_that_girdle_width(folder):
    row = one(folder, "cut,size\nm/SRB.asc,8\n")
    assert (row.kind, row.size, row.units, row.path) == ("design", 8.0, "auto", str((folder / "m" / "SRB.asc").resolve()))
    mesh = row.load_mesh()
    width = mesh.bounds[1][:2] - mesh.bounds[0][:2]
    assert max(width) == pytest.approx(8.0, rel=1e-6)
    assert row.key == key_of({"labcut": labcut.__version__,
                              "cut": {"file_sha256": sha(folder / "m" / "SRB.asc"), "suffix": ".asc"},
                              "material": Labradorite().to_dict(), "scenario": {"name": "bench"}, "quality": "standard",
                              "objective": "energy", "seed": 0, "units": "auto", "up_axis": "auto", "size": 8.0,
                              "max_tilt": 90.0})
    default = one(folder, "cut\nm/SRB.asc\n", "d.csv")
    assert default.size is None and max(default.load_mesh().extents[:2]) == pytest.approx(10.0, rel=1e-6)
    shutil.copy(folder / "m" / "SRB.asc", folder / "m" / "upper.GEM")
    assert read_catalog([{"cut": "m/upper.GEM"}], base=folder).rows[0].kind == "design"  # the suffix in any case


def test_a_mesh_file_loads_in_its_units_and_up_axis(folder):
    plain, cm, number, up = read_catalog([{"cut": "m/cube.ply"}, {"cut": "m/cube.ply", "units": "cm"},
                                          {"cut": "m/cube.ply", "units": 2.5}, {"cut": "m/step.ply", "up_axis": "+Y"}],
                                         base=folder).rows
    assert plain.load_mesh().extents == pytest.approx([10, 10, 10])
    assert cm.units == "cm" and cm.load_mesh().extents == pytest.approx([100, 100, 100])
    assert number.units == 2.5 and number.load_mesh().extents == pytest.approx([25, 25, 25])
    step = read_catalog([{"cut": "m/step.ply", "up_axis": "+Z"}], base=folder).rows[0].load_mesh()
    with pytest.warns(LabcutWarning, match=r"you gave up axis \+Y"):  # the turn is the file reader's, as asked
        turned = up.load_mesh()
    assert up.up_axis == "+Y" and not turned.extents == pytest.approx(step.extents)
    assert sorted(turned.extents) == pytest.approx(sorted(step.extents))


def test_a_cabochon_spec_row(folder):
    row = one(folder, 'cut\n"CAB:Oval,16x12,low,res=32"\n')
    assert row.kind == "cabochon" and row.path is None and row.name == "CAB:Oval,16x12,low,res=32"
    assert row.cab == {"outline": "oval", "length": 16.0, "width": 12.0, "dome": "low", "resolution": 32}
    mesh = row.load_mesh()
    assert mesh.extents[:2] == pytest.approx([16.0, 12.0], rel=1e-3)
    assert Stone.of(mesh).provenance.source == "CAB:Oval,16x12,low,res=32"  # the stone says which row made it
    assert row.key == key_of({"labcut": labcut.__version__, "cut": {"cabochon": row.cab},
                              "material": Labradorite().to_dict(), "scenario": {"name": "bench"}, "quality": "standard",
                              "objective": "energy", "seed": 0, "units": "auto", "up_axis": "auto", "size": None,
                              "max_tilt": 90.0})
    navette = read_catalog([{"cut": "cab:navette,16x8"}], base=folder).rows[0]
    assert navette.kind == "cabochon" and navette.cab["outline"] == "navette"


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply", ".off", ".glb", ".gltf", ".3mf", ".asc", ".gem", ".PLY"])
def test_every_documented_suffix_is_a_cut(folder, suffix):
    """Each documented mesh and design suffix is read as such: a missing file of that kind is
    named as a missing mesh or design file, not as an unknown kind of cut."""
    e = error([{"cut": f"m/nothing{suffix}"}], base=folder)
    what = "design file" if suffix in (".asc", ".gem") else "mesh file"
    assert str(e) == (f"catalogue, row 1, column 'cut': {what} 'm/nothing{suffix}' does not exist "
                      f"(looked for {str(folder.resolve() / 'm' / f'nothing{suffix}')!r})")


def test_cut_errors_word_for_word(folder):
    assert str(error([{"cut": "m/cube.txt"}], base=folder)) == (
        "catalogue, row 1, column 'cut': 'm/cube.txt' is neither a mesh (.stl, .obj, .ply, .off, .glb, .gltf, .3mf), "
        "a GemCad design (.asc, .gem) nor a cabochon spec such as cab:oval,16x12,low")
    assert str(error([{"cut": "cab:ovl,16x12"}], base=folder)) == (
        "catalogue, row 1, column 'cut': unknown outline 'ovl' in 'cab:ovl,16x12'; "
        "choose one of round, oval, cushion, pear, marquise, rectangle")
    (folder / "m" / "dir.ply").mkdir()
    assert str(error([{"cut": "m/dir.ply"}], base=folder)) == "catalogue, row 1, column 'cut': mesh file 'm/dir.ply' is not a file"
    assert str(error([{"cut": "m/dir.asc"}], base=folder)).startswith("catalogue, row 1, column 'cut': design file 'm/dir.asc' does")


@pytest.mark.parametrize("spec, dim", [("cab:oval,0.01x12", "length"), ("cab:oval,16x0.01", "width"),
                                       ("cab:round,0.01", "length"), ("cab:oval,16x1001", "width")])
def test_a_cabochon_size_out_of_range_is_a_catalogue_error(folder, spec, dim):
    e = error([{"cut": spec}], base=folder)
    assert str(e).startswith("catalogue, row 1, column 'cut': ") and dim in str(e) and "\n" not in str(e)


def test_cabochon_and_design_refuse_what_does_not_apply(folder):
    for extra in ({"units": "mm"}, {"up_axis": "+Z"}, {"size": 8}):
        assert str(error([{"cut": "cab:round,8", **extra}], base=folder)) == (
            "catalogue, row 1, column 'cut': a cabochon spec is built in mm, +Z face-up: units, up_axis and size do not apply")
    assert str(error([{"cut": "m/SRB.asc", "units": "mm"}], base=folder)) == (
        "catalogue, row 1, column 'units': a GemCad design has no unit; give its girdle width in mm as size")
    assert str(error([{"cut": "m/cube.ply", "size": 8}], base=folder)) == (
        "catalogue, row 1, column 'size': size is a GemCad design's girdle width; a mesh file takes units")
    row = read_catalog([{"cut": "m/SRB.asc", "up_axis": "-z", "size": 8}], base=folder).rows[0]  # a design may turn
    assert (row.kind, row.up_axis, row.size) == ("design", "-Z", 8.0)


def test_a_file_path_from_home_and_absolute(folder, monkeypatch):
    monkeypatch.setenv("HOME", str(folder))
    row = read_catalog([{"cut": "~/m/cube.ply"}], base=folder / "m").rows[0]
    assert row.path == str((folder / "m" / "cube.ply").resolve()) and row.cut == "~/m/cube.ply"
    absolute = str(folder / "m" / "cube.ply")
    assert read_catalog([{"cut": absolute}], base=folder / "elsewhere").rows[0].path == str(Path(absolute).resolve())
    assert read_catalog([{"cut": "cube.ply"}], base=folder / "m").rows[0].path == str((folder / "m" / "cube.ply").resolve())


def test_python_rows_default_to_the_current_folder(folder, monkeypatch):
    monkeypatch.chdir(folder)
    assert read_catalog([{"cut": "m/cube.ply"}]).rows[0].path == str((folder / "m" / "cube.ply").resolve())
    assert read_catalog(({"cut": "m/cube.ply", "seed": s} for s in (0, 1))).rows[1].seed == 1  # any iterable


# ---------------------------------------------------------------------- material
def test_material_forms_and_labels(folder):
    rows = read_catalog([{"cut": "m/cube.ply", "material": m, "seed": k} for k, m in enumerate(
        [" BLUE ", "505", 505, 505.5, " 505.0 ", "gold.json", "Gold.JSON"])], base=folder).rows
    assert [r.material_label for r in rows] == ["blue", "505 nm", "505 nm", "505.5 nm", "505 nm", "gold.json", "Gold.JSON"]
    assert rows[0].material == Labradorite.preset("blue")
    for r in rows[1:3]:
        assert r.material == Labradorite.from_peak_wavelength(505.0)
    assert rows[3].material == Labradorite.from_peak_wavelength(505.5)
    assert rows[5].material == Labradorite.preset("gold") and rows[6].material == Labradorite.preset("gold")


def test_material_file_wrapped_in_a_recommendation_or_its_settings(folder):
    gold = Labradorite.preset("gold").to_dict()
    red = Labradorite.preset("red").to_dict()
    write(folder / "wrapped.json", json.dumps({"material": gold, "settings": {"material": red}}))
    write(folder / "saved.json", json.dumps({"settings": {"material": red}, "material": "not a dict"}))
    write(folder / "list.json", json.dumps([gold]))
    write(folder / "half.json", json.dumps({"settings": {"material": "blue"}, **red}))  # settings without a material object
    rows = read_catalog([{"cut": "m/cube.ply", "material": f, "seed": k}
                         for k, f in enumerate(["wrapped.json", "saved.json"])], base=folder).rows
    assert [r.material for r in rows] == [Labradorite.preset("gold"), Labradorite.preset("red")]
    assert str(error([{"cut": "m/cube.ply", "material": "half.json"}], base=folder)).startswith(
        "catalogue, row 1, column 'material': unknown material parameter(s): settings")
    assert str(error([{"cut": "m/cube.ply", "material": "list.json"}], base=folder)) == (
        "catalogue, row 1, column 'material': material file 'list.json' must hold a JSON object")
    write(folder / "broken.json", "{not json")
    assert str(error([{"cut": "m/cube.ply", "material": "broken.json"}], base=folder)) == (
        f"catalogue, row 1, column 'material': material file {str((folder / 'broken.json').resolve())!r} is not "
        "readable JSON (Expecting property name enclosed in double quotes: line 1 column 2 (char 1))")
    assert str(error([{"cut": "m/cube.ply", "material": "none.json"}], base=folder)) == (
        "catalogue, row 1, column 'material': material file 'none.json' does not exist "
        f"(looked for {str(folder.resolve() / 'none.json')!r})")


def test_material_default_of_the_batch(folder):
    text = "cut,seed\nm/cube.ply,0\n"
    assert one(folder, text, defaults=Defaults(material="gold")).material_label == "gold"
    row = one(folder, text, defaults=Defaults(material=Labradorite.preset("red")))
    assert row.material == Labradorite.preset("red") and row.material_label == "red"
    row = one(folder, text, defaults=Defaults(material=Labradorite(name=None, d_a=80.0)))
    assert row.material_label == "default" and row.material.d_a == 80.0


def test_material_bool_and_unknown_are_one_line(folder):
    assert str(error(write(folder / "b.yaml", "- {cut: m/cube.ply, material: true}"))) == (
        f"{label(folder / 'b.yaml')}, row 1, column 'material': must be a preset name, a peak wavelength in nm "
        "or a material JSON file, got True")


def test_material_outside_the_visible_warns_once_naming_its_rows(folder, monkeypatch):
    from labcut.physics import material

    monkeypatch.setattr(material, "_NOTED_STACKS", set())  # the material's own warning, as in a fresh process
    rows = "".join(f"m/cube.ply,2000,{k}\n" for k in range(7)) + "m/step.ply,2400,0\nm/step.ply,,1\n"
    path = write(folder / "ir.csv", "cut,material,seed\n" + rows)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        defaults = Defaults(material=Labradorite.from_peak_wavelength(2300))  # the caller's own: warned by the caller
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cat = read_catalog(path, defaults)
    assert len(cat) == 9
    notes = [w for w in caught if issubclass(w.category, LabcutWarning)]
    note = Labradorite.from_peak_wavelength(2000).visibility_note()
    assert [str(w.message) for w in notes] == [
        f"{label(path)}, line 2, line 3, line 4, line 5, line 6 and 2 more, column 'material': {note}",
        f"{label(path)}, line 9, column 'material': {Labradorite.from_peak_wavelength(2400).visibility_note()}"]
    # the warning names the caller's line: not the catalogue module's, nor read_catalog's own frame
    own = read_catalog.__code__  # under mutmut: the trampoline's wrapper, one frame between this test and the code
    own_lines = {line for *_, line in own.co_lines()}
    for w in notes:
        assert Path(w.filename).name != "catalog.py" and not (w.filename == own.co_filename and w.lineno in own_lines)
        if not hasattr(read_catalog, "__wrapped__"):
            assert w.filename == __file__
    assert len(caught) == 2


def test_five_rows_with_one_material_are_all_named(folder, monkeypatch):
    from labcut.physics import material

    monkeypatch.setattr(material, "_NOTED_STACKS", set())
    path = write(folder / "ir.csv", "cut,material,seed\n" + "".join(f"m/cube.ply,2000,{k}\n" for k in range(5)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_catalog(path)
    assert [str(w.message).split(", column")[0] for w in caught] == [f"{label(path)}, line 2, line 3, line 4, line 5, line 6"]


def test_the_material_warning_is_caught_even_where_warnings_are_errors(folder, monkeypatch):
    from labcut.physics import material

    monkeypatch.setattr(material, "_NOTED_STACKS", set())
    path = write(folder / "ir.csv", "cut,material\nm/cube.ply,1900\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        with pytest.raises(LabcutWarning, match=r"line 2, column 'material': the face-on flash peak, 1900 nm"):
            read_catalog(path)


def test_other_warnings_of_a_row_go_on(folder, monkeypatch):
    from labcut.geometry import orient

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        note = Labradorite.from_peak_wavelength(2000).visibility_note()
    real = orient.check_up_axis

    def noisy(value):
        warnings.warn("other", UserWarning)
        warnings.warn("labcut other", LabcutWarning)
        warnings.warn(note, UserWarning)  # the note's text, but not labcut's warning
        return real(value)

    monkeypatch.setattr(orient, "check_up_axis", noisy)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_catalog([{"cut": "m/cube.ply", "material": 2000}], base=folder)
    got = [(w.category, str(w.message)) for w in caught]
    assert got[:3] == [(UserWarning, "other"), (LabcutWarning, "labcut other"), (UserWarning, note)]
    assert got[3][0] is LabcutWarning and got[3][1].startswith("catalogue, row 1, column 'material': ") and len(got) == 4


# ---------------------------------------------------------------------- scenario
def test_scenario_file_row(folder):
    row = one(folder, "cut,scenario\nm/cube.ply,backlit.json\n")
    assert row.scenario == str((folder / "backlit.json").resolve())
    assert row.key == key_of({"labcut": labcut.__version__,
                              "cut": {"file_sha256": sha(folder / "m" / "cube.ply"), "suffix": ".ply"},
                              "material": Labradorite().to_dict(), "scenario": {"file_sha256": sha(folder / "backlit.json")},
                              "quality": "standard", "objective": "energy", "seed": 0, "units": "auto",
                              "up_axis": "auto", "size": None, "max_tilt": 90.0})
    write(folder / "bad.json", json.dumps({"name": "x"}))
    e = error(write(folder / "b.csv", "cut,scenario\nm/cube.ply,bad.json\n"))
    assert str(e).startswith(f"{label(folder / 'b.csv')}, line 2, column 'scenario': ") and "missing 'lighting'" in str(e)
    e = error(write(folder / "n.csv", "cut,scenario\nm/cube.ply,nope.json\n"))
    assert str(e) == (f"{label(folder / 'n.csv')}, line 2, column 'scenario': scenario file 'nope.json' does not exist "
                      f"(looked for {str(folder.resolve() / 'nope.json')!r})")


def test_scenario_default_of_the_batch_and_its_file(folder):
    assert one(folder, "cut\nm/cube.ply\n", defaults=Defaults(scenario="Pendant")).scenario == "pendant"
    row = read_catalog([{"cut": "m/cube.ply"}], Defaults(scenario="backlit.json"), base=folder).rows[0]
    assert row.scenario == str((folder / "backlit.json").resolve())


# ---------------------------------------------------------------------- quality, objective, seed, units, up axis, size, tilt
def test_defaults_of_the_batch_fill_empty_cells(folder):
    row = one(folder, "cut,quality,objective,seed\nm/cube.ply,,,\n",
              defaults=Defaults(quality="draft", objective="intensity", seed=9))
    assert (row.quality, row.objective, row.seed) == ("draft", "intensity", 9)
    row = one(folder, "cut,quality,objective,seed\nm/cube.ply,high,energy,0\n", "b.csv",
              defaults=Defaults(quality="draft", objective="intensity", seed=9))
    assert (row.quality, row.objective, row.seed) == ("high", "energy", 0)


@pytest.mark.parametrize("column, cell, message", [
    ("quality", "fast", "must be one of draft, standard, high, got 'fast'"),
    ("objective", "beauty", "must be one of energy, area, intensity, balanced, got 'beauty'"),
    ("seed", "-1", "must be an integer >= 0, got '-1'"),
    ("seed", "1.5", "must be an integer >= 0, got '1.5'"),
    ("seed", "x", "must be an integer >= 0, got 'x'"),
    ("seed", "nan", "must be an integer >= 0, got 'nan'"),
    ("seed", "inf", "must be an integer >= 0, got 'inf'"),
    ("max_tilt", "0", "must be a number of degrees in (0, 90], got '0'"),
    ("max_tilt", "90.01", "must be a number of degrees in (0, 90], got '90.01'"),
    ("max_tilt", "-5", "must be a number of degrees in (0, 90], got '-5'"),
    ("max_tilt", "nan", "must be a number of degrees in (0, 90], got 'nan'"),
    ("max_tilt", "steep", "must be a number of degrees, got 'steep'"),
    ("units", "furlong", "unknown units 'furlong'"),
    ("up_axis", "sideways", "up axis must be one of"),
])
def test_a_bad_cell_is_one_line_naming_line_and_column(folder, column, cell, message):
    path = write(folder / "bad.csv", f"cut,{column}\nm/cube.ply,{cell}\n")
    e = error(path)
    assert str(e).startswith(f"{label(path)}, line 2, column {column!r}: {message}"), str(e)
    assert "\n" not in str(e) and e.problems == (str(e),)


@pytest.mark.parametrize("cell, message", [
    ("0", "must be a number of mm in (0, 500], got '0'"), ("500.5", "must be a number of mm in (0, 500], got '500.5'"),
    ("inf", "must be a number of mm in (0, 500], got 'inf'"), ("big", "must be a number of mm, got 'big'"),
])
def test_a_bad_size(folder, cell, message):
    assert str(error([{"cut": "m/SRB.asc", "size": cell}], base=folder)) == f"catalogue, row 1, column 'size': {message}"


def test_ranges_include_their_upper_ends(folder):
    rows = read_catalog([{"cut": "m/SRB.asc", "size": "500", "max_tilt": "90"},
                         {"cut": "m/SRB.asc", "size": 0.001, "max_tilt": 0.001, "seed": " 3.0 "}], base=folder).rows
    assert (rows[0].size, rows[0].max_tilt) == (500.0, 90.0)
    assert (rows[1].size, rows[1].max_tilt, rows[1].seed) == (0.001, 0.001, 3)
    assert isinstance(rows[1].seed, int)


@pytest.mark.parametrize("column", ["seed", "size", "max_tilt"])
def test_a_yaml_boolean_is_not_a_number(folder, column):
    path = write(folder / "b.yaml", f"- {{cut: m/SRB.asc, {column}: true}}")
    e = error(path)
    unit = {"seed": "an integer >= 0", "size": "a number of mm", "max_tilt": "a number of degrees"}[column]
    assert str(e) == f"{label(path)}, row 1, column {column!r}: must be {unit}, got True"


def test_units_forms(folder):
    rows = read_catalog([{"cut": "m/cube.ply", "units": u, "seed": k} for k, u in enumerate(
        [" AUTO ", "Inch", "25.4", 0.5, "mm"])], base=folder).rows
    assert [r.units for r in rows] == ["auto", "inch", 25.4, 0.5, "mm"]
    assert rows[1].load_mesh().extents == pytest.approx([254, 254, 254])


def test_up_axis_forms(folder):
    rows = read_catalog([{"cut": "m/cube.ply", "up_axis": u, "seed": k} for k, u in enumerate(["z", "AUTO", " -x "])],
                        base=folder).rows
    assert [r.up_axis for r in rows] == ["+Z", "auto", "-X"]


def test_check_row_directly(folder):
    row = check_row({"cut": "m/cube.ply", "seed": "4"}, 3, "here", folder, Defaults())
    assert row.index == 3 and row.seed == 4 and row.kind == "file"
    digests: dict[str, str] = {}
    check_row({"cut": "m/cube.ply"}, 1, "here", folder, Defaults(), digests)
    assert digests == {str((folder / "m" / "cube.ply").resolve()): sha(folder / "m" / "cube.ply")}
    with pytest.raises(CatalogError) as info:
        check_row({"name": "x"}, 1, "here", folder, Defaults())
    assert str(info.value) == "here, column 'cut': is empty; give a mesh file, a GemCad design or a cab: spec"
    with pytest.raises(CatalogError) as info:
        check_row({"cut": "m/cube.ply", "quality": "fast"}, 1, "here", folder, Defaults())
    assert str(info.value) == "here, column 'quality': must be one of draft, standard, high, got 'fast'"


def test_the_digest_cache_reads_each_file_once(folder, monkeypatch):
    cache = {"x": "stored"}
    assert cat_mod._file_digest(Path("x"), cache) == "stored"  # from the cache, the file never opened
    big = folder / "big.bin"
    big.write_bytes(bytes(range(256)) * 9000)  # over one 1 MiB chunk
    assert cat_mod._file_digest(big, {}) == sha(big)


# ---------------------------------------------------------------------- CSV
def test_csv_comments_blanks_bom_and_quoting(folder):
    text = ("\ufeff# a comment before the header\n\n   \n  # an indented comment\ncut , Name,seed\n"
            '"m/cube.ply","a, quoted ""name""",4\n'
            "\n# between rows\nm/cube.ply, b ,1\n"
            "m/cube.ply,c\n")
    path = folder / "c.csv"
    path.write_text(text, encoding="utf-8")
    rows = read_catalog(path).rows
    assert [r.name for r in rows] == ['a, quoted "name"', "b", "c"]
    assert [r.seed for r in rows] == [4, 1, 0]  # a short row: its missing cells empty
    assert [r.index for r in rows] == [1, 2, 3]


def test_csv_line_numbers_count_comments_and_blank_lines(folder):
    path = write(folder / "c.csv", "# c\n\ncut,seed\n# c\nm/cube.ply,-1\n\nm/cube.ply,-2\n")
    assert str(error(path)).splitlines() == [f"{label(path)} has 2 bad rows:",
                                              "  line 5, column 'seed': must be an integer >= 0, got '-1'",
                                              "  line 7, column 'seed': must be an integer >= 0, got '-2'"]


def test_csv_whole_file_errors_word_for_word(folder):
    def msg(text, name="c.csv"):
        return str(error(write(folder / name, text)))

    where = label(folder / "c.csv")
    for text in ("", "# only a comment\n\n   \n"):
        assert msg(text) == f"{where}: is empty; it needs a header row (e.g. cut,material,scenario) and one row per cut"
    assert msg("cut,seed\n# no rows\n") == f"{where}: has a header but no rows"
    assert msg("# c\nname,seed\nx,0\n") == (
        f"{where}, header (line 2): has no 'cut' column (a mesh file, a GemCad design or a cab: spec per row)")
    assert msg("cut,colour\nm/cube.ply,red\n") == (
        f"{where}, header (line 1): unknown column 'colour'; the columns are " + ", ".join(COLUMNS))
    assert msg("cut,Seed,SEED\nm/cube.ply,0,1\n") == f"{where}, header (line 1): column 'seed' is given twice"
    assert msg("cut,name\nm/cube.ply,a,b\n") == f"{where}, line 2: has 3 cells but the header names 2 columns"
    assert msg("cut,name\nm/cube.ply,a,b\nm/cube.ply,b\nm/cube.ply,c,d,e\nm/step.ply,d\n").splitlines() == [
        f"{where} has 2 bad rows:", "  line 2: has 3 cells but the header names 2 columns",
        "  line 4: has 4 cells but the header names 2 columns"]  # the rows after a long one are read on
    assert msg('cut,name\nm/cube.ply,"a\n') == (
        f"{where}, line 2: is malformed CSV: a quoted cell opens here and no \" closes it, so every line after it "
        "would be read into that cell; close the quote, or remove it")


def test_csv_that_the_csv_module_refuses_names_its_line(folder):
    text = "cut,name\n# c\nm/cube.ply,a\nm/cube.ply," + "x" * 140000 + "\nm/cube.ply,b\n"
    assert str(error(write(folder / "c.csv", text))) == (
        f"{label(folder / 'c.csv')}, line 4: is not readable CSV (field larger than field limit (131072))")
    text = "cut,name\nm/cube.ply," + "x" * 140000 + "\n"
    assert str(error(write(folder / "c.csv", text))).startswith(f"{label(folder / 'c.csv')}, line 2: is not readable CSV")
    text = "# c\ncut," + "x" * 140000 + "\nm/cube.ply,a\n"  # the header itself
    assert str(error(write(folder / "c.csv", text))).startswith(f"{label(folder / 'c.csv')}, line 2: is not readable CSV")


@pytest.mark.parametrize("lines, opened", [
    (['a"b,c'], None),  # a quote inside an unquoted cell is a character
    (['"a,b'], 7), (['a,"b'], 7), (['a, "b'], None), (['"a""b'], 7), (['"a"""'], None),
    (['""'], None), (['"a" x,"'], 7), (['x,"""'], 7), (['"a",""'], None), (['"a,', 'b"', '"c'], 9),
    (['"a', 'b"c,d'], None), (['"a', 'b",c'], None), (['x', '"a', 'b', 'c'], 8),
])
def test_unclosed_quote_by_hand(lines, opened):
    assert cat_mod._unclosed_quote([(n, t) for n, t in enumerate(lines, start=7)]) == opened


def test_a_quoted_cell_over_lines_reads_as_one_row(folder):
    text = 'cut,name\nm/cube.ply,"a\n# not a comment inside quotes\nb"\nm/step.ply,"x,""y"""\n'
    rows = read_catalog(write(folder / "c.csv", text)).rows
    assert [r.name for r in rows] == ["a\nb", 'x,"y"']  # the "#" line inside the quote is a comment line: skipped


def test_catalogue_file_errors(folder):
    assert str(error(folder / "nowhere.csv")) == f"{label(folder / 'nowhere.csv')} does not exist"
    assert str(error(write(folder / "c.txt", "cut\n"))) == (
        f"{label(folder / 'c.txt')} must be a CSV (.csv) or YAML (.yaml, .yml) file")
    (folder / "d.csv").mkdir()
    assert str(error(folder / "d.csv")) == f"{label(folder / 'd.csv')} cannot be read (Is a directory)"
    (folder / "latin.csv").write_bytes("cut,name\nm/cube.ply,caf\u00e9\n".encode("latin-1"))
    assert str(error(folder / "latin.csv")).startswith(f"{label(folder / 'latin.csv')} cannot be read ('utf-8' codec")
    assert str(error({"cut": "m/cube.ply"})) == "a catalogue is a CSV or YAML file or a list of rows, got dict"
    assert str(error(3)) == "a catalogue is a CSV or YAML file or a list of rows, got int"
    assert str(error([])) == "the catalogue has no rows"


def test_upper_case_suffixes_and_str_paths(folder):
    assert len(read_catalog(str(write(folder / "C.CSV", "cut\nm/cube.ply\n")))) == 1
    assert len(read_catalog(write(folder / "c.YML", "- {cut: m/cube.ply}\n"))) == 1
    assert len(read_catalog(write(folder / "c.Yaml", "- {cut: m/cube.ply}\n"))) == 1


def test_utf8_names(folder):
    path = folder / "c.csv"
    path.write_text("cut,name\nm/cube.ply,caf\u00e9 \u00b5\n", encoding="utf-8")
    assert read_catalog(path).rows[0].name == "caf\u00e9 \u00b5"


# ---------------------------------------------------------------------- YAML
def test_yaml_forms(folder):
    plain = read_catalog(write(folder / "a.yaml", "- {cut: m/cube.ply, Seed: 2, name: ''}\n- cut: m/step.ply\n")).rows
    assert [(r.name, r.seed) for r in plain] == [("cube.ply", 2), ("step.ply", 0)]
    text = """
defaults: {quality: draft, seed: 5, material: 505}
rows:
  - {cut: m/cube.ply}
  - {cut: m/cube.ply, seed: 6, quality: ~}
grid:
  CUT: m/step.ply
  seed: [1, ~, 2]
"""
    rows = read_catalog(write(folder / "b.yaml", text)).rows
    assert [(r.cut, r.seed, r.quality, r.material_label) for r in rows] == [
        ("m/cube.ply", 5, "draft", "505 nm"), ("m/cube.ply", 6, "draft", "505 nm"),
        ("m/step.ply", 1, "draft", "505 nm"), ("m/step.ply", 5, "draft", "505 nm"), ("m/step.ply", 2, "draft", "505 nm")]
    rows = read_catalog(write(folder / "g.yml", "grid: {cut: [m/cube.ply, m/step.ply], seed: [1, 2]}\n")).rows
    assert [(r.cut, r.seed) for r in rows] == [("m/cube.ply", 1), ("m/cube.ply", 2), ("m/step.ply", 1), ("m/step.ply", 2)]
    assert len(read_catalog(write(folder / "d.yaml", "defaults: {cut: m/cube.ply}\nrows: [{seed: 1}, {seed: 2}]\n"))) == 2


def test_yaml_rows_are_named_by_their_place(folder):
    text = "rows: [{cut: m/cube.ply, seed: -1}]\ngrid: {cut: m/cube.ply, seed: [0, -2]}\n"
    path = write(folder / "c.yaml", text)
    assert str(error(path)).splitlines() == [f"{label(path)} has 2 bad rows:",
                                              "  row 1, column 'seed': must be an integer >= 0, got -1",
                                              "  grid row 2, column 'seed': must be an integer >= 0, got -2"]


def test_yaml_whole_file_errors_word_for_word(folder):
    path = folder / "c.yaml"
    where = label(path)

    def msg(text):
        return str(error(write(path, text)))

    assert msg("") == f"{where}: must hold a list of rows or a mapping with defaults, rows and/or grid"
    assert msg("just text") == f"{where}: must hold a list of rows or a mapping with defaults, rows and/or grid"
    assert msg("{}") == f"{where}: has no rows"
    assert msg("[]") == f"{where}: has no rows"
    assert msg("zz: 1\nwhat: 2\nrows: []") == (
        f"{where}: unknown top-level key 'what'; a YAML catalogue holds defaults, rows and/or grid")
    assert msg("rows: {cut: m/cube.ply}") == f"{where}: 'rows' must be a list of rows"
    assert msg("grid: [m/cube.ply]") == f"{where}: 'grid' must map columns to lists of values"
    assert msg("grid: {cut: m/cube.ply, seed: []}") == f"{where}, grid, column 'seed': is an empty list"
    assert msg("grid: {cut: m/cube.ply, colour: [red]}") == (
        f"{where}, grid: unknown column 'colour'; the columns are " + ", ".join(COLUMNS))
    assert msg("defaults: {colour: red}\nrows: [{cut: m/cube.ply}]") == (
        f"{where}, defaults: unknown column 'colour'; the columns are " + ", ".join(COLUMNS))
    assert msg("defaults: [1]\nrows: [{cut: m/cube.ply}]") == (
        f"{where}, defaults: must be a mapping of column: value, got list")
    assert msg("- {cut: m/cube.ply, CUT: m/step.ply}") == f"{where}, row 1: column 'cut' is given twice"
    assert msg("- 3") == f"{where}, row 1: must be a mapping of column: value, got int"
    assert msg("{cut: [\n") == f"{where}: is not readable YAML (while parsing a flow node)"  # the parser's first line
    assert msg("a: b: c\n") == f"{where}: is not readable YAML (mapping values are not allowed here)"


def test_python_rows_word_for_word(folder):
    e = error([{"cut": "m/cube.ply"}, ["not", "a row"], {"cut": "m/cube.ply", "colour": 1}], base=folder)
    assert str(e).splitlines() == ["catalogue has 2 bad rows:",
                                   "  row 2: must be a mapping of column: value, got list",
                                   "  row 3: unknown column 'colour'; the columns are " + ", ".join(COLUMNS)]
    assert e.problems == ("catalogue, row 2: must be a mapping of column: value, got list",
                          "catalogue, row 3: unknown column 'colour'; the columns are " + ", ".join(COLUMNS))
    empty = read_catalog([{"cut": "m/cube.ply", "seed": None, "quality": "  ", " NAME ": "x"}], base=folder).rows[0]
    assert (empty.seed, empty.quality, empty.name) == (0, "standard", "x")


# ---------------------------------------------------------------------- repeats and the list of bad rows
def test_a_repeat_names_the_first_row(folder):
    path = write(folder / "c.csv", "cut,seed,name\nm/cube.ply,0,a\nm/cube.ply,1,b\nm/cube.ply,0,c\nm/cube.ply,1,d\n")
    assert str(error(path)).splitlines() == [
        f"{label(path)} has 2 bad rows:",
        "  line 4: repeats line 2 (same cut and settings); each row runs once",
        "  line 5: repeats line 3 (same cut and settings); each row runs once"]
    e = error([{"cut": "m/cube.ply"}, {"cut": "m/cube.ply", "name": "again"}], base=folder)
    assert str(e) == "catalogue, row 2: repeats row 1 (same cut and settings); each row runs once"


def test_a_bad_row_then_a_good_one_keeps_the_row_index(folder):
    """``index`` is the row's place in the catalogue, counting bad rows too."""
    rows = [cat_mod.check_row({"cut": "m/cube.ply"}, 2, "x", folder, Defaults())]
    assert rows[0].index == 2
    cat = read_catalog(write(folder / "c.yaml", "grid: {cut: [m/cube.ply, m/step.ply]}\nrows: [{cut: m/cube.ply, seed: 3}]"))
    assert [r.index for r in cat.rows] == [1, 2, 3]


@pytest.mark.parametrize("bad, extra", [(20, None), (21, "  ... and 1 more bad rows"), (2, None)])
def test_the_list_of_bad_rows_ends(folder, bad, extra):
    path = write(folder / "c.csv", "cut,seed\n" + "".join(f"m/cube.ply,{-k}\n" for k in range(1, bad + 1)))
    e = error(path)
    lines = str(e).splitlines()
    shown = min(bad, MAX_REPORTED_ROWS)
    assert lines[0] == f"{label(path)} has {bad} bad rows:"
    assert lines[1:1 + shown] == [f"  line {k + 1}, column 'seed': must be an integer >= 0, got '{-k}'"
                                  for k in range(1, shown + 1)]
    assert lines[1 + shown:] == ([extra] if extra else [])
    assert e.problems == tuple(f"{label(path)}, line {k + 1}, column 'seed': must be an integer >= 0, got '{-k}'"
                               for k in range(1, bad + 1))


def test_bad_rows_keep_a_problem_without_the_prefix():
    e = cat_mod._bad_rows("catalogue 'c'", ["catalogue 'c', line 2: x", "other: y"])
    assert str(e).splitlines() == ["catalogue 'c' has 2 bad rows:", "  line 2: x", "  other: y"]
    single = cat_mod._bad_rows("catalogue 'c'", ["catalogue 'c', line 2: x"])
    assert str(single) == "catalogue 'c', line 2: x" and single.problems == ("catalogue 'c', line 2: x",)
