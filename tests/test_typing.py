"""The public API type-checks from a user's side: `mypy --strict` on
tests/typing/user_script.py (hairshade's own modules are followed silently,
as an installed package with py.typed is), and the script runs."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import hairshade

SCRIPT = os.path.join(os.path.dirname(__file__), "typing", "user_script.py")


@pytest.mark.slow  # mypy's first run builds its cache of numpy's stubs: ~20 s on 2 cores
def test_01_mypy_strict_on_a_user_script():
    pytest.importorskip("mypy")
    pkg_root = os.path.dirname(os.path.dirname(os.path.abspath(hairshade.__file__)))
    env = dict(os.environ, MYPYPATH=pkg_root)
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--follow-imports=silent", "--no-incremental", SCRIPT],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Success: no issues found in 1 source file" in r.stdout


def test_02_the_user_script_runs():
    r = subprocess.run([sys.executable, SCRIPT], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr


BAD = '''
import hairshade as hs
scene = hs.Scene.load(hs.examples()[0])
hs.render(scene, qualty="fast")
hs.render(scene, transparency={"mlab": {"samples": 4}})
hs.render(scene, quality="slow")
'''


@pytest.mark.slow  # mypy: ~20 s
def test_03_mypy_strict_rejects_misspelt_and_misplaced_settings(tmp_path):
    """Each of the three bad calls is an error of its own: the misspelt
    keyword, `samples` under MLAB, an unknown preset."""
    pytest.importorskip("mypy")
    script = tmp_path / "bad.py"
    script.write_text(BAD)
    pkg_root = os.path.dirname(os.path.dirname(os.path.abspath(hairshade.__file__)))
    env = dict(os.environ, MYPYPATH=pkg_root)
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--follow-imports=silent", "--no-incremental",
                        str(script)], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 1, r.stdout + r.stderr
    lines = [line for line in r.stdout.splitlines() if ": error:" in line]
    assert {int(line.split(":")[1]) for line in lines} == {4, 5, 6}, r.stdout
    assert "qualty" in r.stdout, r.stdout
