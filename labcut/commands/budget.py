"""``time_budget=``: the most accurate quality predicted to fit a time budget.

A ladder of :class:`~labcut.Quality` settings, cheapest first (:func:`ladder`: below ``draft``,
``draft``, between the presets, ``standard``, ``high`` and beyond it), each more accurate than the
one before in every knob the accuracy study (``docs/accuracy.md``) found to matter: surface
samples, directions per lamp and viewing cone, rocking poses, map spacing and optimiser budget.
The time of a recommendation at each rung is predicted from this machine's calibration of the
sample estimator (:func:`labcut.planner.predict_sample_seconds`: measured once per
machine, labcut and numpy version, and kept in the user cache) for the scene's own poses, lights
and viewers, with occlusion where the plan has it; :func:`choose` takes the last rung predicted
to fit.

The calibration adapts: after each budgeted recommendation the ratio of its actual to its
predicted seconds updates a correction factor (a geometric running mean, one for stones with
occlusion and one without, kept in the user cache beside the calibration and reset when it is
measured again), so a machine that runs slower or faster than its calibration, or meshes whose
shadow rays cost more than the calibration's, are predicted better the next time. A factor below 1
(runs faster than calibrated) holds only for predictions up to :data:`REACH` times the largest run
that beat its prediction: what a machine's overheads make of small problems says little of a
problem several times larger, and there an overrun is what a budget must avoid, so beyond that
reach the calibration's own prediction stands until a run of that size beats it. A factor above 1
holds at every size.

The calibration times warm recommendations; the first one of its kind in a process (every CLI
call) also pays for what a warm one finds done: modules imported on first use, compiled kernels
loaded from Dr.Jit's cache, the first Mitsuba variant. That cost is a few tenths of a second
whatever the rung, so it is learnt apart, as seconds added to every rung's prediction
(:func:`first_call_seconds`, a running mean over budgeted first calls), and such a call does not
feed the factor: a machine's CLI calls then predict its CLI calls and its warm calls its warm ones.

A budget below the cheapest rung's prediction is not refused: the cheapest rung runs, and
:attr:`BudgetChoice.note` says so in one line (the CLI prints it as a ``note:``). A budget that is
not a positive finite number of seconds is a :class:`~labcut.errors.ParameterError`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from ..errors import ParameterError
from ..scene.quality import QUALITIES, Quality
from ..validation import check_budget


def ladder() -> list[Quality]:
    """The budget's rungs, cheapest first; each is named (``budget-0`` ... or a preset's name)."""
    d, s, h = (Quality.PRESETS[k] for k in QUALITIES)

    def mid(a: Quality, b: Quality, name: str) -> Quality:
        geo = lambda x, y: int(round(math.sqrt(x * y)))  # noqa: E731
        odd = lambda x, y: geo(x, y) | 1  # noqa: E731  (odd direction counts keep the centre direction)
        return a.replace(name=name, surface_points=geo(a.surface_points, b.surface_points),
                         lamp_samples=odd(a.lamp_samples, b.lamp_samples), env_samples=geo(a.env_samples, b.env_samples),
                         cone_views=odd(a.cone_views, b.cone_views), ring_views=geo(a.ring_views, b.ring_views),
                         rock_steps=(odd(a.rock_steps[0], b.rock_steps[0]), geo(a.rock_steps[1], b.rock_steps[1])),
                         map_spacing_deg=round(math.sqrt(a.map_spacing_deg * b.map_spacing_deg), 2),
                         nlopt_evals=geo(a.nlopt_evals, b.nlopt_evals), gradient_starts=geo(a.gradient_starts, b.gradient_starts))

    below = d.replace(name="budget-0", surface_points=1500, lamp_samples=5, env_samples=16, cone_views=5, ring_views=8,
                      rock_steps=(3, 2), map_spacing_deg=5.0, nlopt_evals=30, gradient_starts=6)
    beyond = h.replace(name="budget-6", surface_points=48000, lamp_samples=37, cone_views=37, ring_views=60,
                       rock_steps=(25, 8), map_spacing_deg=1.0)
    return [below, d, mid(d, s, "budget-2"), s, mid(s, h, "budget-4"), h, beyond]


@dataclass(frozen=True)
class BudgetChoice:
    """What :func:`choose` picked: the quality, its predicted seconds, the budget (seconds), each
    rung's prediction, and a one-line note when even the cheapest rung is predicted to overrun."""

    quality: Quality
    predicted_seconds: float
    budget_seconds: float
    rungs: tuple[tuple[str, float], ...]
    note: str | None = None
    #: the adaptive correction the chosen rung's prediction includes (:func:`factor_at`), and whether
    #: occlusion was counted
    correction: float = 1.0
    occlusion: bool = False
    #: the estimator the prediction is of (``samples``, ``volume`` or ``render``): the correction's kind follows it
    estimator: str = "samples"
    #: seconds of the budget a stone's first plan spent on its pilot renders before choosing (which
    #: the calibration does not include): the rungs had the rest
    pilot_seconds: float = 0.0
    #: whether this process had not yet run a recommendation of this kind (:func:`is_warm`), and the
    #: learnt seconds such a first call costs beyond a warm one, included in every rung's prediction
    cold: bool = False
    first_call_seconds: float = 0.0

    def uncorrected(self, seconds: float) -> float:
        """A rung's prediction ``seconds`` as the calibration alone made it (without the correction
        and the first call's seconds): what :func:`record` is fed."""
        return (seconds - self.first_call_seconds) / self.correction

    @property
    def kind(self) -> bool | str:
        """The correction this choice learns into (:func:`record`)."""
        return "render" if self.estimator == "render" else self.occlusion

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["quality"] = self.quality.name
        out["rungs"] = [{"quality": n, "predicted_seconds": t} for n, t in self.rungs]
        return out


