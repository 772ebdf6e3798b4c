"""The worn scenarios move as jewellery moves and are lit as rooms are (docs/scenarios.md, issue 39)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.scene import Scenario
from labcut.scene.presets import DOWNLIGHT_CUTOFF, ROOM_SHARES, downlight_grid
from labcut.scene.scenario import MOTION, MOTION_VIEWS

WORN = {"ring": (25.0, 25.0), "pendant": (10.0, 10.0), "brooch": (8.0, 8.0), "outdoor": (25.0, 25.0)}


def _turns(scenario: Scenario) -> list[tuple[float, float]]:
    """Each pose's turn from the rest pose as (angle about world X, angle about world Y), degrees."""
    out = []
    for pose, _ in scenario.poses():
        r = pose @ scenario.pose.T  # the motion alone, world frame
        about_x = math.degrees(math.atan2(r[2, 1], r[1, 1]))
        about_y = math.degrees(math.atan2(r[0, 2], r[0, 0]))
        out.append((about_x, about_y))
    return out


@pytest.mark.parametrize("name", sorted(WORN))
def test_a_worn_stone_turns_within_its_documented_range(name):
    assert MOTION[name] == WORN[name]
    for quality in ("draft", "standard"):
        sc = Scenario.preset(name, quality)
        rock, sway = WORN[name]
        assert (sc.rock_deg, sc.sway_deg) == (rock, sway)
        turns = np.array(_turns(sc))
        assert np.allclose(turns[0], 0.0)  # the rest pose first
        assert np.abs(turns[:, 0]).max() == pytest.approx(rock) and np.abs(turns[:, 1]).max() == pytest.approx(sway)
        # one axis at a time, evenly spread, symmetric about the rest pose
        assert np.all(np.min(np.abs(turns), axis=1) < 1e-9)
        assert np.allclose(np.sort(turns[:, 0]), -np.sort(turns[:, 0])[::-1])
        n_rock, n_sway = sc.quality.rock_steps
        assert len(turns) == 1 + (n_rock + (n_rock % 2 == 0) - 1) + (n_sway + (n_sway % 2 == 0) - 1)
        weights = [w for _, w in sc.poses()]
        assert np.allclose(weights, 1.0 / len(weights))


@pytest.mark.parametrize("name", ["ring-diffuse", "pendant-diffuse", "brooch-diffuse", "outdoor-still", "display"])
def test_the_still_scenarios_stay_still(name):
    sc = Scenario.preset(name, "standard")
    assert len(sc.poses()) == 1 and sc.motion_view_share == 1.0


@pytest.mark.parametrize("name", sorted(WORN))
def test_each_moving_pose_keeps_its_share_of_the_viewers_and_together_they_see_all(name):
    sc = Scenario.preset(name, "standard")
    assert sc.motion_view_share == MOTION_VIEWS[name]
    settings = sc.settings()
    n = len(sc.views)
    keep = max(1, round(MOTION_VIEWS[name] * n))
    assert len(settings[0].views) == n
    seen = set()
    for k, st in enumerate(settings[1:], start=1):
        assert len(st.views) == keep and st.views.weights.sum() == pytest.approx(1.0)
        world = st.views.directions @ st.pose.T  # back into the world frame (mesh rows = world rows @ pose)
        rows = [int(np.argmin(np.linalg.norm(sc.views.directions - d, axis=1))) for d in world]
        assert np.allclose(sc.views.directions[rows], world, atol=1e-9)
        seen.update(rows)
    assert seen == set(range(n))  # at standard the moving poses alone see every viewer


def test_a_bad_share_of_viewers_is_refused(tmp_path):
    base = Scenario.preset("ring", "draft")
    for bad in (0.0, -0.1, 1.5, float("nan"), True):
        with pytest.raises(ParameterError, match="motion_view_share"):
            Scenario(base.name, base.pose, base.lights, base.views, 25.0, 25.0, "", "draft", bad)
    path = tmp_path / "s.json"
    path.write_text('{"lighting": "room", "viewing": "above", "rock_deg": 20, "motion_view_share": 0.5}')
    sc = Scenario.from_json(path, "draft")
    assert sc.motion_view_share == 0.5 and sc.to_dict()["motion_view_share"] == 0.5 and len(sc.settings()[1].views) == 6


def test_the_office_is_lit_by_downlights_a_window_and_its_reflected_light():
    d, w = downlight_grid()
    assert w.sum() == pytest.approx(1.0) and len(w) == 18
    # the nearest fixture (0.5 x 0.3 spacings off, 2 m up) is the brightest, and the weights fall as cos³
    cos = d[:, 2]
    assert np.allclose(w / w.max(), (cos / cos.max()) ** 3)
    assert w.min() >= DOWNLIGHT_CUTOFF * w.max() - 1e-12
    nearest = np.degrees(np.arccos(cos.max()))
    assert nearest == pytest.approx(math.degrees(math.atan(1.8 * math.hypot(0.5, 0.3) / 2.0)))
    room = labcut.Lights.preset("room", "standard")
    assert room.total_irradiance == pytest.approx(1.0)
    assert room.lamp_weights[:18].sum() == pytest.approx(ROOM_SHARES["downlights"])
    assert room.weights[room.n_lamps:].sum() == pytest.approx(ROOM_SHARES["reflected"])
    assert sum(ROOM_SHARES.values()) == pytest.approx(1.0)
    for name in ("ring", "pendant", "brooch"):
        assert Scenario.preset(name, "draft").lights.name == "room"
