"""What the explorer's controls hold: :class:`ExploreState`, checked one control at a time.

Every control of ``labcut explore`` (and of :func:`labcut.explore` in a notebook) is a field of
one frozen state; a change is a mapping ``{control: value}`` checked by :func:`changed`, which
raises :class:`ControlError` (a :class:`~labcut.errors.ParameterError` naming the control) for a
value the control does not take, so the page can show the message beside that control and keep
the last good state.

Angles in degrees. The lamp: ``lamp_elevation`` above the horizon (90: overhead),
``lamp_azimuth`` from +X toward +Y (270: in front of the stone, -Y), ``lamp_size`` the lamp's
angular radius seen from the stone (0: a point). The lamella normal: ``normal_tilt`` from +Z,
``normal_azimuth`` from +X toward +Y (DESIGN.md §3).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from typing import Any

from ..errors import ParameterError
from ..geometry.outlines import OUTLINES
from ..physics.material import Labradorite
from ..scene.quality import QUALITIES
from ..scene.scenario import SCENARIOS

#: the lights: the scenario's own, or the one lamp of the lamp controls
LIGHTS = ("scenario", "lamp")
#: the material control: the material given when the explorer started, a preset, or a flash peak
MATERIALS = ("given", *Labradorite.PRESETS, "peak")
#: the outline control: the stone as loaded, or a cabochon of that outline built at the loaded
#: stone's length and width
STONE_OUTLINES = ("as loaded", *OUTLINES)
LOOKS = ("diagram", "studio")
#: flash peaks the control takes (nm): the colours labradorite shows
PEAK_RANGE_NM = (400.0, 700.0)
#: the largest lamp radius (degrees) the control takes: a window or softbox seen from nearby
LAMP_SIZE_MAX_DEG = 45.0

#: control -> (low, high) of the numeric controls; an azimuth wraps into [0, 360)
RANGES: dict[str, tuple[float, float]] = {
    "lamp_elevation": (0.0, 90.0),
    "lamp_azimuth": (0.0, 360.0),
    "lamp_size": (0.0, LAMP_SIZE_MAX_DEG),
    "peak_nm": PEAK_RANGE_NM,
    "normal_tilt": (0.0, 90.0),
    "normal_azimuth": (0.0, 360.0),
    "dome": (0.1, 100.0),
}
#: control -> its choices
CHOICES: dict[str, tuple[str, ...]] = {
    "scenario": tuple(SCENARIOS.names()),
    "lights": LIGHTS,
    "material": MATERIALS,
    "quality": tuple(QUALITIES),
    "outline": STONE_OUTLINES,
    "look": LOOKS,
}
#: the controls that move the lamp: setting one turns the lights to the lamp
LAMP_CONTROLS = ("lamp_elevation", "lamp_azimuth", "lamp_size")


class ControlError(ParameterError):
    """A control's value it does not take; ``control`` names it (the page shows the message there)."""

    def __init__(self, control: str, message: str) -> None:
        super().__init__(f"{control.replace('_', ' ')}: {message}")
        self.control = control


@dataclass(frozen=True)
class ExploreState:
    """Everything the explorer's controls set (module docstring for the angles' frames)."""

    scenario: str = "bench"
    lights: str = "scenario"
    lamp_elevation: float = 90.0
    lamp_azimuth: float = 270.0
    lamp_size: float = 8.0
    material: str = "given"
    peak_nm: float = 470.0
    quality: str = "standard"
    outline: str = "as loaded"
    #: the cabochon's dome height above the girdle (mm), when ``outline`` builds one
    dome: float = 2.4
    normal_tilt: float = 0.0
    normal_azimuth: float = 0.0
    look: str = "diagram"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _number(control: str, value: Any) -> float:
    if isinstance(value, bool):
        raise ControlError(control, f"expected a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ControlError(control, f"expected a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ControlError(control, f"expected a finite number, got {value!r}")
    low, high = RANGES[control]
    if control.endswith("azimuth"):
        return x % 360.0
    if not low <= x <= high:
        raise ControlError(control, f"{x:g} lies outside {low:g}-{high:g}")
    return x


def checked(control: str, value: Any) -> Any:
    """``value`` as ``control`` holds it (a number in range, an azimuth wrapped, a known choice), or
    :class:`ControlError`."""
    if control in RANGES:
        return _number(control, value)
    if control in CHOICES:
        if not isinstance(value, str) or value not in CHOICES[control]:
            raise ControlError(control, f"unknown choice {value!r}; choose one of {', '.join(CHOICES[control])}")
        return value
    raise ControlError(control, f"no such control; the controls are {', '.join(sorted((*RANGES, *CHOICES)))}")


def changed(state: ExploreState, changes: Mapping[str, Any]) -> ExploreState:
    """``state`` with ``changes`` applied, each checked (:func:`checked`); all or none. Setting a
    lamp control turns the lights to the lamp (unless ``lights`` is set in the same change)."""
    if not isinstance(changes, Mapping):
        raise ParameterError(f"changes must be a mapping of control names to values, got {type(changes).__name__}")
    values = {str(k): checked(str(k), v) for k, v in changes.items()}
    if "lights" not in values and any(k in values for k in LAMP_CONTROLS):
        values["lights"] = "lamp"
    return replace(state, **values)
