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
    first = p.c[(p.pair == 0)]
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
    for kernels in (REF, KernelOptions(), KernelOptions(lit_cells=False, dense_chunk=3), KernelOptions(dense_chunk=2)):
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
    return build_problem(mesh, LAB, lights, views, n_points=60, seed=2, kernels=REF)


def _with(problem, kernels, **changes):
    from dataclasses import replace

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
    """A shading normal of zero length (no refraction can be made): its triples are h = +Z, c = 0 on
    both paths, the others as usual."""
    n_sh = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    L, E, V = np.array([[0.0, 0.0, 1.0]]), np.array([1.0]), np.array([[0.0, 0.0, 1.0]])
    table = luminance_table(LAB)
    l_ref = reference_radiance(LAB, 1.0)
    pose = _PosePairs(np.array([0, 1]), np.array([0, 0]), np.array([0.5, 0.5]), np.array([[True], [True]]))
    got = []
    _setting_triples(L, E, V, pose, n_sh, LAB.n_surface, table, l_ref, 2, 100, lambda *a: got.append(a))
    h, c, pair = got[0]
    np.testing.assert_allclose(h, [[0, 0, 1], [0, 0, 1]], atol=1e-6)
    assert c[0] == pytest.approx(1.0 / LAB.lobe_norm, rel=1e-5) and c[1] == 0.0
    np.testing.assert_array_equal(pair, [0, 1])
    assert h.dtype == np.float32 and c.dtype == np.float32
    kernel = _TripleKernel(n_sh, LAB.n_surface, table, l_ref)
    h2, c2 = kernel.dense(L, E, V, np.array([0, 1]), np.array([0, 0]), np.array([0, 0]), 1, np.array([0, 1]))
    np.testing.assert_allclose(h2, [[0, 0, 1], [0, 0, 1]], atol=1e-6)
    assert c2[0] == pytest.approx(1.0 / LAB.lobe_norm, rel=1e-5) and c2[1] == 0.0


def test_pair_chunk_keeps_the_lobe_values_near_17_mb():
    assert problem_module.PAIR_CHUNK == 1 << 18
    assert problem_module.PAIR_CHUNK * 4 == 2**20  # a megabyte of float32 lobe values a stencil normal
