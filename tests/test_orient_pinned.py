"""labcut.geometry.orient pinned by mutation testing (issue 37; docs/testing.md, "labcut/geometry/orient.py").

The face-up rules of the module docstring on small meshes built by hand (pyramids, double
pyramids, a faceted stone, a truncated octahedron, a prism, a plate, a flat sheet), each
with its guess and reason word for word: a flat base (its tolerance exactly at 0.5 % of the
stone's height along that axis), a table over a culet (planar to 0.01 %), a dome's side (the
centroid exactly 3 % off the middle), the thinnest axis exactly at 75 % of the next, a slab,
several bases or tables, a carving. The thresholds at their exact values (``>=`` against
``>``) by setting a constant to the fraction the detector sees. The same answers in metres and
wherever the mesh sits; integer vertices; degenerate faces; the caller's cross products. Every
up-axis spelling, each rotation by hand, ``axis_vector`` and ``describe_up``; the error word for
word. No file, no render: about a second.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from labcut.errors import ParameterError
from labcut.geometry import orient
from labcut.geometry.orient import (UP_AXES, UP_ROTATIONS, UpGuess, axis_vector, check_up_axis, describe_up,
                                    detect_up_axis, up_rotation)

AXES = ("+Z", "-Z", "+Y", "-Y", "+X", "-X")


# ------------------------------------------------------------------ meshes by hand
def outward(v: np.ndarray, faces: list, inside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wind each face so that its normal points away from ``inside`` (a point inside the solid)."""
    v = np.asarray(v, dtype=np.float64)
    out = []
    for a, b, c in faces:
        n = np.cross(v[b] - v[a], v[c] - v[a])
        out.append((a, b, c) if np.dot(n, (v[a] + v[b] + v[c]) / 3 - inside) > 0 else (a, c, b))
    return v, np.array(out, dtype=np.int64)


def hull(points) -> tuple[np.ndarray, np.ndarray]:
    """A convex solid: the convex hull of ``points``, outward-wound."""
    v = np.asarray(points, dtype=np.float64)
    return outward(v, ConvexHull(v).simplices.tolist(), v.mean(axis=0))


def pyramid(delta: float = 0.0, base: float = 20.0, height: float = 2.0, z0: float = -1.0):
    """A square pyramid on its base (z = z0, side ``base``), apex ``height`` above; the base is four
    triangles round a centre vertex raised by ``delta`` (a scanned base that is not quite planar)."""
    h = base / 2
    v = [(-h, -h, z0), (h, -h, z0), (h, h, z0), (-h, h, z0), (0.0, 0.0, z0 + delta), (0.0, 0.0, z0 + height)]
    faces = [(i, (i + 1) % 4, 4) for i in range(4)] + [(i, (i + 1) % 4, 5) for i in range(4)]
    return outward(v, faces, np.array([0.0, 0.0, z0 + height / 3]))


def bipyramid(h1: float, h2: float, a: float = 40.0, b: float = 40.0):
    """Two pyramids on one rhombus girdle (half-diagonals a, b): apex h1 above, h2 below (a double
    cabochon's stand-in). Volume centroid at z = (h1 - h2) / 4."""
    return hull([(a, 0, 0), (-a, 0, 0), (0, b, 0), (0, -b, 0), (0, 0, h1), (0, 0, -h2)])


def faceted(table_rise: float = 0.0):
    """A faceted stone: a square girdle of side 20 at z = 0, a crown to a table of side 8 at z = 2,
    a pavilion to a culet at z = -8. ``table_rise``: the table's centre raised off its plane."""
    pts = [(x, y, 0.0) for x in (-10, 10) for y in (-10, 10)] + [(x, y, 2.0) for x in (-4, 4) for y in (-4, 4)]
    pts += [(0.0, 0.0, -8.0)]
    if table_rise:
        pts.append((0.0, 0.0, 2.0 + table_rise))
    return hull(pts)


def turned(mesh, up: str):
    """The file coordinates of a stone whose face-up side is ``up`` (the inverse of the intake rotation)."""
    v, f = mesh
    return v @ up_rotation(up), f


