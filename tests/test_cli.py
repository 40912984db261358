"""The command line: render, compare, and clear errors with exit code 2."""

import pathlib
import subprocess
import sys

EXAMPLES = pathlib.Path(__file__).parent.parent / "examples"


def run(*args):
    return subprocess.run([sys.executable, "-m", "hairshade", *args], capture_output=True, text=True, timeout=300)


def test_render_and_compare(tmp_path):
    out = tmp_path / "strand.exr"
    r = run("render", str(EXAMPLES / "single_strand.json"), "-o", str(out), "--png", "--width", "160")
    assert r.returncode == 0, r.stderr
    assert out.exists() and (tmp_path / "strand.png").exists()
    assert "160x90" in r.stdout
    r = run("compare", str(out), str(out), "--png", str(tmp_path / "cmp.png"))
    assert r.returncode == 0, r.stderr
    assert "relMSE 0.0000e+00" in r.stdout and (tmp_path / "cmp.png").exists()


def test_errors_exit_2(tmp_path):
    r = run("render", str(tmp_path / "missing.json"))
    assert r.returncode == 2 and "missing.json: file not found" in r.stderr
    bad = tmp_path / "bad.json"
    bad.write_text('{"hairshade_scene": 1, "camera": {"position": [0,0,1], "target": [0,0,0], "fov": -3}}')
    r = run("render", str(bad))
    assert r.returncode == 2 and "camera.fov: must be in" in r.stderr
