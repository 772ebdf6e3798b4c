"""``labcut.commands.budget`` pinned by hand (issue 37, mutation testing): the ladder's rungs knob
by knob, the correction's geometric running mean and its range, the first call's learnt seconds,
the corrections file (its key, a damaged value), the choice's predictions against
``factor x calibration + first-call seconds`` on given calibrations, the pick at the budget's
exact boundary and its notes word for word. The machine's calibration is replaced by a stand-in
(no timing is measured), so the file runs in about a second.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import pytest

from labcut.errors import LabcutWarning, ParameterError
from labcut.commands import budget as B
from labcut.scene.quality import Quality

#: the module's own corrections_path (each test below replaces it with a file of its own)
CORRECTIONS_PATH = B.corrections_path


@pytest.fixture(autouse=True)
def own_cache(monkeypatch, tmp_path):
    """Each test: its own corrections file, a calibration key "k1", no warm kinds."""
    import labcut.planner

    path = tmp_path / "corrections.json"
    monkeypatch.setattr(B, "corrections_path", lambda: path)
    monkeypatch.setattr(labcut.planner, "sample_timing", lambda: SimpleNamespace(key="k1"))
    monkeypatch.setattr(B, "_WARM", set())
    return path


def stored(path) -> dict:
    return json.loads(path.read_text())


def test_the_corrections_file_is_named_as_documented():
    """docs/architecture.md names it: ``time-budget-corrections.json`` in labcut's user cache."""
    from labcut.fileio import cache_path

    path = CORRECTIONS_PATH()
    assert path.name == "time-budget-corrections.json" and path.parent == cache_path("x").parent


# ---------------------------------------------------------------------- the ladder
KNOBS = ("surface_points", "lamp_samples", "env_samples", "cone_views", "ring_views", "rock_steps", "map_spacing_deg",
         "nlopt_evals", "gradient_starts")


def knobs(q: Quality) -> tuple:
    return tuple(getattr(q, k) for k in KNOBS)


def test_the_ladder_rung_by_rung():
    """Seven rungs. budget-0 and budget-6: the documented values on draft and high. The rungs between
    the presets: the geometric mean of the two neighbours, rounded (direction counts and the poses'
    first count made odd: ``| 1``), the map spacing's to 0.01 degree; every other field the cheaper
    neighbour's. By hand: draft-standard sqrt(3000 x 8000) = 4898.98 -> 4899, sqrt(7 x 13) = 9.54
    -> 10 -> 11, sqrt(32 x 64) = 45.25 -> 45, sqrt(12 x 20) = 15.49 -> 15, sqrt(5 x 9) = 6.71 -> 7,
    sqrt(2 x 4) = 2.83 -> 3, sqrt(12) = 3.46, sqrt(2400) = 48.99 -> 49, sqrt(96) = 9.80 -> 10;
    standard-high 13856.4 -> 13856, sqrt(325) = 18.03 -> 18 -> 19, sqrt(8192) = 90.51 -> 91,
    sqrt(800) = 28.28 -> 28, sqrt(153) = 12.37 -> 12 -> 13, sqrt(24) = 4.90 -> 5, sqrt(4.5) = 2.12,
    sqrt(7200) = 84.85 -> 85, sqrt(240) = 15.49 -> 15."""
    rungs = B.ladder()
    assert [q.name for q in rungs] == ["budget-0", "draft", "budget-2", "standard", "budget-4", "high", "budget-6"]
    d, s, h = (Quality.PRESETS[k] for k in ("draft", "standard", "high"))
    assert rungs[1] is d and rungs[3] is s and rungs[5] is h
    assert knobs(rungs[0]) == (1500, 5, 16, 5, 8, (3, 2), 5.0, 30, 6)
    assert knobs(rungs[2]) == (4899, 11, 45, 11, 15, (7, 3), 3.46, 49, 10)
    assert knobs(rungs[4]) == (13856, 19, 91, 19, 28, (13, 5), 2.12, 85, 15)
    assert knobs(rungs[6]) == (48000, 37, 128, 37, 60, (25, 8), 1.0, 120, 20)
    for rung, base in ((rungs[0], d), (rungs[2], d), (rungs[4], s), (rungs[6], h)):
        rest = {k: v for k, v in rung.to_dict().items() if k not in KNOBS + ("name",)}
        assert rest == {k: v for k, v in base.to_dict().items() if k not in KNOBS + ("name",)}, rung.name