def guess(mesh, convex: bool = True) -> tuple:
    v, f = mesh
    g = detect_up_axis(v, f, convex)
    return g.axis, g.reason


# ------------------------------------------------------------------ names and rotations
@pytest.mark.parametrize("given, key", [
    ("auto", "auto"), ("AUTO", "auto"), (" Auto ", "auto"),
    ("+Z", "+Z"), ("-Z", "-Z"), ("+Y", "+Y"), ("-Y", "-Y"), ("+X", "+X"), ("-X", "-X"),
    ("z", "+Z"), ("Z", "+Z"), ("y", "+Y"), ("Y", "+Y"), ("x", "+X"), ("X", "+X"),
    ("-y", "-Y"), ("+x", "+X"), (" -z\t", "-Z"),
])
def test_every_up_axis_spelling(given, key):
    """The names the CLI's ``--up-axis`` and a catalogue accept: any case, spaces around, a bare
    letter meaning its + side."""
    assert check_up_axis(given) == key


@pytest.mark.parametrize("bad", ["sideways", "", "W", "+W", "++Z", "+-Z", "Z+", "+ Z", "xy", "auto-z"])
def test_unknown_up_axis_message(bad):
    with pytest.raises(ParameterError) as info:
        check_up_axis(bad)
    assert str(info.value) == f"up axis must be one of auto, +Z, -Z, +Y, -Y, +X, -X, got {bad!r}"
    assert info.value.parameter == "up axis"


@pytest.mark.parametrize("bad", [None, 3, ("+Z",), b"+Z"])
def test_up_axis_not_a_string_message(bad):
    with pytest.raises(ParameterError) as info:
        check_up_axis(bad)
    assert str(info.value) == f"up axis must be one of auto, +Z, -Z, +Y, -Y, +X, -X, got {bad!r}"
    assert info.value.parameter == "up axis"


def test_up_axes_list():
    assert UP_AXES == ("auto", "+Z", "-Z", "+Y", "-Y", "+X", "-X")
    assert set(UP_ROTATIONS) == set(AXES)


# rotations by hand: (file axis, where the file's +X, +Y, +Z go in labcut's frame)
ROTATED = {
    "+Z": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-Z": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),  # 180 degrees about X
    "+Y": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),  # a Y-up glTF: its front (+Z) becomes labcut's front (-Y)
    "-Y": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    "+X": ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),  # about Y
    "-X": ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
}


@pytest.mark.parametrize("axis", AXES)
def test_rotations_by_hand(axis):
    """Each rotation takes the named file axis to +Z, is proper (never a mirror), and moves the
    file's axes where the docstring says (about X for +-Y and -Z, about Y for +-X)."""
    r = up_rotation(axis)
    for k, image in enumerate(ROTATED[axis]):
        assert np.array_equal(r @ np.eye(3)[k], np.array(image, dtype=float))
    assert np.array_equal(r @ axis_vector(axis), [0.0, 0.0, 1.0])
    assert np.linalg.det(r) == pytest.approx(1.0)
    assert np.array_equal(up_rotation(axis.lower()), r)


def test_up_rotation_is_a_copy():
    r = up_rotation("+Y")
    r[:] = 0.0
    assert np.array_equal(up_rotation("+Y"), np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]))
    with pytest.raises(ParameterError, match="got 'auto-z'"):
        up_rotation("auto-z")


@pytest.mark.parametrize("axis, vec", [("+X", (1, 0, 0)), ("-X", (-1, 0, 0)), ("+Y", (0, 1, 0)),
                                       ("-Y", (0, -1, 0)), ("+Z", (0, 0, 1)), ("-Z", (0, 0, -1)),
                                       ("x", (1, 0, 0)), ("-y", (0, -1, 0)), (" z ", (0, 0, 1))])
def test_axis_vector_by_hand(axis, vec):
    out = axis_vector(axis)
    assert out.dtype == np.float64 and out.shape == (3,)
    assert np.array_equal(out, np.array(vec, dtype=float))


def test_axis_vector_refuses_what_check_up_axis_refuses():
    with pytest.raises(ParameterError, match=r"got 'w'$"):
        axis_vector("w")


