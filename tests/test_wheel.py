"""The package as a user installs it: the wheel built by maturin, installed
with pip into a fresh virtual environment that has nothing else but numpy
(from the package index), used from outside the source tree.

`maturin build --release` reuses the release build of `make build` (same
cargo invocation, same target directory), so after it this test costs the
packaging, the virtual environment and numpy's download."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXTRAS = {  # command -> the extra its one-line error must name
    ("validate",): "mitsuba",
    ("bench", "--bsdf-only", "--n", "256"): "mitsuba",
    ("tables", "--out", "t"): "mapping",
    ("demo", "--out", "d"): "mitsuba,flip",
    ("compare", "a.exr", "a.exr"): "flip",
}

USE = r"""
import sys, numpy as np, hairshade as hs
from hairshade._extras import MissingExtra
scenes = hs.examples()
assert len(scenes) >= 5, scenes
for p in scenes:
    img = hs.render(hs.Scene.load(p), width=48, progress=False)
    assert np.all(np.isfinite(img)) and img.max() > 0, p
    print("rendered", p.split("/")[-1])
try:
    hs.mapping
    raise SystemExit("hs.mapping imported without scipy")
except MissingExtra as e:
    assert "pip install 'hairshade[mapping]'" in str(e), e
try:
    import hairshade.mitsuba
    raise SystemExit("hairshade.mitsuba imported without mitsuba")
except ImportError as e:
    assert "pip install 'hairshade[mitsuba]'" in str(e), e
print("ok")
"""


def run(args, cwd, timeout=600, **kw):
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout, **kw)


@pytest.mark.slow
def test_01_wheel_in_a_fresh_venv(tmp_path):
    pytest.importorskip("maturin", reason="maturin builds the wheel (requirements-dev.txt)")
    if not (ROOT / "pyproject.toml").exists():
        pytest.skip("not a source checkout")
    r = run([sys.executable, "-m", "maturin", "build", "--release", "-q", "-o", str(tmp_path / "dist")], ROOT, timeout=1800)
    assert r.returncode == 0, r.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("hairshade-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert any(n.endswith("hairshade/examples/strand_head.json") for n in names)
    assert {"LICENSE-MIT", "LICENSE-APACHE"} <= {os.path.basename(n) for n in names if ".dist-info/" in n}

    venv = tmp_path / "venv"
    assert run([sys.executable, "-m", "venv", str(venv)], tmp_path).returncode == 0
    py, bin_ = venv / "bin" / "python", venv / "bin"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    r = run([str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check", str(wheel)], tmp_path, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    r = run([str(py), "-m", "pip", "list", "--format=freeze", "--disable-pip-version-check"], tmp_path, env=env)
    installed = {line.split("==")[0].lower() for line in r.stdout.split()}
    assert installed - {"pip", "setuptools", "wheel"} == {"hairshade", "numpy"}, installed

    work = tmp_path / "work"  # outside the source tree: only the installed package is importable
    work.mkdir()
    r = run([str(py), "-c", USE], work, env=env)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stdout + r.stderr

    cli = str(bin_ / "hairshade")
    r = run([cli, "demo", "--help"], work, env=env)
    assert r.returncode == 0 and "--spp" in r.stdout, r.stderr
    scene = run([str(py), "-c", "import hairshade as hs; print(hs.examples()[0])"], work, env=env).stdout.strip()
    r = run([cli, "render", scene, "-o", "a.exr", "--width", "64"], work, env=env)
    assert r.returncode == 0 and (work / "a.exr").exists(), r.stderr
    for args, extra in EXTRAS.items():
        r = run([cli, *args], work, env=env)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and f"pip install 'hairshade[{extra}]'" in lines[0], (args, r.stderr)
        assert r.stdout == "", (args, r.stdout)  # failed before doing any work
    r = run([cli, "compare", "a.exr", "a.exr", "--no-flip"], work, env=env)
    assert r.returncode == 0 and "relMSE 0.0000e+00" in r.stdout, r.stderr
