"""The flash problem of tiny hand-made stones (issue 37), pinned against what a reviewer can work
out by hand or with a direct numpy sum: which (point, view) pairs exist and their projected-area
weights, which lights each point sees (a light below a face's horizon or hidden by another part
gives nothing), each triple's mirror orientation ``h`` and factor ``c`` (the model's own formulas,
:func:`labcut.orientation.radiance.schiller_weights`, in units of ``L_ref``), the visible areas,
the pair sums of the lobe terms, the error bars' reach, the refusals word for word, and that the
Dr.Jit and numpy paths, and any chunk size, give the same problem.

Fast: boxes and a small icosphere of a few dozen surface samples; each test builds its own mesh
(the samples are cached per mesh, so a fresh mesh is a fresh draw)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import labcut
from labcut.colour import luminance_table
from labcut.errors import MeshError, ParameterError
from labcut.orientation import problem as problem_module
from labcut.orientation.kernels import KernelOptions
from labcut.orientation.problem import (FlashProblem, _PosePairs, _setting_triples, _TripleKernel, build_problem,
                                        check_problem_inputs, light_rows, lobe_reach, pair_major, view_pairs,
                                        visible_areas)
from labcut.orientation.radiance import flash_threshold, reference_radiance, schiller_weights
from labcut.scene import Lights, Setting, Views

LAB = labcut.Labradorite.preset("blue")
REF = KernelOptions.reference()
#: every path and chunking the problem can be built with
PATHS = {
    "numpy": REF,
    "numpy, tiny chunks": KernelOptions(triples=False, lit_cells=False, pair_sums=False, dense_chunk=1),
    "numpy, small chunks": KernelOptions(triples=False, lit_cells=False, pair_sums=False, dense_chunk=7),
    "kernel": KernelOptions(),
    "kernel, host lit table": KernelOptions(lit_cells=False),
    "kernel, tiny chunks": KernelOptions(dense_chunk=1),
    "kernel, small chunks": KernelOptions(dense_chunk=5),
    "kernel, host table, small chunks": KernelOptions(lit_cells=False, dense_chunk=5),
}


def box(size=2.0):
    return trimesh.creation.box(extents=(size, size, size))


def unit(*v):
    v = np.array(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def samples_of(mesh, count, seed):
    return labcut.Stone.of(mesh).surface_samples(count, seed)


def expected(mesh, settings, count, seed, occluded=False):
    """The problem worked out point by point: pairs (point, global view, weight), per pose's pairs
    in point order; triples (pair, h, c) in pose, pair, light order; each view's visible area."""
    s = samples_of(mesh, count, seed)
    eta = LAB.n_surface
    table = luminance_table(LAB)
    l_ref = reference_radiance(LAB, 1.0)
    area = float(mesh.area) / count
    pairs, triples, areas = [], [], []
    view0 = 0
    for st in settings:
        V, L = st.views.directions, st.lights.directions
        E = st.lights.weights / st.lights.weights.sum()
        esc_v = escapes(mesh, s.points, s.n_geo, V) if occluded else np.ones((count, len(V)), bool)
        esc_l = escapes(mesh, s.points, s.n_geo, L) if occluded else np.ones((count, len(L)), bool)
        pose_pairs = []
        for i in range(count):
            for j in range(len(V)):
                if s.n_geo[i] @ V[j] > 1e-6 and s.n_sh[i] @ V[j] > 1e-6 and esc_v[i, j]:
                    pose_pairs.append((i, j, float(s.n_geo[i] @ V[j])))
        for j in range(len(V)):
            areas.append(sum(w for (_, jj, w) in pose_pairs if jj == j) * area)
        for i, j, w in pose_pairs:
            total = sum(ww for (_, jj, ww) in pose_pairs if jj == j)
            p = len(pairs)
            pairs.append((i, view0 + j, w / total))
            for k in range(len(L)):
                if s.n_geo[i] @ L[k] > 1e-6 and s.n_sh[i] @ L[k] > 1e-6 and E[k] > 0 and esc_l[i, k]:
                    h, c = schiller_weights(s.n_sh[i][None], L[k][None], V[j][None], np.array([E[k]]), eta, table)
                    h = h[0] * (-1.0 if h[0, 2] < 0 else 1.0)
                    triples.append((p, h, float(c[0]) / l_ref))
        view0 += len(V)
    return pairs, triples, np.array(areas)


def escapes(mesh, points, n_geo, dirs):
    from labcut.rendering.rays import escapes as esc

    return esc(mesh, points, n_geo, dirs)


def assert_matches(problem, mesh, settings, count, seed, occluded=False, rtol=2e-5):
    pairs, triples, areas = expected(mesh, settings, count, seed, occluded)
    assert problem.info["pairs"] == len(pairs) == problem.pair_view.size == problem.pair_weight.size
    np.testing.assert_array_equal(problem.info["pair_point"], [p[0] for p in pairs])
    assert problem.info["pair_point"].dtype == np.int32
    np.testing.assert_array_equal(problem.pair_view, [p[1] for p in pairs])
    assert problem.pair_view.dtype == np.int64
    np.testing.assert_allclose(problem.pair_weight, [p[2] for p in pairs], rtol=1e-12)
    assert problem.n_triples == problem.info["triples"] == len(triples)
    assert problem.h.shape == (len(triples), 3) and problem.h.dtype == np.float32
    assert problem.c.dtype == np.float32 and problem.pair.dtype == np.int32
    np.testing.assert_array_equal(problem.pair, [t[0] for t in triples])
    np.testing.assert_allclose(problem.h, np.array([t[1] for t in triples]), rtol=0, atol=3e-6)
    np.testing.assert_allclose(problem.c, [t[2] for t in triples], rtol=rtol)
    np.testing.assert_allclose(problem.info["view_area_mm2"], areas, rtol=1e-12)
    assert problem.n_points == count and problem.info["poses"] == len(settings)


# ---- the hand-made cases -------------------------------------------------------------------------


@pytest.mark.parametrize("path", list(PATHS))
def test_a_box_lit_and_seen_from_above(path):
    """Light and view straight down on a 2 mm cube: only the top face makes pairs and triples;
    its triples mirror the light into the eye with h = +Z and c = 1/q_norm (L_ref is this very
    case: c q(1) = 1); the sides (light at their horizon) and the bottom give nothing."""
    mesh = box()
    lights, views = Lights([[0, 0, 1]], [3.0]), Views([[0, 0, 1]])
    p = build_problem(mesh, LAB, lights, views, n_points=40, seed=3, kernels=PATHS[path])
    s = samples_of(mesh, 40, 3)
    top = np.flatnonzero(s.n_geo[:, 2] > 0.5)
    assert 0 < top.size < 40
    np.testing.assert_array_equal(p.info["pair_point"], top)
    np.testing.assert_array_equal(p.pair_view, np.zeros(top.size))
    np.testing.assert_allclose(p.pair_weight, np.full(top.size, 1.0 / top.size), rtol=1e-12)
    np.testing.assert_array_equal(p.pair, np.arange(top.size))
    np.testing.assert_allclose(p.h, np.tile([0.0, 0.0, 1.0], (top.size, 1)), atol=1e-6)
    np.testing.assert_allclose(p.c, 1.0 / LAB.lobe_norm, rtol=2e-5)
    # the projected area of the top: the samples on it times the area each stands for (24 mm² / 40)
    assert p.info["view_area_mm2"] == pytest.approx([top.size * 24.0 / 40])
    np.testing.assert_allclose(p.view_weight, [1.0])
    np.testing.assert_allclose(p.pair_alpha, p.pair_weight)
    # the schiller of one point at the lamella normal +Z, in units of L_ref: 1
    np.testing.assert_allclose(p.pair_radiance(np.array([0.0, 0.0, 1.0]))[:, 0], 1.0, rtol=2e-5)


