"""Mutation testing of one module against its own test files (issue 37), reproducible in one command.

    .venv/bin/python tools/mutation.py labcut/physics/lamella.py [--tests tests/test_x.py ...] [--jobs 2]
    make mutation MODULE=labcut/physics/lamella.py

The tool is mutmut 3 (``pip install -e '.[mutation]'``): it keeps one Python process warm and
forks a child per mutant (labcut's import, Mitsuba and Dr.Jit load once, not per mutant), and it
runs for each mutant only the selected tests that call the mutated function (it records which
test reaches which function first): hundreds of mutants of a module take minutes on two cores.
cosmic-ray would start a fresh interpreter and run the whole test command per mutant, about 2 s of
imports each before any test.

The run happens in a fresh clone of this checkout's HEAD in a temporary folder (mutmut writes
its ``mutants/`` copy and ``setup.cfg`` there, never in the working tree), with the module's own
test files (:data:`MODULE_TESTS`, or ``--tests``). It prints one markdown row of counts (the
table of docs/testing.md) and writes every mutant's status, with the diff of each survivor, to
``benchmarks/data/mutation/<module>.json``; which survivors are equivalent (no test can tell
them apart: the code means the same) is a reviewer's call, recorded with the reason in
docs/testing.md.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: each module of issue 37's list and its own test files
MODULE_TESTS: dict[str, list[str]] = {
    "labcut/physics/depth.py": ["tests/test_depth_law.py"],
    "labcut/physics/lamella.py": ["tests/test_physics_bragg.py", "tests/test_physics_hardcases.py",
                                  "tests/test_physics_montecarlo.py", "tests/test_physics_tmm.py",
                                  "tests/test_tmm_reference.py", "tests/test_material.py"],
    "labcut/physics/schiller.py": ["tests/test_physics_montecarlo.py", "tests/test_physics_hardcases.py",
                                   "tests/test_bsdf.py"],
    "labcut/physics/material.py": ["tests/test_material.py", "tests/test_material_pinned.py", "tests/test_physics_bragg.py",
                                   "tests/test_physics_hardcases.py", "tests/test_colour.py", "tests/test_cli_spectrum.py"],
    # not tests/test_batch.py: its 2-worker clusters cost about a minute a mutant, for the runner, not the catalogue
    "labcut/batch/catalog.py": ["tests/test_batch_catalog.py", "tests/test_catalog_pinned.py"],
    # not tests/test_geometry_cli.py: it reaches every Profile through the CLI and a console script
    # (about 13 s a surviving mutant: the 474 mutants would take half an hour on two cores)
    "labcut/geometry/profiles.py": ["tests/test_profiles_pinned.py", "tests/test_geometry_cabochon.py"],
    "labcut/geometry/gemcad.py": ["tests/test_gemcad.py", "tests/test_gemcad_pinned.py"],
    # not tests/test_compare.py: its comparison renders (about 10 s a mutant; the "before" run took an hour)
    "labcut/reports/analysis.py": ["tests/test_analysis_pinned.py"],
    # not tests/test_render_look.py: a recommendation and studio renders, about 20 s a mutant
    "labcut/rendering/denoise.py": ["tests/test_denoise_pinned.py"],
    "labcut/commands/budget.py": ["tests/test_budget_pinned.py"],
    # not tests/test_batch.py: its Dask clusters
    "labcut/batch/store.py": ["tests/test_store_pinned.py", "tests/test_batch_catalog.py"],
    # test_intake.py's up-axis tests only: the rest runs the CLI and recommendations (43 s a mutant)
    "labcut/geometry/orient.py": ["tests/test_orient_pinned.py"] + [
        f"tests/test_intake.py::{name}" for name in (
            "test_every_up_axis_is_found_from_the_flat_base", "test_dome_down_file_warns_and_is_scored_on_its_dome",
            "test_y_up_gltf_is_upright_and_in_mm_without_a_warning", "test_tables_and_domes_say_which_side_is_up",
            "test_bundled_meshes_stay_as_they_are", "test_shapes_that_do_not_say_keep_the_file_convention")],
    "labcut/geometry/outlines.py": ["tests/test_outlines_pinned.py", "tests/test_geometry_cabochon.py"],
    "labcut/geometry/cabochon.py": ["tests/test_cabochon_pinned.py", "tests/test_geometry_cabochon.py"],
    "labcut/orientation/uncertainty.py": ["tests/test_uncertainty_pinned.py", "tests/test_uncertainty.py"],
    # not tests/test_sparse_map.py, test_memory_chunks.py, test_pair_sums.py, test_orientation.py: each builds a
    # problem from a mesh or runs recommendations (seconds a mutant, hours for the 2200 mutants)
    "labcut/orientation/scoring.py": ["tests/test_scoring_pinned.py"],
    # not tests/test_pair_sums.py, test_pairs.py, test_memory_chunks.py, test_triple_batches.py,
    # test_kernel_options.py: problems of the bundled meshes and real scenarios (21 s a mutant reached)
    "labcut/orientation/problem.py": ["tests/test_problem_pinned.py"],
    # not tests/test_orientation.py or test_golden_answers.py: recommendations on meshes, seconds a mutant
    "labcut/orientation/optimize.py": ["tests/test_optimize_pinned.py"],
    # not tests/test_answers.py, test_orientation.py, test_cli_recommend.py, test_golden_answers.py: real
    # recommendations and CLI runs (seconds each, for each of answer_recommendation's ~300 mutants)
    "labcut/orientation/recommend.py": ["tests/test_recommend_pinned.py"],
    # not tests/test_planner.py, test_planner_off.py, test_budget*.py or test_kept_figures.py: pilot renders,
    # this machine's calibrations and whole recommendations (seconds a test, 2258 mutants)
    "labcut/planner.py": ["tests/test_planner_pinned.py"],
    # not tests/test_geometry_load.py, test_speed_big_load.py, test_convex_flag.py: the bundled 20-50k-triangle
    # meshes (405 of 1780 mutants in 9 minutes); not tests/test_intake.py: the CLI and recommendations
    "labcut/geometry/meshio.py": ["tests/test_meshio_pinned.py"],
    # not tests/test_compare.py, test_rankings.py, test_compare_budget.py, test_compare_cli.py: real comparisons,
    # renders and CLI runs (about 10 s a mutant, 1930 mutants)
    "labcut/reports/compare.py": ["tests/test_compare_pinned.py"],
    # not tests/test_batch.py: its 2-worker Dask clusters (about a minute a mutant)
    "labcut/batch/runner.py": ["tests/test_runner_pinned.py"],
    # not tests/test_bsdf.py: its chi-square, reciprocity and energy tests (seconds to minutes each)
    "labcut/rendering/bsdf.py": ["tests/test_bsdf_pinned.py"],
    # not tests/test_exposure.py: its renders (a render per mutant reached)
    "labcut/rendering/exposure.py": ["tests/test_exposure_pinned.py"],
    "labcut/explorer/hemisphere.py": ["tests/test_explore.py"],
    "labcut/explorer/state.py": ["tests/test_explore.py"],
}
#: what the copy of the checkout needs besides the package for the tests to run
ALSO_COPY = ["cli/", "meshes/", "tests/", "examples/", "benchmarks/", "docs/", "tools/", "README.md", "pyproject.toml"]


def config(module: str, tests: list[str]) -> str:
    lines = ["[mutmut]", "source_paths=labcut/", f"only_mutate={module}",
             "pytest_add_cli_args_test_selection=" + "\n    ".join(tests),
             "pytest_add_cli_args=-p no:cacheprovider -q",
             "also_copy=" + "\n    ".join(ALSO_COPY)]
    return "\n".join(lines) + "\n"


def run(module: str, tests: list[str], jobs: int) -> dict:
    mutmut = Path(sys.executable).with_name("mutmut")
    if not mutmut.exists():
        raise SystemExit("mutmut is not installed: .venv/bin/python -m pip install -e '.[mutation]'")
    with tempfile.TemporaryDirectory(prefix="labcut-mutation-") as tmp:
        copy = Path(tmp) / "labcut"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(copy)], check=True)
        (copy / "setup.cfg").write_text(config(module, tests))
        start = time.perf_counter()
        subprocess.run([str(mutmut), "run", "--max-children", str(jobs)], cwd=copy, check=False,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        seconds = time.perf_counter() - start
        listing = subprocess.run([str(mutmut), "results", "--all", "true"], cwd=copy, capture_output=True, text=True).stdout
        status = {}
        for line in listing.splitlines():
            found = re.match(r"\s*(\S+): (.+)$", line)
            if found:
                status[found.group(1)] = found.group(2).strip()
        survivors = {}
        for name, state in status.items():
            if state == "survived":
                shown = subprocess.run([str(mutmut), "show", name], cwd=copy, capture_output=True, text=True).stdout
                survivors[name] = [ln for ln in shown.splitlines() if ln.startswith(("-", "+")) and not ln.startswith(("---", "+++"))]
    counts = Counter(status.values())
    if status and counts.get("not checked", 0) == len(status):
        raise SystemExit(f"mutmut checked no mutant of {module}: its tests fail unmutated in the copy "
                         f"(run mutmut by hand in a clone to see why)")
    return {"module": module, "tests": tests, "seconds": round(seconds, 1), "mutants": len(status),
            "counts": dict(counts), "survivors": survivors, "status": status}


def row(result: dict) -> str:
    c = result["counts"]
    return (f"| `{result['module']}` | {result['mutants']} | {c.get('killed', 0)} | {c.get('survived', 0)} | "
            f"{c.get('timeout', 0)} | {c.get('no tests', 0)} | {result['seconds']:.0f} s |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("module", help="the module to mutate, e.g. labcut/physics/lamella.py")
    parser.add_argument("--tests", nargs="+", help="its test files (default: MODULE_TESTS)")
    parser.add_argument("--jobs", type=int, default=2, help="mutants run at once")
    args = parser.parse_args()
    tests = args.tests or MODULE_TESTS.get(args.module)
    if not tests:
        raise SystemExit(f"no test files known for {args.module}: give them with --tests")
    result = run(args.module, tests, args.jobs)
    out = ROOT / "benchmarks" / "data" / "mutation" / (args.module.replace("/", ".").removesuffix(".py") + ".json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1, ensure_ascii=False) + "\n")
    print("| module | mutants | killed | survived | timeout | no tests | time |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    print(row(result))
    print(f"\nevery mutant's status and each survivor's diff: {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
