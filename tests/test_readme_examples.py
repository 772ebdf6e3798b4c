"""README examples show what they promise (issue 33, item 6): the polarizer pair shows the glare and
then its absence, with the flash kept; the environment-map example runs on the map that ships."""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _readme_lines(word: str) -> list[list[str]]:
    return [shlex.split(line.split("#")[0]) for line in README.splitlines() if line.startswith("labcut ") and word in line]


def test_the_polarizer_pair_removes_the_glare_and_keeps_the_flash(cli, tmp_path):
    lines = _readme_lines("--polarizer")
    assert [a[a.index("--polarizer") + 1] for a in lines] == ["0", "90"]
    images = []
    for args in lines:
        out = tmp_path / args[args.index("-o") + 1]
        args[args.index("-o") + 1] = str(out)
        proc = cli(*args[1:], "--resolution", "48", "--spp", "8", "--exposure", "1", cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        images.append(np.asarray(Image.open(out).convert("RGB"), dtype=np.float64))
    glare, clear = images
    assert glare.max() >= 240  # the lamp's white reflection on the face
    assert clear.max() < 0.8 * glare.max()  # gone behind the polariser at Brewster's angle
    stone = clear[..., 2] > clear[..., 0] + 20  # the blue flash, still there
    assert stone.mean() > 0.05


def test_the_environment_map_example_runs_on_the_shipped_map(cli):
    (args,) = [a for a in _readme_lines("--lighting examples/studio.exr")]
    assert (ROOT / "examples" / "studio.exr").is_file()
    proc = cli(*args[1:], "--quality", "draft", "--json", "-", cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
