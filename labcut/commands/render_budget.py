"""``render(..., time_budget=SECONDS)``: the most samples per pixel predicted to fit.

The render's resolution, colour mode, polariser, integrator, look and views are the caller's;
the budget picks the samples per pixel, a power of two from 1 to :data:`MAX_SPP`, from this
machine's calibration of :func:`labcut.render` (:func:`labcut.planner.render_command_timing`:
two timed renders per mode, integrator and look, measured once and kept in the user cache):
``seconds = views x (fixed + resolution² x (per_pixel + per_sample x spp))``. Below the cheapest (1 spp)
prediction 1 spp runs, with a one-line note; a budget that is not a positive number of seconds
is a :class:`~labcut.errors.ParameterError`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from ..validation import check_budget

MAX_SPP = 4096


@dataclass(frozen=True)
class SppChoice:
    """The samples per pixel chosen, the predicted seconds, the budget, and a note when even 1 spp overruns."""

    spp: int
    predicted_seconds: float
    budget_seconds: float
    note: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def choose_spp(budget: Any, *, mode: str, polarised: bool, integrator: str, resolution: int, views: int,
               look: str = "diagram") -> SppChoice:
    """The largest power-of-two spp whose predicted render time fits ``budget`` seconds."""
    from ..planner import render_seconds

    seconds = check_budget(budget)

    def predict(spp: int) -> float:
        return render_seconds(mode, polarised, integrator, resolution, spp, views, look)

    spp = 1
    while spp * 2 <= MAX_SPP and predict(spp * 2) <= seconds:
        spp *= 2
    t = predict(spp)
    note = None
    if t > seconds:
        note = (f"a time budget of {seconds:g} s is below the predicted {t:.2g} s of 1 sample per pixel at "
                f"{resolution}² px on this machine: rendering that anyway")
    return SppChoice(spp, t, seconds, note)
