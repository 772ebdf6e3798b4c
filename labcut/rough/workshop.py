"""A plan in workshop words: where to saw, where to draw the template, how to tilt the dop, and
where the flash plane will lie in the finished stone.

Angles are measured as a cutter measures them on the bench: a plane's tilt from the rough's top
face (+Z) and the direction it leans towards, as an azimuth from the rough's right edge (+X)
towards its back (+Y); distances in mm from the named reference faces of
:data:`labcut.rough.shape.FACES` (a slab's own faces, a nodule's bounding box).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..scene.directions import tilt_azimuth
from .shape import FACES, Rough

#: a plane tilted less than this from a reference face is "parallel" to it (degrees)
FLAT_DEG = 1.0


def _facing(d: np.ndarray) -> tuple[str, float]:
    """The reference face whose normal is closest to ``d`` and the angle between them (degrees)."""
    best = max(FACES, key=lambda f: float(np.dot(FACES[f], d)))
    return best, math.degrees(math.acos(min(1.0, max(-1.0, float(np.dot(FACES[best], d))))))


def _lean(d: np.ndarray) -> str:
    """A plane with normal ``d`` (either sign) as its tilt from the top face and the way it leans."""
    d = np.asarray(d, dtype=np.float64)
    tilt, az = tilt_azimuth(d if d[2] >= 0 else -d)
    return f"tilted {tilt:.1f}° from the top face, leaning towards azimuth {az:.0f}°"


def saw_step(rough: Rough, normal: np.ndarray, offset: float) -> str:
    """One saw cut ``normal . x = offset`` (rough frame) in workshop words."""
    d = np.asarray(normal, dtype=np.float64)
    centre = np.asarray(rough.mesh.centroid, dtype=np.float64)
    point = centre - (float(d @ centre) - offset) * d  # the plane's point nearest the rough's centre
    face, angle = _facing(d)
    depth = rough.depth_from(face, point)
    if angle <= FLAT_DEG:
        return f"Saw parallel to the {face} face, {depth:.1f} mm in from it."
    return (f"Saw a plane {angle:.1f}° off parallel to the {face} face ({_lean(d)}), passing {depth:.1f} mm in from "
            f"the {face} face at the rough's centre line.")


def stone_steps(stone: Any, rough: Rough, n: np.ndarray, number: int) -> list[str]:
    """The workshop steps of one planned stone (a :class:`~labcut.rough.plan.PlannedStone`)."""
    t = stone.transform
    r = t[:3, :3]
    up = r[:, 2]
    length_axis = r[:, 0]
    length, width, height = stone.size_mm
    lo, hi = np.asarray(stone.cut.bounds, dtype=np.float64)
    base_centre = t @ np.array([(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, 0.0, 1.0])
    base_centre = base_centre[:3]
    steps = [saw_step(rough, d, o) for d, o in stone.saws]
    face, angle = _facing(-up)  # the base faces away from the stone's top
    depth = rough.depth_from(face, base_centre)
    top_face, top_angle = _facing(up)
    dome_room = rough.depth_from(top_face, base_centre) - height
    where = (f"centred {rough.depth_from('left', base_centre):.1f} mm from the left face and "
             f"{rough.depth_from('front', base_centre):.1f} mm from the front face")
    if angle <= FLAT_DEG:
        steps.append(f"Stone {number} lies flat: its base is parallel to the {face} face, {depth:.1f} mm in from it "
                     f"(saw or grind down to that plane); its dome rises {height:.1f} mm towards the {top_face} face "
                     f"({dome_room:.1f} mm of rough above it).")
        dop = "No dop tilt: the base is parallel to the rough's face."
    else:
        steps.append(f"Saw stone {number}'s base flat: a plane {angle:.1f}° off parallel to the {face} face "
                     f"({_lean(-up)}), {depth:.1f} mm in from the {face} face at the stone's centre.")
        tilt_up, az_up = tilt_azimuth(up)
        dop = (f"If the rough is held by its {face} face instead, tilt the dop {angle:.1f}° "
               f"(the stone's top points {tilt_up:.1f}° from +Z towards azimuth {az_up:.0f}°).")
    long_face = "top" if abs(up[2]) >= max(abs(up[0]), abs(up[1])) else _facing(up)[0]
    _, long_az = tilt_azimuth(length_axis)
    steps.append(f"Draw the {length:.1f} x {width:.1f} mm template on the sawn base, {where}, its long axis pointing "
                 f"towards azimuth {long_az:.0f}° as seen from the {long_face} face.")
    steps.append(dop)
    tilt_m, _ = tilt_azimuth(stone.lamella_normal_cut)
    verdict = ("within" if stone.within_tolerance else f"{stone.off_best_deg - stone.tolerance_deg:.1f}° beyond")
    steps.append(f"In the finished stone the flash plane lies {tilt_m:.1f}° from the base; this cut flashes best "
                 f"{stone.off_best_deg:.1f}° away from there (tolerance ±{stone.tolerance_deg:.1f}°: {verdict} it), "
                 f"keeping {100 * stone.flash_ratio:.0f} % of its best flash.")
    return steps
