"""Stratified surface samples (labcut.geometry.surface.draw_samples): one sample in each of as many
equal-area stretches of the faces laid along a Morton curve, so that every compact patch of the
surface holds its share of the samples to within one or two."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.geometry import stone as stone_module
from labcut.geometry import surface
from labcut.scene.directions import direction

MESHES = Path(__file__).resolve().parents[1] / "meshes"


def test_morton_cells_walk_a_grid_in_z_order():
    # a 4 x 4 grid in the plane, as cells of a box 128 cells a side: x is the lowest bit, then y;
    # the first quadrant is walked whole first
    g = np.array([(x, y, 0.0) for y in range(4) for x in range(4)], dtype=np.float64)
    cells = surface.morton_cells(g * 32.0, np.zeros(3), np.full(3, 127.0))
    walked = g[np.argsort(cells)][:, :2].tolist()
    assert walked[:8] == [[0, 0], [1, 0], [0, 1], [1, 1], [2, 0], [3, 0], [2, 1], [3, 1]]
    assert cells.tolist()[:4] == [0, 1 << 15, 1 << 18, (1 << 15) | (1 << 18)]  # x = 32, 64, 96: bits 5 and 6 of x are bits 15 and 18
    # on a line the cells follow the points
    x = np.sort(np.random.default_rng(1).random(50))
    line = surface.morton_cells(np.stack([x, np.zeros(50), np.zeros(50)], axis=1))
    assert np.all(np.diff(line) >= 0) and line[0] == 0 and line[-1] == surface._SPREAD[127]


def test_each_face_gets_its_share_to_within_one():
    rng = np.random.default_rng(4)
    prob = rng.random(40)
    prob[[3, 17, 39]] = 0.0  # faces of no area (the last one too) are never drawn
    cells = rng.integers(0, 12, 40) * 1000  # several faces share a cell
    n = 1000
    faces, r1 = surface._stratified_faces(prob, cells, n, np.random.default_rng(0))
    counts = np.bincount(faces, minlength=40)
    assert np.all(np.abs(counts - n * prob / prob.sum()) < 1.0 + 1e-9)
    assert counts[[3, 17, 39]].sum() == 0
    assert r1.min() >= 0.0 and r1.max() <= 1.0
    # the strata follow the cells, and the faces of a cell in face order
    order = np.lexsort((np.arange(40), cells))
    assert np.all(np.diff(np.argsort(order)[faces]) >= 0)
    # within a face the samples' first barycentric uniforms spread over [0, 1]: the strata cut the face's stretch
    big = int(np.argmax(prob))
    assert np.ptp(r1[faces == big]) > 0.8


@pytest.fixture(scope="module")
def high_oval():
    return labcut.load_mesh(MESHES / "oval-16x12-high.ply")


def test_every_octant_of_the_stone_holds_its_area_share_to_within_one(high_oval):
    """The faces whose centroids lie in one octant of the bounding box are one stretch of the Morton
    curve: their samples number their area's share of the total to within one (random draws: tens)."""
    st = labcut.Stone.of(high_oval)
    split = st.smooth_split()
    v = np.asarray(split.vertices, dtype=np.float32)
    centroid = v[split.faces[:, 0]] + v[split.faces[:, 1]] + v[split.faces[:, 2]]  # as face_cells has them
    lo, hi = 3.0 * v.min(axis=0), 3.0 * v.max(axis=0)
    q = np.clip((centroid - lo) * (127.0 / (hi - lo)).astype(np.float32), 0, 127).astype(np.uint8)
    octant = ((q >= 64).astype(np.int64) * np.array([1, 2, 4])).sum(axis=1)  # the curve's first cut
    share = np.bincount(octant, weights=split.area_faces, minlength=8) / split.area_faces.sum()
    n = 8000
    face = surface._stratified_faces(split.area_faces, surface.face_cells(split), n, np.random.default_rng(7))[0]
    strat = np.bincount(octant[face], minlength=8)
    assert np.all(np.abs(strat - n * share) <= 1.0 + 1e-9), (strat, n * share)
    rand = np.bincount(octant[np.random.default_rng(7).choice(len(share := split.area_faces), n, p=share / share.sum())],
                       minlength=8)
    assert np.abs(rand - n * np.bincount(octant, weights=split.area_faces, minlength=8) / split.area_faces.sum()).max() > 5.0


