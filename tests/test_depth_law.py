"""The stack's depth law and the flash depth (labcut.physics.depth, docs/physics.md "Depth"):
against the model's own reflectance of a shorter stack, computed independently through the colour
tables; the mean depth; the weak-stack limit; the quantile as the share's inverse (hypothesis)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labcut
from labcut.colour import reflectance_luminance
from labcut.physics.depth import depth_law, stack_depth_mm


@pytest.fixture(scope="module")
def material():
    return labcut.Labradorite()


def test_the_depth_law_is_the_models_reflectance_of_a_shorter_stack(material):
    law = depth_law(material)
    assert law.depth_mm == pytest.approx(material.pairs * material.period_nm * 1e-6) == stack_depth_mm(material)
    assert material.stack_depth_mm == pytest.approx(0.93)
    for cos in (1.0, 0.8):
        full = float(reflectance_luminance(material, np.array([cos]))[0])
        for share in (0.25, 0.5, 0.75):
            cut = material.replace(pairs=int(material.pairs * share))
            want = float(reflectance_luminance(cut, np.array([cos]))[0]) / full
            assert law.share_above(share * law.depth_mm, cos) == pytest.approx(want, rel=2e-3), (cos, share)
    assert law.share_above(0.0) == 0.0 and law.share_above(law.depth_mm) == 1.0 and law.share_above(5.0) == 1.0
    assert np.all(np.diff(law.share, axis=1) >= 0)


def test_the_flash_depth_is_the_mean_depth_and_a_weak_stack_spreads_it_evenly(material):
    law = depth_law(material)
    z = np.linspace(0.0, law.depth_mm, 4001)
    density = np.gradient(law.share_above(z, 1.0), z)
    mean = float(np.sum(z * density) * (z[1] - z[0]))
    assert material.flash_depth_mm == pytest.approx(mean, rel=5e-3)
    # saturation mirrors more near the top: the mean lies above half the stack's depth
    assert 0.3 * law.depth_mm < material.flash_depth_mm < 0.5 * law.depth_mm
    weak = material.replace(pairs=300)  # R_kin << 1: reflectance grows linearly with the depth
    assert weak.flash_depth_mm == pytest.approx(0.5 * weak.stack_depth_mm, rel=0.01)


@settings(max_examples=40, deadline=None)
@given(u=st.floats(0.0, 1.0), cos=st.floats(0.2, 1.0))
def test_the_depth_quantile_inverts_the_share(u, cos):
    law = depth_law(labcut.Labradorite())
    z = law.quantile(u, cos)
    assert 0.0 <= z <= law.depth_mm
    assert float(law.share_above(z, cos)) == pytest.approx(u, abs=2e-3)




def test_nan_reads_as_the_surface_and_normal_incidence(material):
    """A path whose depth or angle is not a number (a missed ray) is read at depth 0 and normal
    incidence, so the caller's own checks drop it (docs: DepthLaw.share_above)."""
    law = depth_law(material)
    assert float(law.share_above(np.nan, 0.8)) == 0.0 and float(law.quantile(np.nan, 0.8)) == 0.0
    assert float(law.share_above(0.3, np.nan)) == float(law.share_above(0.3, 1.0))
    assert float(law.quantile(0.4, np.nan)) == float(law.quantile(0.4, 1.0))


def test_the_mean_depth_at_an_oblique_angle_is_that_angles_law(material):
    """At 53° from the lamella normal (cos 0.6) the stack is weaker (its Bragg peak left the
    visible's bright middle), so its flash is mirrored more evenly and a little deeper."""
    law = depth_law(material)
    z = np.linspace(0.0, law.depth_mm, 4001)
    density = np.gradient(law.share_above(z, 0.6), z)
    mean = float(np.sum(z * density) * (z[1] - z[0]))
    assert law.mean_mm(0.6) == pytest.approx(mean, rel=5e-3)
    assert law.mean_mm(0.6) > law.mean_mm(1.0)
