"""Looking at linear renders: tonemap (8-bit sRGB), write_png, show() in a
notebook, and the scripts' pictures encoded once."""

import pathlib
import re

import numpy as np
import pytest

import hairshade as hs

ROOT = pathlib.Path(__file__).resolve().parent.parent


def srgb(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB encoding in float64 (independent of the kernels)."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def test_01_tonemap_is_srgb():
    """Linear 0.18 is 118 (mid grey); a ramp over [0, 1.2] matches the
    float64 sRGB formula rounded, to 1 code value where float32's powf
    lands the other side of a rounding boundary (seen: 0 of 4096)."""
    assert hs.tonemap(np.full((1, 1, 3), 0.18, np.float32))[0, 0].tolist() == [118, 118, 118]
    x = np.linspace(0, 1.2, 4096 * 3, dtype=np.float32).reshape(64, 64, 3)
    got = hs.tonemap(x).astype(int)
    want = np.floor(srgb(x.astype(np.float64)) * 255 + 0.5).astype(int)
    assert np.abs(got - want).max() <= 1 and np.mean(got != want) < 1e-3
    assert hs.tonemap(x).dtype == np.uint8 and hs.tonemap(x).shape == x.shape


def test_02_exposure_and_non_finite_values():
    """exposure scales by 2**stops; "auto" makes the 99.5th percentile
    white; NaN and inf become black; a bad exposure names the parameter."""
    img = np.full((4, 4, 3), 0.045, np.float32)
    assert hs.tonemap(img, exposure=2)[0, 0, 0] == 118  # 0.045 * 4 = 0.18
    ramp = np.linspace(0, 8, 1000, dtype=np.float32).repeat(3).reshape(10, 100, 3)
    auto = hs.tonemap(ramp, exposure="auto")
    p = np.percentile(ramp, 99.5)
    assert auto[ramp >= p].min() == 255 and auto[ramp < 0.99 * p].max() < 255
    bad = np.array([[[np.nan, np.inf, -np.inf]]], np.float32)
    assert hs.tonemap(bad).tolist() == [[[0, 0, 0]]]
    for e in ("bright", np.nan, 1000, True):
        with pytest.raises(ValueError, match="exposure"):
            hs.tonemap(img, exposure=e)
    with pytest.raises(ValueError, match=r"image: expected shape \(H, W, 3\)"):
        hs.tonemap(np.zeros((4, 4)))


def test_03_png_file_and_notebook_preview_hold_the_tonemap(tmp_path):
    """write_png's file and show()'s _repr_png_ are the same PNG, and
    decoded by matplotlib (an independent PNG reader) give tonemap's bytes."""
    mpimg = pytest.importorskip("matplotlib.image")
    rng = np.random.default_rng(2)
    img = rng.uniform(0, 1.5, (9, 13, 3)).astype(np.float32)
    path = tmp_path / "a.png"
    hs.write_png(path, img, exposure=-0.5)
    preview = hs.show(img, exposure=-0.5)
    assert preview._repr_png_() == path.read_bytes()
    decoded = np.round(mpimg.imread(path) * 255).astype(np.uint8)
    np.testing.assert_array_equal(decoded, hs.tonemap(img, exposure=-0.5))
    assert repr(preview) == "Preview(13x9, exposure=-0.50 stops)"


def test_04_scripts_encode_their_pictures_once():
    """The pictures of scripts/ go through write_png, which encodes sRGB:
    none raises values to 1/2.2 (or any power) before it, which washed the
    docs' pictures out (linear 0.18 became 180/255 instead of 118/255)."""
    gamma = re.compile(r"\*\*\s*\(\s*1\s*/\s*2\.[0-9]+\s*\)")
    offenders = [f"{p.name}:{n}" for p in sorted((ROOT / "scripts").glob("*.py"))
                 for n, line in enumerate(p.read_text().splitlines(), 1) if gamma.search(line)]
    assert not offenders, offenders
