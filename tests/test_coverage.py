"""Coverage samples (render option ``transparency: "coverage"``): hair as
opaque sub-pixel geometry. Checked against exact geometric identities
(covered areas of planar curtains computed analytically), against the
sorted composite where the two must agree, and for determinism."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import hairshade as hs
from helpers import pinhole_rays

# Camera looking down -z at the plane z = 0 from distance D: a point (x, y, 0)
# projects to pixel x_px = W/2 + x/PIX, so widths and areas on the plane are
# exact in pixels.
W, H, FOV, D = 320, 180, 40.0, 2.0
PIX = 2 * D * math.tan(math.radians(FOV / 2)) / H  # world size of a pixel on the plane


def _curtain(width_px: float, spacing_px: float, z: float = 0.0, offset_px: float = 0.0) -> list[dict]:
    """Vertical strands on the plane z, `width_px` wide, `spacing_px` apart,
    at x = (offset + k·spacing)·PIX, from y = -0.55 to 0.55."""
    r = 0.5 * width_px * PIX * (D - z) / D  # the same pixel width at depth D - z
    n = int(1.3 / (spacing_px * PIX))
    xs = (offset_px + spacing_px * (np.arange(n) - n // 2)) * PIX * (D - z) / D
    return [{"points": [[x, -0.55, z], [x, 0.0, z], [x, 0.55, z]], "radius": r} for x in xs]


def _scene(strands: list[dict], **render) -> hs.Scene:
    # No light: hair is black over a white background, so 1 − image is the
    # covered fraction of each pixel.
    return hs.Scene.from_dict({
        "hairshade_scene": 1,
        "camera": {"position": [0, 0, D], "target": [0, 0, 0], "up": [0, 1, 0], "fov": FOV, "resolution": [W, H]},
        "lights": [],
        "hair": {"strands": strands, "material": {"model": "chiang"}},
        "render": {"background": [1, 1, 1], **render},
    })


def _covered(img: np.ndarray) -> float:
    """Mean covered fraction over pixels x in [40, 280), y in [30, 150):
    inside the curtain, away from its ends and sides."""
    return float(1.0 - img[30:150, 40:280].mean())


def _exact(width_px: float, spacing_px: float, offset_px: float = 0.0) -> float:
    """Covered fraction of the same window, computed from the strands' pixel
    intervals (disjoint strands: their widths add up). A strand's interval
    is its silhouette's: the rays from the eye tangent to the tube, at
    angles θc ± asin(r / dist) from the optical axis, meet the screen at
    x = W/2 + f tan(·); a strand X off the axis is wider than at the centre
    by about 1/cos θc (up to 11% at this window's sides)."""
    n = int(1.3 / (spacing_px * PIX))
    f = 0.5 * H / math.tan(math.radians(FOV / 2))
    x = (offset_px + spacing_px * (np.arange(n) - n // 2)) * PIX  # strand axes at depth D
    r = 0.5 * width_px * PIX
    theta, delta = np.arctan2(x, D), np.arcsin(r / np.hypot(x, D))
    lo = np.maximum(W / 2 + f * np.tan(theta - delta), 40.0)
    hi = np.minimum(W / 2 + f * np.tan(theta + delta), 280.0)
    return float(np.clip(hi - lo, 0.0, None).sum() / 240.0)


@pytest.mark.parametrize("spacing", [4.6, 1.0, 0.5])
def test_01_subpixel_strands_cover_their_true_area(spacing):
    """A curtain of 0.2-pixel strands covers its exact area within 1 % at
    4.6, 1 and 0.5 pixel spacing with 16 samples per pixel. Noise: each
    pixel's coverage is a count out of 16 stratified points, about ±1
    sample for a 0.2-pixel band (relative ±0.3 per pixel); the window holds
    120 independent pixels per strand and 52 strands at the widest spacing,
    so the mean is good to about 0.3/√6240 = 0.4 %. Measured errors: 0.03
    to 0.3 % (with every strand as wide as at the image centre, 2 r f / z,
    they were 1.7 to 2.0 % short: the off-centre stretch `_exact` includes).
    The MLAB composite (one-pixel footprint, alpha scaled by width) is 0 to
    12 % short on the same curtains, and is not gated here."""
    exact = _exact(0.2, spacing)
    got = _covered(hs.render(_scene(_curtain(0.2, spacing), transparency="coverage")))
    mlab = _covered(hs.render(_scene(_curtain(0.2, spacing), transparency="mlab")))
    print(f"spacing {spacing}: exact {exact:.5f}, coverage {got:.5f} ({got / exact - 1:+.2%}), "
          f"mlab {mlab:.5f} ({mlab / exact - 1:+.2%})")
    assert abs(got / exact - 1) < 0.01


def test_02_opaque_fibers_hide_what_lies_behind():
    """Two curtains of 0.6-pixel strands at different depths: exactly behind
    one another the far one is hidden (coverage is one curtain's); shifted
    by half the spacing they are disjoint on screen (coverage is both). The
    sorted composite of alpha-blended footprints gets neither: it treats
    every fragment as partly transparent. Tolerance as in test 01 (about
    0.4 % noise; 1 % gate)."""
    front = _curtain(0.6, 3.0, z=0.0)
    behind = _curtain(0.6, 3.0, z=-0.3)
    shifted = _curtain(0.6, 3.0, z=-0.3, offset_px=1.5)
    one = _exact(0.6, 3.0)
    hidden = _covered(hs.render(_scene(front + behind, transparency="coverage")))
    both = _covered(hs.render(_scene(front + shifted, transparency="coverage")))
    assert abs(hidden / one - 1) < 0.01, (hidden, one)
    assert abs(both / (one + _exact(0.6, 3.0, offset_px=1.5)) - 1) < 0.01, (both, one)


def test_03_wide_strands_agree_with_the_sorted_composite():
    """Strands several pixels wide, lit, in one layer: away from their edges
    every pixel is wholly covered in both modes, so the images agree there
    to float rounding; the edges (a box-filtered footprint against sample
    counts) agree in their mean within 1 %."""
    strands = _curtain(6.0, 14.0)
    lit = dict(transparency="coverage")
    d = {
        "hairshade_scene": 1,
        "camera": {"position": [0, 0, D], "target": [0, 0, 0], "up": [0, 1, 0], "fov": FOV, "resolution": [W, H]},
        "lights": [{"type": "directional", "direction": [0.3, 0.4, 1.0], "intensity": [3, 3, 3]}],
        "hair": {"strands": strands, "material": {"model": "chiang"}},
        "render": {"background": [0.2, 0.2, 0.2]},
    }
    cov = hs.render(hs.Scene.from_dict(d), **lit)
    srt = hs.render(hs.Scene.from_dict(d), transparency="sorted")
    inner = (np.abs(srt - cov).max(-1) < 1e-6) | (np.abs(srt - 0.2).max(-1) < 1e-6)
    assert inner[30:150].mean() > 0.6
    win = (slice(30, 150), slice(40, 280))
    np.testing.assert_allclose(cov[win].mean((0, 1)), srt[win].mean((0, 1)), rtol=0.01)


def test_04_deterministic_and_thread_count_independent(tmp_path):
    """The sample points depend on the pixel alone: the image is the same
    in every render and on one thread."""
    code = (
        "import numpy as np, hairshade as hs, sys; sys.path.insert(0, {tests!r});"
        "from test_coverage import _scene, _curtain;"
        "np.save({out!r}, hs.render(_scene(_curtain(0.3, 2.3), transparency='coverage', samples=8)))"
    ).format(tests=os.path.dirname(__file__), out=str(tmp_path / "one.npy"))
    a = hs.render(_scene(_curtain(0.3, 2.3), transparency="coverage", samples=8))
    np.testing.assert_array_equal(a, hs.render(_scene(_curtain(0.3, 2.3), transparency="coverage", samples=8)))
    subprocess.run([sys.executable, "-c", code], check=True, env=dict(os.environ, RAYON_NUM_THREADS="1"))
    np.testing.assert_array_equal(np.load(tmp_path / "one.npy"), a)


@pytest.mark.parametrize("bad", [0, 257, 2.5, "16"])
def test_05_samples_out_of_range_is_an_error(bad):
    with pytest.raises(ValueError, match="samples"):
        hs.render(_scene(_curtain(0.3, 2.3)), transparency="coverage", samples=bad)


def test_06_lit_sphere_is_lambertian_under_pcf():
    """A diffuse sphere under a shadowed directional light with PCF: every
    lit pixel equals albedo/π · E · n·l computed here by ray casting (the
    PCF taps are compared with the surface's tangent plane, so the sphere
    does not shadow itself). Tolerance: pixels away from the silhouette and
    the terminator (n·l > 0.1) within 1e-4 relative (float32 shading;
    measured at most 4.2e-5). With one depth for all taps a quarter of the
    head's pixels were a third or more too dark."""
    alb, e, ldir = np.array([0.5, 0.4, 0.35]), 3.0, np.array([0.1, 1.0, 0.3])
    d = {
        "hairshade_scene": 1,
        "camera": {"position": [0.25, 0.1, 2.3], "target": [0, -0.12, 0], "up": [0, 1, 0], "fov": 40,
                   "resolution": [W, H]},
        "meshes": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.48, "albedo": alb.tolist()}],
        "lights": [{"type": "directional", "direction": ldir.tolist(), "intensity": [e] * 3, "shadows": True}],
        "hair": {"strands": [{"points": [[2, 2, -3], [2, 2.1, -3]], "radius": 0.001}]},
        "render": {"pcf_radius": 1},
    }
    img = hs.render(hs.Scene.from_dict(d))
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    eye, dirs = pinhole_rays(hs.Scene.from_dict(d).camera, xs, ys, W, H)
    b = dirs @ eye
    disc = b * b - (eye @ eye - 0.48 ** 2)
    t = -b - np.sqrt(np.maximum(disc, 0))
    n = (eye + dirs * t[..., None]) / 0.48
    cos = n @ (ldir / np.linalg.norm(ldir))
    want = alb * e / math.pi * np.maximum(cos, 0)[..., None]
    lit = (disc > 0.02 * 0.48 ** 2) & (cos > 0.1)
    assert lit.sum() > 5000
    np.testing.assert_allclose(img[lit], want[lit], rtol=1e-4)


def test_07_traced_fiber_shadows_on_a_surface_are_averaged_over_the_pixel():
    """Thin vertical fibers (out of view) shadow a lit diffuse sphere; with
    traced shadows and coverage samples each pixel of the sphere is the
    mean of albedo/π · E · n·l · visibility over its footprint. The truth
    here: 8×8 sub-pixel rays per pixel, each shadow ray tested against the
    fibers' cylinders in numpy. Tolerance: the renderer averages over its
    16 sample points and the truth over 64 on a grid, so the shadowed
    fraction of a pixel crossed by a shadow edge is known to about 3/16
    (the 16 points' discrepancy for a band) plus 1/8 (the grid's): per
    pixel within 0.35 of the unshadowed value (measured 0.234); over the
    875 pixels the shadows touch, whose errors average out, the mean
    within 1% (measured 0.06%). Shaded once at the pixel centre, each
    pixel was all lit or all dark: 0.873 and 5.7%."""
    w, h = 160, 90
    alb, e = np.array([0.5, 0.4, 0.35]), 3.0
    ldir = np.array([1.0, 0.3, 0.6]) / np.linalg.norm([1.0, 0.3, 0.6])
    x_f, r_f, zs = 2.0, 0.003, np.linspace(0.3, 1.6, 40)
    strands = [{"points": [[x_f, -1.5, z], [x_f, 2.0, z]], "radius": r_f} for z in zs]
    eye, tgt = np.array([0.0, 0.0, 2.3]), np.array([0.0, 0.0, 0.0])
    d = {
        "hairshade_scene": 1,
        "camera": {"position": eye.tolist(), "target": tgt.tolist(), "up": [0, 1, 0], "fov": 40,
                   "resolution": [w, h]},
        "meshes": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.48, "albedo": alb.tolist()}],
        "lights": [{"type": "directional", "direction": ldir.tolist(), "intensity": [e] * 3, "shadows": True}],
        "hair": {"strands": strands},
        "render": {"transparency": "coverage", "shadow_model": "traced"},
    }
    img = hs.render(hs.Scene.from_dict(d))
    s = 8
    ys, xs = np.mgrid[0:h * s, 0:w * s] + 0.5
    eye, dirs = pinhole_rays(hs.Scene.from_dict(d).camera, xs / s, ys / s, w, h)
    b = dirs @ eye
    disc = b * b - (eye @ eye - 0.48 ** 2)
    q = eye + dirs * (-b - np.sqrt(np.maximum(disc, 0)))[..., None]
    lit = np.maximum((q / 0.48) @ ldir, 0)
    # the shadow ray q + t·l crosses the fibers' plane x = x_f at t; its
    # distance to a fiber (along y) is |Δz| · l_x / √(l_x² + l_z²)
    t = (x_f - q[..., 0]) / ldir[0]
    dz = q[..., 2][..., None] + t[..., None] * ldir[2] - zs
    blocked = (np.abs(dz) * ldir[0] / math.hypot(ldir[0], ldir[2]) < r_f).any(-1)
    want = (lit * ~blocked).reshape(h, s, w, s).mean(axis=(1, 3))
    unshadowed = lit.reshape(h, s, w, s).mean(axis=(1, 3))
    hit = (disc > 0.02 * 0.48 ** 2).reshape(h, s, w, s).all(axis=(1, 3))
    touched = hit & (want < unshadowed - 1e-6) & (unshadowed > 0.05)
    assert touched.sum() > 300, touched.sum()
    got = img[..., 0] / (alb[0] * e / math.pi)
    err = np.abs(got - want)[touched] / unshadowed[touched]
    ratio = got[touched].mean() / want[touched].mean()
    assert err.max() < 0.35, f"{touched.sum()} pixels: largest error {err.max():.3f}, mean ratio {ratio:.4f}"
    assert abs(ratio - 1) < 0.01, f"{touched.sum()} pixels: largest error {err.max():.3f}, mean ratio {ratio:.4f}"