@pytest.mark.parametrize("path", list(PATHS))
def test_two_lights_and_two_views_on_a_box(path):
    """Two lights (one above, one from -X at 53°) and two views (above, and 30° towards +X): the
    +X face is seen but lit by neither light (pairs without triples), the -X face is lit but not
    seen; the irradiances count as shares of their total (1:3)."""
    mesh = box()
    lights = Lights([[0, 0, 1], unit(-0.6, 0, 0.8)], [1.0, 3.0])
    views = Views([[0, 0, 1], unit(0.5, 0, math.sqrt(3) / 2)], [1.0, 3.0])
    st = [Setting(lights, views, 1.0, np.eye(3))]
    p = build_problem(mesh, LAB, lights, views, n_points=48, seed=5, tau=0.25, kernels=PATHS[path])
    assert_matches(p, mesh, st, 48, 5)
    s = samples_of(mesh, 48, 5)
    plus_x = s.n_geo[p.info["pair_point"], 0] > 0.5
    assert plus_x.any() and not np.isin(np.flatnonzero(plus_x), p.pair).any()
    assert not (s.n_geo[p.info["pair_point"], 0] < -0.5).any()
    np.testing.assert_allclose(p.view_weight, [0.25, 0.75])
    np.testing.assert_allclose(np.bincount(p.pair_view, weights=p.pair_weight), [1.0, 1.0])
    np.testing.assert_allclose(p.pair_alpha, p.pair_weight * p.view_weight[p.pair_view])
    assert p.pair_alpha.dtype == np.float64
    # the top under the two lights, seen from above: two triples per pair; the light from above
    # carries a quarter of the irradiance, so its c is a quarter of the single-light case's
    top = np.flatnonzero((s.n_geo[p.info["pair_point"], 2] > 0.5) & (p.pair_view == 0))[0]  # a point of the top, seen from above
    first = p.c[(p.pair == top)]
    assert first.size == 2 and first[0] == pytest.approx(0.25 / LAB.lobe_norm, rel=2e-5)
    # visible areas: the top's 4 mm² from above, 4 cos 30° + 4 sin 30° from the tilted view (Monte Carlo)
    assert p.info["view_area_mm2"] == pytest.approx([4.0, 4 * math.sqrt(3) / 2 + 2.0], rel=0.5)
    assert p.tau == 0.25 and isinstance(p.tau, float)
    assert p.threshold == pytest.approx(flash_threshold(LAB, lights, 0.25), rel=1e-12)
    assert p.kappa == LAB.lobe_kappa and p.q_norm == LAB.lobe_norm
    assert p.material is LAB and p.lights is lights and p.views is views
    assert p.convex is True and p.kernels is PATHS[path]
    assert p.info["l_ref"] == reference_radiance(LAB, 1.0)


@pytest.mark.parametrize("path", list(PATHS))
def test_smooth_normals_of_a_sphere_against_the_formulas(path):
    """An icosphere (smooth shading normals differ from the facets'): every pair, triple, h and c
    as worked out from the samples, lights near the horizon included."""
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=3.0)
    lights = Lights([unit(0.2, 0.1, 1), unit(-0.9, 0.3, 0.1), unit(0.1, -0.95, 0.05)], [2.0, 1.0, 0.5])
    views = Views([unit(0, 0, 1), unit(0.7, 0.2, 0.3), unit(-0.2, -0.9, 0.1)])
    st = [Setting(lights, views, 1.0, np.eye(3))]
    p = build_problem(mesh, LAB, lights, views, n_points=60, seed=2, kernels=PATHS[path])
    s = samples_of(mesh, 60, 2)
    assert not np.allclose(s.n_geo, s.n_sh)
    assert_matches(p, mesh, st, 60, 2, rtol=1e-4 if PATHS[path].triples else 2e-5)
    assert (p.h[:, 2] >= 0).all()


@pytest.mark.parametrize("path", ["numpy", "kernel", "kernel, tiny chunks", "numpy, tiny chunks"])
def test_poses_pair_their_own_lights_and_views(path):
    """Two poses (weights 1 and 3): a pose's lights light only its own views; the views are both
    poses' in order, weighted pose weight x view weight; the first pose gives lights, views and the
    threshold."""
    mesh = box()
    a = Setting(Lights([[0, 0, 1]], [2.0]), Views([[0, 0, 1], unit(0.5, 0, 1)], [1.0, 1.0]), 1.0, np.eye(3))
    b = Setting(Lights([unit(1, 0, 1), unit(0, 1, 1)], [1.0, 1.0]), Views([unit(1, 0, 1)]), 3.0, np.eye(3))
    p = build_problem(mesh, LAB, settings=[a, b], n_points=50, seed=7, tau=0.3, kernels=PATHS[path])
    assert_matches(p, mesh, [a, b], 50, 7)
    np.testing.assert_allclose(p.view_weight, [0.125, 0.125, 0.75])
    assert p.lights is a.lights and p.views is a.views
    assert p.threshold == pytest.approx(flash_threshold(LAB, a.lights, 0.3), rel=1e-12)
    assert set(np.unique(p.pair_view[p.pair])) == {0, 1, 2}


def test_a_scenario_with_more_lights_in_a_later_pose():
    mesh = box()
    a = Setting(Lights([[0, 0, 1]]), Views([[0, 0, 1]]), 1.0, np.eye(3))
    b = Setting(Lights([[0, 0, 1], unit(1, 0, 1), unit(-1, 0, 1)], [1, 2, 1]), Views([[0, 0, 1]]), 1.0, np.eye(3))
    kernels_all = [REF, KernelOptions(), KernelOptions(dense_chunk=2)] + [
        KernelOptions(lit_cells=False, dense_chunk=3 * k) for k in (1, 2, 3, 4, 5, 7)]
    kernels_all += [KernelOptions(triples=False, lit_cells=False, dense_chunk=k) for k in (1, 2, 3, 5)]
    for kernels in kernels_all:
        p = build_problem(mesh, LAB, settings=[a, b], n_points=30, seed=1, kernels=kernels)
        assert_matches(p, mesh, [a, b], 30, 1)


def _two_blocks():
    base = trimesh.creation.box(extents=(6.0, 6.0, 1.0))
    tower = trimesh.creation.box(extents=(1.0, 6.0, 4.0))
    tower.apply_translation((1.0, 0.0, 2.6))
    return trimesh.util.concatenate([base, tower])