# ---------------------------------------------------------------------- one question, not two
def test_quality_or_budget_word_for_word():
    B.quality_or_budget(True, False)
    B.quality_or_budget(False, True, flags=True)
    B.quality_or_budget(False, False)
    with pytest.raises(ParameterError) as err:
        B.quality_or_budget(True, True)
    assert str(err.value) == "give quality or time_budget, not both (the budget chooses the quality)"
    with pytest.raises(ParameterError) as err:
        B.quality_or_budget(True, True, flags=True)
    assert str(err.value) == "give --quality or --time-budget, not both (the budget chooses the quality)"


# ---------------------------------------------------------------------- kinds and warmth
def test_kinds_and_their_keys():
    assert (B._kind(True), B._kind(False), B._kind("render"), B._kind("compare")) == ("occlusion", "plain", "render", "compare")
    assert B._first_key(True) == "first call occlusion" and B._first_key("render") == "first call render"
    assert B.kind_of("render", True) == "render" and B.kind_of("render", False) == "render"
    assert B.kind_of("samples", 1) is True and B.kind_of("auto", 0) is False


def test_warmth_is_per_kind():
    assert not B.is_warm(True)
    B.mark_warm(True)
    assert B.is_warm(True) and B.is_warm("occlusion") and not B.is_warm(False)
    B.mark_warm("render")
    assert B.is_warm("render") and not B.is_warm(False)


# ---------------------------------------------------------------------- the correction
def test_the_correction_is_a_geometric_running_mean_of_half_weight(own_cache):
    """``new = exp(0.5 ln old + 0.5 ln(actual / predicted))``: from 1, a run 4x slower gives 2, then
    a run at 0.5x gives sqrt(2 x 0.5) = 1; each kind its own; stored under the calibration's key."""
    assert (B.ADAPT, B.CORRECTION_RANGE) == (0.5, (0.2, 5.0))
    assert B.correction(False) == 1.0
    assert B.record(False, 2.0, 8.0) == pytest.approx(2.0, rel=1e-12)
    assert B.correction(False) == pytest.approx(2.0, rel=1e-12) and B.correction(True) == 1.0
    assert B.record(False, 2.0, 1.0) == pytest.approx(1.0, rel=1e-12)
    assert B.record(True, 1.0, 9.0) == pytest.approx(3.0, rel=1e-12)
    assert B.record("compare", 1.0, 0.25) == pytest.approx(0.5, rel=1e-12)
    data = stored(own_cache)
    assert data == {"key": "k1", "plain": pytest.approx(1.0), "occlusion": pytest.approx(3.0), "compare": pytest.approx(0.5),
                    "largest plain": 2.0, "largest compare": 1.0}  # the runs that beat their predictions


def test_a_factor_below_1_holds_within_twice_the_largest_prediction_a_run_beat(own_cache):
    """Runs faster than predicted teach a factor below 1; it holds for predictions up to 2x the
    largest one a run beat (``REACH``), beyond it the calibration's own prediction (factor 1). Above
    1 a factor holds at every size. A larger run that beats its prediction extends the reach, one
    that does not leaves it; ``forget`` drops it."""
    assert B.REACH == 2.0
    assert B.factor_at(B.learnt(), False, 1.0) == 1.0  # nothing learnt
    B.record(False, 1.0, 0.25)  # sqrt(0.25): 0.5, learnt at 1 s
    B.record(False, 0.5, 0.25)  # sqrt(0.5 x 0.5): 0.5, the largest still 1 s
    kept = B.learnt()
    assert kept["largest plain"] == 1.0 and B.correction(False) == pytest.approx(0.5)
    assert B.factor_at(kept, False, 0.1) == pytest.approx(0.5)
    assert B.factor_at(kept, False, 2.0) == pytest.approx(0.5)  # the reach inclusive
    assert B.factor_at(kept, False, math.nextafter(2.0, 3.0)) == 1.0
    assert B.factor_at(kept, False, 20.0) == 1.0
    assert B.factor_at(kept, True, 0.1) == 1.0  # another kind learnt nothing
    B.record(False, 16.0, 32.0)  # a larger run, slower than predicted: the reach stays (factor 1)
    assert B.learnt()["largest plain"] == 1.0 and B.correction(False) == pytest.approx(1.0)
    B.record(False, 16.0, 16.0)  # exactly as predicted: not beaten, the reach stays
    assert B.learnt()["largest plain"] == 1.0
    B.record(False, 1.0, 0.25)  # 0.5 again
    B.record(False, 4.0, 3.0)  # a run of 4 s that beat its prediction: the reach now 8 s
    f = B.correction(False)
    assert f < 1.0 and B.factor_at(B.learnt(), False, 8.0) == pytest.approx(f) and B.factor_at(B.learnt(), False, 8.1) == 1.0
    B.record(True, 1.0, 9.0)  # 3: slower than calibrated, at every size
    assert B.factor_at(B.learnt(), True, 1000.0) == pytest.approx(3.0)
    own_cache.write_text(json.dumps({"key": "k1", "plain": 0.5}))  # a factor with no size kept: not held
    assert B.factor_at(B.learnt(), False, 0.1) == 1.0
    B.record(False, 1.0, 0.25)
    B.forget(False)
    assert "largest plain" not in stored(own_cache)


