#!/usr/bin/env python
"""Accuracy, behaviour and speed of labcut's lamella physics; writes a markdown report.

Usage (from the repository root)::

    .venv/bin/python benchmarks/physics_accuracy.py                       # -> docs/physics-accuracy.md
    .venv/bin/python benchmarks/physics_accuracy.py --out report.md
    .venv/bin/python benchmarks/physics_accuracy.py --quick               # < 1 min, report on stdout

Sections of the report:

1. Monte Carlo: ``labcut.physics.lamella_intensity`` against an independent
   average of explicit random stacks (own implementation, nothing shared with
   the code under test), over wavelength x cos(theta) x sigma.
2. float32 Dr.Jit against float64 numpy: worst absolute error of
   ``Labradorite.reflectance`` on a dense grid (plus points packed around every
   Bragg peak), and the printed closed form evaluated in float32 for contrast.
3. Model behaviour: peak shift against sigma, the paper's Fig. 8 series, the
   presets, ``from_anorthite``, tilt, perfect stacks, saturation, and what the
   one-angle approximation leaves out (exact Snell / Fresnel between phases).
4. Speed: evaluations per second of ``reflectance`` in numpy float64 and in
   Dr.Jit LLVM float32.

The full run takes a few minutes on 2 cores; ``--quick`` uses fewer stacks and
coarser grids. Results are deterministic for a given ``--seed`` (timings aside).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import platform
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import labcut  # noqa: F401  (configures Dr.Jit's libLLVM and cache before drjit loads)
from labcut.physics.search import golden_section_max
from labcut import Labradorite
from labcut.physics import bragg_wavelength, interface_reflectance, lamella_intensity

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
import tmm  # noqa: E402
N_A, N_B, N_SURFACE = 1.555, 1.562, 1.56
TWO_PI = 2.0 * math.pi


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- helpers
def fmt(x: float, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "NaN"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    return f"{x:.{digits}g}"


def table(header: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def f32(x: np.ndarray) -> np.ndarray:
    """The float32 value a kernel sees, back in float64 (input rounding is not an error)."""
    return np.asarray(x, dtype=np.float32).astype(np.float64)


def machine_info() -> dict[str, str]:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        nproc = subprocess.run(["nproc"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        nproc = str(os.cpu_count())
    try:
        load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        load = "unknown"
    return {"nproc": nproc, "cpu": cpu, "load": load}


def git_info() -> str:
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "labcut/physics", "labcut/colour.py"],
                               cwd=REPO, capture_output=True, text=True, check=True).stdout.strip()
        return head + (" (labcut/physics or colour.py modified)" if dirty else " (physics code as committed)")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def command_line() -> str:
    exe = sys.executable
    try:
        rel = os.path.relpath(exe)
        exe = rel if not rel.startswith("..") else exe
    except ValueError:
        pass
    script = os.path.relpath(sys.argv[0]) if not os.path.relpath(sys.argv[0]).startswith("..") else sys.argv[0]
    return " ".join(shlex.quote(a) for a in [exe, script, *sys.argv[1:]])


# ----------------------------------------------------------------------------- 1. Monte Carlo
def mc_plan(lam: float, c: float, s_a: float, s_b: float, min_pairs: int = 30) -> tuple[int, int]:
    """Burn-in pairs n1 (correlations decay as (ab)^n: e^-8 left) and measured pairs m."""
    k_a = 4.0 * math.pi * N_A * c / lam
    k_b = 4.0 * math.pi * N_B * c / lam
    one_ab = -math.expm1(-(0.5 * (k_a * s_a) ** 2 + 0.5 * (k_b * s_b) ** 2))
    n1 = max(min_pairs, int(math.ceil(8.0 / one_ab)))
    return n1, int(math.ceil(1.5 * n1))


def monte_carlo_intensity(lam, c, d_a, d_b, s_a, s_b, stacks, seed, max_elems=2_000_000):
    """Stationary I = <|V|²>/(2Nr²) of explicit random stacks, with its standard error.

    Each stack has 2L interfaces (L = n1 + m pairs) at positions built from
    Gaussian thicknesses; V_n = sum over the first 2n interfaces of (-1)^j exp(iΦ_j),
    Φ_j the round-trip phase to interface j (one angle in both phases). The
    per-stack estimate (|V_L|² - |V_n1|²)/(2m) is the growth of <|V|²> per pair
    away from the ends of the stack, so the O(1/N) end terms of a finite stack
    cancel: its mean is the infinite-stack I up to terms ~ (ab)^n1 ~ e^-8.
    """
    k_a = 4.0 * math.pi * N_A * c / lam
    k_b = 4.0 * math.pi * N_B * c / lam
    n1, m = mc_plan(lam, c, s_a, s_b)
    pairs = n1 + m
    rng = np.random.default_rng(seed)
    chunk = max(1, min(stacks, max_elems // (2 * pairs)))
    sign = np.where(np.arange(2 * pairs) % 2 == 0, 1.0, -1.0).astype(np.float32)
    h = 2 * n1
    total = total2 = 0.0
    done = 0
    while done < stacks:
        k = min(chunk, stacks - done)
        steps = rng.standard_normal((k, 2 * pairs - 1))  # layer j between interfaces j and j+1
        steps[:, 0::2] *= k_a * s_a
        steps[:, 0::2] += k_a * d_a
        steps[:, 1::2] *= k_b * s_b
        steps[:, 1::2] += k_b * d_b
        phase = np.zeros((k, 2 * pairs))
        np.cumsum(steps, axis=1, out=phase[:, 1:])
        phase -= TWO_PI * np.rint(phase / TWO_PI)  # exact reduction in float64, then fast float32 trig
        p32 = phase.astype(np.float32)
        cos_p, sin_p = np.cos(p32), np.sin(p32)
        re1, im1 = (cos_p[:, :h] @ sign[:h]).astype(np.float64), (sin_p[:, :h] @ sign[:h]).astype(np.float64)
        re2 = re1 + (cos_p[:, h:] @ sign[h:]).astype(np.float64)
        im2 = im1 + (sin_p[:, h:] @ sign[h:]).astype(np.float64)
        est = ((re2 * re2 + im2 * im2) - (re1 * re1 + im1 * im1)) / (2.0 * m)
        total += float(est.sum())
        total2 += float((est * est).sum())
        done += k
    mean = total / stacks
    var = max(total2 / stacks - mean * mean, 0.0)
    return mean, math.sqrt(var / stacks), n1, m


def printed_eq9(lam, c, d_a, d_b, s_a, s_b):
    """The paper's eq. 9 exactly as printed (with α = (p σ)²/2, σ absolute, in place of eq. 8)."""
    p_a = 4.0 * math.pi * N_A * c / lam
    p_b = 4.0 * math.pi * N_B * c / lam
    a, b = math.exp(-0.5 * (p_a * s_a) ** 2), math.exp(-0.5 * (p_b * s_b) ** 2)
    big_m, big_n = 0.5 * (p_a * d_a + p_b * d_b), 0.5 * (p_a * d_a - p_b * d_b)
    e2 = (a * b) ** 2
    return (1 - e2) * (1 - math.cos(big_m) * math.cos(big_n) * (a - b) / (1 - e2)
                       + math.sin(big_m) * math.sin(big_n) * (a + b) / (1 + e2)) / (1 + e2 - 2 * math.cos(2 * big_m) * a * b)


