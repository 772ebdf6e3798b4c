"""The examples in the public docstrings run, and say what they print (numpydoc ``Examples``)."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "labcut.physics.material",
    "labcut.physics.lamella",
    "labcut.scene.scenario",
    "labcut.scene.sets",
    "labcut.geometry.cabochon",
    "labcut.planner",
    "labcut.reports.compare",
    "labcut.orientation.question",
    "labcut.rendering.request",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