@pytest.mark.parametrize("path", ["numpy", "kernel", "kernel, small chunks"])
def test_parts_in_the_way_hide_points_from_lights_and_views(path):
    """A slab with a wall standing on it (not convex): the wall hides part of the slab from a
    light and a view low over +X; those pairs and lit cells are dropped (occlusion rays), as
    :func:`labcut.rendering.rays.escapes` says point by point."""
    mesh = _two_blocks()
    lights, views = Lights([unit(1, 0, 0.5), [0, 0, 1]]), Views([unit(1, 0, 0.6), [0, 0, 1]])
    st = [Setting(lights, views, 1.0, np.eye(3))]
    p = build_problem(mesh, LAB, lights, views, n_points=80, seed=4, kernels=PATHS[path])
    assert p.convex is False
    s = samples_of(mesh, 80, 4)
    hidden = ~escapes(mesh, s.points, s.n_geo, views.directions)
    facing = (s.n_geo @ views.directions.T > 1e-6)
    assert (hidden & facing).any()
    assert_matches(p, mesh, st, 80, 4, occluded=True)
    # without the rays every facing point counts
    q = build_problem(mesh, LAB, lights, views, n_points=80, seed=4, occlusion=False, kernels=PATHS[path])
    assert_matches(q, mesh, st, 80, 4, occluded=False)
    assert q.pair_view.size > p.pair_view.size
    # a convex box asked for the rays: nothing hides anything
    b = box()
    r = build_problem(b, LAB, lights, views, n_points=30, seed=4, occlusion=True, kernels=PATHS[path])
    assert_matches(r, b, st, 30, 4)


def test_no_light_on_what_a_viewer_sees_is_refused():
    mesh = box()
    msg = ("no light reaches a part of the stone that a viewer sees: check that the lights are above "
           "the surfaces the views look at (+Z is face-up)")
    for kernels in (REF, KernelOptions()):
        with pytest.raises(ParameterError) as e:
            build_problem(mesh, LAB, Lights([[1, 0, 0]]), Views([[0, 0, 1]]), n_points=30, kernels=kernels)
        assert str(e.value) == msg
    with pytest.raises(ParameterError) as e:
        build_problem(mesh, LAB, Lights([[0, 0, 1]]), None, n_points=30)
    assert str(e.value) == "build_problem needs lights and views, or settings"
    with pytest.raises(ParameterError) as e:
        build_problem(mesh, LAB, None, Views([[0, 0, 1]]), n_points=30)
    assert str(e.value) == "build_problem needs lights and views, or settings"
    with pytest.raises(ParameterError) as e:
        build_problem(mesh, LAB, settings=[], n_points=30)
    assert str(e.value) == "build_problem needs at least one setting"


def test_the_quality_sets_the_point_count_and_the_seed_the_draw():
    mesh = box()
    lights, views = Lights([[0, 0, 1]]), Views([[0, 0, 1]])
    p = build_problem(mesh, LAB, lights, views, quality="draft", kernels=REF)
    assert p.n_points == labcut.Quality.coerce("draft").surface_points if hasattr(labcut, "Quality") else True
    from labcut.scene.quality import Quality

    assert p.n_points == Quality.coerce("draft").surface_points
    s = samples_of(mesh, p.n_points, 0)
    np.testing.assert_array_equal(p.info["pair_point"], np.flatnonzero(s.n_geo[:, 2] > 0.5))
    q = build_problem(mesh, LAB, lights, views, n_points=40, seed=9, kernels=REF)
    np.testing.assert_array_equal(q.info["pair_point"], np.flatnonzero(samples_of(mesh, 40, 9).n_geo[:, 2] > 0.5))
    # a Stone is taken for its mesh
    r = build_problem(labcut.Stone.of(mesh), LAB, lights, views, n_points=40, seed=9, kernels=REF)
    np.testing.assert_array_equal(r.c, q.c)


# ---- the problem's own sums ----------------------------------------------------------------------


def direct_sums(problem, normals, reach=None):
    normals = np.atleast_2d(normals)
    h, c = problem.h.astype(np.float64), problem.c.astype(np.float64)
    keep = np.ones(h.shape[0], bool)
    if reach is not None:
        keep = np.abs(h @ normals[0]) >= math.cos(min(reach, math.pi / 2)) - 1e-7
    out = np.zeros((problem.pair_view.size, len(normals)))
    for k, m in enumerate(normals):
        terms = problem.q_norm * c * np.exp(problem.kappa * (np.abs(h @ m) - 1.0))
        np.add.at(out[:, k], problem.pair[keep], terms[keep])
    return out


@pytest.fixture
def sphere_problem():
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=3.0)
    lights = Lights([unit(0.2, 0.1, 1), unit(-0.5, 0.3, 0.6)], [2.0, 1.0])
    views = Views([unit(0, 0, 1), unit(0.4, 0.2, 0.8), unit(-0.3, -0.2, 0.9)])
    return build_problem(mesh, LAB, lights, views, n_points=200, seed=2, kernels=REF)


def _with(problem, kernels, **changes):
    from dataclasses import replace

    if "h" in changes:  # the host orientations (FlashProblem.host_h, read as FlashProblem.h)
        changes["host_h"] = changes.pop("h")
    return replace(problem, kernels=kernels, info=dict(problem.info), **changes)


def close(got, want):
    """float32 lobe terms summed in float64: within 5e-5 relative (float32 exp of κ(|h·m| - 1)), terms below 1e-7 of the largest aside."""
    np.testing.assert_allclose(got, want, rtol=5e-5, atol=1e-7 * float(np.max(np.abs(want), initial=0.0)))


NORMALS = np.array([unit(0.05, 0.02, 1), unit(0.3, 0.1, 0.9), unit(-0.2, 0.25, 0.9), unit(0.9, 0.0, 0.3)])


@pytest.mark.parametrize("kernels", [REF, KernelOptions()], ids=["numpy", "kernel"])
@pytest.mark.parametrize("chunk", [None, 1, 3])
def test_pair_radiance_is_the_sum_of_the_lobe_terms(sphere_problem, kernels, chunk, monkeypatch):
    """Σ over each pair's triples of q_norm c_t exp(κ(|h_t·m| - 1)), at each normal; with a reach,
    only the triples within it of the first normal (any chunk size, either path)."""
    if chunk is not None:
        monkeypatch.setattr(problem_module, "PAIR_CHUNK", chunk)
    p = _with(sphere_problem, kernels)
    assert (p._pair_sums is None) == (not kernels.pair_sums)
    whole = direct_sums(p, NORMALS)
    assert whole.shape == (p.pair_view.size, 4) and whole[:, 0].max() > 0.5
    close(p.pair_radiance(NORMALS), whole)
    close(p.pair_radiance(NORMALS[1]), whole[:, 1:2])
    for reach in (0.05, 0.3, 5.0):
        near = direct_sums(p, NORMALS, reach)
        got = p.pair_radiance(NORMALS, reach)
        assert got.shape == near.shape
        close(got, near)
        # the first normal alone, after a stencil: every triple's sum (the kept one where the kernel runs)
        close(p.pair_radiance(NORMALS[0]), whole[:, :1])
        close(p.pair_radiance(NORMALS[2]), whole[:, 2:3])
        close(p.pair_radiance(NORMALS[:2]), whole[:, :2])
    assert p.pair_radiance(NORMALS, 0.05)[:, 0].sum() < 0.9 * whole[:, 0].sum()
    close(p.pair_radiance_numpy(NORMALS, 0.3), direct_sums(p, NORMALS, 0.3))


