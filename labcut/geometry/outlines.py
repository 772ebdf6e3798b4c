"""2D cabochon outlines (girdle shapes) as counter-clockwise polygons in mm.

Frame: the outline lies in the XY plane of the stone (DESIGN.md §3); ``length`` is
measured along X and ``width`` along Y, and the outline is centred on its bounding
box. Pointed shapes (pear, marquise) point along X (the pear's point is at +X).

Every outline is returned as an ``(N, 2)`` float64 array of distinct points,
counter-clockwise, implicitly closed (the last point is not repeated), simple (no
self-intersections) and star-shaped about a *centre* point from which the dome is
scaled (:func:`star_centre`). Smooth outlines are sampled densely and then resampled
to ``n`` points, spending half of the points by arc length and half by turning
angle, so tight curves (the pear's point, the rounded corners of a rectangle) get
more points than straight runs; the extreme points (the ends of the length and the
width) are always vertices, so the bounding box is exact.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..errors import ParameterError
from ..validation import check_number

#: Sizes a gem cutter works with: below a grain of sand or above a boulder is an input error.
MIN_SIZE_MM = 0.1
MAX_SIZE_MM = 1000.0

#: names accepted by :func:`make_outline`
OUTLINES = ("round", "oval", "cushion", "pear", "marquise", "rectangle")

#: superellipse exponent of the cushion outline: |x/a|^n + |y/b|^n = 1.
#: n = 2 is an ellipse, n -> inf a rectangle; 3 gives the "pillow" look of a
#: cushion (straight-ish sides, full rounded corners).
CUSHION_EXPONENT = 3.0

_DENSE = 4096  # samples per quarter of a smooth outline before resampling


def check_size(name: str, value: float) -> float:
    """A stone dimension in mm: finite, positive, between MIN_SIZE_MM and MAX_SIZE_MM."""
    return check_number(value, name, MIN_SIZE_MM, MAX_SIZE_MM, unit="mm", why="a stone's size")


# ----------------------------------------------------------------------------- dense curves
def _quarter_curve(fx: Callable[[np.ndarray], np.ndarray], fy: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Dense first-quadrant curve from (a, 0) to (0, b), parameter in [0, pi/2]."""
    t = np.linspace(0.0, math.pi / 2, _DENSE + 1)
    return np.column_stack([fx(t), fy(t)])