@pytest.mark.parametrize("axis, words", [
    ("+Z", "Z-up"), ("+Y", "Y-up"), ("+X", "X-up"),
    ("-Z", "upside down (dome-down: face-up is -Z)"),
    ("-Y", "Y-down (face-up is -Y)"), ("-X", "X-down (face-up is -X)"),
])
def test_describe_up_word_for_word(axis, words):
    """The words of load_mesh's warning ("<file> looks Y-up, ...")."""
    assert describe_up(axis) == words


def test_up_guess_fields():
    g = UpGuess("+Z", "why")
    assert (g.axis, g.reason) == ("+Z", "why")
    with pytest.raises(AttributeError):
        g.axis = "-Z"  # type: ignore[misc]


# ------------------------------------------------------------------ 1. a flat base
OPPOSITE = {"+Z": "-Z", "-Z": "+Z", "+Y": "-Y", "-Y": "+Y", "+X": "-X", "-X": "+X"}


@pytest.mark.parametrize("up", AXES)
def test_flat_base_each_side_word_for_word(up):
    """A pyramid on its base, turned so that face-up is ``up``: the base faces the opposite side."""
    assert guess(turned(pyramid(), up)) == (up, f"a flat base facing {OPPOSITE[up]}")
    assert guess(turned(pyramid(), up), convex=False) == (up, f"a flat base facing {OPPOSITE[up]}")


def test_flat_base_tolerance_is_half_a_percent_of_this_axis():
    """The base's vertices may lie up to 0.5 % of the stone's extent *along that axis* (here its
    2 mm height, not its 20 mm width) off the base plane: exactly 0.01 mm is a base, 0.011 mm is
    not (and then a non-convex stone says nothing)."""
    assert guess(pyramid(0.01), convex=False) == ("+Z", "a flat base facing -Z")
    assert guess(turned(pyramid(0.01), "-Z"), convex=False) == ("-Z", "a flat base facing +Z")
    carving = (None, "no flat base, and a carving's face-up side is not read from its shape")
    assert guess(pyramid(0.011), convex=False) == carving
    assert guess(turned(pyramid(0.011), "-Z"), convex=False) == carving
    assert guess(pyramid(0.05), convex=False) == carving  # within 0.5 % of the width: still not a base


def test_flat_base_in_metres_and_anywhere():
    """The fractions are shares of the outline and the tolerance a share of the extent: a stone in
    metres (an outline of 4e-4 m^2) or far from the origin reads the same."""
    v, f = pyramid()
    for scale, shift in ((1e-3, 0.0), (1.0, 1000.0), (1.0, -1000.0), (1e-3, -5.0)):
        assert guess((v * scale + shift, f)) == ("+Z", "a flat base facing -Z")


def test_several_flat_bases_word_for_word():
    """A right triangular prism lying in a corner: flat bases on -X and -Z (the two legs), its
    triangular ends flat on both sides along Y: no answer, and the sides named."""
    pts = [(x, y, z) for y in (0.0, 8.0) for x, z in ((0.0, 0.0), (10.0, 0.0), (0.0, 6.0))]
    assert guess(hull(pts)) == (None, "flat bases on several sides (-X, -Z)")
    corner = hull([(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)])  # three legs
    assert guess(corner) == (None, "flat bases on several sides (-X, -Y, -Z)")


def test_carving_without_base_word_for_word():
    assert guess(bipyramid(16, 9), convex=False) == (
        None, "no flat base, and a carving's face-up side is not read from its shape")


def test_box_and_slab_keep_the_convention():
    """Flat on both sides along every axis: no base, no table; thin along Z: a slab."""
    box = hull([(x, y, z) for x in (-5, 5) for y in (-4, 4) for z in (-3, 3)])
    assert guess(box) == (None, "flat faces on both sides along Z (a slab)")  # 6 = 0.75 x 8: thin, just
    plate = hull([(x, y, z) for x in (-10, 10) for y in (-10, 10) for z in (0, 2)])
    assert guess(turned(plate, "+X")) == (None, "flat faces on both sides along X (a slab)")
    cube = hull([(x, y, z) for x in (-5, 5) for y in (-5, 5) for z in (-5, 5)])
    assert guess(cube) == (None, "no flat base and no clearly thinnest axis")


