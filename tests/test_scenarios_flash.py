"""Every scenario gives the bundled low oval a flash figure at its recommended orientation (issue 39):
the flash threshold is the scene's own (τ P, docs/orientation.md), so diffuse light does not read 0 %."""

from __future__ import annotations

from pathlib import Path

import pytest

import labcut

OVAL = Path(__file__).resolve().parents[1] / "meshes" / "oval-16x12-low.ply"


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(OVAL)


@pytest.mark.parametrize("scenario", labcut.scene.SCENARIOS.names())
def test_every_scenario_flashes_at_its_recommended_orientation(oval, scenario):
    rec = labcut.recommend_orientation(oval, "blue", scenario=scenario, quality="draft", estimator="samples")
    area = rec.metrics.flash_area
    assert area > 0.01, (scenario, area)
    # the figure tells a good orientation from a poor one: lamellae tipped 40° from the answer flash less
    poor = labcut.evaluate_orientation(oval, tilt=min(rec.tilt_deg + 40.0, 85.0), azimuth=rec.azimuth_deg, material="blue",
                                       scenario=scenario, quality="draft")
    assert poor.flash_energy < rec.metrics.flash_energy, scenario
    peak = rec.settings["scene_peak"]
    assert 0.0 < peak <= 1.0 and rec.settings["flash_threshold"] == pytest.approx(0.1 * peak)
