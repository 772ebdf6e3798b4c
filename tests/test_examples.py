"""The API examples stay runnable (they are what designers copy)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("script, expect", [("sweep_light_tilt.py", "lamella tilt"), ("compare_domes.py", "tolerance")])
def test_example_runs(script, expect):
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / script)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert expect in proc.stdout


def test_recommend_carving_example(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "recommend_carving.py"), "--quick", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / "carving-recommended.png").exists() and (tmp_path / "carving-score-map.png").exists()


def test_scenario_gallery_writes_every_scenario(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "scenario_gallery.py"), "--quick", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = (tmp_path / "scenarios.md").read_text()
    from labcut.scene import SCENARIOS

    for name in SCENARIOS.names():
        assert f"### `{name}`" in text
        assert (tmp_path / "images" / f"scenario-{name}.png").exists() and (tmp_path / "images" / f"scenario-{name}-diagram.png").exists()
