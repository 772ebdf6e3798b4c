"""Backend selection and the libLLVM start-up check."""

from __future__ import annotations

import fnmatch
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from labcut import backend
from labcut.errors import BackendError, LLVMVersionError, ParameterError


def test_picks_llvm_without_cuda_and_names_variants():
    assert backend.device() in ("llvm", "cuda")
    name = backend.variant_name("rgb")
    assert name.endswith("_ad_rgb") and name.split("_")[0] == backend.device()
    assert backend.variant_name("spectral", polarized=True).endswith("_ad_spectral_polarized")


def test_bad_mode_is_a_parameter_error():
    with pytest.raises(ParameterError):
        backend.variant_name("hyperspectral")
    with pytest.raises(ParameterError):
        backend.variant_name("rgb", polarized=True)


def test_check_llvm_names_the_fix(monkeypatch):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setattr(backend, "find_libllvm", lambda: (15, "/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1"))
    monkeypatch.setattr(backend, "_cuda_driver_present", lambda: False)
    with pytest.raises(LLVMVersionError, match="libllvm19") as info:
        backend.check_llvm()
    assert "libLLVM 15" in str(info.value) and "\n" not in str(info.value)


def test_check_llvm_passes_with_a_new_llvm(monkeypatch):
    monkeypatch.setattr(backend, "find_libllvm", lambda: (19, "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"))
    backend.check_llvm()


def test_llvm_file_names_parse():
    assert backend._llvm_major("libLLVM-15.so.1") == 15
    assert backend._llvm_major("libLLVM.so.19.1") == 19
    assert backend._llvm_major("libLLVM-19.so") == 19
    assert backend._llvm_major("libfoo.so") is None


def test_llvm_search_is_drjits_own(monkeypatch, tmp_path):
    """labcut checks the library Dr.Jit will load: the user's DRJIT_LIBLLVM_PATH, else the newest
    in Dr.Jit's own folders (a libLLVM elsewhere is named in the error, not silently used)."""
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    found = backend.find_libllvm()
    if found is not None:
        assert any(fnmatch.fnmatch(found[1], p) for p in backend.DRJIT_LLVM_GLOBS)
    lib = tmp_path / "libLLVM-19.so.1"
    lib.write_bytes(b"")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(lib))
    assert backend.find_libllvm() == (19, str(lib))


def test_check_llvm_names_a_library_drjit_does_not_search(monkeypatch):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setattr(backend, "find_libllvm", lambda: (15, "/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1"))
    monkeypatch.setattr(backend, "_newest", lambda patterns: (19, "/usr/local/lib/libLLVM-19.so"))
    monkeypatch.setattr(backend, "_cuda_driver_present", lambda: False)
    with pytest.raises(LLVMVersionError, match="DRJIT_LIBLLVM_PATH=/usr/local/lib/libLLVM-19.so"):
        backend.check_llvm()


IMPORT_CHANGES = r"""
import json, os, sys, warnings
import numpy, drjit, mitsuba, trimesh, typer, rich  # what they change on import is theirs
env, filters, finders = dict(os.environ), list(warnings.filters), list(sys.meta_path)
modules = {name: dict(vars(m)) for name, m in sys.modules.items()
           if name.split(".")[0] in ("trimesh", "numpy", "scipy", "networkx") and m is not None}
import labcut
changed = {k for k in set(env) | set(os.environ) if env.get(k) != os.environ.get(k)}
rebound = sorted(f"{name}.{attr}" for name, before in modules.items() for attr, value in before.items()
                 if vars(sys.modules[name]).get(attr, None) is not value)
print(json.dumps({"env": sorted(changed), "filters": len(warnings.filters) - len(filters),
                  "finders": [type(f).__name__ for f in sys.meta_path if f not in finders],
                  "rebound": rebound[:5]}))
"""


def test_import_labcut_changes_nothing_in_the_process():
    """A library changes nothing on import: no environment variable, warning filter or import
    hook, and no other package's module namespace rebound."""
    # a bare environment: nothing a parent process (this one imported labcut) may have set
    env = {k: os.environ[k] for k in ("PATH", "HOME", "XDG_CACHE_HOME") if k in os.environ}
    proc = subprocess.run([sys.executable, "-c", IMPORT_CHANGES], capture_output=True, text=True, check=True, env=env)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out == {"env": [], "filters": 0, "finders": [], "rebound": []}


