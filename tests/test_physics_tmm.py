"""The stack reflectance against exact wave optics: transfer-matrix ensemble means of random stacks.

The reference data (benchmarks/data/tmm-ensemble.json) is made by benchmarks/tmm_ensemble.py
(every preset; internal angles 0, 20, 30, 45, 60, 70°; s and p; hundreds of random stacks).
A live recomputation of a few points checks that the stored data is what the code computes.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from labcut import Labradorite

ROOT = Path(__file__).resolve().parents[1]
DATA = json.loads((ROOT / "benchmarks" / "data" / "tmm-ensemble.json").read_text())
WL = np.array(DATA["wavelengths_nm"])
sys.path.insert(0, str(ROOT / "benchmarks"))
import tmm  # noqa: E402

CASES = [(c["preset"], c["theta_deg"], pol) for c in DATA["cases"] for pol in ("s", "p", "u")]


def _exact(case: dict, pol: str) -> tuple[np.ndarray, np.ndarray]:
    rs, rp = np.array(case["R_s"]), np.array(case["R_p"])
    ss, sp = np.array(case["se_s"]), np.array(case["se_p"])
    if pol == "s":
        return rs, ss
    if pol == "p":
        return rp, sp
    return 0.5 * (rs + rp), 0.5 * np.hypot(ss, sp)


@pytest.mark.parametrize("preset, theta, pol", CASES)
def test_model_follows_the_exact_ensemble_mean(preset, theta, pol):
    case = next(c for c in DATA["cases"] if c["preset"] == preset and c["theta_deg"] == theta)
    lab = Labradorite.preset(preset)
    exact, se = _exact(case, pol)
    model = lab.reflectance(WL, math.cos(math.radians(theta)), None if pol == "u" else pol)
    if exact.max() < 0.01:  # p at the phases' Brewster angle: both all but vanish
        assert model.max() < 0.01
        return
    m = tmm.compare(model, exact, se, WL)
    # the ensemble's own noise is allowed for (3 standard errors), as for the pointwise check
    assert abs(m["model_peak"] - m["exact_peak"]) <= 0.05 * m["exact_peak"] + 3.0 * m["peak_se"], ("peak height", m)
    assert abs(m["integral"] - 1.0) <= 0.04 + 3.0 * m["integral_se"], ("integral over 380-780 nm", m)
    assert abs(m["position_nm"]) <= 6.0, ("peak position", m)
    assert m["excess"] <= 0.03, ("pointwise", m)


def test_polarisation_off_normal_is_what_exact_optics_says():
    """R_s/R_p at the peak: ~1 at 0°, ~1.4 at 20°, 2.2-2.6 at 30°, p ~0 near 45° (exact), and the model agrees."""
    for case in DATA["cases"]:
        lab = Labradorite.preset(case["preset"])
        c = math.cos(math.radians(case["theta_deg"]))
        rs, rp = np.array(case["R_s"]), np.array(case["R_p"])
        i = int(np.argmax(rs))
        exact_ratio = rs[i] / max(rp[i], 1e-12)
        model_ratio = float(lab.reflectance(WL[i], c, "s")) / max(float(lab.reflectance(WL[i], c, "p")), 1e-12)
        if case["theta_deg"] == 0.0:
            assert exact_ratio == pytest.approx(1.0, abs=1e-9) and model_ratio == pytest.approx(1.0, abs=1e-9)
        elif case["theta_deg"] in (20.0, 30.0):
            assert model_ratio == pytest.approx(exact_ratio, rel=0.1)
            assert 1.2 < exact_ratio < 3.0
        elif case["theta_deg"] == 45.0:
            assert rp.max() < 0.01 and float(lab.reflectance(WL[i], c, "p")) < 0.01


def test_stored_reference_is_reproducible():
    """A live transfer-matrix ensemble at a few wavelengths agrees with the stored means within their noise."""
    case = next(c for c in DATA["cases"] if c["preset"] == "blue" and c["theta_deg"] == 30.0)
    lab = Labradorite.preset("blue")
    pick = np.argsort(case["R_s"])[-3:]
    live, live_se = tmm.ensemble_mean(WL[pick], 30.0, lab, "s", 48, seed=99)
    stored, stored_se = np.array(case["R_s"])[pick], np.array(case["se_s"])[pick]
    assert np.all(np.abs(live - stored) <= 4.0 * np.hypot(live_se, stored_se) + 1e-3)
    assert DATA["realisations"] >= 500
