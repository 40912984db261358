"""`hairshade demo`: the shipped truth, the equal-error estimate, and a run
end to end."""

import csv
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import hairshade as hs
from hairshade import demo

ROOT = pathlib.Path(__file__).resolve().parent.parent


def test_01_shipped_truth_is_the_reference():
    """The float16 truth in the package is the 640x360 reference: its mean
    RGB is the one recorded beside the float32 original (relative
    difference <= 2e-4: float16 keeps 11 bits, 4.9e-4 per value, and the
    rounding errors average out over 230 400 pixels)."""
    truth, meta = demo.demo_truth()
    assert truth.shape == (360, 640, 3) and truth.dtype == np.float32 and np.isfinite(truth).all()
    assert truth.min() >= 0
    recorded = [0.10696294903755188, 0.10718909651041031, 0.12531036138534546]  # references.json, mean_rgb
    np.testing.assert_allclose(truth.reshape(-1, 3).mean(0), recorded, rtol=2e-4)
    assert meta["width"] == 640 and meta["height"] == 360 and meta["noise_halves_rel_mse"] == pytest.approx(1.2e-3, 0.01)


def test_02_equal_error_spp_predicts_the_measured_ladder():
    """From any one render of Mitsuba's ladder (docs/equal_error_ladder.csv,
    the demo head at 640x360, measured on the GPU machine), relMSE = C/spp
    + floor with the truth's noise as floor predicts the spp that the
    ladder measured at balanced's error (docs/equal_error.csv) within 15%
    (largest deviation seen: 10%, from the 32-spp render)."""
    ladder = [r for r in csv.DictReader(open(ROOT / "docs" / "equal_error_ladder.csv")) if r["head"] == "demo_head_640"]
    row = next(r for r in csv.DictReader(open(ROOT / "docs" / "equal_error.csv"))
               if r["head"] == "demo_head_640" and r["quality"] == "balanced")
    target, measured = float(row["rel_mse"]), int(row["mitsuba_spp"])
    floor = demo.demo_truth()[1]["noise_halves_rel_mse"]
    for r in ladder:
        spp, e = int(r["spp"]), float(r["rel_mse"])
        if 16 <= spp <= 256:
            assert demo.equal_spp(spp, e, target, floor) == pytest.approx(measured, rel=0.15), spp
    with pytest.raises(ValueError, match="target"):
        demo.equal_spp(32, 1e-3, 8e-3, 1.2e-3)


@pytest.mark.mitsuba
def test_03_demo_runs_end_to_end(tmp_path):
    """At a size with no shipped truth, the demo renders a Mitsuba
    reference, every preset, and writes the images; its printed table has a
    row per preset."""
    out = subprocess.run([sys.executable, "-m", "hairshade", "demo", "--out", str(tmp_path), "--width", "96",
                          "--height", "54", "--spp", "2"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "no truth shipped" not in out.stdout and "none shipped for this scene and size" in out.stdout
    for q in ("fast", "balanced", "accurate"):
        assert any(line.startswith(q) for line in out.stdout.splitlines()), out.stdout
        img = hs.read_exr(tmp_path / f"demo_{q}.exr")
        assert img.shape == (54, 96, 3) and np.isfinite(img).all()
    assert (tmp_path / "demo_presets.png").stat().st_size > 0


def test_04_demo_scene_is_the_example():
    """The demo's scene is the packaged example the truth was rendered from."""
    assert pathlib.Path(demo.SCENE).name == "strand_head.json"
    meta = demo.demo_truth()[1]
    assert meta["scene"] == "examples/strand_head.json"
    d = json.loads(pathlib.Path(demo.SCENE).read_text())
    assert d["camera"]["resolution"] == [640, 360]