def test_the_kernel_keeps_the_first_normals_whole_sum_from_a_stencil(sphere_problem, monkeypatch):
    p = _with(sphere_problem, KernelOptions())
    whole = direct_sums(p, NORMALS)
    near = p.pair_radiance(NORMALS, 0.3)
    close(near, direct_sums(p, NORMALS, 0.3))
    kernel = p._pair_sums

    def refuse(*args, **kwargs):
        raise AssertionError("the kept sum is read, no kernel runs")

    monkeypatch.setattr(kernel, "launch", refuse)
    close(p.pair_radiance(NORMALS[0]), whole[:, :1])
    with pytest.raises(AssertionError, match="kept sum"):
        p.pair_radiance(NORMALS[1])
    with pytest.raises(AssertionError, match="kept sum"):
        p.pair_radiance(NORMALS[:2])
    with pytest.raises(AssertionError, match="kept sum"):
        p.pair_radiance(NORMALS[0], 0.3)


def test_launched_sums_wait_for_the_kernel(sphere_problem):
    p = _with(sphere_problem, KernelOptions())
    launched = p.launch_pair_radiance(NORMALS[:2])
    close(launched.value, direct_sums(p, NORMALS[:2]))
    q = _with(sphere_problem, REF)
    close(q.launch_pair_radiance(NORMALS[:2], 0.3).value, direct_sums(q, NORMALS[:2], 0.3))


@pytest.mark.parametrize("kernels", [REF, KernelOptions()], ids=["numpy", "kernel"])
def test_triples_out_of_pair_order_still_sum_per_pair(sphere_problem, kernels, monkeypatch):
    """Triples not sorted by pair (a problem made by hand): the numpy path's per-pair bincount,
    the kernel not taken; chunks as small as one triple."""
    monkeypatch.setattr(problem_module, "PAIR_CHUNK", 2)
    base = sphere_problem
    order = np.random.default_rng(0).permutation(base.n_triples)
    p = _with(base, kernels, h=base.h[order], c=base.c[order], pair=base.pair[order])
    assert p.pairs_sorted is False and p._pair_sums is None
    close(p.pair_radiance(NORMALS), direct_sums(base, NORMALS))
    close(p.pair_radiance(NORMALS, 0.3), direct_sums(base, NORMALS, 0.3))
    # alpha of any rows: those rows' c times their pair's alpha
    rows = np.array([3, 0, 7])
    np.testing.assert_allclose(p.alpha(rows), p.c[rows] * p.pair_alpha[p.pair[rows]])
    np.testing.assert_allclose(p.alpha(), p.c * p.pair_alpha[p.pair])
    np.testing.assert_allclose(p.alpha(slice(2, 5)), p.alpha()[2:5])


def test_pairs_sorted_and_the_kernel_limits(sphere_problem):
    p = sphere_problem
    assert p.pairs_sorted is True
    one = _with(p, KernelOptions(), h=p.h[:1], c=p.c[:1], pair=p.pair[:1])
    assert one.pairs_sorted is True and one.n_triples == 1
    none = _with(p, KernelOptions(), h=p.h[:0], c=p.c[:0], pair=p.pair[:0])
    assert none.pairs_sorted is True and none._pair_sums is None
    np.testing.assert_array_equal(none.pair_radiance(NORMALS), np.zeros((p.pair_view.size, 4)))
    small = _with(p, KernelOptions(pair_sums_max_triples=p.n_triples - 1))
    assert small._pair_sums is None
    close(small.pair_radiance(NORMALS), direct_sums(p, NORMALS))
    exact = _with(p, KernelOptions(pair_sums_max_triples=p.n_triples))
    assert exact._pair_sums is not None
    swapped = _with(p, KernelOptions(), pair=np.r_[p.pair[1:2], p.pair[:1], p.pair[2:]])
    assert (swapped.pairs_sorted is False) == (p.pair[1] != p.pair[0])


def test_the_device_triples_are_the_host_triples(sphere_problem):
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=3.0)
    lights, views = Lights([unit(0.2, 0.1, 1)]), Views([unit(0, 0, 1), unit(0.4, 0.2, 0.8)])
    for kernels in (REF, KernelOptions(), KernelOptions(dense_chunk=3)):
        p = build_problem(mesh, LAB, lights, views, n_points=40, seed=1, kernels=kernels)
        h, c = p.device_triples
        np.testing.assert_array_equal(np.stack([np.asarray(h.x), np.asarray(h.y), np.asarray(h.z)], axis=1), p.h)
        np.testing.assert_array_equal(np.asarray(c), p.c)



def test_the_host_orientations_are_copied_only_when_read():
    """One kernel call made every triple: the problem keeps the device's h and copies it to the host
    only when ``h`` is read; a score map, metrics and pair sums read the device's (a standard
    problem's 9 MB copy per lamp the live view need not make). Several chunks: the host's arrays
    are filled at once; the reference path has no device copy to defer."""
    from labcut.backend import Launched
    from labcut.orientation.scoring import Scorer

    mesh = trimesh.creation.icosphere(subdivisions=2, radius=3.0)
    lights, views = Lights([unit(0.2, 0.1, 1)]), Views([unit(0, 0, 1), unit(0.4, 0.2, 0.8)])
    p = build_problem(mesh, LAB, lights, views, n_points=200, seed=1)
    assert isinstance(p.host_h, Launched)
    scorer = Scorer(p)
    scorer.energy_map(np.array([[0.0, 0.0, 1.0], [0.3, 0.0, 0.954]]))
    scorer.metrics(np.array([0.0, 0.0, 1.0]))
    p.pair_radiance(np.array([[0.0, 0.0, 1.0]]))
    assert isinstance(p.host_h, Launched), "a kernel path read the host's copy of h"
    h, _ = p.device_triples
    first = p.h
    assert isinstance(first, np.ndarray) and first.dtype == np.float32 and p.host_h is first and p.h is first
    np.testing.assert_array_equal(first, np.stack([np.asarray(h.x), np.asarray(h.y), np.asarray(h.z)], axis=1))
    chunked = build_problem(mesh, LAB, lights, views, n_points=200, seed=1, kernels=KernelOptions(dense_chunk=50))
    assert isinstance(chunked.host_h, np.ndarray)
    np.testing.assert_array_equal(chunked.h, first)
    assert isinstance(build_problem(mesh, LAB, lights, views, n_points=200, seed=1, kernels=REF).host_h, np.ndarray)

def test_pair_major_stacks_the_sums_pairs_first():
    assert pair_major([]).shape == (0, 0)
    got = pair_major([np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0])])
    np.testing.assert_array_equal(got, [[1, 4], [2, 5], [3, 6]])
    assert got.dtype == np.float64


# ---- reach, refusals, light rows, view pairs ---------------------------------------------------


