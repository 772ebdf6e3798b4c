"""Compare two dome heights of the same oval cabochon: which flashes more, and how forgiving is each?

    .venv/bin/python examples/compare_domes.py

Builds low and high 16 x 12 mm oval cabochons with labcut.cabochon, scores each at
its recommended orientation for a face-up viewer under an overhead lamp, and prints
a small table.
"""

from __future__ import annotations

import labcut


def main() -> None:
    material = labcut.Labradorite.preset("green")
    print(f"{'dome':8} {'tilt':>6} {'energy':>8} {'area':>6} {'intensity':>9} {'tolerance':>9}")
    for dome in ("low", "high"):
        cab = labcut.cabochon(outline="oval", length=16, width=12, dome=dome)
        rec = labcut.recommend_orientation(cab, material, lighting="overhead", viewing="face-up")
        m = rec.metrics
        print(f"{dome:8} {rec.tilt_deg:5.1f}° {m.flash_energy:8.4f} {m.flash_area:6.0%} {m.flash_intensity:9.3f} {rec.tolerance_deg:8.1f}°")


if __name__ == "__main__":
    main()