def quality_or_budget(quality_given: bool, budget_given: bool, *, flags: bool = False) -> None:
    """Refuse a question that gives both a quality and a time budget (the budget chooses the
    quality). ``flags``: name them as the command line does (``--quality``, ``--time-budget``)."""
    if quality_given and budget_given:
        q, b = ("--quality", "--time-budget") if flags else ("quality", "time_budget")
        raise ParameterError(f"give {q} or {b}, not both (the budget chooses the quality)")


#: weight of the newest run in the correction's geometric running mean; the correction's range
ADAPT = 0.5
CORRECTION_RANGE = (0.2, 5.0)
#: a factor below 1 holds for predictions up to this many times the largest one a run beat
REACH = 2.0


def corrections_path() -> Any:
    """Where the corrections are kept (the user cache)."""
    from ..fileio import cache_path

    return cache_path("time-budget-corrections.json")


def _corrections() -> tuple[Any, dict[str, Any]]:
    from ..fileio import cache_problem, read_cache
    from ..planner import sample_timing

    path = corrections_path()
    data = read_cache(path) or {}
    key = sample_timing().key
    if data.get("key") != key:
        data = {"key": key}
    elif not all(isinstance(v, int | float) and math.isfinite(v) for k, v in data.items() if k != "key"):
        cache_problem(path, "a correction is not a number")
        data = {"key": key}
    return path, data


def learnt() -> dict[str, Any]:
    """This machine's learnt corrections as kept (the factors, their reach and the first-call
    seconds by kind), for :func:`factor_at`: one read of the file for a whole ladder."""
    return _corrections()[1]


def _kind(kind: bool | str) -> str:
    """A correction's key: a recommendation's ``occlusion`` / ``plain`` (``kind`` a bool: whether
    occlusion was counted), or another budgeted command's own name (e.g. ``"compare"``)."""
    if isinstance(kind, str):
        return kind
    return "occlusion" if kind else "plain"


def correction(kind: bool | str) -> float:
    """The factor this machine's recent budgeted runs of ``kind`` (:func:`_kind`) put on the
    calibration's prediction."""
    return float(learnt().get(_kind(kind), 1.0))


#: the kinds (:func:`_kind`) whose recommendation has run in this process (:func:`mark_warm`)
_WARM: set[str] = set()
#: the range of the learnt first-call seconds
FIRST_CALL_RANGE = (0.0, 60.0)


def _largest_key(kind: bool | str) -> str:
    """The corrections file's key of the largest uncorrected prediction of ``kind`` that a run
    beat (took less time than)."""
    return f"largest {_kind(kind)}"


def factor_at(kept: dict[str, Any], kind: bool | str, seconds: float) -> float:
    """The factor the corrections ``kept`` (:func:`learnt`) put on a prediction of
    ``seconds`` (uncorrected) of ``kind``: the learnt factor, except that one below 1 holds only up
    to :data:`REACH` times the largest prediction a run beat (none recorded: it does not hold);
    beyond, 1 (module docstring)."""
    factor = float(kept.get(_kind(kind), 1.0))
    if factor >= 1.0:
        return factor
    largest = kept.get(_largest_key(kind))
    return factor if largest is not None and seconds <= REACH * float(largest) else 1.0


