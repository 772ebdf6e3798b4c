"""Filmic tone mapping for presentation renders: an AgX-like curve, and incident-light exposure.

Two pieces a photographer would recognise:

* :func:`agx` maps scene-linear RGB (after exposure) to display sRGB in [0, 1] the way
  Blender's AgX view transform does (Troy Sobotka's AgX, in the widely used minimal
  form): the colour is pulled slightly towards the achromatic axis (the *inset*
  matrix), encoded as log2 exposure between -12.47 and +4.03 stops around middle grey,
  passed through a sigmoid (a 6th-order polynomial fit of AgX's default contrast) and
  mapped back (the *outset* matrix). Bright colours travel smoothly towards white
  instead of clipping channel by channel: the flash keeps its hue and gradation (no flat
  cyan blob), the lamp's reflection in the polish turns near-white, and middle grey
  (0.18 scene-linear) lands at 0.5 display (sRGB 128/255).
* :func:`metered_exposure`: the exposure an incident-light meter would set, from the
  lights alone (not from the image): an 18 % grey card facing the camera renders at
  0.18, less :data:`STUDIO_EV` stops (exposed for the highlights). A dull stone under the same lights then stays dull, a bright one bright, and a
  series (an animation, a gallery) can share one exposure.

Exposures are multipliers on linear radiance; ``ev = log2(exposure)`` is recorded with them.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

# AgX inset / outset (rows: the output channel as a combination of r, g, b inputs, applied as x @ M.T)
_INSET = np.array([
    [0.842479062253094, 0.0784335999999992, 0.0792237451477643],
    [0.0423282422610123, 0.878468636469772, 0.0791661274605434],
    [0.0423756549057051, 0.0784336, 0.879142973793104],
])
_OUTSET = np.array([
    [1.19687900512017, -0.0980208811401368, -0.0990297440797205],
    [-0.0528968517574562, 1.15190312990417, -0.0989611768448433],
    [-0.0529716355144438, -0.0980434501171241, 1.15107367264116],
])
MIN_EV = -12.47393
MAX_EV = 4.026069
MIDDLE_GREY = 0.18
CURVES = ("agx", "hue")


def _contrast(x: np.ndarray) -> np.ndarray:
    """AgX default contrast: polynomial fit of the sigmoid on the log encoding, x in [0, 1]."""
    x2 = x * x
    x4 = x2 * x2
    return 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x - 0.00232


def agx(image: np.ndarray) -> np.ndarray:
    """Scene-linear RGB (exposure applied, >= 0) -> display sRGB (encoded) in [0, 1], AgX-like."""
    from ..colour import encode_srgb

    x = np.clip(np.nan_to_num(np.asarray(image, dtype=np.float64)), 0.0, None)
    x = x @ _INSET.T
    x = np.log2(np.maximum(x, 1e-10))
    x = np.clip((x - MIN_EV) / (MAX_EV - MIN_EV), 0.0, 1.0)
    x = _contrast(x)
    x = np.clip(x, 0.0, None) @ _OUTSET.T
    linear = np.clip(x, 0.0, None) ** 2.2  # the curve's output is display-encoded with a 2.2 power
    return np.clip(encode_srgb(np.clip(linear, 0.0, 1.0)), 0.0, 1.0)


def check_exposure(exposure: float) -> float:
    """A valid exposure multiplier (finite, > 0) or :class:`ParameterError`."""
    if isinstance(exposure, bool) or not (isinstance(exposure, int | float | np.floating) and math.isfinite(exposure) and exposure > 0):
        raise ParameterError(f"exposure must be a finite number > 0, got {exposure!r}", parameter="exposure")
    return float(exposure)


def ev(exposure: float) -> float:
    """Exposure value in stops: log2 of the multiplier."""
    return float(math.log2(check_exposure(exposure)))


def from_ev(value: float) -> float:
    """Multiplier of an exposure value in stops (finite, within ±40)."""
    if isinstance(value, bool) or not (isinstance(value, int | float) and math.isfinite(value) and abs(value) <= 40.0):
        raise ParameterError(f"exposure value must be a finite number of stops within ±40, got {value!r}", parameter="exposure")
    return float(2.0 ** value)


STUDIO_EV = -1.75
"""Stops below the grey-card exposure a studio render is made at: jewellery is exposed for its
highlights, so the flash keeps its colour under the AgX shoulder (a fixed offset: the exposure
still depends only on the lights, never on the stone)."""


def metered_exposure(irradiance_at_camera: float, offset_ev: float = STUDIO_EV) -> float:
    """Incident-light exposure: ``pi / E`` makes an 18 % grey card facing the camera, lit with
    irradiance ``E`` (the render's linear units), render at 0.18 scene-linear (middle grey);
    ``offset_ev`` stops are added (default :data:`STUDIO_EV`)."""
    e = float(irradiance_at_camera)
    if not (math.isfinite(e) and e > 0.0):
        raise ParameterError("no light reaches a card facing the camera: cannot meter the exposure (give one)")
    return math.pi / e * 2.0 ** float(offset_ev)