def test_slab_is_read_along_its_own_thin_axis():
    """A plate with sloped edges (a frustum: 20 mm below, 16 mm on top, 2 mm thick): flat on both
    sides along Z only (the top covers 64 % of the outline: not a base, as it is over half). The
    slab is named by the Z sides, not by its sloped X edges."""
    pts = [(x, y, 0.0) for x in (-10, 10) for y in (-10, 10)] + [(x, y, 2.0) for x in (-8, 8) for y in (-8, 8)]
    plate = hull(pts)
    assert guess(plate) == (None, "flat faces on both sides along Z (a slab)")
    assert guess(turned(plate, "-Y")) == (None, "flat faces on both sides along Y (a slab)")


# ------------------------------------------------------------------ 2. a table over a culet
@pytest.mark.parametrize("up", AXES)
def test_table_over_culet_word_for_word(up):
    """The table covers 64 / 400 = 16 % of the outline (under the 90 % of a base), the culet none."""
    assert guess(turned(faceted(), up)) == (up, f"a flat table facing {up} over a keel or culet")


def test_table_must_be_planar_to_a_hundredth_of_a_percent():
    """A table whose centre rises 0.02 mm (0.2 % of the 10 mm height) is not cut planar (within
    0.01 %): no table; the stone is then read as a dome whose deep pavilion is the taller side
    (volume centroid -1.23 mm, the middle -2.99 mm: 17.5 % of the height towards +Z)."""
    assert guess(faceted(0.02)) == ("-Z", "a dome rising towards -Z (its bulk sits towards +Z)")
    assert guess(faceted(0.0005))[1] == "a flat table facing +Z over a keel or culet"  # within 1e-4 x 10.0005


def test_two_tables_word_for_word():
    """An octahedron with its +Z and +X points cut off (square tables of half-diagonal 3, each
    about 9 % of the outline): no answer."""
    c = 3.0
    pts = [(-10, 0, 0), (0, 10, 0), (0, -10, 0), (0, 0, -10)]
    pts += [(c, 0, 10 - c), (-c, 0, 10 - c), (0, c, 10 - c), (0, -c, 10 - c)]
    pts += [(10 - c, c, 0), (10 - c, -c, 0), (10 - c, 0, c), (10 - c, 0, -c)]
    assert guess(hull(pts)) == (None, "flat faces on several sides")


# ------------------------------------------------------------------ 3. a dome
@pytest.mark.parametrize("up", AXES)
def test_dome_side_word_for_word(up):
    """Apex 16 mm above a 80 mm girdle, 9 mm below: centroid 1.75 mm, middle 3.5 mm: 7 % towards
    -Z; the taller dome is face-up."""
    assert guess(turned(bipyramid(16, 9), up)) == (up, f"a dome rising towards {up} (its bulk sits towards {OPPOSITE[up]})")


def test_dome_offset_exactly_three_percent_names_the_side():
    """Apex 14 above, 11 below: centroid (14 - 11) / 4 = 0.75, middle 1.5, height 25: the centroid is
    exactly 3 % of the height off the middle (integer coordinates: every sum exact): a side."""
    assert guess(bipyramid(14, 11)) == ("+Z", "a dome rising towards +Z (its bulk sits towards -Z)")
    assert guess(turned(bipyramid(14, 11), "-X")) == ("-X", "a dome rising towards -X (its bulk sits towards +X)")
    # 12.5 / 12.5: the middle; 13 / 12: 1 % off: two domes of about the same height
    assert guess(bipyramid(12.5, 12.5)) == (None, "two domes of about the same height along Z")
    assert guess(bipyramid(13, 12)) == (None, "two domes of about the same height along Z")
    assert guess(turned(bipyramid(13, 12), "+Y")) == (None, "two domes of about the same height along Y")


def test_dome_in_metres_and_anywhere():
    """The offset is a share of the height: the same dome in metres, or 100 mm up or down, reads the same."""
    v, f = bipyramid(16, 9)
    want = ("+Z", "a dome rising towards +Z (its bulk sits towards -Z)")
    for scale, shift in ((1e-3, 0.0), (1.0, 100.0), (1.0, -100.0), (1e-3, -0.1)):
        assert guess((v * scale + np.array([0.0, 0.0, shift]), f)) == want


