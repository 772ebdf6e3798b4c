"""Lamella physics of labradorite: stack reflectance and the material model."""

from .lamella import (
    bragg_wavelength,
    interface_amplitudes,
    interface_reflectance,
    lamella_intensity,
    phase_wavenumbers,
    saturate,
    saturate_random,
    stack_reflectance,
    stack_reflectance_sp,
)
from .material import AN_RANGE, PERIOD_RANGE_NM, Labradorite
from .summary import check_angles, spectrum_summary

__all__ = [
    "AN_RANGE",
    "PERIOD_RANGE_NM",
    "Labradorite",
    "bragg_wavelength",
    "check_angles",
    "interface_amplitudes",
    "interface_reflectance",
    "lamella_intensity",
    "phase_wavenumbers",
    "saturate",
    "saturate_random",
    "spectrum_summary",
    "stack_reflectance",
    "stack_reflectance_sp",
]
