"""Every script in examples/ runs."""

import pathlib
import subprocess
import sys

import pytest

EXAMPLES = sorted((pathlib.Path(__file__).parent.parent / "examples").glob("*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.name)
def test_example_runs(script):
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip()


def test_there_are_examples():
    assert EXAMPLES


SCENES = sorted((pathlib.Path(__file__).parent.parent / "examples").glob("*.json"))


@pytest.mark.parametrize("scene", SCENES, ids=lambda p: p.name)
def test_example_scene_renders(scene):
    """Every example scene loads and renders (small) to a finite image with content."""
    import numpy as np

    import hairshade as hs

    img = hs.render(hs.Scene.load(scene), width=80)
    assert np.all(np.isfinite(img)) and img.max() > 0 and img.shape[1] == 80


def test_there_are_example_scenes():
    assert len(SCENES) >= 5