def test_lobe_reach_is_the_spread_plus_five_lobe_widths():
    assert lobe_reach(100.0) == pytest.approx(0.5, rel=1e-15)
    assert lobe_reach(400.0, 0.25) == pytest.approx(0.5, rel=1e-15)
    assert lobe_reach(LAB.lobe_kappa, 0.1) == pytest.approx(0.1 + 5.0 / math.sqrt(LAB.lobe_kappa), rel=1e-15)
    assert lobe_reach(0.0) == pytest.approx(5000.0, rel=1e-12)  # kappa floored at 1e-6
    assert lobe_reach(-4.0, 1.0) == pytest.approx(5001.0, rel=1e-12)
    assert lobe_reach(2e-6) == pytest.approx(5.0 / math.sqrt(2e-6), rel=1e-12)
    assert isinstance(lobe_reach(4, 1), float)


def test_check_problem_inputs_refuses_word_for_word():
    mesh = box()
    assert check_problem_inputs(mesh, 0, 0.1) is mesh
    assert check_problem_inputs(labcut.Stone.of(mesh), np.int64(5), 9.99) is mesh
    assert check_problem_inputs(mesh, 2**63 - 1, 1e-9) is mesh
    assert check_problem_inputs(mesh, 3, 5) is mesh
    for seed in (-1, 2**63, 1.0, "1", None, np.float64(2.0)):
        with pytest.raises(ParameterError) as e:
            check_problem_inputs(mesh, seed, 0.1)
        assert str(e.value) == f"seed must be a whole number >= 0, got {seed!r}"
        assert e.value.parameter == "seed"
    for tau in (0.0, 10.0, -0.1, 10, math.nan, math.inf, "0.1", None, np.float32(0.1)):
        with pytest.raises(ParameterError) as e:
            check_problem_inputs(mesh, 0, tau)
        assert str(e.value) == f"flash threshold tau must lie in (0, 10), got {tau!r}"
    for bad in (None, "mesh.ply", trimesh.Trimesh(vertices=np.zeros((3, 3)), faces=np.zeros((0, 3), dtype=int))):
        with pytest.raises(MeshError) as e:
            check_problem_inputs(bad, 0, 0.1)
        assert str(e.value) == "the mesh is empty or not a trimesh.Trimesh (load it with labcut.load_mesh)"
    # the seed is checked before the threshold and the threshold before the mesh
    with pytest.raises(ParameterError, match="seed"):
        check_problem_inputs(None, -1, 0.0)
    with pytest.raises(ParameterError, match="tau"):
        check_problem_inputs(None, 0, 0.0)


