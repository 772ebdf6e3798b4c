"""How bright a render's PNG is: one reference exposure for every scene, unless asked otherwise.

Every scenario's lights are scaled to the same total irradiance
(:data:`~labcut.rendering.scene.RENDER_IRRADIANCE`), so under one exposure a stone worn as a
pendant (its face turned away from the overhead lamp) looks dimmer than the same stone on the
bench, as it does to the eye. Metering each scene on its own would hide that: the pendant was
brightened 3x over the bench, and looked as if it flashed as much.

Three modes (:class:`ExposureChoice`):

* ``reference`` (the default): the exposure the **bench** scenario's rest pose meters, as an
  incident-light meter facing its main viewer would (:func:`reference_exposure`): one number per
  look, whatever the scene, so every render, comparison, animation and orbit shares it.
* ``auto``: brightened to the scene: in the studio look metered from the scene's own lights
  towards its camera; in the diagram look from the image's bright pixels
  (:func:`~labcut.rendering.images.auto_exposure`). The result records how many stops that is
  over the reference (``+1.6 EV``), and captions say so.
* ``given``: a multiplier the caller chose.

Units: exposures are multipliers on the renderer's linear radiance; EV = log2 of a ratio.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene import Setting, resolve_scene
from .scene import RENDER_IRRADIANCE, ROOM_AMBIENT, CameraView
from .images import auto_exposure
from .studio import irradiance_at_camera, irradiance_towards, lamps_of, studio_environment
from .tonemap import STUDIO_EV, check_exposure, metered_exposure

#: the scenario whose rest pose meters the reference exposure
REFERENCE_SCENARIO = "bench"
#: exposure modes (module docstring)
MODES = ("reference", "auto")

DIAGRAM_EV = -1.0
"""Stops below the grey-card exposure the diagram look's reference is set at: the diagram's
hue-preserving curve clips at 1, and a stone flashing face-up under the bench lamp keeps its
colour a stop down (the bundled cabochons flashing face-up on the bench render within half a
stop of their image-metered exposure; tests/test_exposure.py)."""


def check_mode(exposure: Any) -> float | str:
    """A render request's exposure: ``None`` or ``"reference"`` -> ``"reference"``; ``"auto"``; or
    a finite multiplier > 0. Anything else is a :class:`~labcut.errors.ParameterError`."""
    if exposure is None:
        return "reference"
    if isinstance(exposure, str):
        key = exposure.strip().lower()
        if key in MODES:
            return key
        raise ParameterError(f"exposure must be reference, auto or a multiplier > 0, got {exposure!r}", parameter="exposure")
    return check_exposure(exposure)


def diagram_irradiance_at_camera(setting: Setting, camera_direction: Any) -> float:
    """Irradiance (render units) on a card at the stone facing the camera in the diagram look:
    the lamps (distant, scaled to :data:`RENDER_IRRADIANCE` in all) and the dim constant room
    (``pi`` times its radiance), or the scenario's map over the card's hemisphere."""
    v = np.asarray(camera_direction, dtype=np.float64)
    v = v / np.linalg.norm(v)
    lights = setting.lights
    scale = RENDER_IRRADIANCE / float(np.sum(lights.weights))
    d = np.asarray(lights.lamp_directions, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(lights.lamp_weights, dtype=np.float64).reshape(-1)
    e = float(np.sum(w * scale * np.clip(d @ v, 0.0, None)))
    env = lights.environment
    if env is None:
        return e + math.pi * ROOM_AMBIENT
    return e + float(irradiance_towards(env.scaled(scale), v))


def metered(setting: Setting, studio: Any, camera_direction: Any) -> float:
    """The incident-light exposure of ``setting`` towards a camera in a look (``studio`` a
    :class:`~labcut.rendering.studio.Studio`, or None for the diagram look)."""
    if studio is None:
        return metered_exposure(diagram_irradiance_at_camera(setting, camera_direction), DIAGRAM_EV)
    return metered_exposure(studio_irradiance_at_camera(setting, studio, camera_direction), STUDIO_EV)


def studio_irradiance_at_camera(setting: Setting, studio: Any, camera_direction: Any) -> float:
    """Irradiance (render units) on a card facing the camera in the studio look: its lamps and
    its environment (the scenario's map, if any, and the light tent)."""
    scale = RENDER_IRRADIANCE / float(np.sum(setting.lights.weights))
    lamps = lamps_of(setting.lights, studio.point_lamp_deg)
    env = studio_environment(setting, studio, scale)
    return irradiance_at_camera(lamps, env, camera_direction, scale)


@functools.lru_cache(maxsize=16)
def reference_exposure(studio: Any = None) -> float:
    """The reference exposure of a look (``studio``: a :class:`~labcut.rendering.studio.Studio`, or
    None for the diagram look): what the :data:`REFERENCE_SCENARIO`'s rest pose meters towards its
    main viewer. The same for every stone and scene: it depends only on the look."""
    setting = resolve_scene(REFERENCE_SCENARIO).main_setting()
    return metered(setting, studio, setting.views.main)


@dataclass(frozen=True)
class ExposureChoice:
    """The exposure a render's PNG is tonemapped with and why.

    ``value``: the multiplier; ``mode``: ``reference``, ``auto`` or ``given``; ``reference``: the
    look's reference exposure (:func:`reference_exposure`); ``metering``: how ``auto`` found its
    value (``incident``: from the lights; ``image``: from the image), or ``reference``/``given``."""

    value: float
    mode: str
    reference: float
    metering: str


class Exposed:
    """What a picture made under an exposure says of it (a render, an animation): mixed into a class
    with ``exposure`` (the multiplier), ``exposure_mode`` and ``exposure_reference`` (the look's
    reference exposure)."""

    exposure: float
    exposure_mode: str
    exposure_reference: float

    @property
    def exposure_ev(self) -> float:
        """The exposure in stops (log2 of the multiplier)."""
        return float(math.log2(self.exposure))

    @property
    def exposure_vs_reference_ev(self) -> float:
        """Stops the exposure lies over the look's reference (0: the reference; > 0 brighter)."""
        return float(math.log2(self.exposure / self.exposure_reference))

    @property
    def exposure_caption(self) -> str:
        """One line for a caption: the reference, or how many stops over it and why."""
        return exposure_caption(self.exposure_mode, self.exposure_vs_reference_ev)


def exposure_caption(mode: str, ev_vs_reference: float) -> str:
    """The caption of an exposure (:attr:`Exposed.exposure_caption`), from its mode and its stops
    over the reference."""
    if mode == "reference":
        return f"{REFERENCE_SCENARIO} reference exposure (one for every scene: a dimmer scene looks dimmer)"
    why = "auto: brightened to this scene" if mode == "auto" else "given"
    if abs(ev_vs_reference) < 0.05:
        return f"{REFERENCE_SCENARIO} reference exposure ({why})"
    return f"{ev_vs_reference:+.1f} EV over the {REFERENCE_SCENARIO} reference ({why})"


def choose_exposure(asked: float | str, studio: Any, setting: Setting, views: Sequence[CameraView],
                    image: np.ndarray, irradiance: float | None = None) -> ExposureChoice:
    """The exposure of a render (module docstring): ``asked`` as :func:`check_mode` returns it,
    the look (``studio`` or None), the rest pose's ``setting`` and cameras (mesh frame), the
    linear image (for the diagram look's ``auto``) and, when the caller has it, the studio's
    irradiance on a card facing the first camera (else it is metered here)."""
    ref = reference_exposure(studio)
    if asked == "reference":
        return ExposureChoice(ref, "reference", ref, "reference")
    if asked == "auto":
        if studio is None:
            return ExposureChoice(auto_exposure(np.clip(np.nan_to_num(image), 0.0, None)), "auto", ref, "image")
        if irradiance is None:
            irradiance = studio_irradiance_at_camera(setting, studio, views[0].direction)
        return ExposureChoice(metered_exposure(irradiance, STUDIO_EV), "auto", ref, "incident")
    return ExposureChoice(check_exposure(asked), "given", ref, "given")