def test_face_cells_rank_the_occupied_cells_in_curve_order(high_oval):
    """face_cells gives each face the rank of its Morton cell among the occupied cells: 0 .. K-1,
    every rank used, in the codes' order; a draw over the ranks is the draw over the codes to the
    bit (the empty cells between add exact zeros to the running total), over arrays of K cells
    instead of the grid's 2^21."""
    split = labcut.Stone.of(high_oval).smooth_split()
    f = split.faces
    codes = surface.face_codes(split)
    ranks = surface.face_cells(split)
    assert ranks.dtype.itemsize <= 4 and ranks.min() == 0
    assert np.array_equal(np.unique(ranks), np.arange(ranks.max() + 1))
    assert np.array_equal(ranks, np.unique(codes, return_inverse=True)[1].ravel())
    assert ranks.max() + 1 < len(f) < (1 << 21)
    for seed in (0, 7):
        by_rank = surface._stratified_faces(split.area_faces, ranks, 5000, np.random.default_rng(seed))
        by_code = surface._stratified_faces(split.area_faces, codes, 5000, np.random.default_rng(seed))
        assert np.array_equal(by_rank[0], by_code[0]) and np.array_equal(by_rank[1], by_code[1])


def test_the_samples_are_area_uniform_on_the_surface(high_oval):
    """Their points lie on the mesh, their shading normals are unit, and the share above half the
    dome's height is the area's there, stratified or random."""
    st = labcut.Stone.of(high_oval)
    split = st.smooth_split()
    z_mid = 0.5 * float(split.vertices[:, 2].max())
    tri_above = split.vertices[split.faces].mean(axis=1)[:, 2] > z_mid
    want = float(split.area_faces[tri_above].sum() / split.area_faces.sum())
    for sampling, slack in (("stratified", 0.008), ("random", 0.016)):  # faces astride the cut: about 0.004
        s = st.surface_samples(20000, 2, sampling)
        assert s.points.shape == (20000, 3) and np.allclose(np.linalg.norm(s.n_sh, axis=1), 1.0)
        lo, hi = high_oval.bounds
        assert np.all(s.points >= lo - 1e-9) and np.all(s.points <= hi + 1e-9)
        assert abs(float(np.mean(s.points[:, 2] > z_mid)) - want) < slack


def test_random_sampling_is_the_independent_draws_of_before(high_oval):
    st = labcut.Stone.of(high_oval)
    split = st.smooth_split()
    s = st.surface_samples(300, 9, "random")
    rng = np.random.default_rng(9)
    face = rng.choice(len(split.area_faces), size=300, p=split.area_faces / split.area_faces.sum())
    r1, r2 = rng.random(300), rng.random(300)
    sq = np.sqrt(r1)
    bary = np.stack([1 - sq, sq * (1 - r2), sq * r2], axis=1)
    np.testing.assert_array_equal(s.points, np.einsum("ij,ijk->ik", bary, split.vertices[split.faces[face]]))


def test_a_stone_keeps_its_face_cells_and_each_samplings_samples(high_oval, monkeypatch):
    fresh = labcut.Stone(high_oval.copy())
    orders = []
    real = stone_module.face_cells
    monkeypatch.setattr(stone_module, "face_cells", lambda mesh: orders.append(1) or real(mesh))
    a = fresh.surface_samples(500, 3)
    assert fresh.surface_samples(500, 3, "stratified") is a
    b = fresh.surface_samples(500, 4)
    r = fresh.surface_samples(500, 3, "random")
    assert orders == [1] and r is not a and not np.array_equal(r.points, a.points) and b is not a
    with pytest.raises(ParameterError, match="surface sampling must be one of stratified, random, got 'sobol'"):
        fresh.surface_samples(500, 3, "sobol")


def test_quality_names_the_sampling():
    assert labcut.Quality.coerce("standard").surface_sampling == "stratified"
    assert labcut.Quality.coerce({"surface_sampling": "random"}).surface_sampling == "random"
    with pytest.raises(ParameterError, match="quality surface_sampling must be one of stratified, random"):
        labcut.Quality.coerce("draft").replace(surface_sampling="grid")


def test_stratified_samples_scatter_the_flash_less_over_seeds(high_oval):
    """The point of it: the high oval's flash energy under a front spot, at one normal, over six
    seeds of 3,000 samples, scatters several times less stratified than drawn at random."""
    m = direction(18.0, 270.0)
    spread = {}
    for sampling in ("stratified", "random"):
        q = labcut.Quality.coerce("draft").replace(surface_sampling=sampling)
        values = []
        for seed in range(6):
            study = labcut.Study(high_oval, lighting="spot", viewing="face-up", quality=q, seed=seed)
            values.append(study.scorer.metrics(m).flash_energy)
        spread[sampling] = float(np.std(values, ddof=1) / np.mean(values))
    assert spread["stratified"] < 0.4 * spread["random"], spread
