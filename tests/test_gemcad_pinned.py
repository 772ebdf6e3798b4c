"""labcut/geometry/gemcad.py pinned to GemCad's formats by hand (issue 37; docs/testing.md,
"labcut/geometry/gemcad.py"): every legal form of a ``.asc`` record that the format allows
(signed and fractional indices, negative gears, a gear location, continuation lines, CR, CRLF,
a byte-order mark, Windows-1252 text), each malformed record's one-line message word for word,
where a facet's pole points for a given gear, index and angle, and what a ``.gem`` file's
records become. Expected values are computed by hand in each test."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from labcut.errors import MeshError
from labcut.geometry import gemcad
from labcut.geometry.gemcad import facet_pole, parse_asc, parse_gem, read_design

S41, C41 = math.sin(math.radians(41.0)), math.cos(math.radians(41.0))


# ---------------------------------------------------------------------- where a facet points
@pytest.mark.parametrize("index, azimuth", [(24, 0.0), (48, -90.0), (72, -180.0), (96, 90.0), (0, 90.0),
                                            (12.5, 43.125), (-24, -180.0), (120, 0.0)])
def test_the_index_turns_clockwise_from_plus_y_on_a_96_gear(index, azimuth):
    """GemCad's index 96 (= 0) points the facet to +Y (the top of the screen), 24 to +X: the
    azimuth 90 - index x 360 / 96 degrees, wrapped into [-180, 180)."""
    pole, az = facet_pole(41.0, index, 1.0, 96, 0.0)
    assert az == pytest.approx(azimuth, abs=1e-12)
    phi = math.radians(azimuth)
    assert np.allclose(pole, [S41 * math.cos(phi), S41 * math.sin(phi), C41], atol=1e-12)


def test_a_negative_gear_turns_the_other_way_and_the_location_shifts_the_indices():
    # gear -96: index 24 is 90 + 90 = 180 degrees, wrapped to -180
    assert facet_pole(41.0, 24, 1.0, -96, 0.0)[1] == pytest.approx(-180.0)
    assert facet_pole(41.0, 8, 1.0, -96, 0.0)[1] == pytest.approx(120.0)  # 90 + 30
    # location 1.5 on a 96 gear: index 24 sits 22.5 teeth from the mark, 90 - 84.375 = 5.625 degrees
    assert facet_pole(41.0, 24, 1.0, 96, 1.5)[1] == pytest.approx(5.625)
    # an 80 gear: 4.5 degrees a tooth
    assert facet_pole(41.0, 10, 1.0, 80, 0.0)[1] == pytest.approx(45.0)


def test_the_angles_sign_the_crown_pavilion_girdle_and_culet_and_the_distance_scales_the_pole():
    crown, _ = facet_pole(41.0, 24, 2.0, 96, 0.0)
    assert np.allclose(crown, np.array([S41, 0.0, C41]) / 2.0, atol=1e-15)
    pavilion, _ = facet_pole(-41.0, 24, 0.5, 96, 0.0)
    assert np.allclose(pavilion, np.array([S41, 0.0, -C41]) / 0.5, atol=1e-15)
    girdle, _ = facet_pole(90.0, 24, 1.0, 96, 0.0)
    assert girdle[2] == 0.0 and girdle[0] == pytest.approx(1.0)  # exactly in the girdle plane
    girdle_low, _ = facet_pole(-90.0, 24, 1.0, 96, 0.0)
    assert girdle_low[2] == 0.0 and girdle_low[0] == pytest.approx(1.0)
    culet, _ = facet_pole(-0.0, 96, 1.0, 96, 0.0)
    assert culet.tolist() == [0.0, 0.0, -1.0]  # -0: the culet, pointing down
    table, _ = facet_pole(0.0, 96, 4.0, 96, 0.0)
    assert table.tolist() == [0.0, 0.0, 0.25]
    flipped, _ = facet_pole(41.0, 24, -1.0, 96, 0.0)
    assert np.allclose(flipped, -np.array([S41, 0.0, C41]))


def test_facet_parts():
    def part(angle):
        return gemcad.Facet(1, "", "", angle, 0, 0, 1, facet_pole(angle, 24, 1.0, 96, 0.0)[0]).part

    assert [part(a) for a in (0.0, 41.0, 90.0, -90.0, -41.0, -0.0)] == ["table", "crown", "girdle", "girdle",
                                                                       "pavilion", "culet"]


# ---------------------------------------------------------------------- numbers
@pytest.mark.parametrize("token, value", [("1", 1.0), ("+1", 1.0), ("-2.5", -2.5), (".5", 0.5), ("5.", 5.0),
                                          ("1e3", 1000.0), ("1E-2", 0.01), ("-.25", -0.25), ("007", 7.0)])
def test_decimal_numbers_in_every_legal_form(token, value):
    assert gemcad._number(token) == value


def test_minus_zero_keeps_its_sign():
    assert math.copysign(1.0, gemcad._number("-0")) == -1.0 and math.copysign(1.0, gemcad._number("-0.00")) == -1.0


@pytest.mark.parametrize("token", ["", "1,5", "nan", "inf", "--1", "1e", "e3", "0x10", "1.2.3", "12a", "."])
def test_what_is_not_a_number(token):
    assert gemcad._number(token) is None


# ---------------------------------------------------------------------- .asc records
MINIMAL = "GemCad 5.0\ng 96 0.0\na 0 1 96 n T\n"


def _one(text, name="round.asc"):
    return parse_asc(text, name)


def test_every_record_read():
    text = ("GemCad 5.0\r\ng 96 0.0\r\ny 8 y\r\nI 1.54\r\nH Round Brilliant\r\nH by someone\r\nF a note\r\n"
            "a -41 1.0 3 15 n P G cut first\r\na 0 0.5 96 n T\r\n")
    d = _one(text)
    assert d.format == "asc" and d.title == "Round Brilliant" and d.headers == ["Round Brilliant", "by someone"]
    assert d.footnotes == ["a note"] and d.gear == 96 and d.location == 0.0
    assert d.symmetry == 8 and d.mirror is True and d.refractive_index == pytest.approx(1.54)
    assert [(t.number, t.angle_deg, t.distance, t.indices, t.name, t.instructions) for t in d.tiers] == [
        (1, -41.0, 1.0, [3.0, 15.0], "P", "cut first"), (2, 0.0, 0.5, [96.0], "T", "")]
    assert [(f.tier, f.name, f.own_name, f.index) for f in d.facets] == [(1, "P", "", 3.0), (1, "P", "P", 15.0),
                                                                        (2, "T", "T", 96.0)]
    assert d.notes == []


def test_a_name_names_the_index_before_it_and_the_tier_takes_its_first_name():
    d = _one("GemCad 5.0\ng 96 0\na 41 1 3 n A1 15 27 n A3\na 30 1 6\n")
    assert [f.own_name for f in d.facets] == ["A1", "", "A3", ""]
    assert [f.name for f in d.facets] == ["A1", "A1", "A3", "tier 2"]
    assert [t.name for t in d.tiers] == ["A1", ""]


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])
def test_line_endings_and_continuation_lines(ending):
    """A line that starts with a space or a tab continues the ``a`` record before it; so does a
    line of its own that starts with ``G `` (its instructions)."""
    text = ending.join(["GemCad 5.0", "g 96 0", "a 41 1 3", " 15", "\t27 n C", "G polish last", "a 0 0.5 96", ""])
    d = _one(text)
    assert d.tiers[0].indices == [3.0, 15.0, 27.0] and d.tiers[0].name == "C"
    assert d.tiers[0].instructions == "polish last"
    assert d.tiers[1].indices == [96.0] and d.tiers[1].instructions == ""


def test_a_continuation_after_another_record_is_no_continuation():
    d = _one("GemCad 5.0\ng 96 0\nH title\n  indented header text\na 0 1 96\n")
    assert d.tiers[0].indices == [96.0]
    assert d.notes == ["ignored 1 unrecognised line (line 4: 'indented header text')"]


def test_signed_fractional_indices_a_negative_gear_and_a_location():
    d = _one("GemCad 5.0\ng -80 1.5\na 41 1 -2.5 10.25\n")
    assert d.gear == -80 and d.location == 1.5
    assert d.tiers[0].indices == [-2.5, 10.25]
    # azimuth 90 - (index - location) x 360 / gear
    assert d.facets[0].azimuth_deg == pytest.approx(90.0 - (-2.5 - 1.5) * 360.0 / -80.0)
    assert d.facets[1].azimuth_deg == pytest.approx((90.0 - (10.25 - 1.5) * 360.0 / -80.0 + 180.0) % 360.0 - 180.0)


def test_the_gear_alone_and_without_g():
    assert _one("GemCad 5.0\ng 64\na 0 1 64\n").location == 0.0
    d = _one("GemCad 5.0\n96 0.25\na 0 1 96\n")
    assert (d.gear, d.location) == (96, 0.25)
    assert d.notes == ["line 2: read '96 0.25' as the gear and its location (no 'g')"]
    # not a whole number of teeth, or after a tier, or with a g record: an unrecognised line
    for text in ("GemCad 5.0\n96.5 0\na 0 1 96\n", "GemCad 5.0\na 0 1 96\n80 0\n", "GemCad 5.0\ng 96\n80 0\na 0 1 96\n",
                 "GemCad 5.0\n0 0\na 0 1 96\n"):
        assert any(n.startswith("ignored 1 unrecognised line") for n in _one(text).notes), text


def test_no_gear_no_version_and_unknown_lines_are_noted():
    d = _one("a 0 1 96\nzz top\nq 3\n")
    assert d.gear == gemcad.DEFAULT_GEAR == 96
    assert d.notes == ["ignored 2 unrecognised lines (line 2: 'zz top')",
                       "no gear record: GemCad's default gear 96 assumed", "no 'GemCad' version line"]
    long = "x" * 60
    assert _one(f"GemCad 5.0\ng 96 0\n{long}\na 0 1 96\n").notes == [f"ignored 1 unrecognised line (line 3: {'x' * 40!r})"]


def test_the_title_is_the_first_header_else_the_files_stem():
    assert _one(MINIMAL, "designs/My Oval.asc").title == "My Oval"
    assert _one("GemCad 5.0\nH  \nH Second\na 0 1 96\n").title == "Second"  # an empty header is no header
    assert _one("GemCad 5.0\nF  \na 0 1 96\n").footnotes == []


def test_symmetry_and_index_records_in_every_legal_form():
    assert (_one("y 1\na 0 1 96\n").symmetry, _one("y 1\na 0 1 96\n").mirror) == (1, False)
    assert _one("y 6 N\na 0 1 96\n").mirror is False and _one("y 6 Y\na 0 1 96\n").mirror is True
    assert _one("I 1\na 0 1 96\n").refractive_index == 1.0 and _one("I 5\na 0 1 96\n").refractive_index == 5.0
    assert _one("a 0 1 96\n").refractive_index is None and _one("a 0 1 96\n").symmetry is None


def test_a_tier_without_an_index_is_skipped_with_a_note():
    d = _one("GemCad 5.0\ng 96 0\na 41 1\na 0 1 96\n")
    assert len(d.tiers) == 1 and d.tiers[0].number == 1
    assert d.notes == ["line 3: the tier at 41 deg lists no index and was skipped"]
    d = _one("GemCad 5.0\ng 96 0\na 41 1 G no index here\na 0 1 96\n")
    assert d.notes == ["line 3: the tier at 41 deg lists no index and was skipped"]


def test_instructions_keep_their_spacing_after_g():
    d = _one("GemCad 5.0\ng 96 0\na 41 1 3 n A G  cut  to  meet   \n")
    assert d.tiers[0].instructions == "cut  to  meet"


@pytest.mark.parametrize("line, message", [
    ("g", "round.asc, line 2: the gear record must be 'g GEAR LOCATION', got 'g'"),
    ("g 96 0 1", "round.asc, line 2: the gear record must be 'g GEAR LOCATION', got 'g 96 0 1'"),
    ("g x 0", "round.asc, line 2: the gear record must be 'g GEAR LOCATION', got 'g x 0'"),
    ("g 0 0", "round.asc, line 2: the gear must be a non-zero whole number of teeth, got '0'"),
    ("g 96.5 0", "round.asc, line 2: the gear must be a non-zero whole number of teeth, got '96.5'"),
    ("g 10001 0", "round.asc, line 2: the gear must be a non-zero whole number of teeth, got '10001'"),
    ("g -10001 0", "round.asc, line 2: the gear must be a non-zero whole number of teeth, got '-10001'"),
    ("y", "round.asc, line 2: the symmetry record must be 'y FOLDS y|n', got 'y'"),
    ("y 0 n", "round.asc, line 2: the symmetry record must be 'y FOLDS y|n', got 'y 0 n'"),
    ("y 2.5 n", "round.asc, line 2: the symmetry record must be 'y FOLDS y|n', got 'y 2.5 n'"),
    ("y 8 x", "round.asc, line 2: the symmetry record must be 'y FOLDS y|n', got 'y 8 x'"),
    ("I", "round.asc, line 2: the refractive index record must be 'I INDEX' with 1 <= INDEX <= 5, got 'I'"),
    ("I 0.99", "round.asc, line 2: the refractive index record must be 'I INDEX' with 1 <= INDEX <= 5, got 'I 0.99'"),
    ("I 5.01", "round.asc, line 2: the refractive index record must be 'I INDEX' with 1 <= INDEX <= 5, got 'I 5.01'"),
    ("I 1.5 2", "round.asc, line 2: the refractive index record must be 'I INDEX' with 1 <= INDEX <= 5, got 'I 1.5 2'"),
    ("a 41", "round.asc, line 2: a tier record must start 'a ANGLE DISTANCE', got 'a 41'"),
    ("a x 1 3", "round.asc, line 2: a tier record must start 'a ANGLE DISTANCE', got 'a x 1 3'"),
    ("a 41 y 3", "round.asc, line 2: a tier record must start 'a ANGLE DISTANCE', got 'a 41 y 3'"),
    ("a 90.5 1 3", "round.asc, line 2: angle 90.5 is outside -90..90 degrees"),
    ("a -91 1 3", "round.asc, line 2: angle -91 is outside -90..90 degrees"),
    ("a 41 0 3", "round.asc, line 2: distance 0 puts the facet through the centre of the stone, which leaves no stone"),
    ("a 41 1 3 n", "round.asc, line 2: 'n' must be followed by a facet name"),
    ("a 41 1 n A 3", "round.asc, line 2: the name 'A' comes before any index"),
    ("a 41 1 3 x", "round.asc, line 2: 'x' is not a gear index, a name ('n NAME') or instructions ('G ...')"),
])
def test_each_malformed_record_is_one_line_naming_it(line, message):
    with pytest.raises(MeshError) as info:
        parse_asc(f"GemCad 5.0\n{line}\na 0 1 96\n", "round.asc")
    assert str(info.value) == message


def test_the_limits_themselves_are_legal():
    assert _one("g 10000 0\na 0 1 96\n").gear == 10000 and _one("g -10000 0\na 0 1 96\n").gear == -10000
    d = _one("GemCad 5.0\ng 96 0\na 90 1 24\na -90 1 48\na 0 1 96\n")
    assert [t.angle_deg for t in d.tiers] == [90.0, -90.0, 0.0]


def test_no_tier_record_is_no_design():
    with pytest.raises(MeshError) as info:
        parse_asc("GemCad 5.0\ng 96 0\n", "x.asc")
    assert str(info.value) == "x.asc is not a GemCad .asc design: it has no facet records ('a ANGLE DISTANCE INDEX ...')"
    with pytest.raises(MeshError) as info:
        parse_asc("hello\n", "x.asc")
    assert str(info.value) == ("x.asc is not a GemCad .asc design: it has no GemCad header and no facet records "
                               "('a ANGLE DISTANCE INDEX ...')")


# ---------------------------------------------------------------------- encodings and files
def test_utf8_a_byte_order_mark_and_windows_1252(tmp_path):
    body = "GemCad 5.0\ng 96 0\nH Brillant taill\u00e9\na 0 1 96\n"
    for name, data in (("utf8.asc", body.encode("utf-8")), ("bom.asc", b"\xef\xbb\xbf" + body.encode("utf-8")),
                       ("cp1252.asc", body.encode("cp1252"))):
        (tmp_path / name).write_bytes(data)
        d = read_design(tmp_path / name)
        assert d.title == "Brillant taill\u00e9" and d.notes == [], name
        assert d.source == str(tmp_path / name)
    (tmp_path / "bin.asc").write_bytes(b"GemCad\x00\x01")
    with pytest.raises(MeshError) as info:
        read_design(tmp_path / "bin.asc")
    assert str(info.value) == "bin.asc is a binary file, not a GemCad .asc text design (a .gem file? give it the .gem suffix)"


def test_read_design_refuses_what_is_no_design_file(tmp_path):
    cases = {}
    (tmp_path / "x.txt").write_text(MINIMAL)
    cases["x.txt"] = "x.txt: a GemCad design ends in .asc or .gem"
    cases["missing.asc"] = f"design file {str(tmp_path / 'missing.asc')!r} does not exist"
    (tmp_path / "dir.asc").mkdir()
    cases["dir.asc"] = f"{str(tmp_path / 'dir.asc')!r} is a folder, not a design file"
    (tmp_path / "empty.gem").write_bytes(b"")
    cases["empty.gem"] = "empty.gem is empty (0 bytes)"
    for name, message in cases.items():
        with pytest.raises(MeshError) as info:
            read_design(tmp_path / name)
        assert str(info.value) == message
    (tmp_path / "UPPER.ASC").write_text(MINIMAL)
    assert read_design(tmp_path / "UPPER.ASC").format == "asc"


# ---------------------------------------------------------------------- .gem records
def _text(s: str) -> bytes:
    raw = s.encode("cp1252")
    return struct.pack("<B", len(raw)) + raw


def _gem(facets, *, symmetry=8, mirror=1, gear=96, ri=1.54, location=0.0, texts=("Title", "", "", "", "Foot", "", "", ""),
         tail=b""):
    out = b""
    for pole, tier, label, polygon in facets:
        out += struct.pack("<3d", *pole) + struct.pack("<i", tier) + _text(label)
        for p in polygon:
            out += struct.pack("<i", 1) + struct.pack("<3d", *p)
        out += struct.pack("<i", 0)
    out += struct.pack("<d", gemcad.GEM_SENTINEL) + struct.pack("<3i", symmetry, mirror, gear) + struct.pack("<d", ri)
    out += struct.pack("<i", 0x7FFF) + struct.pack("<d", location) + b"".join(_text(t) for t in texts)
    return out + tail


def test_a_gem_file_by_hand():
    crown = facet_pole(41.0, 24, 1.0, 96, 0.0)[0]
    pav = facet_pole(-41.0, 48, 0.8, 96, 0.0)[0]
    tri = [(0.0, 0.0, 1.0), (1.0, 0.0, 0.5), (0.0, 1.0, 0.5)]
    data = _gem([(crown, 3, "C\tcut me", tri), (pav, 7, "P", []), ((0.0, 0.0, 2.0), 9, "T", [])])
    d = parse_gem(data, "x.gem")
    assert d.format == "gem" and d.title == "Title" and d.footnotes == ["Foot"] and d.headers == ["Title"]
    assert (d.gear, d.symmetry, d.mirror, d.refractive_index, d.location) == (96, 8, True, 1.54, 0.0)
    assert [t.number for t in d.tiers] == [1, 2, 3]  # renumbered from 3, 7, 9
    assert [(f.tier, f.own_name, f.name) for f in d.facets] == [(1, "C", "C"), (2, "P", "P"), (3, "T", "T")]
    assert d.tiers[0].instructions == "cut me" and d.tiers[1].instructions == ""
    assert d.facets[0].angle_deg == pytest.approx(41.0) and d.facets[0].index == pytest.approx(24.0)
    assert d.facets[1].angle_deg == pytest.approx(-41.0) and d.facets[1].index == pytest.approx(48.0)
    assert d.facets[1].distance == pytest.approx(0.8) and d.tiers[1].distance == pytest.approx(0.8)
    assert d.facets[2].angle_deg == 0.0 and d.facets[2].index == 96.0 and d.facets[2].distance == 0.5
    assert d.facets[0].polygon.tolist() == [list(p) for p in tri] and d.facets[1].polygon.shape == (0, 3)
    assert d.notes == []


def test_a_gem_files_culet_girdle_and_index_on_a_negative_gear():
    culet = (0.0, 0.0, -1.0)
    girdle = facet_pole(90.0, 24, 1.0, -80, 0.0)[0]
    d = parse_gem(_gem([(girdle, 1, "G", []), (culet, 2, "", [])], gear=-80, ri=float("nan"), mirror=0), "y.gem")
    assert d.facets[0].angle_deg == -90.0 and d.facets[0].index == pytest.approx(24.0)
    assert d.facets[1].angle_deg == 0.0 and math.copysign(1, d.facets[1].angle_deg) == -1.0  # -0: the culet
    assert d.facets[1].index == -80.0 and d.facets[1].name == "tier 2"
    assert d.refractive_index is None and d.mirror is False and d.title == "Title"


def test_a_gem_files_preform_is_ignored_with_a_note_and_a_broken_file_is_named():
    pole = facet_pole(41.0, 24, 1.0, 96, 0.0)[0]
    assert parse_gem(_gem([(pole, 1, "", [])], tail=b"\x01\x02\x03"), "z.gem").notes == [
        "ignored 3 bytes after the footnotes (a preform)"]
    good = _gem([(pole, 1, "", [])])
    with pytest.raises(MeshError) as info:
        parse_gem(good[:40], "z.gem")
    assert str(info.value).startswith("z.gem is a truncated GemCad .gem file: it ends at byte 40 inside ")
    with pytest.raises(MeshError) as info:
        parse_gem(_gem([(pole, 1, "", [])], gear=0), "z.gem")
    assert str(info.value) == "z.gem is corrupt: its trailer holds gear 0, mirror flag 1"
    with pytest.raises(MeshError) as info:
        parse_gem(_gem([(pole, 1, "", [])], mirror=2), "z.gem")
    assert str(info.value) == "z.gem is corrupt: its trailer holds gear 96, mirror flag 2"
    with pytest.raises(MeshError) as info:
        parse_gem(_gem([(pole, 2, "", []), (pole, 1, "", [])]), "z.gem")
    assert str(info.value) == "z.gem is corrupt: facet record 2 goes back from tier 2 to tier 1"
    with pytest.raises(MeshError) as info:
        parse_gem(_gem([((0.0, 0.0, 0.0), 1, "", [])]), "z.gem")
    assert str(info.value) == "z.gem is not a GemCad .gem file (or is corrupt): facet record 1 at byte 0 holds no facet plane"
    with pytest.raises(MeshError) as info:
        parse_gem(_gem([]), "z.gem")
    assert str(info.value) == "z.gem holds no facets"
    good = bytearray(good)
    good[29:33] = struct.pack("<i", 5)  # after the pole (24 bytes), the tier (4) and an empty text (1)
    with pytest.raises(MeshError) as info:
        parse_gem(bytes(good), "z.gem")
    assert str(info.value) == "z.gem is corrupt: facet record 1 has a polygon marker 5 at byte 29 (0 or 1 expected)"
