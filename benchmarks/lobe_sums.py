"""Cost per lobe term of the energy map's block sums: the einsum form against the broadcast form.

    .venv/bin/python benchmarks/lobe_sums.py [--out docs/performance.md]

``labcut.orientation.scoring._lobe_sums`` (the energy map, its single normals, rings and the
hemisphere map) evaluates Σ_b a_b exp(κ(|h_b·m_k| - 1)) over (normals x bins) blocks. It writes
the block's dot products in one ``einsum`` pass with κ folded into the normals; the form it
replaced wrote them as three broadcast multiply-adds (two (k, n) temporaries, five passes). This
prints nanoseconds per term of each over block shapes the map meets (a ring of 16 normals over
a tile union, a map tile, one normal) and their largest relative difference. Single-threaded
numpy, float64; figures move by ±30 % with other load on the machine. The table replaces the
section between the ``lobe-sums`` markers of the report (printed too).
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from labcut.orientation.scoring import _lobe_sums

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- lobe-sums: begin -->", "<!-- lobe-sums: end -->"
KAPPA = 365.0  # the blue preset's lobe (3° spread)


def broadcast_form(m: np.ndarray, ht: np.ndarray, a: np.ndarray, kappa: float) -> np.ndarray:
    """The form before: dot products as three broadcast multiply-adds, then abs, shift, scale, exp."""
    hx, hy, hz = ht
    d = np.multiply(m[:, 0:1], hx[None, :])
    tmp = np.multiply(m[:, 1:2], hy[None, :])
    d += tmp
    np.multiply(m[:, 2:3], hz[None, :], out=tmp)
    d += tmp
    np.abs(d, out=d)
    d -= 1.0
    d *= kappa
    np.exp(d, out=d)
    return np.einsum("kb,b->k", d, a)


def per_term_ns(f, m: np.ndarray, ht: np.ndarray, a: np.ndarray) -> float:
    reps = max(3, int(2e7 // (len(m) * ht.shape[1])))
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        for _ in range(reps):
            f(m, ht, a, KAPPA)
        best = min(best, (time.perf_counter() - t) / reps)
    return best / (len(m) * ht.shape[1]) * 1e9


def table() -> list[str]:
    rng = np.random.default_rng(0)
    rows = ["| block (normals x bins) | einsum form, ns/term | broadcast form, ns/term | speed-up | largest relative difference |",
            "|---|---|---|---|---|"]
    for k, n, what in [(16, 15000, "a ring over a tile union"), (50, 100, "a map tile"), (300, 2000, "many normals, one tile"),
                       (1, 20000, "one normal over a union")]:
        m = rng.normal(size=(k, 3))
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        h = m[rng.integers(0, k, n)] + 0.05 * rng.normal(size=(n, 3))
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        ht, a = np.ascontiguousarray(h.T), rng.random(n)
        new, old = per_term_ns(_lobe_sums, m, ht, a), per_term_ns(broadcast_form, m, ht, a)
        ref = broadcast_form(m, ht, a, KAPPA)
        diff = float(np.max(np.abs(_lobe_sums(m, ht, a, KAPPA) - ref) / np.maximum(ref, 1e-300)))
        rows.append(f"| {k} x {n} ({what}) | {new:.2f} | {old:.2f} | {old / new:.1f}x | {diff:.1e} |")
        if k == 16:  # the same union gathered by column fancy indexing: rows with a stride of 3
            strided = np.ascontiguousarray(h).T[:, np.arange(n)]
            assert not strided.flags.c_contiguous
            slow = per_term_ns(_lobe_sums, m, strided, a)
            rows.append(f"| {k} x {n}, the union strided (`ht[:, idx]` instead of `ht.take(idx, axis=1)`) | {slow:.2f} | | "
                        f"{slow / new:.1f}x slower than contiguous | |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = parser.parse_args()
    rows = table()
    print("\n".join(rows))
    section = [BEGIN, "", f"Made by `.venv/bin/python benchmarks/lobe_sums.py` on {platform.processor() or platform.machine()}, "
               "one core (numpy), float64, best of three.", "", *rows, "", END]
    out = Path(args.out)
    text = out.read_text()
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        text = head + "\n".join(section) + rest.split(END, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + "\n".join(section) + "\n"
    out.write_text(text)
    print(f"written to {out}")


if __name__ == "__main__":
    main()