def test_light_rows_line_up_each_poses_lights():
    one = Setting(Lights([[0, 0, 1]], [2.0]), Views([[0, 0, 1]]), 1.0, np.eye(3))
    three = Setting(Lights([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [1.0, 2.0, 3.0]), Views([[0, 0, 1]]), 1.0, np.eye(3))
    L, E, width = light_rows([one, three])
    assert width == 3 and L.shape == (6, 3) and E.shape == (6,)
    np.testing.assert_array_equal(L, [[0, 0, 1], [0, 0, 1], [0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    np.testing.assert_array_equal(E, [2, 0, 0, 1, 2, 3])
    L, E, width = light_rows([one, three], [0.5, 2.0])
    np.testing.assert_array_equal(E, [1, 0, 0, 2, 4, 6])
    L, E, width = light_rows([one])
    assert width == 1
    np.testing.assert_array_equal(L, [[0, 0, 1]])
    np.testing.assert_array_equal(E, [2.0])


def test_view_pairs_and_visible_areas_by_hand():
    """Four points: up, up-tilted, sideways and down; views +Z and +X."""
    n = np.array([[0, 0, 1], unit(0.6, 0, 0.8), [1, 0, 0], [0, 0, -1]], dtype=np.float64)
    V = np.array([[0, 0, 1], [1, 0, 0]], dtype=np.float64)
    pi, pv, w = view_pairs(V, np.zeros((4, 3)), n, n, None, False)
    np.testing.assert_array_equal(pi, [0, 1, 1, 2])
    np.testing.assert_array_equal(pv, [0, 0, 1, 1])
    np.testing.assert_allclose(w, [1 / 1.8, 0.8 / 1.8, 0.6 / 1.6, 1 / 1.6])
    # a shading normal turned away from the view drops the pair too
    sh = n.copy()
    sh[1] = unit(0.6, 0, -0.8)
    pi2, pv2, _ = view_pairs(V, np.zeros((4, 3)), n, sh, None, False)
    np.testing.assert_array_equal(pi2, [0, 1, 2])
    np.testing.assert_array_equal(pv2, [0, 1, 1])
    pose = _PosePairs(pi, pv, w, None)
    np.testing.assert_allclose(visible_areas(V, pose, n, 0.5), [0.9, 0.8])
    # a view that sees nothing: area 0 and no pairs
    V3 = np.array([[0, 0, 1], [0, 1, 0]], dtype=np.float64)
    pi3, pv3, w3 = view_pairs(V3, np.zeros((4, 3)), n, n, None, False)
    np.testing.assert_allclose(visible_areas(V3, _PosePairs(pi3, pv3, w3, None), n, 2.0), [3.6, 0.0])


def test_pose_pairs_count_their_triples():
    lit = np.array([[True, True], [False, False], [True, False]])
    pose = _PosePairs(np.array([0, 0, 1, 2]), np.array([0, 1, 0, 1]), np.ones(4), lit)
    assert pose.n_triples == 2 + 2 + 0 + 1
    assert _PosePairs(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0), lit).n_triples == 0
    assert _PosePairs(np.array([2]), np.array([0]), np.ones(1), lit).n_triples == 1


def test_degenerate_terms_become_empty_triples():
    """Terms that are not finite (a shading normal of NaNs, a light of infinite irradiance) are no
    triples: h = +Z and c = 0, on both paths; the others as usual. A triple whose h lies exactly in
    the horizontal plane keeps its sign (only h_z < 0 is folded)."""
    n_sh = np.array([[0.0, 0.0, 1.0], [np.nan, np.nan, np.nan], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    L = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    E = np.array([1.0, np.inf, 1.0])
    V = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    table = luminance_table(LAB)
    l_ref = reference_radiance(LAB, 1.0)
    # pairs (point, view): (0, 0) lit by light 0, (1, 0) lit by light 0, (2, 0) lit by light 1, (3, 1) by light 2
    pose = _PosePairs(np.array([0, 1, 2, 3]), np.array([0, 0, 0, 1]), np.full(4, 0.5),
                      np.array([[True, False, False], [True, False, False], [False, True, False], [False, False, True]]))
    want_h = [[0, 0, 1], [0, 0, 1], [0, 0, 1], [1, 0, 0]]
    want_c = [1.0 / LAB.lobe_norm, 0.0, 0.0, 1.0 / LAB.lobe_norm]
    got = []
    _setting_triples(L, E, V, pose, n_sh, LAB.n_surface, table, l_ref, 4, 100, lambda *a: got.append(a))
    h, c, pair = got[0]
    # one point a chunk: the chunk of the infinite light's triple has a finite h and an infinite c
    one = []
    _setting_triples(L, E, V, pose, n_sh, LAB.n_surface, table, l_ref, 4, 1, lambda *a: one.append(a))
    assert len(one) == 4
    np.testing.assert_array_equal(np.concatenate([x[0] for x in one]), h)
    np.testing.assert_array_equal(np.concatenate([x[1] for x in one]), c)
    np.testing.assert_array_equal(pair, [0, 1, 2, 3])
    np.testing.assert_allclose(h, want_h, atol=1e-6)
    assert h[3, 0] > 0.5
    np.testing.assert_allclose(c, want_c, rtol=1e-5)
    assert c[1] == 0.0 and c[2] == 0.0
    assert h.dtype == np.float32 and c.dtype == np.float32
    kernel = _TripleKernel(n_sh, LAB.n_surface, table, l_ref)
    lazy_h, c2 = kernel.dense(L, E, V, np.array([0, 1, 2, 3]), np.array([0, 0, 0, 1]), np.array([0, 0, 0, 0]), 3,
                              np.array([0, 3, 7, 11]))
    h2 = lazy_h.value  # the host's copy of the device's h, made when read
    np.testing.assert_allclose(h2, want_h, atol=1e-6)
    assert h2[3, 0] > 0.5
    np.testing.assert_allclose(c2, want_c, rtol=1e-5)
    assert c2[1] == 0.0 and c2[2] == 0.0
    dh, dc = kernel.last_device
    np.testing.assert_array_equal(np.asarray(dc), c2)
    np.testing.assert_array_equal(np.stack([np.asarray(dh.x), np.asarray(dh.y), np.asarray(dh.z)], axis=1), h2)


def test_one_kernel_call_gives_the_problem_its_device_copy():
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=3.0)
    lights, views = Lights([unit(0.2, 0.1, 1)]), Views([unit(0, 0, 1), unit(0.4, 0.2, 0.8)])
    assert "device_triples" in build_problem(mesh, LAB, lights, views, n_points=40, seed=1).__dict__
    assert "device_triples" in build_problem(mesh, LAB, lights, views, n_points=40, seed=1,
                                             kernels=KernelOptions(lit_cells=False)).__dict__
    assert "device_triples" not in build_problem(mesh, LAB, lights, views, n_points=40, seed=1, kernels=REF).__dict__
    assert "device_triples" not in build_problem(mesh, LAB, lights, views, n_points=40, seed=1,
                                                 kernels=KernelOptions(dense_chunk=3)).__dict__


def test_pair_chunk_keeps_the_lobe_values_near_17_mb():
    assert problem_module.PAIR_CHUNK == 1 << 18
    assert problem_module.PAIR_CHUNK * 4 == 2**20  # a megabyte of float32 lobe values a stencil normal


def test_pair_major_keeps_float64_whatever_it_is_given():
    got = pair_major([np.array([1, 2, 3], dtype=np.float32), np.array([4, 5, 6], dtype=np.float32)])
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, [[1, 4], [2, 5], [3, 6]])


def test_add_lobe_terms_one_step():
    """One step of the pair-sum kernels: each normal's float32 term cq exp(κ(|h·m_k| - 1)) added to
    its float64 sum; the terms of triples beyond the reach of the first normal (|h·m_0| below its
    cosine, equal kept) or not valid add 0; the whole first-normal sum steps with every term."""
    from labcut.backend import ad_types
    from labcut.orientation.problem import add_lobe_terms, opaque_stencil

    dr, t = ad_types()
    hs = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -0.8, -0.6], [0.995, 0.0, 0.0998749]], dtype=np.float32)
    cq = np.array([2.0, 3.0, 5.0, 7.0], dtype=np.float32)
    h = t.Array3f(*(hs[:, k] for k in range(3)))
    normals = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    kappa = 4.0
    terms = cq[:, None] * np.exp(kappa * (np.abs(hs.astype(np.float64) @ normals.T) - 1.0))
    for reach, near in ((None, [1, 1, 1, 1]), (0.0, [1, 0, 0, 0]), (math.acos(0.6), [1, 1, 1, 0]),
                        (math.acos(0.8), [1, 1, 0, 0]), (1.6, [1, 1, 1, 1]), (5.0, [1, 1, 1, 1])):
        stencil = opaque_stencil(normals, reach, kappa, 1.0)
        start = [t.Float64(np.full(4, 10.0)), t.Float64(np.full(4, 20.0))]
        out, every = add_lobe_terms(start, h, t.Float(cq), stencil)
        assert every is None and len(out) == 2
        want = np.array([10.0, 20.0]) + terms * np.array(near)[:, None]
        np.testing.assert_allclose(np.stack([np.asarray(s) for s in out], axis=1), want, rtol=1e-6)
        valid = t.Bool(np.array([True, False, True, True]))
        out, every = add_lobe_terms(start, h, t.Float(cq), stencil, valid=valid, every_first=t.Float64(np.ones(4)))
        want = np.array([10.0, 20.0]) + terms * (np.array(near) * [1, 0, 1, 1])[:, None]
        np.testing.assert_allclose(np.stack([np.asarray(s) for s in out], axis=1), want, rtol=1e-6)
        np.testing.assert_allclose(np.asarray(every), 1.0 + terms[:, 0], rtol=1e-6)


@pytest.mark.parametrize("kernels", [REF, KernelOptions()], ids=["numpy", "kernel"])
def test_a_reach_past_the_horizon_keeps_every_triple(sphere_problem, kernels):
    """Reaches above 90°: every term counts (|h·m_0| >= cos 90° = 0), however far the other normal."""
    p = _with(sphere_problem, kernels)
    normals = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    whole = direct_sums(p, normals)
    assert whole[:, 1].sum() > 0.3
    for reach in (1.6, 2.5, 5.0, 7.0):
        close(p.pair_radiance(normals, reach), whole)
    close(p.pair_radiance(normals, 1.0), direct_sums(p, normals, 1.0))
    assert p.pair_radiance(normals, 1.0)[:, 1].sum() < 0.5 * whole[:, 1].sum()


@pytest.mark.parametrize("path", ["numpy", "kernel"])
def test_a_reach_of_zero_keeps_the_triples_exactly_at_the_normal(path):
    """The box lit and seen from above: every triple's h is +Z; a reach of 0 around +Z keeps them."""
    p = build_problem(box(), LAB, Lights([[0, 0, 1]]), Views([[0, 0, 1]]), n_points=30, seed=3, kernels=PATHS[path])
    assert (p.h == np.array([0, 0, 1], dtype=np.float32)).all()
    np.testing.assert_allclose(p.pair_radiance(np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]]), 0.0)[:, 0], 1.0,
                               rtol=2e-5)


def test_the_kernel_called_gives_sums_and_the_whole_first_sum_only_when_asked(sphere_problem):
    p = _with(sphere_problem, KernelOptions())
    kernel = p._pair_sums
    sums, full = kernel(NORMALS, None)
    assert full is None
    assert kernel.launch(NORMALS, None)()[1] is None  # the whole first sum only when asked
    close(sums, direct_sums(p, NORMALS))
    sums, full = kernel(NORMALS, 0.3, full_first=True)
    close(sums, direct_sums(p, NORMALS, 0.3))
    close(full, direct_sums(p, NORMALS)[:, 0])
    assert full.dtype == np.float64 and full.shape == (p.pair_view.size,)