@pytest.mark.parametrize("actual, expected", [(100.0, 5.0), (0.01, 0.2), (25.0, 5.0), (0.04, 0.2), (24.0, math.sqrt(24.0))])
def test_the_correction_stays_within_0_2_and_5(actual, expected):
    """From 1 with predicted 1: ``sqrt(actual)`` clipped to [0.2, 5] (25 -> 5 exactly; 0.04 -> 0.2)."""
    assert B.record(False, 1.0, actual) == pytest.approx(expected, rel=1e-12)
    assert B.correction(False) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("predicted, actual", [(0.0, 1.0), (1.0, 0.0), (-1.0, 1.0), (1.0, -2.0), (math.nan, 1.0),
                                               (1.0, math.nan), (math.inf, 1.0), (1.0, math.inf)])
def test_nonsense_runs_are_not_learnt(own_cache, predicted, actual):
    """A prediction or a time that is not a positive finite number: the correction as it was, the
    file not written."""
    assert B.record(False, predicted, actual) == 1.0  # nothing learnt yet: no correction
    assert not own_cache.exists()
    B.record(False, 1.0, 4.0)  # 2
    before = own_cache.read_text()
    assert B.record(False, predicted, actual) == pytest.approx(2.0)
    assert B.record(False, predicted, actual, first_call=True) == pytest.approx(2.0)
    assert own_cache.read_text() == before


def test_a_first_call_learns_its_extra_seconds_not_the_factor(own_cache):
    """A first call: what it took beyond the corrected prediction (``actual - factor x predicted``,
    at least 0) is learnt as the kind's first-call seconds (the first one as it is, then the same
    half-weight running mean, within [0, 60]); the factor stays and is returned."""
    B.record(True, 1.0, 4.0)  # factor 2
    assert B.record(True, 1.0, 5.0, first_call=True) == pytest.approx(2.0)  # 5 - 2 x 1 = 3
    assert B.first_call_seconds(True) == pytest.approx(3.0) and B.correction(True) == pytest.approx(2.0)
    B.record(True, 1.0, 10.0, first_call=True)  # extra 8: 0.5 x 3 + 0.5 x 8
    assert B.first_call_seconds(True) == pytest.approx(5.5)
    B.record(True, 2.0, 1.0, first_call=True)  # faster than predicted: extra 0
    assert B.first_call_seconds(True) == pytest.approx(2.75)
    B.record(True, 1.0, 1000.0, first_call=True)  # 0.5 x 2.75 + 0.5 x 998: capped at 60
    assert B.first_call_seconds(True) == 60.0
    assert B.first_call_seconds(False) == 0.0 and B.FIRST_CALL_RANGE == (0.0, 60.0)
    assert stored(own_cache)["first call occlusion"] == 60.0
    B.record(False, 1.0, 0.5, first_call=True)  # the first one, 0, kept as it is
    assert stored(own_cache)["first call plain"] == 0.0 and "plain" not in stored(own_cache)


