"""Shared test configuration: deterministic hypothesis runs, CLI runner."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

import labcut  # noqa: F401 - registers the labradorite plugin with Mitsuba for every test

settings.register_profile(
    "labcut",
    deadline=None,
    derandomize=True,  # CI must not flake: the same examples every run
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "labcut"))

# every test computes its answers: the command's answer store (labcut_cli.answers) is off for the
# suite and its own processes; tests/test_cli_answers.py switches it on where it tests it
os.environ["LABCUT_ANSWERS"] = "off"

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args: str, cwd: Path | None = None, columns: int = 120) -> subprocess.CompletedProcess[str]:
    """Run the installed ``labcut`` console script in a terminal ``columns`` wide; returns the completed process."""
    exe = Path(sys.executable).with_name("labcut")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "labcut_cli.app"]
    env = {**os.environ, "COLUMNS": str(columns), "NO_COLOR": "1"}
    env.pop("LABCUT_DEBUG", None)
    return subprocess.run([*cmd, *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=300)


@pytest.fixture
def cli(request, capsys):
    """``cli(*args, cwd=None, columns=120)``: the ``labcut`` command as a ``CompletedProcess``. The
    installed console script in a new process (:func:`run_cli`), or, in a module that sets
    ``CLI_IN_PROCESS = True`` (nothing it checks depends on a fresh interpreter: no first call of a
    process, no signal), ``labcut_cli.app.main`` in this process (:func:`cli_main`), without an
    interpreter's start-up and imports per call."""
    if getattr(request.module, "CLI_IN_PROCESS", False):
        return _in_process_cli(capsys)
    return run_cli


def _in_process_cli(capsys):
    from cli_run import in_process

    def run(*args: str, cwd: Path | None = None, columns: int = 120) -> subprocess.CompletedProcess[str]:
        return in_process(args, capsys, cwd=cwd, columns=columns)  # 120 columns: as run_cli's terminal

    return run


@pytest.fixture
def cli_main(capsys):
    """The CLI in this process (``labcut_cli.app.main``, as the console script runs it, without a
    new interpreter's start-up and imports: about 1.5 s a call): ``cli_main(*args)`` returns a
    ``subprocess.CompletedProcess`` of its exit status, stdout and stderr, like :func:`run_cli`."""
    return _in_process_cli(capsys)


@pytest.fixture
def variant():
    """Set a Mitsuba variant for one test, as Mitsuba's own conftest does: ``variant("spectral",
    polarized=True)`` picks the CUDA or LLVM form (labcut.backend), skips the test when the
    variant is missing on this machine, and restores the previous variant afterwards."""
    import mitsuba as mi

    from labcut.backend import set_variant, variant_name
    from labcut.errors import BackendError

    previous = mi.variant()

    def use(mode: str = "rgb", polarized: bool = False) -> str:
        name = variant_name(mode, polarized)
        if name not in mi.variants():
            pytest.skip(f"Mitsuba variant {name} is not available here")
        try:
            return set_variant(mode, polarized)
        except BackendError as exc:  # pragma: no cover - a broken backend on this machine
            pytest.skip(str(exc))

    yield use
    if previous is not None and mi.variant() != previous:
        mi.set_variant(previous)


@pytest.fixture(scope="module")
def fresh_pilot_cache(tmp_path_factory):
    """The effect planner's pilot renders measured in this module, not read from an earlier run's
    cache (its own cache file and an empty in-process cache)."""
    import labcut.planner as planner

    mp = pytest.MonkeyPatch()
    mp.setattr(planner, "_pilot_cache_path", lambda: tmp_path_factory.mktemp("cache") / "planner-pilot.json")
    mp.setattr(planner, "_PILOT_CACHE", {})
    yield
    mp.undo()


@pytest.fixture
def catalogue_folder(tmp_path):
    """A folder for the batch catalogue tests: ``m/`` holds a 10 mm cube, a step cut and the SRB
    GemCad design (copies of the bundled meshes); returns the folder."""
    import shutil
    from pathlib import Path

    meshes = Path(__file__).resolve().parents[1] / "meshes"
    (tmp_path / "m").mkdir()
    shutil.copy(meshes / "cube-10.ply", tmp_path / "m" / "cube.ply")
    shutil.copy(meshes / "step-cut-12x10.ply", tmp_path / "m" / "step.ply")
    shutil.copy(meshes / "designs" / "SRB.asc", tmp_path / "m" / "SRB.asc")
    return tmp_path


@pytest.fixture
def fresh_user_cache(tmp_path, monkeypatch):
    """labcut's user cache as a new user's: an empty folder of its own, nothing kept in this
    process (the calibration files' and the scene peaks' memos); returns the folder."""
    from labcut import fileio
    from labcut.orientation import radiance

    folder = tmp_path / "user-cache"
    monkeypatch.setattr(fileio, "cache_path", lambda name: folder / name)
    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    monkeypatch.setattr(fileio, "_CACHE_WARNED", set())
    monkeypatch.setattr(radiance, "_PEAKS", {})
    return folder


@pytest.fixture(autouse=True, scope="module")
def _let_go_of_the_modules_scenes():
    """Collect what a test module left behind when it ends: every live Mitsuba shape and BSDF (a
    mesh's cached ray scene, a fixture's render objective) is traced into each later
    differentiable render's calls, so a worker that kept a module's meshes alive ran the render
    estimator's tests 10-20x slower for the rest of its run (docs/performance.md)."""
    yield
    import gc

    gc.collect()


def _explorer_threads() -> set[int]:
    import threading

    return {t.ident for t in threading.enumerate() if t.name.startswith("labcut-explore") and t.ident is not None}


@pytest.fixture(autouse=True)
def _no_explorer_left_running(request):
    """Fail the test that leaves an explorer running, not the one it hurts: an explorer's worker
    draws its pictures in Mitsuba, whose variant is the process's, so one left running by a test
    (the README's snippet, which starts one) switched tests/test_backend.py's variant to rgb under
    it on the same xdist worker, in CI. tests/test_explore.py's module-wide explorer is exempt
    while its tests use it (its fixture stops it and checks its threads ended)."""
    before = _explorer_threads()
    yield
    if "explorer" in request.fixturenames:
        return
    import time

    deadline = time.monotonic() + 30.0  # an explorer stopping: its threads end in moments
    while (left := _explorer_threads() - before) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not left, f"{request.node.nodeid} left a labcut explorer running (call Explorer.stop())"
