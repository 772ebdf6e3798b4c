"""One home for checking numbers and vectors that come from users.

Every check raises :class:`labcut.errors.ParameterError` with a one-line message that
names the parameter, the allowed range and the value given. Booleans are refused
where a number is expected (``{"pairs": true}`` is not 1).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import ParameterError

__all__ = ["check_budget", "check_number", "given_besides", "is_default", "name_or_mm", "unit_vector"]


def check_number(value: Any, name: str, low: float = -math.inf, high: float = math.inf, *,
                 low_open: bool = False, integer: bool = False, unit: str = "", why: str = "") -> Any:
    """``value`` as a float (an int with ``integer=True``) in ``[low, high]`` (``(low, high]``
    with ``low_open``); finite, not a bool. ``unit`` (e.g. ``"mm"``) and ``why`` (e.g. "a
    stone's size") only word the message."""
    of = f" of {unit}" if unit else ""
    if isinstance(value, bool):
        raise ParameterError(f"{name} must be a number{of}, got {value!r}", parameter=name)
    # a whole number given as one is checked and kept exactly: through a float, seeds above 2**53
    # would be rounded (two seeds running as one) and 2**63 - 1 read as 2**63
    exact = integer and isinstance(value, int | np.integer)
    try:
        x = int(value) if exact else float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number{of}, got {value!r}", parameter=name) from None
    if not exact and not math.isfinite(x):
        raise ParameterError(f"{name} must be a finite number{of}, got {value!r}", parameter=name)

    def shown(b: float) -> str:  # a bound or the value as the message prints it: whole numbers in full
        if integer and -2**64 < b < 2**64 and b == int(b):
            return str(int(b))
        return f"{b:g}" if not isinstance(b, int) else f"{b:.6g}" if abs(b) < 10**300 else "a number too large to use"

    if (x <= low if low_open else x < low) or x > high:
        unit_s = f" {unit}" if unit else ""
        if high == math.inf:
            bound = f"{'greater than' if low_open else 'at least'} {shown(low)}{unit_s}"
        elif low == -math.inf:
            bound = f"at most {shown(high)}{unit_s}"
        else:
            bound = f"lie in {'(' if low_open else '['}{shown(low)}, {shown(high)}]{unit_s}"
        bound = bound if bound.startswith("lie") else f"be {bound}"
        raise ParameterError(f"{name} must {bound}{f' ({why})' if why else ''}, got {shown(x)}", parameter=name)
    if integer:
        if x != int(x):
            raise ParameterError(f"{name} must be a whole number, got {value!r}", parameter=name)
        return int(x)
    return x


def unit_vector(value: Any, name: str) -> np.ndarray:
    """A unit vector (float64, shape (3,)) from three finite numbers, not all zero; huge
    components are scaled down before normalising so the norm cannot overflow."""
    try:
        v = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be three numbers [x, y, z], got {value!r}", parameter=name) from None
    if not np.all(np.isfinite(v)):
        raise ParameterError(f"{name} must be finite, got {v.tolist()}", parameter=name)
    scale = float(np.max(np.abs(v)))
    if scale == 0.0:
        raise ParameterError(f"{name} must not be the zero vector", parameter=name)
    v = v / scale
    return v / np.linalg.norm(v)


def is_default(value: Any, default: Any) -> bool:
    """Whether an argument was left at its default: ``None`` is only ``None``; a number or string
    equal to the default counts; an array or object that does not compare is not the default."""
    if value is None or default is None:
        return value is default
    try:
        return bool(value == default) and type(value) in (type(default), int, float)
    except Exception:  # noqa: BLE001 - an array or object that does not compare: not the default
        return False


def given_besides(asked: dict[str, Any], defaults: dict[str, Any], holder: str) -> None:
    """Refuse arguments passed beside an object that already holds them: every ``asked`` value
    must be its ``defaults`` entry, else a one-line ParameterError naming ``holder`` (e.g.
    ``"setup= already holds the render request"``) and the arguments given."""
    clash = [k for k, v in asked.items() if not is_default(v, defaults[k])]
    if clash:
        raise ParameterError(f"{holder}; do not also pass {', '.join(clash)}")


def name_or_mm(text: str, names: tuple[str, ...], what: str, where: str = "") -> str | float:
    """A text that is one of ``names`` (returned lower-cased) or a finite number of millimetres
    (returned as a float): ``"low"`` -> ``"low"``, ``"2.5"`` -> 2.5. ``where`` (e.g. the spec the
    text came from) only words the one-line ParameterError."""
    key = str(text).strip().lower()
    if key in names:
        return key
    try:
        value = float(key)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        place = f" in {where!r}" if where else ""
        raise ParameterError(f"{what} must be {', '.join(names)} or a number of mm{place}, got {text!r}", parameter=what)
    return value


def check_budget(value: Any) -> float:
    """A time budget in seconds: a finite number > 0 (one-line error otherwise)."""
    return float(check_number(value, "time budget", 0.0, 86_400.0, low_open=True, unit="s"))