@pytest.mark.parametrize("chunk", [None, 2])
def test_the_kernel_and_the_numpy_passes_sum_the_same_float32_terms(sphere_problem, chunk, monkeypatch):
    """The numpy passes and the kernel make the same float32 terms: their sums agree to 1e-6 (a
    float64 term on one side would differ by 2e-5 here), with and without a reach."""
    if chunk is not None:
        monkeypatch.setattr(problem_module, "PAIR_CHUNK", chunk)
    p = _with(sphere_problem, REF)
    k = _with(sphere_problem, KernelOptions())
    for reach in (None, 0.3, 2.0):
        num, ker = p.pair_radiance(NORMALS, reach), k.pair_radiance(NORMALS, reach)
        np.testing.assert_allclose(num, ker, rtol=1e-6, atol=1e-9 * float(ker.max()))
        np.testing.assert_allclose(k.pair_radiance_numpy(NORMALS, reach), ker, rtol=1e-6, atol=1e-9 * float(ker.max()))
    assert np.abs(num - direct_sums(p, NORMALS, 2.0)).max() > 1e-7 * float(num.max())  # float32 terms, not float64


@pytest.mark.parametrize("kernels", [REF, KernelOptions()], ids=["numpy", "kernel"])
def test_a_lamella_normal_and_its_opposite_are_the_same(sphere_problem, kernels):
    """Axial lamellae: m and -m give the same sums (|h·m| in the lobe)."""
    p = _with(sphere_problem, kernels)
    close(p.pair_radiance(-NORMALS), p.pair_radiance(NORMALS))
    close(p.pair_radiance(-NORMALS, 0.3), direct_sums(p, NORMALS, 0.3))


def test_the_kept_sum_is_found_for_the_same_normal_given_as_whole_numbers(sphere_problem, monkeypatch):
    p = _with(sphere_problem, KernelOptions())
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]])
    p.pair_radiance(normals, 0.3)
    monkeypatch.setattr(p._pair_sums, "launch", lambda *a, **k: pytest.fail("the kept sum is read"))
    close(p.pair_radiance([0, 0, 1]), direct_sums(p, normals)[:, :1])


def test_exactly_1e_6_above_the_horizon_is_below_it():
    """The facing tests are strict: a light or view whose cosine with the normal is exactly 1e-6
    counts as below the horizon, on the host and on the device alike."""
    from labcut.backend import ad_types
    from labcut.orientation.problem import _setting_pairs, lights_reach

    dr, t = ad_types()
    up = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    tilted = np.array([unit(0.3, 0.0, 1.0), unit(0.3, 0.0, 1.0)])
    graze = np.array([[1.0, 0.0, 1e-6], [1.0, 0.0, 2e-6]])
    assert float(np.array([0.0, 0.0, 1.0]) @ graze[0]) == 1e-6
    a3 = lambda x: t.Array3f64(*(np.ascontiguousarray(x[:, k]) for k in range(3)))  # noqa: E731
    bright = t.Bool(np.array([True, True]))
    np.testing.assert_array_equal(np.asarray(lights_reach(a3(up), a3(up), a3(graze), bright)), [False, True])
    np.testing.assert_array_equal(np.asarray(lights_reach(a3(up), a3(tilted), a3(graze), bright)), [False, True])
    np.testing.assert_array_equal(np.asarray(lights_reach(a3(tilted), a3(up), a3(graze), bright)), [False, True])
    np.testing.assert_array_equal(np.asarray(lights_reach(a3(up), a3(up), a3(graze), t.Bool(np.array([True, False])))),
                                  [False, False])
    for n_geo, n_sh in ((up, up), (up, tilted), (tilted, up)):
        pi, pv, _ = view_pairs(graze, np.zeros((2, 3)), n_geo, n_sh, None, False)
        np.testing.assert_array_equal(pi, [0, 1])
        np.testing.assert_array_equal(pv, [1, 1])
        pose = _setting_pairs(graze, np.array([1.0, 1.0]), graze, np.zeros((2, 3)), n_geo, n_sh, None, True)
        np.testing.assert_array_equal(pose.lit, [[False, True], [False, True]])
    pose = _setting_pairs(graze, np.array([1.0, 1.0]), graze, np.zeros((2, 3)), up, up, None, True)
    np.testing.assert_array_equal(pose.lit, [[False, True], [False, True]])
    pose = _setting_pairs(graze, np.array([1.0, 0.0]), graze, np.zeros((2, 3)), up, up, None, True)
    np.testing.assert_array_equal(pose.lit, [[False, False], [False, False]])
    # the shading normal's own test, host side: a shading normal tilted away drops the light
    away = np.array([[0.0, 0.0, 1.0], unit(-0.3, 0.0, 1.0)])
    pose = _setting_pairs(np.array([unit(1, 0, 0.1)]), np.array([1.0]), np.array([[0.0, 0.0, 1.0]]), np.zeros((2, 3)),
                          up, away, None, True)
    np.testing.assert_array_equal(pose.lit, [[True], [False]])
    pose = _setting_pairs(np.array([unit(1, 0, 0.1)]), np.array([1.0]), np.array([[0.0, 0.0, 1.0]]), np.zeros((2, 3)),
                          away, up, None, True)
    np.testing.assert_array_equal(pose.lit, [[True], [False]])


def test_lit_cells_of_one_chunk_are_kept_and_of_several_found_again():
    from labcut.backend import ad_types
    from labcut.orientation.problem import _LitCells

    dr, t = ad_types()
    masks = [np.array([True, False, True]), np.array([False, False, False]), np.array([False, True, True, True])]
    calls = []

    def test(k):
        calls.append(k)
        return t.Bool(masks[k])

    one = _LitCells(test, 1)
    assert one.total == 2 and calls == [0]
    np.testing.assert_array_equal(np.asarray(one.chunk(0)), [0, 2])
    assert calls == [0]
    calls.clear()
    three = _LitCells(test, 3)
    assert three.total == 5 and calls == [0, 1, 2]
    np.testing.assert_array_equal(np.asarray(three.chunk(2)), [1, 2, 3])
    np.testing.assert_array_equal(np.asarray(three.chunk(0)), [0, 2])
    assert calls == [0, 1, 2, 2, 0]
    assert np.asarray(three.chunk(1)).size == 0


def test_the_defaults_standard_quality_and_tau_0_1():
    p = build_problem(box(), LAB, Lights([[0, 0, 1]]), Views([[0, 0, 1]]), kernels=REF)
    from labcut.scene.quality import Quality

    assert p.n_points == Quality.coerce("standard").surface_points == 8000
    assert p.tau == 0.1
    assert p.threshold == pytest.approx(0.1 * flash_threshold(LAB, p.lights, 1.0), rel=1e-12)


def test_a_material_without_contrast_is_refused():
    from dataclasses import replace

    flat = replace(LAB, n_b=LAB.n_a)
    assert reference_radiance(flat, 1.0) == 0.0
    with pytest.raises(ParameterError) as e:
        build_problem(box(), flat, Lights([[0, 0, 1]]), Views([[0, 0, 1]]), n_points=20, kernels=REF)
    assert str(e.value) == "the material reflects nothing at normal incidence: no flash can be scored"