def section_monte_carlo(quick: bool, stacks: int, seed: int) -> tuple[str, dict]:
    log("[1/6] Monte Carlo ...")
    t0 = time.perf_counter()
    if quick:
        wavelengths = [380.0, 530.0, 680.0, 780.0]
        cosines = [1.0, 0.6]
        sigmas = [12.0, 24.0]
    else:
        wavelengths = [float(w) for w in range(380, 781, 50)]
        cosines = [1.0, 0.8, 0.6]
        sigmas = [8.0, 12.0, 16.0, 24.0, 35.0]
    d_a, d_b = 85.0, 68.0
    rows = []
    errs, zs, printed = [], [], []
    point = 0
    for s in sigmas:
        s_a, s_b = s, 0.75 * s
        for c in cosines:
            for lam in wavelengths:
                point += 1
                mc, se, n1, m = monte_carlo_intensity(lam, c, d_a, d_b, s_a, s_b, stacks, seed + 7919 * point)
                an = float(lamella_intensity(lam, c, N_A, N_B, d_a, d_b, s_a, s_b))
                err = (mc - an) / an
                errs.append(abs(err))
                zs.append((mc - an) / se)
                pr = printed_eq9(lam, c, d_a, d_b, s_a, s_b) / mc
                printed.append(pr)
                rows.append([fmt(s_a, 3), fmt(s_b, 3), fmt(c, 2), fmt(lam, 4), f"{n1}+{m}", fmt(an, 5), fmt(mc, 5),
                             f"{100 * se / an:.2f}", f"{100 * err:+.2f}", f"{(mc - an) / se:+.2f}", f"{pr:.3f}"])
    errs_a, zs_a = np.array(errs), np.array(zs)
    stats = {
        "points": len(errs),
        "stacks": stacks,
        "max_rel": float(errs_a.max()),
        "median_rel": float(np.median(errs_a)),
        "rms_z": float(np.sqrt(np.mean(zs_a**2))),
        "max_abs_z": float(np.abs(zs_a).max()),
        "printed_min": float(min(printed)),
        "printed_max": float(max(printed)),
        "seconds": time.perf_counter() - t0,
    }
    bragg = float(bragg_wavelength(1.0, N_A, N_B, d_a, d_b))
    text = f"""## 1. Monte Carlo check of `lamella_intensity`

Independent estimate of I = <|V|²>/(2Nr²) from explicit random stacks (code in
this script, nothing shared with `labcut.physics`): interfaces at positions
built from Gaussian thicknesses, amplitude ±r alternating, round-trip phase
Φ_j = Σ p_x t_x with one angle in both phases. To remove the O(1/N) end terms of
a finite stack, each stack is n1 + m pairs long and contributes
(|V_(n1+m)|² − |V_n1|²)/(2m), the growth of |V|² per pair away from the ends
(n1 ≥ 8/(1−ab), so the neglected correlations are ~e^-8). The analytic value is the
infinite stack (`pairs=None`).

Stack: n_a = {N_A}, n_b = {N_B}, d_a = {d_a:g} nm, d_b = {d_b:g} nm (unequal, so the a/b
asymmetry of the formula is exercised; first-order Bragg peak at normal incidence
{bragg:.1f} nm), σ_a = σ, σ_b = 0.75 σ. {stacks} stacks per point, {stats['points']} points.
"SE" is the Monte Carlo standard error (from the per-stack variance), "z" the
error in units of SE: if the formula is right, z behaves like a standard normal
variable.

**Result: max |relative error| {100 * stats['max_rel']:.2f} %, median {100 * stats['median_rel']:.2f} %;
RMS z = {stats['rms_z']:.2f}, max |z| = {stats['max_abs_z']:.2f}** (run time {stats['seconds']:.0f} s).
The Monte Carlo uses the same one-angle geometry as the model: it checks the
statistics (the closed form), not the approximations of physics.md §3.

The last column is the paper's eq. 9 exactly as printed ((a−b)/(1−a²b²) and
(a+b)/(1+a²b²) in place of (a+b)/(1+ab) and (a−b)/(1−ab)), with the correct
α = (pσ)²/2, divided by the Monte Carlo value: {stats['printed_min']:.2f} to {stats['printed_max']:.2f}.

"""
    text += table(["σ_a nm", "σ_b nm", "cos θ", "λ nm", "pairs n1+m", "I formula", "I Monte Carlo",
                   "SE %", "error %", "z", "printed eq. 9 / MC"], rows)
    return text, stats


# ----------------------------------------------------------------------------- 2. float32 vs float64
def printed_form(wl, c, lab: Labradorite, dtype):
    """DESIGN.md's corrected closed form (product form with M, N), evaluated naively in ``dtype``.

    I = (1-a²b²)[1 - cosM cosN (a+b)/(1+ab) + sinM sinN (a-b)/(1-ab)] / [1 + a²b² - 2ab cos 2M],
    with the same finite-stack damping as the library, R = tanh²(sqrt(2 N r² I)).
    """
    wl = np.asarray(wl, dtype=dtype)
    c = np.abs(np.asarray(c, dtype=dtype))
    one = dtype(1.0)
    k = dtype(4.0 * math.pi) * c / wl
    p_a, p_b = k * dtype(lab.n_a), k * dtype(lab.n_b)
    phi_a, phi_b = p_a * dtype(lab.d_a), p_b * dtype(lab.d_b)
    inv = dtype(1.0 / (math.pi**2 * lab.pairs))
    al_a = dtype(0.5) * (p_a * dtype(lab.sigma_a)) ** 2 + phi_a * phi_a * inv
    al_b = dtype(0.5) * (p_b * dtype(lab.sigma_b)) ** 2 + phi_b * phi_b * inv
    a, b = np.exp(-al_a), np.exp(-al_b)
    M, N = dtype(0.5) * (phi_a + phi_b), dtype(0.5) * (phi_a - phi_b)
    ab = a * b
    with np.errstate(all="ignore"):
        num = (one - ab * ab) * (one - np.cos(M) * np.cos(N) * (a + b) / (one + ab)
                                 + np.sin(M) * np.sin(N) * (a - b) / (one - ab))
        den = one + ab * ab - dtype(2.0) * ab * np.cos(dtype(2.0) * M)
        intensity = num / den
        r2 = dtype(float(interface_reflectance(lab.n_a, lab.n_b)))
        t = np.tanh(np.sqrt(dtype(2.0 * lab.pairs) * r2 * intensity))
    return (t * t).astype(np.float64)