def test_trimesh_imported_after_labcut_is_plain_trimesh():
    code = ("import inspect, sys, labcut, trimesh.proximity as p; "
            "print(inspect.isclass(p.cKDTree), type(sys.modules['scipy.spatial']).__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True", "module"]


def test_import_fails_clearly_without_a_usable_llvm(tmp_path):
    fake = tmp_path / "libLLVM-15.so.1"
    fake.write_bytes(b"")
    env = {**os.environ, "DRJIT_LIBLLVM_PATH": str(fake)}
    proc = subprocess.run([sys.executable, "-c", "import labcut"], capture_output=True, text=True, env=env)
    if backend._cuda_driver_present():
        pytest.skip("a CUDA driver is present: labcut runs on CUDA without LLVM")
    assert proc.returncode != 0
    assert "LLVMVersionError" in proc.stderr and "libllvm19" in proc.stderr


def test_bad_forced_backend(monkeypatch):
    backend.device.cache_clear()
    monkeypatch.setenv("LABCUT_BACKEND", "opencl")
    try:
        with pytest.raises(BackendError):
            backend.device()
    finally:
        backend.device.cache_clear()


def test_set_variant_selects_mitsuba_variant():
    import threading

    import mitsuba as mi

    name = backend.set_variant("mono")
    # (an intermittent failure here has read rgb right after: the threads alive say who switched it)
    assert mi.variant() == name, [t.name for t in threading.enumerate()]


def test_cuda_probe_loads_the_driver_library_by_name(monkeypatch):
    """The probe asks the dynamic loader (no ldconfig/gcc subprocesses): a library that loads
    means a driver, none means none."""
    import ctypes

    tried: list[str] = []

    def fake(name, *a, **k):
        tried.append(name)
        if name != "libcuda.so":
            raise OSError(name)
        return object()

    monkeypatch.setattr(ctypes, "CDLL", fake)
    backend._cuda_driver_present.cache_clear()
    try:
        assert backend._cuda_driver_present() is True
        assert tried[:2] == ["libcuda.so.1", "libcuda.so"]
        monkeypatch.setattr(ctypes, "CDLL", lambda name, *a, **k: (_ for _ in ()).throw(OSError(name)))
        backend._cuda_driver_present.cache_clear()
        assert backend._cuda_driver_present() is False
    finally:
        backend._cuda_driver_present.cache_clear()


def test_recommendation_runs_numpy_blas_on_one_thread_and_restores_it(monkeypatch):
    """Inside a recommendation (and an evaluation) numpy's BLAS runs on one thread beside
    Dr.Jit's pool (backend.serial_blas); the caller's thread count comes back afterwards."""
    from threadpoolctl import threadpool_info, threadpool_limits

    import labcut
    from labcut.orientation import recommend as rec_module

    def blas_threads() -> set[int]:
        return {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}

    from labcut.orientation import optimize as opt

    seen: list[set[int]] = []
    real = opt.run_optimizer

    def spy(*args, **kwargs):
        seen.append(blas_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(opt, "run_optimizer", spy)
    real_metrics = rec_module.Scorer.metrics

    def spy_metrics(self, *args, **kwargs):
        seen.append(blas_threads())
        return real_metrics(self, *args, **kwargs)

    monkeypatch.setattr(rec_module.Scorer, "metrics", spy_metrics)
    mesh = labcut.load_mesh(Path(__file__).resolve().parents[1] / "meshes" / "oval-16x12-low.ply")
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == {2}
        labcut.recommend_orientation(mesh, "blue", scenario="bench", quality="draft")
        assert blas_threads() == {2}
        labcut.evaluate_orientation(mesh, (0, 0, 1), "blue", scenario="bench", quality="draft")
        assert blas_threads() == {2}
    assert len(seen) >= 2 and all(s == {1} for s in seen), seen
