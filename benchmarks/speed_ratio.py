"""Recommendation time as a ratio to one render, and big meshes (issue 17 §4-5).

    .venv/bin/python benchmarks/speed_ratio.py [--out docs/performance.md] [--big] [--env] [--compare]

1. The standard recommendation of the bundled oval cabochon under the ``bench`` scenario, warm
   in-process (the best and the median of :data:`ROUNDS` calls after :data:`ROUNDS` renders, and
   the best of :data:`ROUNDS` recommendations each right after a render) and as a whole CLI call (``labcut recommend-orientation ... --json -``, a fresh
   process, the kernel cache warm), each divided by one 256 x 256, 16 spp render of the same
   stone made in the same process (kernels warm), so the figure compares across machines. Targets on 2 cores: in-process <= 1 render, CLI <= 1 s.
2. ``--big``: the bundled biplane carving subdivided to about 1.2 M and 5 M triangles, load and
   recommend (standard, bench) in a fresh process each: wall time and peak memory (max RSS).
   Targets: a 5 M-triangle carving, load + recommend <= 10 s and <= 2 GB.
3. ``--env``: high quality under the ``ceiling`` and ``sky`` environment lights (tens of millions
   of triples), the oval cabochon and the carving, a fresh process each: wall time and peak
   memory. Target: <= 2 GB.
4. ``--compare``: a comparison of the three bundled ovals under bench and pendant against its own
   recommendations plus its renders (``benchmarks/compare_benchmark.py``). Target: <= 1.3x.

The section between the ``speed-ratio`` markers of the report is replaced; the rest is kept.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- speed-ratio: begin -->", "<!-- speed-ratio: end -->"

#: calls of each in the in-process measurement: the best (and the median) of this many
ROUNDS = 9

IN_PROCESS = r"""
import json, statistics, sys, time
import labcut
mesh = labcut.load_mesh(sys.argv[1])
rounds = int(sys.argv[2])
lab = labcut.Labradorite.preset("blue")
render = lambda: labcut.render(mesh, lab, (0, 0, 1), scenario="bench", spp=16, resolution=256, look="diagram", check_flash=False)
recommend = lambda: labcut.recommend_orientation(mesh, lab, scenario="bench", quality="standard")
def timed(f, n):
    out = []
    for _ in range(n):
        s = time.perf_counter(); f(); out.append(time.perf_counter() - s)
    return out
recommend(); render(); recommend(); render()
r = timed(render, rounds)  # the renders, then the recommendations (as the earlier rounds measured)
t = timed(recommend, rounds)
ri, ti = [], []  # interleaved: each recommendation right after a render (whose arrays left the caches)
for _ in range(rounds):
    ri += timed(render, 1)
    ti += timed(recommend, 1)
rec = recommend()
u = rec.uncertainty
print(json.dumps({"render": min(r), "recommend": min(t), "render_median": statistics.median(r),
                  "recommend_median": statistics.median(t), "render_interleaved": min(ri),
                  "recommend_interleaved": min(ti), "rounds": rounds,
                  "tilt": rec.tilt_deg, "bar_deg": u.angle_deg, "bar_score": u.score_rel}))
"""

BIG = r"""
import json, resource, sys, time
t0 = time.perf_counter()
import labcut
mesh = labcut.load_mesh(sys.argv[1])
t1 = time.perf_counter()
rec = labcut.recommend_orientation(mesh, "blue", scenario="bench", quality="standard")
t2 = time.perf_counter()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
from labcut import planner
copy = planner.pilot_mesh(mesh)  # what the pilots render (a first plan built it already), after the figures
print(json.dumps({"faces": len(mesh.faces), "load": t1 - t0, "recommend": t2 - t1, "tilt": rec.tilt_deg,
                  "azimuth": rec.azimuth_deg, "normal": [float(x) for x in rec.normal], "bar_deg": rec.uncertainty.angle_deg,
                  "rss_mb": rss, "pilot_faces": len(copy.faces), "on_copy": copy is not mesh}))
