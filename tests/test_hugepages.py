"""numpy's huge page advice in labcut's own processes (labcut.hugepages): off where the kernel acts
on it (transparent huge pages enabled always or on madvise) in a command that runs once and ends,
left alone elsewhere, in a library call, in the explorer, and wherever the user set
NUMPY_MADVISE_HUGEPAGE."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from labcut import hugepages

SWITCH = np._core.multiarray._set_madvise_hugepage


def _policy(tmp_path, text):
    path = tmp_path / "defrag"
    path.write_text(text + "\n")
    return path


@pytest.mark.parametrize("text, policy, taken", [
    ("always [madvise] never", "madvise", True),
    ("[always] madvise never", "always", True),
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
    now = SWITCH(True)
    SWITCH(now)
    return now


def test_the_command_process_turns_the_advice_off_where_the_kernel_acts_on_it(tmp_path, monkeypatch, numpy_switch):
    monkeypatch.delenv(hugepages.NUMPY_VARIABLE, raising=False)
    SWITCH(True)
    assert not hugepages.numpy_off_for_this_process(_policy(tmp_path, "always madvise [never]"))
    assert _advice_now() is True
    assert hugepages.numpy_off_for_this_process(_policy(tmp_path, "always [madvise] never"))
    assert _advice_now() is False


def test_a_variable_the_user_set_is_left_as_set(tmp_path, monkeypatch, numpy_switch):
    taken = _policy(tmp_path, "[always] madvise never")  # the kernel acts on the advice
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

