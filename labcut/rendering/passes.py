"""One pass of a Mitsuba render that lets Ctrl-C through (:func:`render_pass`): what a render,
its denoiser's guide passes and the estimators' renders run."""

from __future__ import annotations

from typing import Any


def render_pass(scene: Any, spp: int, seed: int) -> Any:
    """One ``mi.render`` call that lets Ctrl-C through as ``KeyboardInterrupt``.

    Mitsuba handles SIGINT itself in two ways: arriving while the Python BSDF is traced,
    the ``KeyboardInterrupt`` comes back wrapped in a ``RuntimeError`` by ``dr.custom``;
    arriving while the kernel runs, Mitsuba's handler "winds down" the pass and sets the
    integrator's stop flag, and the next pass would start as if nothing happened.
    """
    import mitsuba as mi

    try:
        img = mi.render(scene, spp=spp, seed=seed)
    except RuntimeError as exc:
        if isinstance(exc.__cause__, KeyboardInterrupt) or isinstance(exc.__context__, KeyboardInterrupt):
            raise KeyboardInterrupt from None
        raise
    integrator = scene.integrator()
    if integrator is not None and integrator.should_stop():
        raise KeyboardInterrupt
    return img