def dense_grid(lab: Labradorite, quick: bool) -> tuple[np.ndarray, np.ndarray]:
    """Regular λ x cos θ grid, log-spaced near grazing, plus points packed around Bragg peaks."""
    nl, nc = (236, 251) if quick else (941, 1001)
    wl = np.linspace(360.0, 830.0, nl)
    cs = np.concatenate([np.linspace(0.0, 1.0, nc), np.logspace(-8, -1, 15 if quick else 57)])
    W, C = np.meshgrid(wl, cs)
    wl_list, c_list = [W.ravel()], [C.ravel()]
    # around every Bragg peak in range: relative offsets ±1e-9 .. ±1e-2 and 0
    off = np.logspace(-9, -2, 15 if quick else 57)
    off = np.concatenate([-off[::-1], [0.0], off])
    for c in np.linspace(0.05, 1.0, 48 if quick else 191):
        for order in range(1, 40):
            peak = float(bragg_wavelength(c, lab.n_a, lab.n_b, lab.d_a, lab.d_b, order))
            if peak < 360.0:
                break
            if peak <= 830.0:
                wl_list.append(peak * (1.0 + off))
                c_list.append(np.full(off.size, c))
    return f32(np.concatenate(wl_list)), f32(np.concatenate(c_list))


def section_float32(quick: bool) -> tuple[str, dict]:
    log("[2/6] float32 vs float64 ...")
    from drjit.llvm import Float

    t0 = time.perf_counter()
    sigmas = [0.0, 1e-3, 0.5, 16.0, 100.0]
    pair_counts = [1, 100, 6000, 100_000]
    rows, naive_rows = [], []
    worst = 0.0
    points = 0
    algebra = 0.0
    for s in sigmas:
        for n in pair_counts:
            lab = Labradorite(sigma_a=s, sigma_b=s, pairs=n)
            wl, c = dense_grid(lab, quick)
            points = wl.size
            r64 = lab.reflectance(wl, c)
            r32 = np.array(lab.reflectance(Float(wl.astype(np.float32)), Float(c.astype(np.float32))),
                           dtype=np.float64)
            finite = bool(np.all(np.isfinite(r32)))
            inside = bool(finite and r32.min() >= 0.0 and r32.max() <= 1.0)
            err = np.abs(r32 - r64)
            i = int(np.nanargmax(err))
            worst = max(worst, float(err[i]))
            rows.append([fmt(s, 3), str(n), f"{err[i]:.2e}", f"{np.percentile(err, 99.9):.1e}",
                         f"{wl[i]:.3f}", f"{c[i]:.6g}", f"{r64[i]:.4f}", "yes" if inside else "**no**"])
            if n in (6000, 100_000) and s in (0.0, 1e-3, 0.5, 16.0):
                naive = printed_form(wl, c, lab, np.float32)
                bad = ~np.isfinite(naive)
                nerr = np.abs(np.where(bad, np.nan, naive) - r64)
                naive_rows.append([fmt(s, 3), str(n), f"{np.nanmax(nerr):.2e}", str(int(bad.sum())),
                                   f"{c[bad].max():.2g}" if bad.any() else "-", f"{err[i]:.2e}"])
            if s == 16.0 and n == 6000:
                # the closed form and the cancellation-free form are the same function in float64
                ref = printed_form(wl, c, lab, np.float64)
                ok = (c > 0.05)
                algebra = float(np.max(np.abs(ref[ok] - r64[ok]) / np.maximum(r64[ok], 1e-300)))
    stats = {"worst": worst, "points": points, "seconds": time.perf_counter() - t0, "algebra": algebra}
    text = f"""## 2. float32 (Dr.Jit LLVM) against float64 (numpy)

`Labradorite(sigma_a=σ, sigma_b=σ, pairs=N).reflectance` (default period 155 nm,
equal phase thicknesses) on ~{points / 1e6:.2f} M points per row: λ every 0.5 nm over 360-830 nm
(coarser with `--quick`) × cos θ on [0, 1] in steps of 0.001 plus log-spaced values down to
1e-8, plus points packed at relative offsets 0, ±1e-9 … ±1e-2 around every Bragg peak
in range. Inputs are rounded to float32 first and the float64 reference is evaluated
at the rounded values, so input rounding is not counted as error.

**Result: worst absolute error {worst:.1e} over all rows; every float32 value finite and in [0, 1]
where the last column says yes.**

"""
    text += table(["σ nm", "pairs", "max abs error", "99.9th pct", "at λ nm", "at cos θ", "R64 there",
                   "finite, in [0,1]"], rows)
    text += f"""
For contrast, the closed form as DESIGN.md §2 writes it after correcting the paper
(`(1−a²b²)[1 − cosM cosN (a+b)/(1+ab) + sinM sinN (a−b)/(1−ab)] / [1 + a²b² − 2ab cos 2M]`),
evaluated naively in float32 (numpy) on the same points with the same damping and
saturation. In float64 it agrees with the library to {algebra:.1e} relative
(σ = 16, N = 6000, cos θ > 0.05), so the two are the same function; in float32 it is not usable:

"""
    text += table(["σ nm", "pairs", "printed form: max abs error (finite values)", "non-finite values",
                   "largest cos θ with a non-finite value", "library float32: max abs error"], naive_rows)
    text += """
Ablation: the library's float32 path with the Bragg phase t = 2 cos θ (n_a d_a + n_b d_b)/λ
formed and reduced modulo 1 in float32 instead of float64 (`ops.wide`/`ops.narrow`
replaced by the identity for this table only), same points:

"""
    text += table(["σ nm", "pairs", "max abs error, phase in float32", "max abs error, phase in float64 (library)"],
                  ablation_rows(quick))
    stats["ablation_worst"] = max(float(r[2]) for r in ablation_rows(quick))
    return text, stats


_ABLATION: list[list[str]] = []


def ablation_rows(quick: bool) -> list[list[str]]:
    """Worst float32 error with the Bragg phase in float32 vs in float64 (cached)."""
    if _ABLATION:
        return _ABLATION
    from drjit.llvm import Float

    from labcut.physics.ops import _drjit_ops

    ops = _drjit_ops()
    saved = (ops.wide, ops.narrow)
    for s in (0.0, 0.5, 4.0, 16.0):
        for n in (1000, 100_000, 10_000_000):
            lab = Labradorite(sigma_a=s, sigma_b=s, pairs=n)
            wl, c = dense_grid(lab, quick)
            r64 = lab.reflectance(wl, c)
            errs = []
            for narrow_phase in (True, False):
                if narrow_phase:
                    ops.wide = ops.narrow = (lambda x: x)
                try:
                    r32 = np.array(lab.reflectance(Float(wl.astype(np.float32)), Float(c.astype(np.float32))))
                finally:
                    ops.wide, ops.narrow = saved
                errs.append(float(np.max(np.abs(r32 - r64))))
            _ABLATION.append([fmt(s, 3), str(n), f"{errs[0]:.2e}", f"{errs[1]:.2e}"])
    return _ABLATION


