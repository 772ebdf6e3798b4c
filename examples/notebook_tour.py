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
# What that recommendation simulated, and why (docs/planner.md).
labcut.plan_effects(stone, material, command="recommend", scenario="bench", quality="draft", predict=False)

# %%
# A small render at the recommended orientation: a notebook shows it as an image (`_repr_png_`).
picture = labcut.render(stone, material, rec.normal, scenario="bench", resolution=64, spp=4, look="diagram")
picture

# %%
# Two cabochon domes side by side (a comparison: ranked, normalised to the first).
comparison = labcut.compare_cuts(["cab:oval,16x12,low,res=48", "cab:oval,16x12,high,res=48"], material,
                                 ["bench"], quality="draft", resolution=32, spp=2)
comparison

# %%
if __name__ == "__main__":
    print(rec.description)
    print(f"{again!r}")
