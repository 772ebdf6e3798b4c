"""Sweep the tilt of a single lamp and watch the recommended lamella tilt follow it.

    .venv/bin/python examples/sweep_light_tilt.py

A face-up viewer looks at the bundled oval cabochon while one lamp moves from
overhead towards the front. The mirror condition inside the stone asks for a lamella
tilt of about half the refracted lamp angle; the printout shows how the optimum and
the flash energy follow.
"""

from __future__ import annotations

import math
from pathlib import Path

import labcut

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    material = labcut.Labradorite.preset("blue")
    print(f"{'lamp tilt':>9} {'lamella tilt':>12} {'azimuth':>8} {'energy':>8}")
    for lamp in (0.0, 10.0, 20.0, 30.0, 40.0):
        t = math.radians(lamp)
        lights = labcut.Lights([[0.0, -math.sin(t), math.cos(t)]], name=f"lamp {lamp:g}°")
        rec = labcut.recommend_orientation(mesh, material, lighting=lights, viewing="face-up", quality="draft")
        print(f"{lamp:8.0f}° {rec.tilt_deg:11.1f}° {rec.azimuth_deg:7.0f}° {rec.score:8.4f}")


if __name__ == "__main__":
    main()