def _first_key(kind: bool | str) -> str:
    """The corrections file's key of ``kind``'s learnt first-call seconds."""
    return f"first call {_kind(kind)}"


def kind_of(estimator: str, occlusion: bool) -> bool | str:
    """The kind a recommendation is timed and calibrated as: ``"render"`` for the render estimator,
    else whether its flash problem casts occlusion rays."""
    return "render" if estimator == "render" else bool(occlusion)


def mark_warm(kind: bool | str) -> None:
    """Note that a recommendation of ``kind`` ran in this process: the next is predicted warm."""
    _WARM.add(_kind(kind))


def is_warm(kind: bool | str) -> bool:
    """Whether a recommendation of ``kind`` has run in this process (:func:`mark_warm`)."""
    return _kind(kind) in _WARM


def first_call_seconds(kind: bool | str) -> float:
    """The seconds the first recommendation of ``kind`` in a process costs on this machine beyond
    a warm one's prediction, learnt from budgeted first calls (0 before any)."""
    _, data = _corrections()
    return float(data.get(_first_key(kind), 0.0))


def forget(kind: bool | str) -> None:
    """Drop the learnt correction of ``kind`` (the next prediction is the calibration's alone)."""
    from ..fileio import write_cache

    path, data = _corrections()
    dropped = [data.pop(k, None) for k in (_kind(kind), _first_key(kind), _largest_key(kind))]
    if any(v is not None for v in dropped):
        write_cache(path, data)


def record(kind: bool | str, predicted_seconds: float, actual_seconds: float, *, first_call: bool = False) -> float:
    """Fold one run of ``kind`` (predicted seconds before correction, actual seconds) into its
    correction; returns it. ``first_call``: the first of its kind in its process (the choice's
    ``cold``): what it took beyond the corrected prediction feeds :func:`first_call_seconds`
    instead, the factor is left as it is. A run under a profiler or tracer
    (:func:`labcut.fileio.instrumented`) times the instrumentation: nothing is learnt."""
    from ..fileio import instrumented, write_cache

    path, data = _corrections()
    name = _kind(kind)
    sound = predicted_seconds > 0 and actual_seconds > 0 and math.isfinite(predicted_seconds) and math.isfinite(actual_seconds)
    if not sound or instrumented():  # nonsense, or a run that timed a profiler or tracer: nothing learnt
        return float(data.get(name, 1.0))
    old = float(data.get(name, 1.0))
    if first_call:
        key = _first_key(kind)  # beyond the prediction as corrected for its size (:func:`factor_at`)
        extra = max(actual_seconds - factor_at(data, kind, predicted_seconds) * predicted_seconds, 0.0)
        seen = data.get(key)
        value = extra if seen is None else (1.0 - ADAPT) * float(seen) + ADAPT * extra
        data[key] = float(min(max(value, FIRST_CALL_RANGE[0]), FIRST_CALL_RANGE[1]))
        write_cache(path, data)
        return old
    new = math.exp((1.0 - ADAPT) * math.log(old) + ADAPT * math.log(actual_seconds / predicted_seconds))
    data[name] = float(min(max(new, CORRECTION_RANGE[0]), CORRECTION_RANGE[1]))
    if actual_seconds < predicted_seconds:  # a run that beat its prediction: a factor below 1 holds this far
        data[_largest_key(kind)] = float(max(float(data.get(_largest_key(kind), 0.0)), predicted_seconds))
    write_cache(path, data)
    return data[name]