# ----------------------------------------------------------------------------- 3. behaviour
def transfer_matrix_reflectance(wl, theta_deg, lab: Labradorite, reals: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Exact unpolarised reflectance of random stacks (benchmarks/tmm.py: Rouard's recursion, Snell
    and exact Fresnel in every layer): mean of (R_s + R_p)/2 over realisations, and its SE."""
    return tmm.ensemble_mean(wl, theta_deg, lab, "u", reals, seed)


def fwhm(lab: Labradorite, peak: float, c: float = 1.0, quantity: str = "reflectance") -> float:
    """Full width at half maximum (nm) of R (or of the intensity I) around ``peak``, by bisection."""
    f = (lambda x: float(getattr(lab, quantity)(x, c)))
    half = 0.5 * f(peak)

    def edge(direction: float) -> float:
        step = peak * 1e-10
        inner = peak
        while True:
            x = peak + direction * step
            if x <= 1.0 or step > peak:
                return math.nan
            if f(x) < half:
                break
            inner = x
            step *= 1.5
        lo, hi = inner, x
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if f(mid) >= half:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    return edge(+1.0) - edge(-1.0)


def refine_peak(f, lo: float, hi: float, tol: float = 1e-11) -> float:
    """Golden-section maximum of a unimodal f on [lo, hi] (labcut's own search, tighter tolerance)."""
    return golden_section_max(f, lo, hi, tol)


def colour_cells(lab: Labradorite, c: float = 1.0) -> list[str]:
    col = lab.flash_colour(c)
    return [fmt(col.dominant_wavelength_nm, 4), f"{col.purity:.3f}", f"{col.luminance:.4f}", f"`{col.hex}`"]


def section_behaviour(quick: bool) -> tuple[str, dict]:
    log("[3/6] model behaviour ...")
    t0 = time.perf_counter()
    stats: dict = {}
    parts = ["## 3. Model behaviour\n"]

    # 3.1 peak shift against sigma
    rows = []
    for s in (0.0, 4.0, 8.0, 12.0, 16.0, 20.0, 30.0):
        lab = Labradorite(sigma_a=s, sigma_b=s)
        bragg = lab.bragg_wavelength()
        peak = lab.peak_wavelength()
        rows.append([fmt(s, 3), f"{bragg:.2f}", f"{peak:.2f}", f"{peak - bragg:+.3f}",
                     f"{lab.peak_reflectance():.4f}", f"{fwhm(lab, peak):.3g}"])
        if s == 16.0:
            stats["default_peak_R"] = lab.peak_reflectance()
            stats["default_shift"] = peak - bragg
    parts.append("""### 3.1 Peak position against thickness disorder

`Labradorite(sigma_a=s, sigma_b=s)`, other parameters default (d_a = d_b = 77.5 nm,
N = 6000), normal incidence. "shift" is `peak_wavelength() − bragg_wavelength()`.
The damping α ∝ σ²/λ² removes more at short wavelengths, so the peak moves
to longer wavelengths as σ grows.

""")
    parts.append(table(["σ_a = σ_b nm", "Bragg nm", "peak nm", "shift nm", "peak R", "FWHM nm"], rows))

    # 3.2 paper Fig. 8
    rows = []
    for s in (1.0, 10.0, 20.0, 30.0, 40.0, 50.0, 80.0):
        lab = Labradorite(sigma_a=s, sigma_b=16.0)
        peak = lab.peak_wavelength()
        pr = lab.peak_reflectance()
        width = fwhm(lab, peak) if not math.isnan(peak) else math.nan
        rows.append([fmt(s, 3), fmt(peak, 5), fmt(pr, 4), fmt(width, 3), *colour_cells(lab)])
    parts.append("""
### 3.2 The paper's Fig. 8 series: σ_a grows, σ_b = 16 nm

Default material otherwise (Bragg estimate 483.1 nm), normal incidence, D65.
"peak nm" is NaN when R has no first-order maximum within 0.7-1.45 × the Bragg
estimate. Dominant wavelength and purity as in CIE 15 (section 7 of physics.md);
Y is the luminance of the lamella reflection alone (white reflector = 1); the hex
code is the display swatch (brightest channel scaled to 1).

""")
    parts.append(table(["σ_a nm", "peak nm", "peak R", "FWHM nm", "dominant nm", "purity", "Y", "swatch"], rows))

    # 3.3 presets
    rows, tilt_rows = [], []
    ext_angles = (0.0, 15.0, 30.0, 45.0, 60.0)
    for name, target in Labradorite.PRESETS.items():
        lab = Labradorite.preset(name)
        peak = lab.peak_wavelength()
        rows.append([name, f"{target:g}", f"{lab.period_nm:.2f}", f"{lab.bragg_wavelength():.2f}", f"{peak:.3f}",
                     f"{lab.peak_reflectance():.4f}", f"{fwhm(lab, peak):.3g}", *colour_cells(lab)])
        peaks = []
        for e in ext_angles:
            internal = math.asin(math.sin(math.radians(e)) / lab.n_surface)
            peaks.append(lab.peak_wavelength(math.cos(internal)))
        slope_int = [(lab.peak_wavelength(math.cos(math.radians(a + 0.5)))
                      - lab.peak_wavelength(math.cos(math.radians(a - 0.5)))) for a in (10.0, 20.0, 30.0)]
        slope_ext = (peaks[3] - peaks[1]) / (ext_angles[3] - ext_angles[1])
        tilt_rows.append([name, *[f"{p:.1f}" for p in peaks], f"{slope_ext:+.2f}",
                          *[f"{s:+.2f}" for s in slope_int]])
    parts.append("""
### 3.3 Presets (`Labradorite.preset`, via `from_peak_wavelength`)

Equal phase thicknesses, σ_a = σ_b = 16 nm, N = 6000. The period is refined until the
true peak of R (not the Bragg estimate) is at the target, so "Bragg nm" sits
below the target by the σ-shift of table 3.1.

""")
    parts.append(table(["preset", "target nm", "period nm", "Bragg nm", "peak nm", "peak R", "FWHM nm", "dominant nm",
                        "purity", "Y", "swatch"], rows))
    parts.append("""
Tilt: peak wavelength against the EXTERNAL angle of incidence on a flat polished
face with the lamellae parallel to it, lit and viewed in the mirror direction
(internal angle asin(sin θ_ext / 1.56)), and the rate of change per degree:
over 15-45° external, and per degree of INTERNAL angle at 10°, 20°, 30°
(centred difference over ±0.5°). Near normal incidence the shift is second order
(λ ≈ λ0 cos θ), so there is no single nm/degree figure; the published
1.5-1.9 nm per degree (Miura 1978) is of the same size as the model's rates at moderate tilts.

""")
    parts.append(table(["preset", *[f"peak at {e:g}° ext" for e in ext_angles], "nm/° ext (15-45°)",
                        "nm/° int at 10°", "at 20°", "at 30°"], tilt_rows))

    # 3.4 from_anorthite
    rows = []
    for an in range(44, 62):
        lab = Labradorite.from_anorthite(float(an))
        peak = lab.peak_wavelength()
        rows.append([str(an), f"{lab.period_nm:.1f}", f"{lab.bragg_wavelength():.1f}",
                     f"{lab.bragg_wavelength(order=2):.1f}", fmt(peak, 5), fmt(lab.peak_reflectance(), 4),
                     *colour_cells(lab)])
    parts.append("""
### 3.4 `Labradorite.from_anorthite(An)`

Period = 128 + (An − 44)/(61 − 44) × (252 − 128) nm, equal phase thicknesses,
σ = 16 nm, N = 6000; normal incidence, D65. "2nd-order Bragg" is where the second
order peak falls (it carries the colour once the first order leaves the visible).

""")
    parts.append(table(["An %", "period nm", "Bragg nm", "2nd-order Bragg nm", "peak nm", "peak R", "dominant nm",
                        "purity", "Y", "swatch"], rows))

    # 3.5 perfect stacks: peak height, widths of R and of I, float32 resolution
    r = math.sqrt(float(interface_reflectance(N_A, N_B)))
    rows = []
    for n in (10, 100, 1000, 6000, 100_000, 1_000_000):
        lab = Labradorite(sigma_a=0.0, sigma_b=0.0, pairs=n)
        peak = lab.peak_wavelength()
        peak = refine_peak(lambda x: float(lab.intensity(x, 1.0)), peak - 2e-3, peak + 2e-3)
        w_r = fwhm(lab, peak)
        w_i = fwhm(lab, peak, quantity="intensity")
        rows.append([str(n), f"{lab.peak_reflectance():.6f}", f"{math.tanh(2 * n * r) ** 2:.6f}",
                     f"{2 * n * r * r * float(lab.intensity(peak, 1.0)):.3g}",
                     f"{w_r:.3g}", f"{w_r / peak:.2e}", f"{w_i:.3g}", f"{w_i / peak:.2e}",
                     f"{w_i / peak / 2.0**-24:.3g}"])
    parts.append(f"""
### 3.5 Perfect stacks (σ = 0): peak height and width

Equal phases (d = 77.5 nm), normal incidence; r = (n_b − n_a)/(n_a + n_b) = {r:.6f},
r² = {r * r:.3e}. Dynamical theory gives tanh²(2Nr) at the Bragg peak of such a stack.
Widths are full widths at half maximum, of R and of the kinematic intensity I
(∝ R_kin, before saturation); the last column is the relative width of the I peak
in units of float32's unit roundoff 2^-24 = 6.0e-8. The R band stops narrowing once
R saturates (N ≳ 1/r): its width is then set by r (the stop band of a Bragg mirror,
Δλ/λ ≈ (4/π)·r = {4 / math.pi * r:.2e} between the band edges), while the I peak keeps
narrowing as 1/N.

""")
    parts.append(table(["pairs N", "peak R (model)", "tanh²(2Nr)", "peak R_kin", "R: FWHM nm", "R: FWHM/λ",
                        "I: FWHM nm", "I: FWHM/λ", "I: FWHM/λ in units of 2^-24"], rows))

    rows = []
    for d_a, d_b, order in ((77.5, 77.5, 1), (93.0, 62.0, 1), (232.5, 232.5, 3), (279.0, 186.0, 3)):
        lab = Labradorite(d_a=d_a, d_b=d_b, sigma_a=0.0, sigma_b=0.0, pairs=100)
        centre = lab.bragg_wavelength(order=order)
        grid = centre * (1 + np.linspace(-0.01, 0.01, 401))
        exact, _ = transfer_matrix_reflectance(grid, 0.0, lab, 1, seed=0)
        model = lab.reflectance(grid, 1.0)
        rows.append([f"{d_a:g} / {d_b:g}", str(order), f"{centre:.1f}", f"{model.max():.4f}", f"{exact.max():.4f}",
                     f"{model.max() / exact.max():.3f}"])
    parts.append("""
Finite-stack damping away from the simplest case: N = 100 pairs (2Nr = 0.45, R_kin = 0.20:
little saturation), σ = 0, largest R within ±1 % of the Bragg wavelength of the given order,
model against the exact transfer matrix. The damping α_x += φ_x²/(π²N) reproduces the coherent peak exactly only for
φ_a = φ_b = π (first order, equal optical thicknesses); in general the peak R_kin is scaled by
2π²/(φ_a² + φ_b²): 0.96 for a 60:40 split, 1/k² for order k.

""")
    parts.append(table(["d_a / d_b nm", "order", "Bragg nm", "model max R", "exact max R", "model / exact"], rows))

    # 3.6 saturation in the incoherent limit
    rows = []
    for n in (1000, 6000, 20000, 100_000, 1_000_000):
        lab = Labradorite(sigma_a=1e4, sigma_b=1e4, pairs=n)
        rk = 2 * n * r * r * float(lab.intensity(550.0, 1.0))
        rows.append([str(n), f"{rk:.4g}", f"{float(lab.reflectance(550.0, 1.0)):.4f}", f"{rk / (1 + rk):.4f}",
                     f"{math.tanh(math.sqrt(rk)) ** 2:.4f}"])
    parts.append("""
### 3.6 Saturation in the incoherent (grey) limit

σ_a = σ_b = 10 µm (no coherence, I = 1), λ = 550 nm, normal incidence. The model's
R (the random-medium law 1 − ⟨T⟩ of a coherent but disordered stack) against the
pile-of-plates result for 2N interfaces of reflectance r² adding *intensities* (ray
optics, no interference), 2N r²/(1 + (2N−1) r²) ≈ R_kin/(1 + R_kin), and against the
dynamical tanh²(√R_kin). The pile of plates is the incoherent limit; a stack whose
waves interfere with random phases localises light and reflects more (Anderson
localisation in 1D), so the model lies above it once R_kin ≳ 1.

""")
    parts.append(table(["pairs N", "R_kin = 2N r²", "model R", "pile of plates R_kin/(1+R_kin)", "tanh²(√R_kin)"], rows))

    # 3.7 one angle for both phases: what exact Snell / Fresnel would change
    def fresnel(n1: float, n2: float, t1: float) -> tuple[float, float]:
        s2 = n1 * math.sin(t1) / n2
        c1 = math.cos(t1)
        c2 = complex(1.0 - s2 * s2) ** 0.5
        rs = (n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2)
        rp = (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2)
        return abs(rs) ** 2, abs(rp) ** 2

    r2_0 = float(interface_reflectance(N_A, N_B))
    rows = []
    for deg in (0.0, 10.0, 20.0, 30.0, 40.0, 45.0, 50.0, 60.0, 70.0, 75.0, 80.0, 84.0, 85.0):
        t = math.radians(deg)
        sa = N_SURFACE * math.sin(t) / N_A
        sb = N_SURFACE * math.sin(t) / N_B
        ta = math.degrees(math.asin(sa)) if sa < 1 else math.nan
        tb = math.degrees(math.asin(sb))
        rs, rp = fresnel(N_B, N_A, math.radians(tb))
        exact_opt = sum(math.sqrt(max(n * n - (N_SURFACE * math.sin(t)) ** 2, 0.0)) for n in (N_A, N_B))
        model_opt = math.cos(t) * (N_A + N_B)
        approx = (1 + math.cos(2 * t) ** 2) / (2 * math.cos(t) ** 4)
        rows.append([f"{deg:g}", fmt(ta - tb, 3) if not math.isnan(ta) else "TIR in a",
                     f"{100 * (model_opt - exact_opt) / exact_opt:+.3f}", f"{rs / r2_0:.4g}", f"{rp / r2_0:.4g}",
                     f"{0.5 * (rs + rp) / r2_0:.4g}", f"{approx:.4g}", f"{1 / math.cos(t) ** 4:.4g}"])
    crit_b = math.degrees(math.asin(N_A / N_B))
    crit_s = math.degrees(math.asin(N_A / N_SURFACE))
    parts.append(f"""
### 3.7 Snell in each phase and the angle-dependent interface reflectance

θ is the angle to the lamella normal in the bulk stone (n = {N_SURFACE}). The model refracts
it into each phase (κ = n_s sin θ conserved); the first-wave model used θ in both phases and
r² fixed at its normal-incidence value. Columns: θ_a − θ_b, the angles in the two phases
(n_a = {N_A}, n_b = {N_B}); the relative error the one-angle optical period
cos θ (n_a d_a + n_b d_b) had against the exact Σ d_x √(n_x² − n_s² sin²θ) (equal d),
which is its error in the Bragg wavelength; the Fresnel power reflectance of
a b|a interface relative to its normal-incidence value r² = {r2_0:.3e} (s, p and their mean),
the weak-contrast approximation (1 + cos²2θ)/(2 cos⁴θ) of that mean, and 1/cos⁴θ (the s term).
Phase a cannot be entered from the bulk beyond θ = {crit_s:.2f}°; light in phase b is totally
reflected at a b|a interface beyond θ_b = {crit_b:.2f}°.

""")
    parts.append(table(["θ deg", "θ_a − θ_b deg", "Bragg error %", "r_s²/r²", "r_p²/r²", "unpolarised/r²",
                        "(1+cos²2θ)/(2cos⁴θ)", "1/cos⁴θ"], rows))
    # 3.8 perfect stack band against exact wave optics
    log("      transfer-matrix comparison (perfect stack) ...")
    parts.append("""
### 3.8 A perfect stack's band against exact wave optics
""")
    # perfect stack band
    lab0 = Labradorite(sigma_a=0.0, sigma_b=0.0, pairs=1000)
    centre = lab0.bragg_wavelength()
    offsets = [0.0, 5e-4, 1e-3, 1.5e-3, 2e-3, 3e-3, 5e-3, 1e-2, 3e-2]
    sub = np.linspace(-0.5, 0.5, 21) / lab0.pairs
    grid = np.concatenate([centre * (1 + o + sub) for o in offsets])
    exact, _ = transfer_matrix_reflectance(grid, 0.0, lab0, 1, seed=0)
    exact = exact.reshape(len(offsets), sub.size)
    rows = []
    for k, o in enumerate(offsets):
        rows.append([f"{o:g}", f"{float(lab0.reflectance(centre * (1 + o), 1.0)):.4f}", f"{exact[k, 10]:.4f}",
                     f"{exact[k].mean():.4f}"])
    parts.append(f"""
Perfect stack (σ = 0, N = 1000, d = 77.5 nm), normal incidence, at relative offsets from the
Bragg wavelength {centre:.3f} nm. A perfect stack's exact spectrum has side lobes with a period
of about 1/N in relative wavelength; "exact, local mean" averages 21 points over one such period.

""")
    parts.append(table(["(λ − λ_B)/λ_B", "model R", "exact R", "exact, local mean"], rows))

    stats["seconds"] = time.perf_counter() - t0
    return "\n".join(parts), stats


# ----------------------------------------------------------------------------- 5. exact ensembles
ENSEMBLE = REPO / "benchmarks" / "data" / "tmm-ensemble.json"
TOLERANCES = {"peak": 0.05, "integral": 0.04, "position_nm": 6.0, "pointwise": 0.03}


def first_wave_reflectance(lab: Labradorite, wl, c):
    """The first-wave model, kept for comparison: one angle in both phases, r² at normal
    incidence, R = tanh²(√R_kin)."""
    from labcut.physics.lamella import saturate

    i = lamella_intensity(wl, c, lab.n_a, lab.n_b, lab.d_a, lab.d_b, lab.sigma_a, lab.sigma_b, pairs=lab.pairs)
    return saturate(2.0 * lab.pairs * interface_reflectance(lab.n_a, lab.n_b) * i)


def compare_to_ensemble(model: np.ndarray, exact: np.ndarray, se: np.ndarray, wl: np.ndarray) -> dict:
    """benchmarks/tmm.py's comparison (the definitions the tests use)."""
    return tmm.compare(np.asarray(model, dtype=np.float64), exact, se, wl)


def section_exact_ensemble(quick: bool) -> tuple[str, dict]:
    """The closed form (and the first-wave model) against the stored transfer-matrix ensemble means."""
    import json

    log("[5/6] against exact ensemble means ...")
    data = json.loads(ENSEMBLE.read_text())
    wl = np.array(data["wavelengths_nm"])
    rows, worst = [], {"peak": 0.0, "integral": 0.0, "position_nm": 0.0, "excess": -1.0}
    old_rows = []
    for case in data["cases"]:
        lab = Labradorite.preset(case["preset"])
        c = math.cos(math.radians(case["theta_deg"]))
        rs, rp = np.array(case["R_s"]), np.array(case["R_p"])
        ss, sp = np.array(case["se_s"]), np.array(case["se_p"])
        exact = {"s": (rs, ss), "p": (rp, sp), "u": (0.5 * (rs + rp), 0.5 * np.hypot(ss, sp))}
        cells = []
        for pol in ("s", "p", "u"):
            model = lab.reflectance(wl, c, None if pol == "u" else pol)
            e, se = exact[pol]
            if e.max() < 0.01:  # p near the phases' Brewster angle: nothing to compare but zeros
                cells.append(f"{e.max():.3f} / {model.max():.3f}")
                continue
            m = compare_to_ensemble(model, e, se, wl)
            cells.append(f"{m['exact_peak']:.3f}: {m['peak']:.3f}, {m['position_nm']:+.0f}, {m['integral']:.3f}, "
                         f"{m['pointwise']:.3f} ({max(m['excess'], 0.0):.3f})")
            worst["peak"] = max(worst["peak"], abs(m["peak"] - 1.0))
            worst["peak_beyond_noise"] = max(worst.get("peak_beyond_noise", 0.0),
                                             max(abs(m["model_peak"] - m["exact_peak"]) - 3 * m["peak_se"], 0.0) / m["exact_peak"])
            worst["integral"] = max(worst["integral"], abs(m["integral"] - 1.0))
            worst["position_nm"] = max(worst["position_nm"], abs(m["position_nm"]))
            worst["excess"] = max(worst["excess"], m["excess"])
        rows.append([case["preset"], f"{case['theta_deg']:g}", *cells])
        e, se = exact["u"]
        old = compare_to_ensemble(np.asarray(first_wave_reflectance(lab, wl, c)), e, se, wl)
        new = compare_to_ensemble(lab.reflectance(wl, c), e, se, wl)
        old_rows.append([case["preset"], f"{case['theta_deg']:g}", f"{e.max():.3f}", f"{100 * (old['peak'] - 1):+.1f} %",
                         f"{100 * (new['peak'] - 1):+.1f} %", f"{100 * (old['integral'] - 1):+.1f} %",
                         f"{100 * (new['integral'] - 1):+.1f} %"])
    text = f"""## 5. Against exact ensemble means (transfer matrix)

`benchmarks/tmm_ensemble.py` ({data['realisations']} random stacks per case, seed {data['seed']};
command `{data['command']}`) stores the mean reflectance of exact wave optics: Rouard's
recursion through explicit stacks (benchmarks/tmm.py) with Snell refraction and the exact
Fresnel s and p amplitudes in every layer, all multiple reflections, Gaussian thicknesses; the
same stacks for s and p. θ is the angle to the lamella normal in the bulk stone (n = {data['n_surface']}),
380-780 nm in 5 nm steps. `tests/test_physics_tmm.py` asserts the tolerances below on the same data
(peak within {100 * TOLERANCES['peak']:.0f} %, integral within {100 * TOLERANCES['integral']:.0f} %, peak
position within {TOLERANCES['position_nm']:g} nm, pointwise within {TOLERANCES['pointwise']} beyond 3 standard errors);
tests/tmm_reference.py (characteristic matrices) checks the recursion on known answers.

Each cell: exact peak R: model peak / exact peak, peak shift nm, model integral / exact
integral, worst |model − exact| (its excess over 3 SE). Peaks are those of the 3-point
smoothed curves and positions the centroids of their top 10 % (benchmarks/tmm.py `compare`,
the definitions the tests use; the noise of a smoothed exact peak is about SE/√3, a few
per cent where R is small, and the tests allow 3 of it). "x / y": the exact and model maxima
where p all but vanishes (the phases' Brewster angle, ≈ 45°).

"""
    text += table(["preset", "θ deg", "s", "p", "unpolarised"], rows)
    text += """

The first-wave model (one angle in both phases, r² fixed at normal incidence, tanh²
saturation) against the same unpolarised means, next to the model of this release:

"""
    text += table(["preset", "θ deg", "exact peak R", "first wave: peak", "now: peak", "first wave: integral", "now: integral"], old_rows)
    return text + "\n", {"worst": worst, "realisations": data["realisations"]}


def section_internal_angles(quick: bool) -> tuple[str, dict]:
    """Which internal angles to the lamellae the product's scenes reach (weighted by flash)."""
    from labcut.orientation.radiance import light_terms, view_terms
    from labcut.physics import schiller as lobe
    from labcut.physics.ops import NUMPY
    from labcut.scene import Scenario

    log("[6/6] internal angles reached by the scenarios ...")
    lab = Labradorite.preset("blue")
    rows, stats = [], {}
    for mesh_name in ("oval-16x12-low.ply", "carving-biplane.ply"):
        mesh = labcut.load_mesh(REPO / "meshes" / mesh_name)
        rng = np.random.default_rng(3)
        pts, face = mesh.sample(2000 if quick else 6000, return_index=True)
        n = mesh.face_normals[face]
        for name in ("bench", "ring", "pendant", "display", "outdoor"):
            angles, weights = [], []
            for st in Scenario.preset(name, "draft").settings():
                L, E = st.lights.directions, st.lights.weights
                V, W = st.views.directions, st.views.weights
                for li in range(len(L)):
                    lit = n @ L[li] > 0
                    for vi in range(len(V)):
                        ok = lit & (n @ V[vi] > 0)
                        if not np.any(ok):
                            continue
                        nn = n[ok]
                        a, etl = light_terms(nn, np.tile(L[li], (len(nn), 1)), np.full(len(nn), E[li]), lab.n_surface)
                        b, tv = view_terms(nn, np.tile(V[vi], (len(nn), 1)), lab.n_surface)
                        _, cos_l, _ = lobe.mirror_terms(a, b, nn, NUMPY)
                        angles.append(np.degrees(np.arccos(np.clip(cos_l, 0, 1))))
                        weights.append(etl * tv * W[vi] * st.weight)
            ang, w = np.concatenate(angles), np.concatenate(weights)
            order = np.argsort(ang)
            cw = np.cumsum(w[order]) / w.sum()
            q = [float(ang[order][np.searchsorted(cw, p)]) for p in (0.5, 0.9, 0.99)]
            rows.append([mesh_name, name, f"{q[0]:.1f}", f"{q[1]:.1f}", f"{q[2]:.1f}", f"{ang.max():.1f}"])
            stats[f"{mesh_name}:{name}"] = q
    text = """## 6. Internal angles the product reaches

The angle θ between the ray inside the stone and the lamella orientation h that mirrors
it into the eye, over every (surface point, light, view) of a scenario (draft quality),
weighted by the light that reaches the eye (E T_i T_o, view weight): the angles at which
the stack reflectance is actually used. Light refracts into a face from outside within
40° of that face's normal, so θ stays small on a cabochon; the carving's steep faces and
the scenarios' oblique lamps reach further.

"""
    text += table(["mesh", "scenario", "median θ deg", "90 % below", "99 % below", "max θ deg"], rows)
    return text + "\n", stats


# ----------------------------------------------------------------------------- 4. timing
def section_timing(quick: bool) -> tuple[str, dict]:
    log("[4/6] timing ...")
    import drjit as dr
    from drjit.llvm import Float

    n = 1_000_000 if quick else 4_000_000
    rng = np.random.default_rng(1)
    wl = rng.uniform(360.0, 830.0, n)
    c = rng.uniform(0.0, 1.0, n)
    lab = Labradorite()
    chunk = 500_000

    def run_numpy() -> None:
        for i in range(0, n, chunk):
            lab.reflectance(wl[i:i + chunk], c[i:i + chunk])

    run_numpy()  # warm-up
    t_np = []
    for _ in range(3):
        t = time.perf_counter()
        run_numpy()
        t_np.append(time.perf_counter() - t)

    W = Float(wl.astype(np.float32))
    C = Float(c.astype(np.float32))
    dr.eval(W, C)
    dr.sync_thread()
    t = time.perf_counter()
    r = lab.reflectance(W, C)
    dr.eval(r)
    dr.sync_thread()
    t_first = time.perf_counter() - t
    t_dr = []
    for _ in range(5):
        t = time.perf_counter()
        r = lab.reflectance(W, C)
        dr.eval(r)
        dr.sync_thread()
        t_dr.append(time.perf_counter() - t)
    r = first_wave_reflectance(lab, W, C)
    dr.eval(r)
    dr.sync_thread()
    t_old = []
    for _ in range(5):
        t = time.perf_counter()
        r = first_wave_reflectance(lab, W, C)
        dr.eval(r)
        dr.sync_thread()
        t_old.append(time.perf_counter() - t)
    threads = dr.thread_count() if hasattr(dr, "thread_count") else "?"
    best_np, best_dr, best_old = min(t_np), min(t_dr), min(t_old)
    stats = {"numpy_per_s": n / best_np, "drjit_per_s": n / best_dr, "n": n, "cost_ratio": best_dr / best_old}
    text = f"""## 4. Speed of `Labradorite.reflectance`

{n / 1e6:g} M evaluations at random (λ, cos θ), default material. numpy float64 in chunks
of {chunk // 1000} k (to bound memory), best of 3 after a warm-up. Dr.Jit LLVM float32:
inputs already on the Dr.Jit side, `dr.eval` + `dr.sync_thread()`, best of 5 after one
warm-up call (which traces and compiles, or loads the kernel from the on-disk cache:
{1e3 * t_first:.0f} ms). Dr.Jit thread pool: {threads} threads. The machine is shared, so
timings may vary by tens of percent between runs.

"""
    text += table(["backend", "best time s", "median time s", "evaluations / s"], [
        ["numpy float64", f"{best_np:.3f}", f"{float(np.median(t_np)):.3f}", f"{n / best_np / 1e6:.2f} M"],
        ["Dr.Jit LLVM float32", f"{best_dr:.4f}", f"{float(np.median(t_dr)):.4f}", f"{n / best_dr / 1e6:.1f} M"],
        ["Dr.Jit, first-wave model", f"{best_old:.4f}", f"{float(np.median(t_old)):.4f}", f"{n / best_old / 1e6:.1f} M"],
    ])
    text += f"""

Kernel cost of this release's model (Snell in each phase, R_s and R_p each saturated) against
the first-wave model, same inputs: **{best_dr / best_old:.2f}x** (best of 5 each).
"""
    return text, stats


# ----------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="markdown report to write (default docs/physics-accuracy.md; "
                                  "with --quick the report goes to stdout unless --out is given)")
    ap.add_argument("--quick", action="store_true", help="fewer stacks and coarser grids: under a minute")
    ap.add_argument("--stacks", type=int, default=None,
                    help="Monte Carlo stacks per point (default 40000, 8000 with --quick)")
    ap.add_argument("--seed", type=int, default=20090101, help="Monte Carlo seed")
    args = ap.parse_args(argv)
    stacks = args.stacks or (8000 if args.quick else 40000)
    out = args.out if args.out is not None else (None if args.quick else str(REPO / "docs" / "physics-accuracy.md"))

    import drjit as dr
    import mitsuba

    t_start = time.perf_counter()
    info = machine_info()
    started = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    mc_text, mc = section_monte_carlo(args.quick, stacks, args.seed)
    f32_text, fl = section_float32(args.quick)
    beh_text, beh = section_behaviour(args.quick)
    tim_text, tim = section_timing(args.quick)
    ens_text, ens = section_exact_ensemble(args.quick)
    ang_text, ang = section_internal_angles(args.quick)
    total = time.perf_counter() - t_start
    llvm = ".".join(str(v) for v in dr.detail.llvm_version())

    head = f"""# labcut physics: accuracy, behaviour and speed

Generated by `benchmarks/physics_accuracy.py`; do not edit by hand. Command:

    {command_line()}

{"**Quick mode: fewer stacks and coarser grids than the committed report.**" if args.quick else ""}
Run {started}, {total:.0f} s in all. Machine: {info['nproc']} cores (`nproc`), CPU "{info['cpu']}",
load average at start {info['load']}. Python {platform.python_version()}, numpy {np.__version__},
Dr.Jit {dr.__version__} (libLLVM {llvm}), Mitsuba {mitsuba.__version__}; labcut at git {git_info()}.
The physics is described in [physics.md](physics.md).

## Summary

| check | result |
|---|---|
| Monte Carlo vs `lamella_intensity` ({mc['points']} points, {mc['stacks']} stacks each) | max {100 * mc['max_rel']:.2f} %, median {100 * mc['median_rel']:.2f} %, RMS z {mc['rms_z']:.2f} |
| float32 Dr.Jit vs float64 numpy, `reflectance`, worst absolute error | {fl['worst']:.1e} |
| default material (σ = 16 nm, N = 6000): peak R, peak − Bragg | {beh['default_peak_R']:.3f}, {beh['default_shift']:+.2f} nm |
| `reflectance` speed, numpy float64 | {tim['numpy_per_s'] / 1e6:.2f} M evaluations/s |
| `reflectance` speed, Dr.Jit LLVM float32 | {tim['drjit_per_s'] / 1e6:.1f} M evaluations/s ({tim['cost_ratio']:.2f}x the first-wave model's kernel time) |
| against exact ensemble means ({ens['realisations']} stacks; every preset, 0-70°, s, p, unpolarised) | worst peak {100 * ens['worst']['peak']:.1f} % ({100 * ens['worst'].get('peak_beyond_noise', 0):.1f} % beyond 3 SE), integral {100 * ens['worst']['integral']:.1f} %, peak position {ens['worst']['position_nm']:.0f} nm, pointwise excess over 3 SE {max(ens['worst']['excess'], 0):.3f} |

"""
    report = "\n".join([head, mc_text, f32_text, beh_text, tim_text, ens_text, ang_text])
    if out is None:
        print(report)
    else:
        path = Path(out)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(report, encoding="utf-8")
        os.replace(tmp, path)
        log(f"wrote {path} ({total:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
