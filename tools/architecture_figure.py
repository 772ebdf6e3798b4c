"""Draw docs/images/architecture.png: labcut's layers and how a scenario and a lamella normal flow.

    .venv/bin/python tools/architecture_figure.py

The layers are those tests/test_layers.py enforces (its LAYERS list is read here, so the
figure cannot drift from the contract).
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    from test_layers import LAYER_NAMES, LAYERS

    assert len(LAYER_NAMES) == len(LAYERS)
    layers = [("labcut_cli", "CLI: typer + rich; parses options, builds a question once, prints tables, writes JSON/PNG")] + [
        (name, "") for name in reversed(LAYER_NAMES)
    ]
    notes = {
        "batch": "Dask batch runs over catalogues",
        "reports": "compare_cuts: reports over cuts x scenarios",
        "study": "Study: a Stone + one question; keeps plan, problem, answers; with_...() re-asks",
        "commands · budgets": "recommend_orientation, evaluate_orientation, render, animate; time budgets",
        "planner": "plan_effects decides effects and estimator; predicts seconds (calibrations in orientation.timing)",
        "orientation · rendering · plots": "FlashProblem → Scorer (KernelOptions), answers  |  BSDF, render plan, scenes, passes",
        "geometry · scene": "Stone: mesh (mm, +Z up), facts, derived geometry  |  Lights, Views, Scenario",
        "physics · colour": "Stack → R_s, R_p (numpy f64 / Dr.Jit f32)  |  schiller lobe f_s  |  CIE tables",
        "backend · fileio": "CUDA or LLVM variant, libLLVM check  |  atomic outputs, the user cache",
        "errors · validation": "typed errors, one-line messages  |  number and vector checks",
    }
    fig, ax = plt.subplots(figsize=(11, 7.2))
    ax.set_xlim(0, 11.2)
    ax.set_ylim(0, len(layers) + 0.6)
    ax.axis("off")
    for k, (name, note) in enumerate(layers):
        y = len(layers) - 1 - k + 0.2
        box = FancyBboxPatch((0.2, y), 6.6, 0.72, boxstyle="round,pad=0.02,rounding_size=0.08",
                             fc="#eef3fb" if k % 2 else "#f8f8f8", ec="#5b6b8c", lw=1.0)
        ax.add_patch(box)
        ax.text(0.4, y + 0.47, name, fontsize=10.5, weight="bold", va="center", family="monospace")
        ax.text(0.4, y + 0.18, note or notes.get(name, ""), fontsize=7.6, va="center", color="#333")
    ax.annotate("", xy=(0.1, 0.3), xytext=(0.1, len(layers) - 0.1),
                arrowprops={"arrowstyle": "->", "color": "#5b6b8c", "lw": 1.5})
    ax.text(0.02, len(layers) / 2, "imports only point down", rotation=90, va="center", ha="center", fontsize=8, color="#5b6b8c")
    centre = {name: len(layers) - 1 - k + 0.56 for k, (name, _) in enumerate(layers)}
    flow = [
        ("--scenario pendant --normal ...\n→ one Scenario, validated once", centre["labcut_cli"]),
        ("Study / recommend_orientation:\ncheck, plan, budget, then answer", centre["commands · budgets"]),
        ("plan_question: occlusion from stone.convex,\ninter-reflection from pilot renders", centre["planner"]),
        ("FlashProblem → Scorer sums q(h·m) for every\nnormal m (Dr.Jit kernels: KernelOptions);\nrender: main pose, camera, emitters",
         centre["orientation · rendering · plots"]),
        ("Scenario.settings(): per pose, Lights\nand Views rotated into the mesh frame", centre["geometry · scene"]),
        ("one schiller lobe f_s and R_s, R_p: the\nestimator (numpy) and the BSDF (Dr.Jit)", centre["physics · colour"]),
    ]
    for i, (text, y) in enumerate(flow):
        ax.text(8.95, y, text, fontsize=7.6, ha="center", va="center",
                bbox={"boxstyle": "round,pad=0.3", "fc": "#fff7e6", "ec": "#c08a2d"})
        if i:
            y0 = flow[i - 1][1]
            sign = -1.0 if y < y0 else 1.0
            ax.add_patch(FancyArrowPatch((10.75, y0), (10.75, y), arrowstyle="->", mutation_scale=12, color="#c08a2d",
                                         connectionstyle="arc3,rad=-0.25" if sign < 0 else "arc3,rad=0.25"))
        ax.add_patch(FancyArrowPatch((7.35, y), (6.85, y), arrowstyle="-", color="#c08a2d", lw=0.8, linestyle=":"))
    ax.text(8.9, len(layers) + 0.25, "how a scenario and a lamella normal flow", ha="center", fontsize=9, weight="bold", color="#8a5a10")
    out = ROOT / "docs" / "images" / "architecture.png"
    fig.savefig(out, dpi=110, bbox_inches="tight")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
