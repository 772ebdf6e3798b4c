"""How fast ``labcut explore`` answers (issue 35): from a control change sent over the page's
WebSocket to the answer (score map and metrics) and to the first picture (the preview), for the
bundled stones at standard quality, as the page sees it.

    .venv/bin/python benchmarks/explore_latency.py [--quality standard] [--stone meshes/oval-16x12-low.ply ...]
        [--json benchmarks/data/explore-latency.json]

For each stone the explorer is started in this process (``labcut.explore``, its server on a
thread), a WebSocket client connects as the page does, and waits until the first pictures are
done; then it makes changes one at a time, each after the pictures of the last one are done
("settled"): the lamp's elevation (4 steps), the material (3: two presets and a flash peak) and
the lamella normal (4). One lamp change more is made while the refined picture of the last one
is still under way ("during refinement": it waits for the pass in flight). Every lamp, material
and normal is one the session has not seen, so each lamp or material change builds its Study.

Prints a markdown table (docs/explore.md) and the machine's load, then the process's user and system
CPU time over each answer (the server runs in this process); ``--json`` keeps every figure.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import resource
import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STONES = ["oval-16x12-low", "oval-16x12-medium", "oval-16x12-high", "round-12-low", "round-12-high",
          "buff-top-oval-16x12", "double-cabochon-oval-16x12", "step-cut-12x10", "carving-biplane"]

LAMP = [{"lamp_elevation": e} for e in (61.3, 47.9, 74.2, 90.0)]
MATERIAL = [{"material": "green"}, {"material": "gold"}, {"material": "peak", "peak_nm": 503.0}]
NORMAL = [{"normal_tilt": t, "normal_azimuth": a} for t, a in ((4.0, 270.0), (11.5, 250.0), (20.0, 90.0), (2.0, 0.0))]


async def measure(url: str, timeout: float = 600.0) -> dict[str, list[float]]:
    import tornado.websocket

    ws = await tornado.websocket.websocket_connect(url.replace("http", "ws") + "ws", max_message_size=1 << 28)
    ident = [0]
    before = [resource.getrusage(resource.RUSAGE_SELF)]

    async def next_message() -> dict:
        return json.loads(await asyncio.wait_for(ws.read_message(), timeout))

    async def ask(op: str, changes: dict | None = None, settle: bool = True) -> tuple[float, float, dict]:
        ident[0] += 1
        before[0] = resource.getrusage(resource.RUSAGE_SELF)
        sent = time.perf_counter()
        ws.write_message(json.dumps({"op": op, "id": ident[0], **({"changes": changes} if changes else {})}))
        answered = preview = None
        generation = None
        view = {}
        while True:
            m = await next_message()
            if m["type"] == "error" and ident[0] in m.get("ids", []):
                raise RuntimeError(m["message"])
            if m["type"] == "view" and ident[0] in m["ids"]:
                answered, generation, view = time.perf_counter() - sent, m["generation"], m["view"]
                now = resource.getrusage(resource.RUSAGE_SELF)  # the server runs in this process
                view["_cpu_ms"] = (1000.0 * (now.ru_utime - before[0].ru_utime), 1000.0 * (now.ru_stime - before[0].ru_stime))
                if not settle:
                    return answered, float("nan"), view
            if m["type"] == "render" and generation is not None and m["generation"] >= generation and preview is None:
                preview = time.perf_counter() - sent
            if m["type"] == "render-done" and generation is not None and m["generation"] >= generation:
                return answered, preview, view

    await next_message()  # the controls' spec
    t = time.perf_counter()
    _, _, first = await ask("hello")
    out: dict[str, list[float]] = {"first view and pictures (s)": [time.perf_counter() - t]}
    for kind, changes in (("lamp", LAMP), ("material", MATERIAL), ("normal", NORMAL)):
        for change in changes:
            answered, preview, view = await ask("set", change)
            out.setdefault(f"{kind}: answer", []).append(answered * 1000)
            out.setdefault(f"{kind}: preview", []).append(preview * 1000)
            out.setdefault(f"{kind}: server's own ms", []).append(view["timings_ms"]["total"])
            out.setdefault(f"{kind}: user CPU ms", []).append(view["_cpu_ms"][0])
            out.setdefault(f"{kind}: system CPU ms", []).append(view["_cpu_ms"][1])
    # one more lamp change while the refined picture is under way
    ident[0] += 1
    ws.write_message(json.dumps({"op": "set", "id": ident[0], "changes": {"lamp_elevation": 66.6}}))
    while True:
        m = await next_message()
        if m["type"] == "render" and m["stage"] == "refined":
            break
    answered, _, _ = await ask("set", {"lamp_elevation": 55.5}, settle=False)
    out["lamp during refinement: answer"] = [answered * 1000]
    ws.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--stone", action="append", help="mesh paths (default: the bundled stones)")
    parser.add_argument("--json", type=Path, help="write every figure here")
    args = parser.parse_args()

    import labcut

    stones = args.stone or [str(ROOT / "meshes" / f"{s}.ply") for s in STONES]
    results = {}
    for path in stones:
        ex = labcut.explore(path, quality=args.quality)
        try:
            results[Path(path).stem] = asyncio.run(measure(ex.url))
        finally:
            ex.stop()
        r = results[Path(path).stem]
        print(f"{Path(path).stem}: lamp {statistics.median(r['lamp: answer']):.0f} ms, "
              f"material {statistics.median(r['material: answer']):.0f} ms, normal {statistics.median(r['normal: answer']):.0f} ms",
              flush=True)

    cols = ["lamp: answer", "lamp: preview", "material: answer", "material: preview", "normal: answer", "normal: preview",
            "lamp during refinement: answer"]
    print(f"\n{args.quality} quality; {platform.node()}, {os.cpu_count()} cores, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}; median (max) ms from the change sent to the message received\n")
    print("| stone | " + " | ".join(cols) + " |")
    print("|---|" + "---:|" * len(cols))
    for name, r in results.items():
        cells = []
        for c in cols:
            v = r[c]
            cells.append(f"{statistics.median(v):.0f}" + (f" ({max(v):.0f})" if len(v) > 1 else ""))
        print(f"| {name} | " + " | ".join(cells) + " |")
    cpu = ["lamp: user CPU ms", "lamp: system CPU ms", "material: user CPU ms", "material: system CPU ms"]
    print("\nCPU time of the process (all threads) from the change sent to the answer, median (max) ms: the system "
          "time is the kernel's, most of it clearing fresh pages (docs/performance.md, \"fresh memory\")\n")
    print("| stone | " + " | ".join(cpu) + " |")
    print("|---|" + "---:|" * len(cpu))
    for name, r in results.items():
        print(f"| {name} | " + " | ".join(f"{statistics.median(r[c]):.0f} ({max(r[c]):.0f})" for c in cpu) + " |")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"quality": args.quality, "cores": os.cpu_count(), "results": results}, indent=1) + "\n")


if __name__ == "__main__":
    main()