def choose(budget: Any, scene_spec: tuple[Any, Any, Any], occlusion: bool, *, plan: Any = None) -> BudgetChoice:
    """The most accurate rung of :func:`ladder` predicted to fit ``budget`` seconds for the scene
    ``scene_spec`` (``(scenario, lighting, viewing)`` as asked), occlusion as planned.

    ``plan``: the stone's effect plan (:func:`labcut.planner.plan_effects`). When it picks the
    render estimator, the rungs are the three presets (the render estimator's own settings go by
    them) and each is predicted as the planner predicts that estimator
    (:func:`labcut.planner.estimator_seconds`: the sample answer it starts from, then the renders);
    the correction is then the ``render`` kind's. Otherwise the sample estimator's calibration, and
    for a plan of the ``volume`` estimator its paths on top (:func:`labcut.planner.volume_path_seconds`,
    as the planner predicts that estimator).

    The pilot renders ``plan`` made (``plan.pilot_seconds``: a stone not planned before; the
    calibration does not include them) are spent: the rungs must fit in what is left (:func:`pick`).
    They sample the scene at :data:`labcut.planner.PILOT_QUALITY` whatever the plan's quality, so
    the chosen rung's plan finds them cached."""
    from ..planner import env_samples_enough, estimator_seconds, predict_sample_seconds, volume_path_seconds
    from ..scene import resolve_scene

    seconds = check_budget(budget)
    pilots = float(getattr(plan, "pilot_seconds", 0.0) or 0.0)
    renders = plan is not None and plan.estimator == "render"
    volume = plan is not None and plan.estimator == "volume"
    kind = "render" if renders else occlusion
    kept = learnt()  # one read of the corrections file: the factors and the first-call seconds
    cold = not is_warm(kind)
    extra = float(kept.get(_first_key(kind), 0.0)) if cold else 0.0
    rungs: list[tuple[Quality, float]] = []
    for q in ladder():
        if renders and q.name not in QUALITIES:
            continue
        scene = resolve_scene(*scene_spec, q)
        if renders:
            t = estimator_seconds(scene, "recommend", plan.on("occlusion"), plan.on("inter_reflection"), plan.convex,
                                  plan.on("zoning"))["render"]
        else:
            if plan is not None and plan.env_samples:  # the map seen past the parts: as densely at this rung
                scene = scene.with_env_samples(env_samples_enough(len(scene.lights) - scene.lights.n_lamps, len(scene.poses())))
            settings = scene.settings()
            t = predict_sample_seconds(settings, q.surface_points, occlusion)
            if volume:  # the light carried through the stone: its paths on top (as the planner predicts it)
                t += volume_path_seconds(settings, q.surface_points)
        rungs.append((q, t))
    return pick_corrected(rungs, kept, kind, seconds, "the cheapest setting's", extra=extra, pilot_seconds=pilots,
                          occlusion=occlusion, estimator="render" if renders else "volume" if volume else "samples",
                          cold=cold, first_call_seconds=extra)


def pick_corrected(raw: list[tuple[Quality, float]], kept: dict[str, Any], kind: bool | str, seconds: float,
                   cheapest: str, detail: str = "", *, extra: float = 0.0, **fields: Any) -> BudgetChoice:
    """:func:`pick` over ``raw`` (``(quality, uncorrected seconds)``, cheapest first), each rung
    predicted as its :func:`factor_at` of ``kind`` in ``kept`` (:func:`learnt`) times its seconds,
    plus ``extra`` (a cold call's first-call seconds); the choice's ``correction`` is the factor of
    the rung it took. ``fields``: the rest of the :class:`BudgetChoice`."""
    factors = {q.name: factor_at(kept, kind, t) for q, t in raw}
    choice = pick([(q, factors[q.name] * t + extra) for q, t in raw], seconds, cheapest, detail, **fields)
    return replace(choice, correction=factors[choice.quality.name])


def pick(rungs: list[tuple[Quality, float]], seconds: float, cheapest: str, detail: str = "",
         pilot_seconds: float = 0.0, **fields: Any) -> BudgetChoice:
    """The last (most accurate) of ``rungs`` (``(quality, predicted seconds)``, cheapest first)
    predicted to fit ``seconds``, less the ``pilot_seconds`` a stone's first plan already spent on
    its pilot renders (which no rung's prediction includes); none fitting, the first with a one-line
    note naming ``cheapest`` (e.g. "the cheapest setting's") prediction, then ``detail``, and what
    the pilots took. ``fields``: the rest of the :class:`BudgetChoice`."""
    named = tuple((q.name, float(t)) for q, t in rungs)
    fitting = [(q, t) for q, t in rungs if t <= seconds - pilot_seconds]
    if fitting:
        q, t = fitting[-1]
        return BudgetChoice(q, float(t), seconds, named, pilot_seconds=pilot_seconds, **fields)
    q, t = rungs[0]
    if pilot_seconds > 0.0:
        note = (f"the stone's first plan took {pilot_seconds:.2g} s of the {seconds:g} s time budget on its pilot "
                f"renders (cached for the next call), which leaves less than {cheapest} predicted {t:.2g} s on this "
                f"machine{detail}: running that ({q.name}) anyway")
    else:
        note = f"a time budget of {seconds:g} s is below {cheapest} predicted {t:.2g} s on this machine{detail}: running that ({q.name}) anyway"
    return BudgetChoice(q, float(t), seconds, named, note=note, pilot_seconds=pilot_seconds, **fields)