"""


ENV = r"""
import json, resource, sys, time
t0 = time.perf_counter()
import labcut
mesh = labcut.load_mesh(sys.argv[1])
rec = labcut.recommend_orientation(mesh, "blue", lighting=sys.argv[2], quality="high")
print(json.dumps({"seconds": time.perf_counter() - t0, "triples": rec.settings["triples"], "tilt": rec.tilt_deg,
                  "bar_deg": rec.uncertainty.angle_deg, "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def user_env() -> dict:
    """This environment as a user's shell has it: Python may write its bytecode caches
    (``PYTHONDONTWRITEBYTECODE`` unset), so a process after the first imports labcut's modules
    from them rather than compiling every one again (about 0.15 s of a CLI call)."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def child(code: str, *args: str, env: dict | None = None) -> dict:
    env = user_env() if env is None else env
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


#: what labcut keeps per stone in its user cache (a never-seen stone has none of it): the planner's
#: pilot renders, its depth exposure, the smooth-shaded split copy (under tables/)
PER_STONE = ("planner-pilot.json", "depth-exposure.json")
PER_STONE_TABLES = ("smooth-split-",)


def cold_pilot_env(folder: Path) -> dict:
    """The environment of a process whose labcut cache (XDG_CACHE_HOME) holds everything this
    machine's does (calibrations, material tables, Dr.Jit's kernels) but what labcut keeps per stone
    (:data:`PER_STONE`: the pilot renders, the depth exposure, the smooth split): a stone's first
    plan."""
    from platformdirs import user_cache_dir

    real = Path(user_cache_dir("labcut"))
    mine = folder / "cache" / "labcut"
    mine.mkdir(parents=True, exist_ok=True)
    for entry in real.iterdir() if real.exists() else ():
        if entry.name in PER_STONE or (mine / entry.name).exists():
            continue
        if entry.name == "tables" and entry.is_dir():
            (mine / "tables").mkdir(exist_ok=True)
            for table in entry.iterdir():
                if not table.name.startswith(PER_STONE_TABLES):
                    (mine / "tables" / table.name).symlink_to(table)
            continue
        (mine / entry.name).symlink_to(entry)
    return {**user_env(), "XDG_CACHE_HOME": str(folder / "cache")}


def process_seconds(cmd: list[str]) -> float:
    """Wall time of a fresh process running ``cmd``: the best of three, after one warm-up run
    (Dr.Jit's kernel cache, the time-budget calibration, Python's bytecode caches: :func:`user_env`)."""
    env = user_env()
    subprocess.run(cmd, capture_output=True, check=True, env=env)
    best = []
    for _ in range(3):
        t = time.perf_counter()
        subprocess.run(cmd, capture_output=True, check=True, env=env)
        best.append(time.perf_counter() - t)
    return min(best)


def cli_seconds(mesh: Path, *options: str) -> float:
    """The CLI call's best wall time; after the warm-up run an identical call reads the answer the
    command remembers (labcut_cli.answers) unless ``options`` hold ``--recompute``."""
    exe = Path(sys.executable).with_name("labcut")
    return process_seconds([str(exe), "recommend-orientation", str(mesh), "--scenario", "bench", "--json", "-", *options])


#: the libraries every computed CLI call imports: labcut (which registers its BSDF plugin with Mitsuba,
#: bringing Dr.Jit), the stone's mesh type (trimesh, with the scipy and networkx modules it
#: imports), the CLI's typer and rich. No Mitsuba variant: a convex stone's recommendation never
#: loads one
FLOOR = "import labcut, trimesh, mitsuba, typer, rich.table"


def floor_seconds(code: str = FLOOR) -> float:
    """A fresh process that only imports ``code``'s libraries (:data:`FLOOR`)."""
    return process_seconds([sys.executable, "-c", code])


def subdivided(levels: int, folder: Path) -> Path:
    import trimesh

    mesh = trimesh.load(ROOT / "meshes" / "carving-biplane.ply", process=False)
    v, f = mesh.vertices, mesh.faces
    for _ in range(levels):
        v, f = trimesh.remesh.subdivide(v, f)
    path = folder / f"biplane-{len(f)}.ply"
    trimesh.Trimesh(v, f, process=False).export(path)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    parser.add_argument("--big", action="store_true", help="also the subdivided carvings (a few minutes)")
    parser.add_argument("--env", action="store_true", help="also high quality under environment lights (a few minutes)")
    parser.add_argument("--compare", action="store_true",
                        help="also a comparison against its own recommendations (benchmarks/compare_benchmark.py, about a minute)")
    args = parser.parse_args()
    oval = ROOT / "meshes" / "oval-16x12-low.ply"
    inproc = child(IN_PROCESS, str(oval), str(ROUNDS))
    cli = cli_seconds(oval)
    cli_computed = cli_seconds(oval, "--recompute")
    floor = floor_seconds()
    print(inproc, cli, cli_computed, floor)
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), platform.processor())
    lines = [BEGIN, "", "## Recommendation time in renders", "",
             f"Made by `.venv/bin/python benchmarks/speed_ratio.py{' --big' if args.big else ''}{' --env' if args.env else ''}"
             f"{' --compare' if args.compare else ''}` on {os.cpu_count()} cores "
             f"({cpu}). The unit is one 256 x 256, 16 spp render of the same stone in the same process "
             f"({inproc['render']:.3f} s here), so the ratios compare across machines. The recommendation includes its "
             "error bars (the answer's flash problem, and the stencil sums of two more built as pairs: half the "
             "directions from the same surface samples, twice the rocking poses).", "",
             "| what | seconds | in renders | target |", "|---|---|---|---|",
             f"| standard recommendation, oval cabochon, bench, warm in-process (best of {inproc['rounds']} calls; the "
             f"render: best of {inproc['rounds']} before them) | {inproc['recommend']:.3f} s | "
             f"{inproc['recommend'] / inproc['render']:.2f} | <= 1 render |",
             f"| the same, medians (render {inproc['render_median']:.3f} s) | "
             f"{inproc['recommend_median']:.3f} s | {inproc['recommend_median'] / inproc['render_median']:.2f} | |",
             f"| the same, each recommendation right after a render (best of {inproc['rounds']} such pairs; render "
             f"{inproc['render_interleaved']:.3f} s) | {inproc['recommend_interleaved']:.3f} s | "
             f"{inproc['recommend_interleaved'] / inproc['render_interleaved']:.2f} | |",
             f"| the same as a CLI call asked again (`labcut recommend-orientation meshes/oval-16x12-low.ply --scenario bench "
             f"--json -`: the answer the command remembers, the mesh not loaded) | {cli:.2f} s | "
             f"{cli / inproc['render']:.1f} | <= 1 s |",
             f"| the same CLI call computed (`... --recompute`) | {cli_computed:.2f} s | "
             f"{cli_computed / inproc['render']:.1f} | |",
             f"| a process that only imports the libraries a computed CLI call loads (labcut, trimesh, Mitsuba, "
             f"typer, rich: `python -c \"{FLOOR}\"`) | {floor:.2f} s | {floor / inproc['render']:.1f} | |",
             "", "Every process here runs with Python's bytecode caches written and read, as in a user's shell "
             "(`PYTHONDONTWRITEBYTECODE` unset), after one warm-up run.", "",
             f"Answer: tilt {inproc['tilt']:.1f}° ± {inproc['bar_deg']:.1f}°, score ± {inproc['bar_score']:.0%}.", ""]
    if args.big:
        from labcut.planner import PILOT_CELLS, PILOT_FACES

        with tempfile.TemporaryDirectory() as tmp:
            rows = []
            for levels in (0, 4, 5):  # 4.8 k, 1.2 M and 4.9 M triangles
                path = subdivided(levels, Path(tmp)) if levels else ROOT / "meshes" / "carving-biplane.ply"
                child(BIG, str(path))  # warm: the planner's pilot renders of this stone, cached on disk
                rows.append(child(BIG, str(path)))
                # the stone's first plan: its pilot renders not cached yet (everything else as here)
                rows[-1]["first"] = child(BIG, str(path), env=cold_pilot_env(Path(tmp) / f"cold-{levels}"))
                print(rows[-1])
        import numpy as np

        base = np.asarray(rows[0]["normal"])
        lines += ["## Big meshes", "",
                  "The bundled biplane carving and the same surface subdivided (trimesh's 4-to-1 subdivision), each loaded "
                  "and recommended (standard, bench) in a fresh process (load includes `import labcut`), with the "
                  "planner's pilot renders of the stone's inter-reflection cached on disk (by the mesh's contents) as "
                  "after its first plan; the last two columns are that first plan, the pilot renders not cached (the rest "
                  "of the cache as it is: a new stone on a machine that has run labcut before), whose pilots render a "
                  f"copy clustered to {PILOT_CELLS} cells along the diagonal above {PILOT_FACES:,} triangles "
                  "(`labcut.geometry.proxy`). Targets for 5 M triangles: "
                  "load + recommend <= 10 s, peak memory <= 2 GB, the same answer within its error bar.", "",
                  "| triangles | load | recommend | total | peak memory | tilt | angle to the original's answer | error bar "
                  "| first plan of the stone: load + recommend | its peak memory | what its pilots render |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in rows:
            ang = float(np.degrees(np.arccos(min(1.0, abs(float(np.dot(base, r["normal"])))))))
            lines.append(f"| {r['faces']:,} | {r['load']:.1f} s | {r['recommend']:.1f} s | {r['load'] + r['recommend']:.1f} s | "
                         f"{r['rss_mb']:.0f} MB | {r['tilt']:.1f}° | {ang:.2f}° | ±{r['bar_deg']:.2f}° | "
                         f"{r['first']['load'] + r['first']['recommend']:.1f} s | {r['first']['rss_mb']:.0f} MB | "
                         + (f"a copy of {r['first']['pilot_faces']:,} triangles |" if r["first"]["on_copy"] else "the mesh |"))
        lines.append("")
    if args.env:
        lines += ["## High quality under environment lights", "",
                  "`recommend_orientation(mesh, \"blue\", lighting=..., quality=\"high\")` in a fresh process (including "
                  "`import labcut` and the load), each stone's pilot renders cached. Target: peak memory <= 2 GB.", "",
                  "| stone | lighting | (point, light, view) triples | wall time | peak memory | tilt |",
                  "|---|---|---|---|---|---|"]
        for name, mesh in (("oval cabochon", "oval-16x12-low.ply"), ("biplane carving", "carving-biplane.ply")):
            for lighting in ("ceiling", "sky"):
                path = str(ROOT / "meshes" / mesh)
                if name == "biplane carving":  # its first plan makes the pilot renders: cached for the measured run
                    child(ENV, path, lighting)
                r = child(ENV, path, lighting)
                print(name, lighting, r)
                lines.append(f"| {name} | {lighting} | {r['triples']:,} | {r['seconds']:.1f} s | {r['rss_mb']:.0f} MB | "
                             f"{r['tilt']:.1f}° ± {r['bar_deg']:.1f}° |")
        lines.append("")
    if args.compare:
        with tempfile.TemporaryDirectory() as tmp:
            figures = Path(tmp) / "compare.json"
            subprocess.run([sys.executable, str(ROOT / "benchmarks" / "compare_benchmark.py"), "--repeat", "2", "--json",
                            str(figures)], check=True, capture_output=True, env=user_env())
            c = json.loads(figures.read_text())
        last = c["runs"][-1]
        lines += ["## A comparison against its own recommendations", "",
                  f"`labcut.compare_cuts` of the {c['cuts']} bundled ovals x {', '.join(c['scenarios'])} at {c['quality']} "
                  "quality in one process (`benchmarks/compare_benchmark.py`: the second, warm run of two), against the "
                  "sum of its own recommendations (`Study.recommend`, which builds each cut's flash problem once) and its "
                  "renders. Target: at most 1.3x.", "",
                  "| compare_cuts | its recommendations | its renders | ratio |", "|---|---|---|---|",
                  f"| {last['compute']:.1f} s | {c['recommendations']:.1f} s | {c['renders']:.1f} s | {c['ratio']:.2f}x |", ""]
    lines.append(END)
    out = Path(args.out)
    text = out.read_text() if out.exists() else ""
    block = "\n".join(lines)
    if BEGIN in text and END in text:
        text = text[:text.index(BEGIN)] + block + text[text.index(END) + len(END):]
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    out.write_text(text)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