def test_thinnest_axis_exactly_three_quarters():
    """Girdle 60 x 40 mm: a height of exactly 30 mm (0.75 x 40) is thin enough to read a dome's
    side; 30.5 mm is not. A stone thinner than 0.75 of its longest size but not of its second
    (100 x 50 x 40) does not say either."""
    assert guess(bipyramid(17, 13, a=30, b=20)) == ("+Z", "a dome rising towards +Z (its bulk sits towards -Z)")
    assert guess(bipyramid(17.5, 13, a=30, b=20)) == (None, "no flat base and no clearly thinnest axis")
    assert guess(bipyramid(22, 18, a=50, b=25)) == (None, "no flat base and no clearly thinnest axis")
    assert guess(hull([(10, 0, 0), (-10, 0, 0), (0, 10, 0), (0, -10, 0), (0, 0, 10), (0, 0, -10)])) == (
        None, "no flat base and no clearly thinnest axis")


# ------------------------------------------------------------------ thresholds at their exact values
@pytest.fixture
def seen(monkeypatch):
    """The side fractions each call of detect_up_axis computed (flat, then planar)."""
    calls = []
    original = orient._side_fractions

    def spy(*args, **kwargs):
        out = original(*args, **kwargs)
        calls.append(out)
        return out

    monkeypatch.setattr(orient, "_side_fractions", spy)
    return calls


def test_base_fraction_is_at_least(seen, monkeypatch):
    """A base covering exactly BASE_FRACTION of the outline is a base ("at least 90 %")."""
    mesh = pyramid()
    guess(mesh)
    bottom = seen[0]["+Z"][1]
    assert bottom == pytest.approx(1.0, rel=1e-12)
    monkeypatch.setattr(orient, "BASE_FRACTION", bottom)
    assert guess(mesh) == ("+Z", "a flat base facing -Z")
    monkeypatch.setattr(orient, "BASE_FRACTION", np.nextafter(bottom, 2.0))
    assert guess(mesh, convex=False)[0] is None


def test_top_flat_limit_is_below(seen, monkeypatch):
    """The frustum plate's top covers 64 % of the outline: with TOP_FLAT_LIMIT at exactly that share
    its base is not a base (the top must be under the limit), just above it is."""
    pts = [(x, y, 0.0) for x in (-10, 10) for y in (-10, 10)] + [(x, y, 2.0) for x in (-8, 8) for y in (-8, 8)]
    plate = hull(pts)
    guess(plate)
    top, bottom = seen[0]["-Z"][1], seen[0]["+Z"][1]
    assert top == pytest.approx(0.64, rel=1e-12) and bottom == pytest.approx(1.0, rel=1e-12)
    monkeypatch.setattr(orient, "TOP_FLAT_LIMIT", top)
    assert guess(plate) == (None, "flat faces on both sides along Z (a slab)")
    monkeypatch.setattr(orient, "TOP_FLAT_LIMIT", np.nextafter(top, 1.0))
    assert guess(plate) == ("+Z", "a flat base facing -Z")


def test_table_fraction_is_at_least_and_keel_limit_at_most(seen, monkeypatch):
    """A table of exactly TABLE_FRACTION counts; a culet with exactly KEEL_LIMIT of flat faces (here
    0 with the limit 0) still counts as a culet."""
    mesh = faceted()
    guess(mesh)
    top, bottom = seen[1]["+Z"]
    assert top == pytest.approx(0.16, rel=1e-12) and bottom == 0.0
    table = ("+Z", "a flat table facing +Z over a keel or culet")
    monkeypatch.setattr(orient, "TABLE_FRACTION", top)
    assert guess(mesh) == table
    monkeypatch.setattr(orient, "KEEL_LIMIT", 0.0)
    assert guess(mesh) == table
    monkeypatch.setattr(orient, "TABLE_FRACTION", np.nextafter(top, 1.0))
    assert guess(mesh)[1] != table[1]


