"""Every script in examples/ runs; every example scene renders and ships with the package."""

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


def test_example_scenes_ship_with_the_package():
    """hs.examples() lists the scene files inside the installed package
    (examples/ in the repository points there), each loadable."""
    import os

    import hairshade as hs

    paths = hs.examples()
    assert [os.path.basename(p) for p in paths] == [p.name for p in SCENES]
    pkg = os.path.dirname(os.path.abspath(hs.__file__))
    for p in paths:
        assert os.path.commonpath([pkg, p]) == pkg
        assert hs.Scene.load(p).strand_count > 0 or hs.Scene.load(p).cards is not None
