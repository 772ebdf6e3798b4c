"""Stone geometry: cabochon builder, outlines, dome profiles, mesh intake, carvings.

Frame and units (DESIGN.md §3): millimetres, +Z face-up, base in the XY plane at
z = 0. The public entry points are re-exported lazily by :mod:`labcut`
(``labcut.cabochon``, ``labcut.load_mesh``).
"""

from __future__ import annotations