def test_slab_needs_more_than_keel_limit(monkeypatch):
    """A dome without any flat face (its largest flat share exactly 0) is not a slab even with KEEL_LIMIT 0."""
    monkeypatch.setattr(orient, "KEEL_LIMIT", 0.0)
    assert guess(bipyramid(16, 9)) == ("+Z", "a dome rising towards +Z (its bulk sits towards -Z)")


# ------------------------------------------------------------------ the side fractions
def normals_areas(v, f):
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(cross, axis=1)
    return cross / norm[:, None], 0.5 * norm


def test_side_fractions_by_hand():
    """The pyramid: along Z the base is the whole outline (far side along +Z: 0, near side: 1);
    its sloped sides (cos 10 / sqrt(104) = 0.98 < 0.995) are flat nowhere."""
    v, f = pyramid()
    n, a = normals_areas(v, f)
    sides = orient._side_fractions(v, f, n, a)
    assert list(sides) == ["+X", "-X", "+Y", "-Y", "+Z", "-Z"]
    assert sides["+Z"] == pytest.approx((0.0, 1.0), abs=1e-12)
    assert sides["-Z"] == pytest.approx((1.0, 0.0), abs=1e-12)
    for d in ("+X", "-X", "+Y", "-Y"):
        assert sides[d] == (0.0, 0.0)


def test_side_fractions_normal_exactly_at_cos_min():
    """A face whose normal is exactly ``cos_min`` off the axis counts ("within"): with cos_min = 1
    a box's faces (normals exactly +-1) are all flat."""
    v, f = hull([(x, y, z) for x in (0, 4) for y in (0, 3) for z in (0, 2)])
    n, a = normals_areas(v, f)
    assert set(np.abs(n).ravel()) == {0.0, 1.0}
    sides = orient._side_fractions(v, f, n, a, 1.0, 0.0)
    assert all(sides[d] == (1.0, 1.0) for d in AXES)


def test_flat_sheet():
    """A triangle seen from both sides (no thickness): flat on both sides along Z; along X and Y no
    face points that way at all (no outline): (0, 0), and the sheet reads as a slab."""
    v = np.array([(0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 8.0, 0.0)])
    f = np.array([(0, 1, 2), (0, 2, 1)])
    n, a = normals_areas(v, f)
    sides = orient._side_fractions(v, f, n, a)
    assert sides == {"+X": (0.0, 0.0), "-X": (0.0, 0.0), "+Y": (0.0, 0.0), "-Y": (0.0, 0.0),
                     "+Z": (1.0, 1.0), "-Z": (1.0, 1.0)}
    assert guess((v, f)) == (None, "flat faces on both sides along Z (a slab)")


def test_sheet_flat_to_rounding_anywhere():
    """A sheet whose thickness is rounding noise (one vertex 4 ulps off, far from the origin in the
    negative octant) is flat on both sides: the tolerance never falls below 1e-12 of the stone's
    largest extent."""
    z = -5.0
    v = np.array([(-30.0, -30.0, z), (-10.0, -30.0, z), (-30.0, -10.0, np.nextafter(np.nextafter(z, 0), 0))])
    f = np.array([(0, 1, 2), (0, 2, 1)])
    n, a = normals_areas(v, f)
    sides = orient._side_fractions(v, f, n, a)
    assert sides["+Z"] == pytest.approx((1.0, 1.0), rel=1e-9)


# ------------------------------------------------------------------ inputs
def test_integer_vertices_and_faces_as_lists():
    v, f = bipyramid(16, 9)
    vi = [[int(x) for x in row] for row in v]
    assert np.array_equal(np.asarray(vi, dtype=float), v)
    g = detect_up_axis(vi, f.tolist(), True)
    assert (g.axis, g.reason) == ("+Z", "a dome rising towards +Z (its bulk sits towards -Z)")


def test_degenerate_faces_are_left_out():
    """Zero-area faces (a repeated vertex, collinear points) have no normal; they change nothing."""
    v, f = pyramid()
    f2 = np.vstack([f, [(0, 0, 1), (0, 1, 1)]])
    assert guess((v, f2)) == ("+Z", "a flat base facing -Z")
    v3 = np.vstack([v, [(-10.0, -10.0, -1.0)]])  # a copy of vertex 0: a sliver face of area 0
    f3 = np.vstack([f, [(0, 6, 1)]])
    assert guess((v3, f3), convex=False) == ("+Z", "a flat base facing -Z")