def test_a_first_call_beyond_the_reach_learns_beyond_the_uncorrected_prediction(own_cache):
    """Factor 0.5 held up to 0.8 s: a first call predicted 2.4 s (beyond the reach, so predicted at
    2.4 s) that took 2.9 s cost 0.5 s beyond its prediction, not 2.9 - 0.5 x 2.4 = 1.7 s; within the
    reach, 0.6 s predicted (0.3 s corrected) and 1.3 s taken: 1 s (0.5 x 0.5 + 0.5 x 1 = 0.75)."""
    own_cache.write_text(json.dumps({"key": "k1", "plain": 0.5, "largest plain": 0.4}))
    assert B.record(False, 2.4, 2.9, first_call=True) == 0.5
    assert B.first_call_seconds(False) == pytest.approx(0.5)
    B.record(False, 0.6, 1.3, first_call=True)
    assert B.first_call_seconds(False) == pytest.approx(0.75)


def test_a_first_call_learns_the_first_value_whole(own_cache):
    """The first learnt value is the extra itself, not half of it (no earlier value to average)."""
    B.record("render", 2.0, 7.0, first_call=True)  # factor 1: 7 - 2
    assert B.first_call_seconds("render") == 5.0


def test_forget_drops_a_kind_and_its_first_call_seconds(own_cache):
    B.record(True, 1.0, 4.0)
    B.record(True, 1.0, 5.0, first_call=True)
    B.record(False, 1.0, 9.0)
    B.forget(True)
    assert stored(own_cache) == {"key": "k1", "plain": pytest.approx(3.0)}
    assert B.correction(True) == 1.0 and B.first_call_seconds(True) == 0.0
    mtime = own_cache.stat().st_mtime_ns
    own_cache.write_text(json.dumps({"key": "k1", "plain": 3.0}))  # nothing of True left: not written again
    before = own_cache.read_text()
    B.forget(True)
    assert own_cache.read_text() == before and mtime is not None


def test_forget_writes_when_only_the_first_call_seconds_were_kept(own_cache):
    B.record(True, 1.0, 5.0, first_call=True)
    B.forget(True)
    assert stored(own_cache) == {"key": "k1"}


def test_the_corrections_belong_to_one_calibration(own_cache, monkeypatch):
    """Kept under the calibration's key: another key (measured again) starts from no correction; a
    value that is not a finite number is a damaged file: one warning, and no correction."""
    import labcut.fileio
    import labcut.planner

    own_cache.write_text(json.dumps({"key": "k1", "plain": 2.0, "first call plain": 1.5}))
    assert B.correction(False) == 2.0 and B.first_call_seconds(False) == 1.5
    monkeypatch.setattr(labcut.planner, "sample_timing", lambda: SimpleNamespace(key="k2"))
    assert B.correction(False) == 1.0 and B.first_call_seconds(False) == 0.0
    assert B.record(False, 1.0, 4.0) == pytest.approx(2.0)
    assert stored(own_cache) == {"key": "k2", "plain": pytest.approx(2.0)}
    monkeypatch.setattr(labcut.fileio, "_CACHE_WARNED", set())
    for bad in ("2", None, math.nan, math.inf):
        labcut.fileio._CACHE_WARNED.clear()
        own_cache.write_text(json.dumps({"key": "k2", "plain": 2.0, "occlusion": bad}))
        with pytest.warns(LabcutWarning) as caught:
            assert B.correction(False) == 1.0
        assert [str(w.message) for w in caught] == [
            f"labcut's cache file {own_cache} is damaged (a correction is not a number): ignored, and what it held is "
            "computed again"]
    with pytest.warns(LabcutWarning):  # the damaged file starts again from the calibration's key alone
        labcut.fileio._CACHE_WARNED.clear()
        assert B.record(False, 1.0, 4.0) == pytest.approx(2.0)
    assert stored(own_cache) == {"key": "k2", "plain": pytest.approx(2.0)}
    own_cache.write_text(json.dumps({"key": "k2", "plain": 3, "occlusion": 0.5}))  # an int is a number
    assert B.correction(False) == 3.0 and B.correction(True) == 0.5


# ---------------------------------------------------------------------- BudgetChoice
def test_budget_choice_by_hand():
    q = Quality.PRESETS["draft"]
    c = B.BudgetChoice(q, 5.0, 10.0, (("draft", 5.0), ("standard", 12.0)), correction=2.0, occlusion=True,
                       first_call_seconds=1.0, cold=True, pilot_seconds=0.5)
    assert c.uncorrected(5.0) == 2.0  # (5 - 1) / 2
    assert c.kind is True and B.BudgetChoice(q, 1.0, 1.0, ()).kind is False
    assert B.BudgetChoice(q, 1.0, 1.0, (), estimator="render", occlusion=True).kind == "render"
    assert c.to_dict() == {"quality": "draft", "predicted_seconds": 5.0, "budget_seconds": 10.0,
                           "rungs": [{"quality": "draft", "predicted_seconds": 5.0}, {"quality": "standard", "predicted_seconds": 12.0}],
                           "note": None, "correction": 2.0, "occlusion": True, "estimator": "samples", "pilot_seconds": 0.5,
                           "cold": True, "first_call_seconds": 1.0}
    d = B.BudgetChoice(q, 1.0, 1.0, ())
    assert (d.note, d.correction, d.occlusion, d.estimator, d.pilot_seconds, d.cold, d.first_call_seconds) == \
        (None, 1.0, False, "samples", 0.0, False, 0.0)


