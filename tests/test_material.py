"""Labradorite parameters: validation, constructors, serialisation."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labcut import Labradorite, LabcutError, LabcutWarning, ParameterError


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        ({"d_a": -5.0}, "d_a"),
        ({"d_b": 0.0}, "d_b"),
        ({"n_a": 1.0}, "n_a"),
        ({"n_b": 0.9}, "n_b"),
        ({"n_surface": float("nan")}, "finite"),
        ({"sigma_a": -1.0}, "sigma_a"),
        ({"sigma_b": float("inf")}, "finite"),
        ({"pairs": 0}, "pairs"),
        ({"pairs": 2.5}, "whole"),
        ({"spread_deg": 0.0}, "spread"),
        ({"body_albedo": 1.5}, "body_albedo"),
        ({"d_a": "thick"}, "number"),
    ],
)
def test_bad_parameters_raise_typed_error_with_message(kwargs, fragment):
    with pytest.raises(ParameterError, match=fragment):
        Labradorite(**kwargs)


@pytest.mark.parametrize("wavelength, cos_theta", [(0.0, 1.0), (-400.0, 1.0), (float("nan"), 1.0), (500.0, float("nan")), (500.0, 1.5), ("x", 1.0)])
def test_bad_evaluation_arguments(wavelength, cos_theta):
    with pytest.raises(ParameterError):
        Labradorite().reflectance(wavelength, cos_theta)


@pytest.mark.parametrize("an", [43.9, 61.1, 0.0, 100.0, float("nan")])
def test_anorthite_outside_boggild_range(an):
    with pytest.raises(ParameterError):
        Labradorite.from_anorthite(an)


@pytest.mark.filterwarnings("ignore::labcut.LabcutWarning")  # An61 peaks at 786 nm
def test_anorthite_ends_map_to_visible_period_range():
    assert Labradorite.from_anorthite(44.0).period_nm == pytest.approx(128.0)
    assert Labradorite.from_anorthite(61.0).period_nm == pytest.approx(252.0)
    assert Labradorite.from_anorthite(52.0).name == "An52"


def test_unknown_preset_and_bad_peak():
    with pytest.raises(ParameterError, match="blue"):
        Labradorite.preset("purple")
    with pytest.raises(ParameterError):
        Labradorite.from_peak_wavelength(float("nan"))
    with pytest.raises(ParameterError):
        Labradorite.from_peak_wavelength(-470.0)


def test_errors_are_labcut_errors_and_value_errors():
    with pytest.raises(LabcutError):
        Labradorite(d_a=-1)
    with pytest.raises(ValueError):
        Labradorite(d_a=-1)


def test_round_trip_through_dict():
    lab = Labradorite.preset("gold", sigma_a=20.0, pairs=8000)
    again = Labradorite.from_dict(lab.to_dict())
    assert again == lab
    with pytest.raises(ParameterError, match="colour"):
        Labradorite.from_dict({**lab.to_dict(), "colour": "gold"})


def test_replace_validates():
    with pytest.raises(ParameterError):
        Labradorite().replace(d_a=-3)
    assert Labradorite().replace(pairs=10).pairs == 10


@pytest.mark.filterwarnings("ignore::labcut.LabcutWarning")  # thin lamellae peak in the ultraviolet
@settings(max_examples=60)
@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10, 10)))
def test_any_thickness_is_accepted_or_rejected_cleanly(d):
    try:
        lab = Labradorite(d_a=d)
    except ParameterError as exc:
        assert str(exc) and "\n" not in str(exc)
    else:
        assert lab.d_a > 0 and math.isfinite(lab.d_a)
        assert np.all(np.isfinite(lab.reflectance(np.linspace(380, 780, 5), 1.0)))


def test_material_name_must_be_text():
    with pytest.raises(ParameterError, match="name"):
        Labradorite(name=[1, 2])


@pytest.mark.parametrize("key", ["pairs", "d_a", "sigma_b", "spread_deg"])
def test_booleans_are_not_numbers(key):
    """{"pairs": true} in a material file is a mistake, not 1 pair."""
    with pytest.raises(ParameterError, match="must be a number"):
        Labradorite(**{key: True})


# ---------------------------------------------------------------------- a flash outside the visible
@pytest.fixture
def fresh_notes(monkeypatch):
    """Forget which stacks this process has warned about (each warns once per process)."""
    from labcut.physics import material

    monkeypatch.setattr(material, "_NOTED_STACKS", set(), raising=False)


@pytest.mark.parametrize("make, words", [
    (lambda: Labradorite.from_peak_wavelength(2000.0), ["2000 nm", "infrared", "over 67°", "higher orders"]),
    (lambda: Labradorite.from_anorthite(61.0), ["An61: ", "786 nm", "infrared", "over 7°"]),
    (lambda: Labradorite(d_a=40.0, d_b=40.0), ["ultraviolet", "at any angle"]),
    (lambda: Labradorite.from_dict({"d_a": 600.0, "d_b": 600.0}), ["infrared"]),
])
def test_a_flash_outside_the_visible_is_accepted_with_a_warning_that_says_what_shows(fresh_notes, make, words):
    """A dark labradorite that schillers in the infrared is a real stone: no error, but one
    LabcutWarning that the face-on peak is not visible and what a viewer sees instead, the same
    sentence :meth:`visibility_note` gives front ends, whatever way the period is set."""
    with pytest.warns(LabcutWarning, match="outside the visible range \\(380-780 nm\\)") as caught:
        lab = make()
    assert len(caught) == 1
    note = str(caught[0].message)
    assert note == lab.visibility_note() and "\n" not in note
    for word in words:
        assert word in note, note


def test_a_visible_flash_gives_no_warning(fresh_notes):
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        for lab in (Labradorite(), Labradorite.preset("blue"), Labradorite.from_anorthite(44.0),
                    Labradorite.from_anorthite(60.0), Labradorite.from_peak_wavelength(385.0),
                    Labradorite.from_peak_wavelength(779.0)):
            assert lab.visibility_note() is None
    with pytest.warns(LabcutWarning, match="peak, 780.3 nm, lies"):  # the peak's edge, not its Bragg estimate's (779.8 nm)
        Labradorite.from_peak_wavelength(780.3)


def test_each_stack_warns_once_per_process(fresh_notes):
    """labcut re-creates materials from their parameters (the renderer's plugin): the same stack,
    named or not, does not warn again; its note is still there to ask for."""
    with pytest.warns(LabcutWarning):
        lab = Labradorite.from_peak_wavelength(1500.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        again = Labradorite(**{k: v for k, v in lab.to_dict().items() if k != "name"})
        lab.replace(name="dark")
    assert again.visibility_note() == lab.visibility_note() is not None
    with pytest.warns(LabcutWarning):
        lab.replace(sigma_a=17.0)  # another stack


# ---------------------------------------------------------------------- pinned by mutation testing (docs/testing.md)
#: every parameter's documented range: (name, highest accepted, lowest refused above it, a value
#: refused below it); the indices must exceed 1, thicknesses 0, the spread 0 (open below)
BOUNDS = [("n_a", 4.0, 4.001, 1.0, 1.001), ("n_b", 4.0, 4.001, 1.0, 1.001), ("n_surface", 4.0, 4.001, 1.0, 1.001),
          ("d_a", 1e5, 100000.5, 0.0, 0.5), ("d_b", 1e5, 100000.5, 0.0, 0.5),
          ("sigma_a", 1e5, 100000.5, -0.1, 0.0), ("sigma_b", 1e5, 100000.5, -0.1, 0.0),
          ("pairs", 1e8, 100000001, 0.5, 1), ("spread_deg", 45.0, 45.01, 0.0, 0.5), ("body_albedo", 1.0, 1.001, -0.01, 0.0)]


@pytest.mark.parametrize("name, top, over, under, low", BOUNDS)
def test_each_parameter_takes_its_whole_range_and_names_itself_outside_it(name, top, over, under, low):
    """Each parameter's documented range, to its ends: the highest and a low value accepted, the
    values just beyond refused with a message that starts with the parameter's name."""
    import re
    import warnings

    import labcut
    from labcut import Labradorite

    for good in (top, low):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an odd stack's visibility note
            kept = Labradorite(**{name: int(good) if name == "pairs" else good})
        assert getattr(kept, name) == good
    for bad in (over, under):
        with pytest.raises(labcut.ParameterError, match=rf"^{re.escape(name)}\b"):
            Labradorite(**{name: bad})


def test_parameters_are_stored_as_the_numbers_they_mean():
    """Numbers given as ints, numpy scalars or whole floats are stored as Python floats, the pair
    count as an int (the material's JSON and its cache keys read them)."""
    import numpy as np

    from labcut import Labradorite

    lab = Labradorite(n_a=np.float32(1.5), d_a=80, sigma_a=np.int64(12), pairs=6000.0, spread_deg=3, body_albedo=1)
    for name in ("n_a", "d_a", "sigma_a", "spread_deg", "body_albedo"):
        assert type(getattr(lab, name)) is float, name
    assert type(lab.pairs) is int and lab.pairs == 6000


def test_the_materials_intensity_is_its_finite_refracting_stacks():
    """Labradorite.intensity passes its pair count and its stone's index on (a finite stack with
    Snell in each phase), not the infinite-stack, one-angle form."""
    from labcut import Labradorite
    from labcut.physics import lamella_intensity

    lab = Labradorite(pairs=40, sigma_a=2.0, sigma_b=2.0)
    got = float(lab.intensity(480.0, 0.6))
    args = (480.0, 0.6, lab.n_a, lab.n_b, lab.d_a, lab.d_b, lab.sigma_a, lab.sigma_b)
    assert got == pytest.approx(float(lamella_intensity(*args, pairs=40, n_surface=lab.n_surface)), rel=1e-12)
    assert abs(got / float(lamella_intensity(*args, n_surface=lab.n_surface)) - 1.0) > 1e-3
    assert abs(got / float(lamella_intensity(*args, pairs=40)) - 1.0) > 1e-3


@pytest.mark.parametrize("wl, c, message", [
    ("blue", 0.5, "wavelength and cos_theta must be numbers or numeric arrays"),
    (480.0, float("nan"), "wavelength and cos_theta must be finite (no NaN or inf)"),
    ([480.0, float("inf")], 0.5, "wavelength and cos_theta must be finite (no NaN or inf)"),
    ([480.0, -5.0], 0.5, "wavelength must be > 0 nm, got -5"),
    (480.0, [0.5, -1.25], "cos_theta must lie in [-1, 1], got 1.25"),
])
def test_a_bad_wavelength_or_cosine_is_one_plain_sentence(wl, c, message):
    import labcut
    from labcut import Labradorite

    with pytest.raises(labcut.ParameterError) as info:
        Labradorite().reflectance(wl, c)
    assert str(info.value) == message


def test_a_grazing_peak_is_refused_in_words():
    import labcut
    from labcut import Labradorite

    with pytest.raises(labcut.ParameterError) as info:
        Labradorite().peak_wavelength(0.0)
    assert str(info.value) == "cos_theta must be > 0: at grazing incidence there is no peak"


@pytest.mark.parametrize("slot", ["wavelength", "cos"])
def test_the_material_takes_the_drjit_path_from_either_input(slot):
    import numpy as np
    from drjit.llvm import Float

    from labcut import Labradorite
    from labcut.physics.ops import is_drjit

    lab = Labradorite()
    want = float(lab.reflectance(480.0, 0.8))
    got = lab.reflectance(Float([480.0]) if slot == "wavelength" else 480.0, Float([0.8]) if slot == "cos" else 0.8)
    assert is_drjit(got) and float(np.array(got)[0]) == pytest.approx(want, rel=2e-4)


def test_the_visibility_note_names_the_material_and_says_when_no_face_reaches_the_peak():
    """An infrared peak near the visible is seen through a face at a steep enough angle (no
    "more than ..." clause); one far out is not (the clause, with the face's limiting angle); the
    note starts with the material's name when it has one."""
    import warnings

    from labcut import Labradorite

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        near = Labradorite.from_peak_wavelength(850.0)
        far = Labradorite.from_peak_wavelength(1600.0, name="deep")
        unnamed = Labradorite.from_peak_wavelength(1600.0).replace(name=None)
    assert near.visibility_note().startswith("the face-on flash peak, 850 nm")  # no name: no "None: "
    assert "over 23° from the lamella normal, where" in near.visibility_note()  # 23° < 40°: a face reaches it
    note = far.visibility_note()
    assert note.startswith("deep: the face-on flash peak, 1600 nm, lies outside the visible range (380-780 nm)")
    assert "(more than the 40° that light reaches through a face parallel to the lamellae)" in note
    assert unnamed.visibility_note().startswith("the face-on flash peak, 1600 nm")