def _mirror_quarter(q: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Whole closed curve (CCW, starting at +X) from a first-quadrant curve (a,0)->(0,b).

    Returns the dense points (no repeated end) and the indices of the four extreme
    points, which must stay vertices after resampling.
    """
    q = np.asarray(q, dtype=float)
    q1 = q
    q2 = (q[::-1] * [-1, 1])[1:]
    q3 = (q * [-1, -1])[1:]
    q4 = (q[::-1] * [1, -1])[1:-1]
    pts = np.vstack([q1, q2, q3, q4])
    m = len(q) - 1
    return pts, [0, m, 2 * m, 3 * m]


def _ellipse_dense(a: float, b: float) -> tuple[np.ndarray, list[int]]:
    return _mirror_quarter(_quarter_curve(lambda t: a * np.cos(t), lambda t: b * np.sin(t)))


def _superellipse_dense(a: float, b: float, n: float) -> tuple[np.ndarray, list[int]]:
    e = 2.0 / n
    return _mirror_quarter(
        _quarter_curve(lambda t: a * np.cos(t) ** e, lambda t: b * np.sin(t) ** e)
    )


def _lens_arc(half_length: float, half_width: float, x0: float, n: int) -> np.ndarray:
    """Circular arc from (x0, half_width) with horizontal tangent down to (x0+half_length, 0).

    The arc of a circle centred at (x0, half_width - R) through both points, with
    R = (half_length^2 + half_width^2) / (2 half_width). Requires half_length >= half_width.
    """
    R = (half_length**2 + half_width**2) / (2.0 * half_width)
    cy = half_width - R
    phi_end = math.atan2(-cy, half_length)  # angle of the tip seen from the centre
    phi = np.linspace(math.pi / 2, phi_end, n + 1)
    return np.column_stack([x0 + R * np.cos(phi), cy + R * np.sin(phi)])


def _marquise_dense(a: float, b: float) -> tuple[np.ndarray, list[int]]:
    arc = _lens_arc(a, b, 0.0, _DENSE)[::-1]  # (a, 0) -> (0, b)
    return _mirror_quarter(arc)


def _pear_dense(a: float, b: float) -> tuple[np.ndarray, list[int]]:
    """Half circle of radius b at -X, half marquise (tangent-continuous) at +X."""
    c = -a + b  # centre of the round end
    arc = _lens_arc(a - c, b, c, _DENSE)[::-1]  # (a, 0) -> (c, b)
    t = np.linspace(math.pi / 2, 3 * math.pi / 2, 2 * _DENSE + 1)
    round_end = np.column_stack([c + b * np.cos(t), b * np.sin(t)])  # (c,b) -> (-a,0) -> (c,-b)
    lower = (arc[::-1] * [1, -1])[1:-1]  # (c,-b) -> (a,0), without both ends
    pts = np.vstack([arc, round_end[1:], lower])
    m = len(arc) - 1
    return pts, [0, m, m + _DENSE, m + 2 * _DENSE]


def _rounded_rectangle_dense(a: float, b: float, r: float) -> tuple[np.ndarray, list[int]]:
    if r <= 0:
        pts = np.array([[a, 0.0], [a, b], [0.0, b], [-a, b], [-a, 0.0], [-a, -b], [0.0, -b], [a, -b]])
        return pts, list(range(8))
    t = np.linspace(0.0, math.pi / 2, _DENSE + 1)
    corner = np.column_stack([a - r + r * np.cos(t), b - r + r * np.sin(t)])
    parts = [np.array([[a, 0.0]])]
    if b - r > 1e-12:
        parts.append(np.array([[a, b - r]]))
    parts.append(corner[1:-1] if b - r > 1e-12 else corner[1:-1])
    if a - r > 1e-12:
        parts.append(np.array([[a - r, b]]))
    parts.append(np.array([[0.0, b]]))
    q = np.vstack(parts)
    # remove exact duplicates (square with r = half size)
    keep = np.ones(len(q), bool)
    keep[1:] = np.any(np.abs(np.diff(q, axis=0)) > 1e-12, axis=1)
    q = q[keep]
    return _mirror_quarter(q)


# ----------------------------------------------------------------------------- resampling
def resample(dense: np.ndarray, keys: list[int], n: int, keep_all_vertices: bool = False) -> np.ndarray:
    """Resample a closed dense polyline to about ``n`` points, keeping the ``keys``.

    Points are spaced by a measure that is half arc length, half turning angle, per
    segment between consecutive keys (each segment gets points in proportion to its
    share of the measure, at least one).
    """
    m = len(dense)
    keys = sorted(set(int(k) % m for k in keys))
    if keep_all_vertices or m <= n:
        return dense.copy()
    nxt = np.roll(dense, -1, axis=0)
    seg = np.linalg.norm(nxt - dense, axis=1)
    d_in = dense - np.roll(dense, 1, axis=0)
    d_out = nxt - dense
    ang = np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0], np.einsum("ij,ij->i", d_in, d_out)))
    # measure of segment i (from point i to i+1): its length share + its turning share
    turn = 0.5 * (ang + np.roll(ang, -1))
    total_len, total_turn = seg.sum(), max(turn.sum(), 1e-12)
    w = 0.5 * seg / total_len + 0.5 * turn / total_turn
    out: list[np.ndarray] = []
    bounds = keys + [keys[0] + m]
    budget = n
    for k0, k1 in zip(bounds[:-1], bounds[1:]):
        idx = np.arange(k0, k1) % m
        ws = w[idx]
        share = ws.sum()
        cnt = max(1, int(round(budget * share)))
        cum = np.concatenate([[0.0], np.cumsum(ws)])
        targets = np.linspace(0.0, cum[-1], cnt + 1)[:-1]
        # map measure -> position along the dense polyline (piecewise linear)
        j = np.clip(np.searchsorted(cum, targets, side="right") - 1, 0, len(idx) - 1)
        frac = np.where(ws[j] > 0, (targets - cum[j]) / np.where(ws[j] > 0, ws[j], 1.0), 0.0)
        p0 = dense[idx[j]]
        p1 = dense[(idx[j] + 1) % m]
        pts = p0 + frac[:, None] * (p1 - p0)
        pts[0] = dense[k0 % m]  # the key itself, exactly
        out.append(pts)
    res = np.vstack(out)
    keep = np.ones(len(res), bool)
    keep[1:] = np.linalg.norm(np.diff(res, axis=0), axis=1) > 1e-9
    if np.linalg.norm(res[-1] - res[0]) <= 1e-9:
        keep[-1] = False
    return res[keep]


# ----------------------------------------------------------------------------- public API
def make_outline(
    name: str,
    length: float,
    width: float,
    n: int = 256,
    corner_radius: float | None = None,
) -> np.ndarray:
    """A named outline, ``length`` (X) by ``width`` (Y) mm, as an (about) ``n``-point CCW polygon.

    * ``round``: circle of diameter ``length`` (``width`` must be equal).
    * ``oval``: ellipse.
    * ``cushion``: superellipse with exponent :data:`CUSHION_EXPONENT`.
    * ``pear``: half circle of diameter ``width`` at -X joined tangentially to a
      pointed half-marquise at +X (needs length >= width).
    * ``marquise`` (navette): the lens between two circular arcs, pointed at +-X
      (needs length >= width).
    * ``rectangle``: rectangle with rounded corners of radius ``corner_radius``
      (default 15 % of the smaller side; 0 gives sharp corners).
    """
    if not isinstance(name, str) or name.lower() not in OUTLINES:
        raise ParameterError(f"unknown outline {name!r}; use one of {', '.join(OUTLINES)} or an (N, 2) array of points")
    name = name.lower()
    L = check_size("length", length)
    W = check_size("width", width)
    a, b = L / 2.0, W / 2.0
    if name == "round":
        if abs(L - W) > 1e-9 * max(L, W):
            raise ParameterError(f"a round outline has length == width (the diameter), got {L:g} x {W:g} mm")
        dense, keys = _ellipse_dense(a, a)
    elif name == "oval":
        dense, keys = _ellipse_dense(a, b)
    elif name == "cushion":
        dense, keys = _superellipse_dense(a, b, CUSHION_EXPONENT)
    elif name in ("pear", "marquise"):
        if L < W * (1 - 1e-12):
            raise ParameterError(f"{'an' if name[:1] in 'aeiou' else 'a'} {name} outline needs length >= width (it points along the length), got {L:g} x {W:g} mm")
        dense, keys = (_pear_dense if name == "pear" else _marquise_dense)(a, b)
    else:  # rectangle
        r = 0.15 * min(L, W) if corner_radius is None else corner_radius
        r = check_number(r, "corner_radius", 0.0, min(a, b) * (1 + 1e-12), unit="mm", why="up to half the smaller side")
        dense, keys = _rounded_rectangle_dense(a, b, min(r, min(a, b)))
        if r == 0:
            return dense
    pts = resample(dense, keys, int(n))
    return pts


def polygon_area(points: np.ndarray) -> float:
    """Signed area (mm^2) of a closed polygon; positive when counter-clockwise."""
    p = np.asarray(points, dtype=float)
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def segments_intersect(p: np.ndarray) -> tuple[int, int] | None:
    """First pair of non-adjacent edges of the closed polygon ``p`` that intersect, or None.

    Vectorised O(N^2) test in chunks; fine for a few thousand points.
    """
    n = len(p)
    a = p
    b = np.roll(p, -1, axis=0)
    scale = max(float(np.ptp(p[:, 0])), float(np.ptp(p[:, 1])), 1e-300)
    eps = 1e-12 * scale * scale

    def orient(p1, p2, p3):
        return (p2[..., 0] - p1[..., 0]) * (p3[..., 1] - p1[..., 1]) - (p2[..., 1] - p1[..., 1]) * (p3[..., 0] - p1[..., 0])

    idx = np.arange(n)
    for start in range(0, n, 256):
        i = idx[start : start + 256][:, None]
        j = idx[None, :]
        A, B = a[i[:, 0]][:, None, :], b[i[:, 0]][:, None, :]
        C, D = a[None, :, :], b[None, :, :]
        d1 = orient(A, B, C)
        d2 = orient(A, B, D)
        d3 = orient(C, D, A)
        d4 = orient(C, D, B)
        proper = (d1 * d2 < -eps * eps) & (d3 * d4 < -eps * eps)
        # touching / collinear overlap: an endpoint lies on the other segment
        def on_seg(P, Q, R, d):
            return (np.abs(d) <= eps) & (np.minimum(P[..., 0], Q[..., 0]) - 1e-12 * scale <= R[..., 0]) & (
                R[..., 0] <= np.maximum(P[..., 0], Q[..., 0]) + 1e-12 * scale
            ) & (np.minimum(P[..., 1], Q[..., 1]) - 1e-12 * scale <= R[..., 1]) & (
                R[..., 1] <= np.maximum(P[..., 1], Q[..., 1]) + 1e-12 * scale
            )

        touch = on_seg(A, B, C, d1) | on_seg(A, B, D, d2) | on_seg(C, D, A, d3) | on_seg(C, D, B, d4)
        hit = proper | touch
        adjacent = (j == i) | (j == (i + 1) % n) | (j == (i - 1) % n)
        hit &= ~adjacent
        hit &= j > i
        if hit.any():
            ii, jj = np.argwhere(hit)[0]
            return int(i[ii, 0]), int(jj)
    return None


def star_centre(points: np.ndarray) -> np.ndarray | None:
    """A point from which the whole polygon is visible (its kernel), or None.

    Returns the polygon's area centroid when it lies well inside the kernel (the
    usual case), else the centroid of the kernel. The kernel is found by clipping
    the bounding box with the inner half-plane of every edge.
    """
    p = np.asarray(points, dtype=float)
    centroid = _centroid(p)
    e0 = p
    e1 = np.roll(p, -1, axis=0)
    d = e1 - e0
    # inner side of a CCW edge: cross(d, x - e0) >= 0
    size = max(float(np.ptp(p[:, 0])), float(np.ptp(p[:, 1])))
    margin = 1e-6 * size
    cross_c = d[:, 0] * (centroid[1] - e0[:, 1]) - d[:, 1] * (centroid[0] - e0[:, 0])
    dist_c = cross_c / np.linalg.norm(d, axis=1)
    if np.all(dist_c > margin):
        return centroid
    lo, hi = p.min(axis=0) - size, p.max(axis=0) + size
    poly = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    for q0, dq in zip(e0, d):
        if len(poly) == 0:
            return None
        s = dq[0] * (poly[:, 1] - q0[1]) - dq[1] * (poly[:, 0] - q0[0])
        inside = s >= 0
        if inside.all():
            continue
        new = []
        for k in range(len(poly)):
            cur, nxt_ = poly[k], poly[(k + 1) % len(poly)]
            sc, sn = s[k], s[(k + 1) % len(poly)]
            if sc >= 0:
                new.append(cur)
            if (sc >= 0) != (sn >= 0):
                t = sc / (sc - sn)
                new.append(cur + t * (nxt_ - cur))
        poly = np.array(new) if new else np.zeros((0, 2))
    if len(poly) < 3 or abs(polygon_area(poly)) < (margin * size):
        return None
    c = _centroid(poly)
    cross_k = d[:, 0] * (c[1] - e0[:, 1]) - d[:, 1] * (c[0] - e0[:, 0])
    if not np.all(cross_k / np.linalg.norm(d, axis=1) > margin):
        return None
    return c


def _centroid(p: np.ndarray) -> np.ndarray:
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    A = cr.sum() / 2.0
    if abs(A) < 1e-300:
        return p.mean(axis=0)
    return np.array([((x + xn) * cr).sum() / (6 * A), ((y + yn) * cr).sum() / (6 * A)])


def validate_outline(points: object, name: str = "outline") -> np.ndarray:
    """Check a user outline and return it as a CCW (N, 2) float64 array in mm.

    Accepts any (N, 2) array-like with N >= 3; a repeated closing point is
    dropped, consecutive duplicates are removed and clockwise input is reversed.
    Raises :class:`~labcut.errors.ParameterError` if the points are not finite,
    the polygon has (almost) no area, or two of its edges cross or touch.
    """
    try:
        p = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a name or an (N, 2) array of points in mm") from None
    if p.ndim != 2 or p.shape[1] != 2:
        raise ParameterError(f"{name} must be an (N, 2) array of x, y points in mm, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ParameterError(f"{name} has non-finite points (NaN or inf)")
    if len(p) >= 2 and np.allclose(p[0], p[-1], rtol=0, atol=1e-12):
        p = p[:-1]
    keep = np.ones(len(p), bool)
    if len(p) > 1:
        keep[1:] = np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-12
    p = p[keep]
    if len(p) < 3:
        raise ParameterError(f"{name} needs at least 3 distinct points, got {len(p)}")
    size = max(float(np.ptp(p[:, 0])), float(np.ptp(p[:, 1])))
    if size <= 0:
        raise ParameterError(f"{name} encloses no area (its points coincide)")
    hit = segments_intersect(p) if len(p) > 3 else None
    if hit is not None:
        raise ParameterError(f"{name} is self-intersecting (edges {hit[0]} and {hit[1]} cross or touch)")
    area = polygon_area(p)
    if abs(area) <= 1e-9 * size * size:
        raise ParameterError(f"{name} encloses no area (its points are collinear)")
    if area < 0:
        p = p[::-1].copy()
    return p


def densify(points: np.ndarray, n: int) -> np.ndarray:
    """Insert points along the edges of a polygon so it has about ``n`` points.

    Original vertices are kept exactly (corners stay sharp); new points are spread
    by edge length. Returns the input when it already has ``n`` points or more.
    """
    p = np.asarray(points, dtype=float)
    if len(p) >= n:
        return p.copy()
    seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    extra = n - len(p)
    counts = np.floor(extra * seg / seg.sum()).astype(int)
    # distribute the remainder to the longest edges
    rem = extra - counts.sum()
    if rem > 0:
        counts[np.argsort(-(extra * seg / seg.sum() - counts))[:rem]] += 1
    out = []
    for i, c in enumerate(counts):
        q0, q1 = p[i], p[(i + 1) % len(p)]
        t = np.arange(c + 1) / (c + 1)
        out.append(q0 + t[:, None] * (q1 - q0))
    return np.vstack(out)


def is_convex_polygon(points: np.ndarray, rtol: float = 1e-9) -> bool:
    """True when the CCW polygon has no reflex vertex (collinear vertices allowed)."""
    p = np.asarray(points, dtype=float)
    d_in = p - np.roll(p, 1, axis=0)
    d_out = np.roll(p, -1, axis=0) - p
    cr = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    scale = np.linalg.norm(d_in, axis=1) * np.linalg.norm(d_out, axis=1)
    return bool(np.all(cr >= -rtol * scale))