# ---------------------------------------------------------------------- pick
def rungs_of(*seconds):
    names = ["budget-0", "draft", "budget-2", "standard"]
    return [(Quality.PRESETS["draft"].replace(name=n), t) for n, t in zip(names, seconds)]


def test_pick_takes_the_last_rung_that_fits_including_the_boundary():
    """Rungs predicted 1, 2, 3, 4 s: a budget of exactly 3 s takes the third (``<=``); 2.999 the
    second; 10 the last. Pilot seconds come off the budget: 3.5 s with 0.5 spent takes the third."""
    rungs = rungs_of(1.0, 2.0, 3.0, 4.0)
    c = B.pick(rungs, 3.0, "x")
    assert c.quality.name == "budget-2" and c.predicted_seconds == 3.0 and c.budget_seconds == 3.0 and c.note is None
    assert c.rungs == (("budget-0", 1.0), ("draft", 2.0), ("budget-2", 3.0), ("standard", 4.0))
    assert B.pick(rungs, 2.999, "x").quality.name == "draft"
    assert B.pick(rungs, 10.0, "x").quality.name == "standard"
    c = B.pick(rungs, 3.5, "x", pilot_seconds=0.5, correction=2.0)
    assert c.quality.name == "budget-2" and c.pilot_seconds == 0.5 and c.correction == 2.0
    assert B.pick(rungs, 3.49, "x", pilot_seconds=0.5).quality.name == "draft"


def test_pick_below_the_cheapest_says_so_word_for_word():
    rungs = rungs_of(1.234, 2.0)
    c = B.pick(rungs, 0.5, "the cheapest setting's", correction=1.5)
    assert c.quality.name == "budget-0" and c.predicted_seconds == 1.234 and c.correction == 1.5
    assert c.budget_seconds == 0.5 and c.rungs == (("budget-0", 1.234), ("draft", 2.0)) and c.pilot_seconds == 0.0
    assert c.note == ("a time budget of 0.5 s is below the cheapest setting's predicted 1.2 s on this machine: "
                      "running that (budget-0) anyway")
    c = B.pick(rungs, 0.5, "the cheapest setting's", " (3 renders)")
    assert c.note == ("a time budget of 0.5 s is below the cheapest setting's predicted 1.2 s on this machine (3 renders): "
                      "running that (budget-0) anyway")
    c = B.pick(rungs, 1.5, "the cheapest setting's", pilot_seconds=0.75)
    assert c.quality.name == "budget-0" and c.pilot_seconds == 0.75
    assert c.note == ("the stone's first plan took 0.75 s of the 1.5 s time budget on its pilot renders (cached for the "
                      "next call), which leaves less than the cheapest setting's predicted 1.2 s on this machine: "
                      "running that (budget-0) anyway")
    # exactly the cheapest's prediction left: it fits, no note
    assert B.pick(rungs, 1.984, "x", pilot_seconds=0.75).note is None


# ---------------------------------------------------------------------- choose
@pytest.fixture
def calibration(monkeypatch):
    """A calibration of known speed: 1e-4 s a surface point, twice that with occlusion; the
    lights of the first setting and the points each rung was predicted for recorded."""
    import labcut.planner

    seen = []

    def predict(settings, points, occlusion):
        seen.append((len(settings[0].lights), points, occlusion))
        return 1e-4 * points * (2.0 if occlusion else 1.0)

    monkeypatch.setattr(labcut.planner, "predict_sample_seconds", predict)
    return seen


POINTS = [1500, 3000, 4899, 8000, 13856, 24000, 48000]