def test_the_lit_cells_are_found_on_the_device_only_without_occlusion_rays(monkeypatch):
    """KernelOptions.lit_cells: the kernel path tests the lights on the device (the poses carry no
    lit tables) unless occlusion rays are cast; the host tables otherwise."""
    calls = []
    real = problem_module._lit_cells
    monkeypatch.setattr(problem_module, "_lit_cells", lambda *a: calls.append(1) or real(*a))
    lights, views = Lights([[0, 0, 1]]), Views([[0, 0, 1]])
    build_problem(box(), LAB, lights, views, n_points=20, kernels=KernelOptions())
    assert calls == [1]
    build_problem(box(), LAB, lights, views, n_points=20, kernels=KernelOptions(), occlusion=True)
    build_problem(box(), LAB, lights, views, n_points=20, kernels=KernelOptions(lit_cells=False))
    build_problem(box(), LAB, lights, views, n_points=20, kernels=REF)
    assert calls == [1]


def test_three_poses_number_their_views_one_after_another():
    mesh = box()
    poses = [Setting(Lights([[0, 0, 1]]), Views([[0, 0, 1], unit(0.2, 0, 1)]), 1.0, np.eye(3)),
             Setting(Lights([[0, 0, 1]]), Views([[0, 0, 1]]), 1.0, np.eye(3)),
             Setting(Lights([unit(0.3, 0, 1)]), Views([unit(-0.2, 0, 1), [0, 0, 1], unit(0, 0.2, 1)]), 2.0, np.eye(3))]
    for kernels in (REF, KernelOptions()):
        p = build_problem(mesh, LAB, settings=poses, n_points=30, seed=2, kernels=kernels)
        assert_matches(p, mesh, poses, 30, 2)
        assert set(p.pair_view) == set(range(6))
        np.testing.assert_allclose(p.view_weight, [0.125, 0.125, 0.25, 1 / 6, 1 / 6, 1 / 6])


def test_one_triple_is_a_problem():
    mesh = box()
    seed = next(k for k in range(100) if samples_of(mesh, 1, k).n_geo[0, 2] > 0.5)  # the one point on the top
    p = build_problem(mesh, LAB, Lights([[0, 0, 1]]), Views([[0, 0, 1]]), n_points=1, seed=seed, kernels=REF)
    assert p.n_triples == 1 and p.c[0] == pytest.approx(1.0 / LAB.lobe_norm, rel=2e-5)


def test_triples_that_carry_nothing_are_refused(monkeypatch):
    """Every triple's factor 0 (here: a luminance table dark below normal incidence, light and view
    tilted): no flash can be seen, refused as when no light reaches what a viewer sees."""
    grid, values = luminance_table(LAB)
    dark = np.zeros_like(values)
    dark[-1] = values[-1]
    monkeypatch.setattr(problem_module, "luminance_table", lambda material: (grid, dark))
    mesh = box()
    with pytest.raises(ParameterError, match="^no light reaches a part of the stone that a viewer sees"):
        build_problem(mesh, LAB, Lights([unit(0.5, 0, 1)]), Views([unit(-0.5, 0, 1)]), n_points=20, kernels=REF)
    p = build_problem(mesh, LAB, Lights([[0, 0, 1]]), Views([[0, 0, 1]]), n_points=20, seed=3, kernels=REF)
    assert p.n_triples > 0 and (p.c > 0).all()


def test_the_reach_is_tested_in_float32_as_the_triples_are_stored(sphere_problem):
    """A triple whose float32 orientation is the float32 of the normal: its float32 cosine is 1, so
    a reach of 0 keeps it (in float64 against the unrounded normal it would be 1 - 1.2e-8, dropped)."""
    m = np.array([-0.6163616173170751, 0.6670578943701972, 0.41848789977331285])
    h = m.astype(np.float32)[None]
    assert float(h[0].astype(np.float64) @ m) < 1.0
    p = _with(sphere_problem, REF, h=h, c=np.array([2.0], dtype=np.float32), pair=np.array([0], dtype=np.int32))
    got = p.pair_radiance(m, 0.0)
    assert got[0, 0] == pytest.approx(2.0 * p.q_norm, rel=1e-6) and got[1:].sum() == 0.0


def test_a_view_that_sees_little_still_has_weights_summing_to_1():
    """One point at cos 0.8 from the only view: its pair's weight is 1 (not 0.8)."""
    n = np.array([unit(0.6, 0, 0.8)])
    pi, pv, w = view_pairs(np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3)), n, n, None, False)
    np.testing.assert_array_equal(pi, [0])
    np.testing.assert_allclose(w, [1.0])


def test_a_pose_with_more_lights_before_one_with_fewer_in_every_chunking():
    """The host's (pair x light slot) table of a chunk that holds the end of one pose and the start
    of the next: each pose's rows only, whatever the chunk size (the first pose has three lights,
    the second one)."""
    mesh = box()
    a = Setting(Lights([[0, 0, 1], unit(1, 0, 1), unit(-1, 0, 1)], [1, 2, 1]), Views([[0, 0, 1]]), 1.0, np.eye(3))
    b = Setting(Lights([unit(0, 1, 1)]), Views([[0, 0, 1]]), 1.0, np.eye(3))
    s = samples_of(mesh, 60, 1)
    assert (s.n_geo[:, 2] > 0.5).sum() >= 6
    for k in range(1, 10):
        p = build_problem(mesh, LAB, settings=[a, b], n_points=60, seed=1,
                          kernels=KernelOptions(lit_cells=False, dense_chunk=3 * k))
        assert_matches(p, mesh, [a, b], 60, 1)


def test_the_device_path_makes_no_host_lit_tables(monkeypatch):
    calls = []
    real = problem_module._setting_pairs
    monkeypatch.setattr(problem_module, "_setting_pairs", lambda *a: calls.append(1) or real(*a))
    lights, views = Lights([[0, 0, 1]]), Views([[0, 0, 1]])
    build_problem(box(), LAB, lights, views, n_points=20, kernels=KernelOptions())
    assert calls == []
    build_problem(box(), LAB, lights, views, n_points=20, kernels=KernelOptions(lit_cells=False))
    assert calls == [1]


def test_the_pairs_of_device_cells_are_the_hosts():
    """``_pairs_of_cells``: the pair of each (pair, light slot) cell, ``index // width + first`` as
    int32, the same from the device's lit cells (divided there, one host copy) as from numpy's."""
    from labcut.backend import ad_types
    from labcut.orientation.problem import _pairs_of_cells

    _, t = ad_types()
    kernel = _TripleKernel(np.array([[0.0, 0.0, 1.0]]), LAB.n_surface, luminance_table(LAB), reference_radiance(LAB, 1.0))
    rng = np.random.default_rng(5)
    for width, first in ((1, 0), (3, 0), (7, 123_456), (64, 2**30)):
        index = np.sort(rng.choice(50_000 * width, size=20_000, replace=False)).astype(np.uint32)
        host = _pairs_of_cells(kernel, index, width, first)
        device = _pairs_of_cells(kernel, t.UInt32(index), width, first)
        assert host.dtype == device.dtype == np.int32
        np.testing.assert_array_equal(device, host)
        np.testing.assert_array_equal(host, index.astype(np.int64) // width + first)