def test_callers_cross_products_are_used_and_overwritten():
    """``cross``: the faces' cross products, used as given and overwritten with the unit normals;
    an array of another shape is not the faces' and is ignored."""
    v, f = bipyramid(16, 9)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    unit = cross / np.linalg.norm(cross, axis=1)[:, None]
    g = detect_up_axis(v, f, True, cross=cross)
    assert g.axis == "+Z"
    assert np.allclose(cross, unit, atol=1e-15)
    for wrong in (np.zeros((len(f), 2)), np.zeros((len(f) - 1, 3)), np.zeros((len(f), 4))):
        before = wrong.copy()
        assert detect_up_axis(v, f, True, cross=wrong).axis == "+Z"
        assert np.array_equal(wrong, before)


# ------------------------------------------------------------------ the volume centroid
def test_volume_centroid_by_hand():
    """The double pyramid (apexes 16 above, 9 below): centroid (0, 0, (16 - 9) / 4), not the vertex
    mean (7 / 6); the same in metres (a volume of 1e-5)."""
    v, f = bipyramid(16, 9)
    assert orient._volume_centroid(v, f) == pytest.approx([0.0, 0.0, 1.75], abs=1e-12)
    assert orient._volume_centroid(v * 1e-3, f) == pytest.approx([0.0, 0.0, 1.75e-3], abs=1e-15)
    tet = np.array([(0.0, 0.0, 0.0), (4.0, 0.0, 0.0), (0.0, 8.0, 0.0), (0.0, 0.0, 12.0)])
    vt, ft = outward(tet, [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)], tet.mean(axis=0))
    assert orient._volume_centroid(vt, ft) == pytest.approx([1.0, 2.0, 3.0], abs=1e-12)
    # the same tetrahedron wound inward: the signed volume is negative, the centroid the same
    assert orient._volume_centroid(vt, ft[:, ::-1]) == pytest.approx([1.0, 2.0, 3.0], abs=1e-12)


def test_volume_centroid_of_a_flat_mesh_is_the_vertex_mean():
    v = np.array([(0.0, 0.0, 1.0), (10.0, 0.0, 1.0), (0.0, 8.0, 1.0), (2.0, 2.0, 1.0)])
    f = np.array([(0, 1, 2), (0, 2, 1), (0, 1, 3), (0, 3, 1)])  # each face twice, opposite ways: volume 0
    out = orient._volume_centroid(v, f)
    assert out.shape == (3,)
    assert out == pytest.approx([3.0, 2.5, 1.0], abs=1e-12)


def test_walls_within_the_tolerance_are_not_base_area():
    """A pyramid on a plinth 0.005 mm high (within the base tolerance, 0.5 % of its 2 mm height):
    the plinth's vertical walls lie within the tolerance of the base plane but face sideways, so
    only the base itself counts: exactly the whole outline, not the outline plus the walls' 0.4 mm^2."""
    pts = [(x, y, z) for x in (-10, 10) for y in (-10, 10) for z in (-1.0, -0.995)] + [(0.0, 0.0, 1.0)]
    v, f = hull(pts)
    n, a = normals_areas(v, f)
    sides = orient._side_fractions(v, f, n, a)
    assert sides["+Z"] == pytest.approx((0.0, 1.0), rel=1e-12, abs=1e-12)
    assert guess((v, f)) == ("+Z", "a flat base facing -Z")


def test_faces_of_any_number_type():
    """Faces as int32 or uint32 (as PLY files store them) or as floats holding whole numbers (as
    ``np.loadtxt`` reads an index list) index the same vertices."""
    v, f = pyramid()
    want = ("+Z", "a flat base facing -Z")
    for faces in (f.astype(np.int32), f.astype(np.uint32), f.astype(np.float64)):
        g = detect_up_axis(v, faces, True)
        assert (g.axis, g.reason) == want