def test_choose_predicts_each_rung_from_the_calibration(calibration):
    """Every rung predicted as ``factor x calibration(rung) + first-call seconds``; with no
    correction yet 1e-4 s a point: 0.15, 0.3, 0.4899, 0.8, 1.3856, 2.4, 4.8 s; a budget of 0.8 s
    takes standard (exactly at its prediction)."""
    c = B.choose(0.8, ("bench", None, None), False)
    assert [p for _, p, _ in calibration] == POINTS and {o for *_, o in calibration} == {False}
    assert [n for n, _ in c.rungs] == [q.name for q in B.ladder()]
    assert [t for _, t in c.rungs] == pytest.approx([1e-4 * p for p in POINTS], rel=1e-12)
    assert c.quality.name == "standard" and c.predicted_seconds == pytest.approx(0.8)
    assert (c.correction, c.occlusion, c.estimator, c.cold, c.first_call_seconds, c.pilot_seconds) == (1.0, False, "samples", True, 0.0, 0.0)
    assert c.budget_seconds == 0.8 and c.note is None


def test_choose_applies_the_learnt_factor_and_first_call_seconds(calibration, own_cache):
    """Learnt: factor 2 and 0.5 first-call seconds for occlusion. A cold call predicts
    ``2 x 2e-4 x points + 0.5``: 1.1, 1.7, 2.4596, 3.7 ...; warm, without the 0.5: 0.6, 1.2, 1.9596,
    3.2 ... A budget of 2 s takes draft cold and budget-2 warm."""
    own_cache.write_text(json.dumps({"key": "k1", "occlusion": 2.0, "first call occlusion": 0.5, "plain": 3.0}))
    c = B.choose(2.0, ("bench", None, None), True)
    assert [t for _, t in c.rungs] == pytest.approx([4e-4 * p + 0.5 for p in POINTS], rel=1e-12)
    assert c.quality.name == "draft" and c.cold and c.first_call_seconds == 0.5 and c.correction == 2.0 and c.occlusion
    B.mark_warm(True)
    c = B.choose(2.0, ("bench", None, None), True)
    assert [t for _, t in c.rungs] == pytest.approx([4e-4 * p for p in POINTS], rel=1e-12)
    assert c.quality.name == "budget-2" and not c.cold and c.first_call_seconds == 0.0
    c = B.choose(1.0, ("bench", None, None), False)  # the plain kind: factor 3, cold, no first-call seconds learnt
    assert [t for _, t in c.rungs] == pytest.approx([3e-4 * p for p in POINTS], rel=1e-12) and c.cold


def test_choose_holds_a_fast_machines_factor_only_within_its_reach(calibration, own_cache):
    """Factor 0.5 learnt from runs of up to 0.4 s: the rungs predicted at most 0.8 s (0.15, 0.3,
    0.4899, 0.8 s) are halved, the rest stand (1.3856, 2.4, 4.8 s). A budget of 1 s takes standard
    at its halved 0.4 s, where a factor held at every size would have taken budget-4 at 0.69 s; the
    choice's ``correction`` is the factor of the rung it took, so what it records is uncorrected."""
    own_cache.write_text(json.dumps({"key": "k1", "plain": 0.5, "largest plain": 0.4}))
    B.mark_warm(False)
    c = B.choose(1.0, ("bench", None, None), False)
    assert [t for _, t in c.rungs] == pytest.approx([0.5e-4 * p for p in POINTS[:4]] + [1e-4 * p for p in POINTS[4:]],
                                                    rel=1e-12)
    assert c.quality.name == "standard" and c.correction == 0.5 and c.uncorrected(c.predicted_seconds) == pytest.approx(0.8)
    c = B.choose(1.5, ("bench", None, None), False)
    assert c.quality.name == "budget-4" and c.correction == 1.0 and c.predicted_seconds == pytest.approx(1.3856)


def test_choose_refuses_a_bad_budget(calibration):
    for bad in (0, -1.0, math.nan, math.inf, "soon", True, 86_401):
        with pytest.raises(ParameterError, match="time budget"):
            B.choose(bad, ("bench", None, None), False)
    assert calibration == []


def test_choose_below_the_cheapest_names_the_cheapest_setting(calibration):
    c = B.choose(0.1, ("bench", None, None), False)
    assert c.quality.name == "budget-0"
    assert c.note == ("a time budget of 0.1 s is below the cheapest setting's predicted 0.15 s on this machine: "
                      "running that (budget-0) anyway")


