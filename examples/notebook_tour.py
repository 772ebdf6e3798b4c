# %% [markdown]
# # labcut in a notebook
#
# A designer's first session, written as notebook cells (the jupytext "percent" format:
# open it in Jupyter with jupytext, in VS Code as an interactive window, or run it as a
# script: `.venv/bin/python examples/notebook_tour.py`). The last expression of each cell
# is what a notebook would display: labcut's results show a one-line repr and a small HTML
# table (`_repr_html_`).

# %%
import tempfile
from pathlib import Path

import labcut

stone = labcut.load_mesh("meshes/oval-16x12-low.ply")
material = labcut.Labradorite.preset("blue")
material

# %%
# The recommended lamella orientation for a stone on the bench, at draft quality (seconds).
rec = labcut.recommend_orientation(stone, material, scenario="bench", quality="draft")
rec

# %%
# The flash metrics at that orientation (DESIGN.md §4).
rec.metrics

# %%
# Save the answer as JSON and read it back: the same numbers, the same scenario.
out = Path(tempfile.mkdtemp()) / "oval-bench.json"
rec.save(out)
again = labcut.Recommendation.load(out)
again

# %%
# How much is lost by cutting the lamellae parallel to the base instead?
base = labcut.evaluate_orientation(stone, [0.0, 0.0, 1.0], material, scenario="bench", quality="draft")
base

# %%
if __name__ == "__main__":
    print(rec.description)
    print(f"{again!r}")
