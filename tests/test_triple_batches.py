"""Every pose's triples in one Dr.Jit kernel call per chunk of (pair, light) cells
(``problem._all_triples``, issue 17 §4) give the per-pose numpy reference's triples: the same
triples in the same order (pose, pair, light), their terms to float32 rounding, whatever the chunk
and however many lights each pose has."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.orientation import problem as problem_module
from labcut.orientation.kernels import KernelOptions
from labcut.orientation.problem import build_problem
from labcut.scene import Lights, Setting, Views, resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"
KEYS = ("pair", "pair_view", "pair_weight", "view_weight")


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(MESHES / "oval-16x12-low.ply")


def _same(fast, slow):
    for key in KEYS:
        np.testing.assert_array_equal(getattr(fast, key), getattr(slow, key))
    np.testing.assert_allclose(fast.h, slow.h, rtol=0, atol=1e-6)
    np.testing.assert_allclose(fast.c, slow.c, rtol=0, atol=1e-5 * float(slow.c.max()))


def test_poses_of_unequal_light_counts(oval, monkeypatch):
    """Poses with 1, 4 and 2 lights (empty light slots are unlit) and unequal view counts."""
    rng = np.random.default_rng(3)

    def lights(n):
        d = rng.normal(size=(n, 3)) * [0.4, 0.4, 0.0] + [0.0, 0.0, 1.0]
        return Lights(d / np.linalg.norm(d, axis=1, keepdims=True), weights=rng.uniform(0.5, 2.0, n))

    settings = [Setting(lights(1), Views([[0.0, 0.0, 1.0]]), 0.5, np.eye(3)),
                Setting(lights(4), Views([[0.0, 0.2, 0.98], [0.1, 0.0, 0.995]], weights=[0.7, 0.3]), 0.3, np.eye(3)),
                Setting(lights(2), Views([[0.3, 0.0, 0.954]]), 0.2, np.eye(3))]
    lab = labcut.Labradorite.preset("blue")
    fast = build_problem(oval, lab, quality="draft", settings=settings)
    slow = build_problem(oval, lab, quality="draft", settings=settings, kernels=KernelOptions(triples=False))
    assert fast.n_triples == slow.n_triples > 0
    _same(fast, slow)


def test_chunks_of_cells_give_the_one_call_triples(oval, monkeypatch):
    """A chunk far smaller than the problem (pairs of one pose split between calls): the triples
    of one call, bit for bit."""
    lab = labcut.Labradorite.preset("blue")
    settings = resolve_scene("bench", None, None, "draft").settings()
    kw: dict = {}
    whole = build_problem(oval, lab, quality="draft", settings=settings, **kw)
    width = max(len(st.lights.directions) for st in settings)  # light slots per pair
    assert whole.info["pairs"] * width > 20 * 1000  # twenty chunks and more
    chunked = build_problem(oval, lab, quality="draft", settings=settings, kernels=KernelOptions(dense_chunk=1000), **kw)
    for key in ("h", "c", *KEYS):
        np.testing.assert_array_equal(getattr(chunked, key), getattr(whole, key))
    _same(whole, build_problem(oval, lab, quality="draft", settings=settings, kernels=KernelOptions(triples=False), **kw))


@pytest.mark.parametrize("chunk", [None, 20_000])
def test_the_device_copy_of_the_triples_is_the_host_arrays(oval, chunk, monkeypatch):
    """A problem made in one kernel call keeps that call's device arrays as its device copy (no copy
    back from the host); made in several chunks, the copy is made from the host arrays. Either way
    the device copy holds the host arrays' values bit for bit."""
    kernels = KernelOptions() if chunk is None else KernelOptions(dense_chunk=chunk)
    setup_settings = labcut.Scenario.preset("bench", "draft").settings()
    p = build_problem(oval, labcut.Labradorite.preset("blue"), quality="draft", settings=setup_settings, kernels=kernels)
    kept = "device_triples" in p.__dict__
    assert kept is (chunk is None)  # one call: its arrays were kept
    h, c = p.device_triples
    np.testing.assert_array_equal(np.stack([np.asarray(h.x), np.asarray(h.y), np.asarray(h.z)], axis=1), p.h)
    np.testing.assert_array_equal(np.asarray(c), p.c)


@pytest.mark.parametrize("scenario", ["bench", "ring", "pendant"])
@pytest.mark.parametrize("chunk", [None, 30_000])
def test_lights_tested_on_the_device_give_the_host_tables_triples(oval, scenario, chunk, monkeypatch):
    """Without occlusion rays the kernel path tests which lights reach each pair's point on the
    device (KernelOptions.lit_cells) instead of the host's (points x lights) tables: the same triples
    in the same order, in one chunk or several."""
    kernels = KernelOptions() if chunk is None else KernelOptions(dense_chunk=chunk)
    settings = labcut.Scenario.preset(scenario, "draft").settings()
    lab = labcut.Labradorite.preset("blue")
    on_device = build_problem(oval, lab, quality="draft", settings=settings, kernels=kernels)
    on_host = build_problem(oval, lab, quality="draft", settings=settings, kernels=replace(kernels, lit_cells=False))
    assert on_device.n_triples == on_host.n_triples > 0
    for key in ("h", "c", "pair", "pair_view", "pair_weight", "view_weight"):
        np.testing.assert_array_equal(getattr(on_device, key), getattr(on_host, key))


def test_the_device_light_test_is_the_hosts(oval, monkeypatch):
    """Lights at the horizon of some points and one of no irradiance: a light counts where it faces
    the point's geometric and shading normals and carries light, as on the host."""
    rng = np.random.default_rng(5)
    d = rng.normal(size=(9, 3)) * [0.9, 0.9, 0.3] + [0.0, 0.0, 0.35]
    weights = rng.uniform(0.5, 2.0, 9)
    weights[4] = 0.0
    settings = [Setting(Lights(d / np.linalg.norm(d, axis=1, keepdims=True), weights=weights),
                        Views([[0.0, 0.0, 1.0], [0.4, 0.0, 0.9]]), 1.0, np.eye(3))]
    lab = labcut.Labradorite.preset("blue")
    on_device = build_problem(oval, lab, quality="draft", settings=settings)
    on_host = build_problem(oval, lab, quality="draft", settings=settings, kernels=KernelOptions(lit_cells=False))
    for key in ("h", "c", "pair"):
        np.testing.assert_array_equal(getattr(on_device, key), getattr(on_host, key))