def test_choose_with_a_plan_of_the_sample_estimator(calibration, monkeypatch):
    """A plan of the sample estimator: its pilot seconds come off the budget; one that draws the
    environment map densely predicts each rung's scene with as many map samples as
    ``env_samples_enough`` gives for the rung's map samples and poses (here a stand-in: 77), every
    rung; a plan that does not keeps the rung's own lights."""
    import labcut.planner

    asked = []
    plan = SimpleNamespace(estimator="samples", pilot_seconds=0.3, env_samples=False)
    c = B.choose(1.1, ("bench", None, None), False, plan=plan)
    assert c.quality.name == "standard" and c.pilot_seconds == 0.3  # 0.8 <= 1.1 - 0.3
    c = B.choose(1.09, ("bench", None, None), False, plan=plan)
    assert c.quality.name == "budget-2"
    # bench's lamp, sampled at each rung's lamp_samples: the scene is resolved at each rung's quality
    assert [lights for lights, _, _ in calibration] == [5, 7, 11, 13, 19, 25, 37] * 2
    monkeypatch.setattr(labcut.planner, "env_samples_enough", lambda n_env, poses: asked.append((n_env, poses)) or 77)
    plain = len(calibration)
    B.choose(10.0, ("outdoor", None, None), False, plan=SimpleNamespace(estimator="samples", pilot_seconds=None, env_samples=True))
    # outdoor: one lamp (the sun) and the sky's 32 samples at draft; 7 poses
    assert asked[1] == (32, 7) and len(asked) == 7
    assert [lights for lights, _, _ in calibration[plain:]] == [1 + 77] * 7
    assert [points for _, points, _ in calibration[plain:]] == POINTS


def test_choose_with_a_plan_of_the_volume_estimator(calibration, monkeypatch):
    """A plan of the volume estimator: each rung is the sample estimator's prediction plus its
    paths at ``VOLUME_PATH_SECONDS`` each (a stand-in: 1000 paths a surface point, 2.5 ms a
    point), as the planner predicts that estimator; the choice names the estimator."""
    import labcut.orientation.volume
    import labcut.planner

    assert labcut.planner.VOLUME_PATH_SECONDS == 2.5e-6
    monkeypatch.setattr(labcut.orientation.volume, "volume_paths", lambda settings, points: 1000.0 * points)
    plan = SimpleNamespace(estimator="volume", pilot_seconds=None, env_samples=False)
    c = B.choose(5.0, ("bench", None, None), True, plan=plan)
    assert [t for _, t in c.rungs] == pytest.approx([2e-4 * p + 2.5e-3 * p for p in POINTS], rel=1e-12)
    assert c.quality.name == "budget-0" and c.note is None  # 2.7e-3 x 1500 = 4.05 s fits; draft's 8.1 s not
    assert c.estimator == "volume" and c.kind is True  # learnt as the stones with occlusion
    c = B.choose(5.0, ("bench", None, None), True, plan=SimpleNamespace(estimator="samples", pilot_seconds=None,
                                                                        env_samples=False))
    assert [t for _, t in c.rungs] == pytest.approx([2e-4 * p for p in POINTS], rel=1e-12) and c.estimator == "samples"


def test_choose_with_the_render_estimator(monkeypatch, own_cache):
    """The render estimator: the three presets only, each predicted as the planner predicts that
    estimator (its ``render`` seconds, for the plan's effects), times the ``render`` kind's factor."""
    import labcut.planner

    own_cache.write_text(json.dumps({"key": "k1", "render": 1.5, "occlusion": 9.0}))
    calls = []

    def seconds(scene, command, occlusion, inter, convex, zoning):
        calls.append((command, occlusion, inter, convex, zoning))
        return {"render": {"draft": 1.0, "standard": 2.0, "high": 4.0}[scene.quality.name], "samples": 99.0}

    monkeypatch.setattr(labcut.planner, "estimator_seconds", seconds)
    plan = SimpleNamespace(estimator="render", pilot_seconds=0.0, convex="convex?", on=lambda k: f"{k} on?")
    c = B.choose(3.0, ("bench", None, None), True, plan=plan)
    assert c.rungs == (("draft", 1.5), ("standard", 3.0), ("high", 6.0))
    assert c.quality.name == "standard" and c.estimator == "render" and c.correction == 1.5
    assert calls == [("recommend", "occlusion on?", "inter_reflection on?", "convex?", "zoning on?")] * 3
