"""numpy's huge page advice in labcut's own processes (labcut.hugepages): off where it decides
(transparent huge pages enabled on madvise) in a command that runs once and ends, left alone
elsewhere, in a library call, in the explorer, and wherever the user set NUMPY_MADVISE_HUGEPAGE."""

from __future__ import annotations

import os
import subprocess
import sys
import types

import pytest

from labcut import hugepages

SWITCH = hugepages._numpy_switch()
pytestmark = pytest.mark.skipif(SWITCH is None, reason="this numpy has no huge page switch")


def _policy(tmp_path, text):
    path = tmp_path / "enabled"
    path.write_text(text + "\n")
    return path


@pytest.mark.parametrize("text, policy, taken", [
    ("always [madvise] never", "madvise", True),
    ("[always] madvise never", "always", False),  # huge pages with or without the advice
    ("always madvise [never]", "never", False),
    ("always madvise never", None, False),
    ("", None, False),
])
def test_the_policy_is_the_bracketed_word(tmp_path, text, policy, taken):
    path = _policy(tmp_path, text)
    assert hugepages.thp_policy(path) == policy
    assert hugepages.advice_taken(path) is taken


def test_no_policy_file_takes_no_advice(tmp_path):
    assert hugepages.thp_policy(tmp_path / "absent") is None and not hugepages.advice_taken(tmp_path / "absent")


@pytest.fixture
def numpy_switch():
    """numpy's advice as it was, put back after the test."""
    before = SWITCH(True)
    SWITCH(before)
    yield
    SWITCH(before)


def _advice_now() -> bool:
    return hugepages.numpy_advice()


def test_the_command_process_turns_the_advice_off_where_the_kernel_acts_on_it(tmp_path, monkeypatch, numpy_switch):
    monkeypatch.delenv(hugepages.NUMPY_VARIABLE, raising=False)
    SWITCH(True)
    assert not hugepages.numpy_off_for_this_process(_policy(tmp_path, "always madvise [never]"))
    assert _advice_now() is True
    assert hugepages.numpy_off_for_this_process(_policy(tmp_path, "always [madvise] never"))
    assert _advice_now() is False


def test_a_variable_the_user_set_is_left_as_set(tmp_path, monkeypatch, numpy_switch):
    taken = _policy(tmp_path, "always [madvise] never")  # the advice decides
    SWITCH(True)
    for value in ("1", "0"):
        monkeypatch.setenv(hugepages.NUMPY_VARIABLE, value)
        assert not hugepages.numpy_off_for_this_process(taken)
        assert _advice_now() is True


def test_only_the_console_script_of_a_command_that_ends_turns_it_off(monkeypatch):
    """labcut_cli.app.main: run as the console script (argv None) it decides for its process; called
    with arguments (a program or a test driving the CLI in its own process) it does not, nor for a
    command whose process answers for minutes (the explorer: its answers reuse freed memory)."""
    from labcut_cli import app as app_module

    calls = []
    monkeypatch.setattr(app_module, "numpy_off_for_this_process", lambda: calls.append(1) or True)
    monkeypatch.setattr(app_module, "gc", types.SimpleNamespace(freeze=lambda: None))  # this process goes on
    with pytest.raises(SystemExit) as done:
        app_module.main(["scenarios"])
    assert done.value.code == 0 and calls == []
    monkeypatch.setattr(sys, "argv", ["labcut", "scenarios"])
    with pytest.raises(SystemExit) as done:
        app_module.main()
    assert done.value.code == 0 and calls == [1]
    assert "explore" in app_module.LONG_LIVED
    monkeypatch.setattr(sys, "argv", ["labcut", "explore", "--help"])
    with pytest.raises(SystemExit) as done:
        app_module.main()
    assert done.value.code == 0 and calls == [1]


def test_a_library_call_leaves_numpys_advice_as_it_was():
    """In a process of the user's own, importing labcut and asking it something changes nothing of
    numpy's advice."""
    # numpy's own switch read before labcut is imported (labcut.hugepages would import labcut first)
    code = ("import numpy as np; switch = (getattr(np, '_core', None) or np.core).multiarray._set_madvise_hugepage; "
            "before = switch(True); switch(before); import labcut; "
            "labcut.evaluate_orientation(labcut.cabochon('oval', 8, 6, dome='low'), (0, 0, 1), 'blue', quality='draft'); "
            "after = switch(True); switch(after); print(before, after)")
    env = {k: v for k, v in os.environ.items() if k != hugepages.NUMPY_VARIABLE}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    before, after = out.stdout.split()[-2:]
    assert before in ("True", "False") and after == before
