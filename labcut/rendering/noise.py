"""3D gradient noise for colour zoning: Perlin noise, its fractal sum, and a rank equaliser.

Points are in mm in the mesh frame; the noise is deterministic for a seed.
"""

from __future__ import annotations

import numpy as np

_LACUNARITY = 2.0
_GAIN = 0.5


def _perlin_tables(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Permutation (512) and 256 random unit gradients of one seed."""
    rng = np.random.default_rng(np.random.SeedSequence([0x1AB0, int(seed)]))
    perm = rng.permutation(256)
    grads = rng.normal(size=(256, 3))
    grads /= np.linalg.norm(grads, axis=1, keepdims=True)
    return np.concatenate([perm, perm]).astype(np.int64), grads


def perlin3(points: np.ndarray, perm: np.ndarray, grads: np.ndarray) -> np.ndarray:
    """3D Perlin gradient noise (quintic fade, unit gradients) at ``points`` (N, 3), lattice spacing 1.

    Zero at every lattice point; values lie within about +-1.
    """
    p = np.asarray(points, dtype=np.float64)
    cell = np.floor(p)
    f = p - cell
    i = cell.astype(np.int64) & 255
    fade = f * f * f * (f * (f * 6.0 - 15.0) + 10.0)
    out = np.zeros(p.shape[0])
    for dx in (0, 1):
        wx = fade[:, 0] if dx else 1.0 - fade[:, 0]
        hx = perm[i[:, 0] + dx]
        for dy in (0, 1):
            wy = fade[:, 1] if dy else 1.0 - fade[:, 1]
            hy = perm[hx + i[:, 1] + dy]
            for dz in (0, 1):
                wz = fade[:, 2] if dz else 1.0 - fade[:, 2]
                g = grads[perm[hy + i[:, 2] + dz]]
                dot = g[:, 0] * (f[:, 0] - dx) + g[:, 1] * (f[:, 1] - dy) + g[:, 2] * (f[:, 2] - dz)
                out += wx * wy * wz * dot
    return out


def fbm(points: np.ndarray, scale_mm: float, octaves: int, seed: int) -> np.ndarray:
    """Fractal sum of Perlin noise at ``points`` (N, 3) in mm: lattice spacing ``scale_mm``,
    each octave twice the frequency and half the amplitude of the one before, each with
    its own random offset. Deterministic for a seed; not normalised."""
    perm, grads = _perlin_tables(seed)
    rng = np.random.default_rng(np.random.SeedSequence([0x0C7A, int(seed)]))
    offsets = rng.uniform(0.0, 256.0, size=(int(octaves), 3))
    p = np.asarray(points, dtype=np.float64) / float(scale_mm)
    total = np.zeros(p.shape[0])
    amp, freq = 1.0, 1.0
    for o in range(int(octaves)):
        total += amp * perlin3(p * freq + offsets[o], perm, grads)
        amp *= _GAIN
        freq *= _LACUNARITY
    return total


def equalise(values: np.ndarray) -> np.ndarray:
    """Rank transform to [0, 1]: the smallest value -> 0, the largest -> 1, uniform in between."""
    v = np.asarray(values, dtype=np.float64).ravel()
    ranks = np.empty(v.size)
    ranks[np.argsort(v, kind="stable")] = np.arange(v.size)
    return (ranks / max(v.size - 1, 1)).reshape(np.shape(values))
