"""Numerical stress: property-based tests over the full parameter and
direction ranges (hypothesis), and the scene-loader fuzz target run for a
bounded time (atheris)."""

from __future__ import annotations

import math
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import hairshade as hs

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# Components that include exact zeros, signs, denormals and huge magnitudes.
component = st.one_of(
    st.floats(-1.0, 1.0, allow_nan=False),
    st.sampled_from([0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 1e-300, 1e300, -1e300, 1e-40]),
)
direction = st.tuples(component, component, component)
unit01 = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1 / 255, 1e-3, 1.0]))


def special_directions():
    """theta = +-90 deg, phi = 0 and pi exactly, h = +-1 (x = -+1, z = 0)."""
    return np.array([
        [0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1],
        [np.cos(0.3), np.sin(0.3), 0.0], [-np.cos(0.3), np.sin(0.3), 0.0],
    ])


def _check(a):
    assert np.all(np.isfinite(a)), a
    assert np.all(a >= 0), a


@SETTINGS
@given(wi=direction, wo=direction, bm=unit01, bn=unit01, sigma=st.floats(0, 1e3), eta=st.floats(1.01, 3.0),
       tilt=st.floats(-10, 10), i0=st.sampled_from(["exact", "mitsuba"]))
def test_01_chiang_finite_nonnegative(wi, wo, bm, bn, sigma, eta, tilt, i0):
    m = hs.ChiangHair(sigma_a=sigma, longitudinal_roughness=bm, azimuthal_roughness=bn, eta=eta, scale_tilt=tilt, i0=i0)
    sp = special_directions()
    wi_all = np.vstack([np.array(wi), sp, sp[::-1]])
    wo_all = np.vstack([np.array(wo), sp[::-1], sp])
    for dtype in (np.float64, np.float32):
        with np.errstate(over="ignore"):  # 1e300 -> inf in float32: a non-finite input, documented as 0
            a, b = wi_all.astype(dtype), wo_all.astype(dtype)
            for f in (m.eval, m.pdf, m.eval_far):
                _check(f(a, b))
            wo_s, w, p = m.sample(a, np.full(len(a), 0.37, dtype), np.full((len(a), 2), 0.61, dtype))
            _check(w)
            _check(p)
            assert np.all(np.isfinite(wo_s))


@SETTINGS
@given(L=direction, V=direction, T=direction, r=unit01, color=st.tuples(unit01, unit01, unit01),
       scatter=unit01, shadow=unit01, legacy=st.booleans(), fast=st.booleans())
def test_02_karis_and_deon_finite_nonnegative(L, V, T, r, color, scatter, shadow, legacy, fast):
    k = hs.KarisHair(base_color=color, roughness=r, scatter=scatter, legacy_absorption=legacy, fast_asin=fast)
    sp = special_directions()
    Ls = np.vstack([L, sp, sp, -sp[:1]])
    Vs = np.vstack([V, sp, -sp, sp[:1]])  # includes V = L and V = -L
    Ts = np.vstack([T, np.tile([0.0, 1.0, 0.0], (2 * len(sp) + 1, 1))])
    for dtype in (np.float64, np.float32):
        with np.errstate(over="ignore"):
            a, b, c = Ls.astype(dtype), Vs.astype(dtype), Ts.astype(dtype)
            _check(k.eval(a, b, c, shadow=shadow))
            _check(k.eval_env(b, c, np.ones(3)))
    d = hs.DEonHair(base_color=color, roughness=r, h_samples=8)
    _check(d.eval(Ls, Vs, Ts))


def test_03_reference_albedo_at_most_one():
    """sigma_a = 0 at extreme roughness and eta: the near-field albedo is 1
    up to the stratified integration's error (measured <= 3e-3 here)."""
    rng = np.random.default_rng(0)
    n_y, n_phi = 512, 1024
    y = (np.arange(n_y)[:, None] + rng.random((n_y, n_phi))) / n_y * 2 - 1
    phi = (np.arange(n_phi)[None, :] + rng.random((n_y, n_phi))) / n_phi * 2 * np.pi
    r = np.sqrt(1 - y * y)
    d = np.stack([r * np.cos(phi), y, r * np.sin(phi)], -1).reshape(-1, 3)
    dw = 4 * np.pi / (n_y * n_phi)
    for bm, bn, eta in ((0.2, 0.2, 1.01), (1.0, 1.0, 3.0), (0.2, 1.0, 1.55), (1.0, 0.2, 2.2)):
        m = hs.ChiangHair(sigma_a=0.0, longitudinal_roughness=bm, azimuthal_roughness=bn, eta=eta)
        for wi in ([0.3, 0.5, 0.8], [0.0, 0.99, 0.14], [-1.0, 0.0, 0.0]):
            a = m.eval(wi, d).sum(axis=0) * dw
            assert np.all(a <= 1.01), (bm, bn, eta, wi, a)


def test_04_f32_against_f64_bound():
    """f32 within 1e-3 of f64 (relative, where above 1e-4 of the batch max)
    for every model at moderate roughness, including grazing directions."""
    rng = np.random.default_rng(1)
    v = rng.normal(size=(2, 4000, 3))
    v[:, :50, 1] = 50.0  # near the tangent
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    T = np.array([0.0, 1.0, 0.0])
    cases = [
        lambda a, b, t: hs.ChiangHair(longitudinal_roughness=0.3).eval(a, b),
        lambda a, b, t: hs.KarisHair(roughness=0.4, scatter=0.3).eval(a, b, t),
        lambda a, b, t: hs.DEonHair(roughness=0.5, h_samples=32).eval(a[:500], b[:500], t),
    ]
    for f in cases:
        x64 = f(v[0], v[1], T)
        x32 = f(v[0].astype(np.float32), v[1].astype(np.float32), T.astype(np.float32)).astype(np.float64)
        mask = x64 > 1e-4 * x64.max()
        assert np.max(np.abs(x32 - x64)[mask] / x64[mask]) < 1e-3


@settings(max_examples=30, deadline=None)
@given(pts=st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-3, 3)), min_size=2, max_size=6),
       radius=st.floats(0, 0.5), cam_z=st.floats(-1.0, 3.0), light_inside=st.booleans())
def test_05_rasterizer_hostile_scenes(pts, radius, cam_z, light_inside):
    """Random strands (crossing the near plane, degenerate, huge or zero
    width), the camera possibly among them, lights inside the hair: a
    finite, non-negative image, or a SceneError."""
    d = {
        "hairshade_scene": 1,
        "camera": {"position": [0.0, 0.0, cam_z + 1e-3], "target": [0.0, 0.0, -5.0], "resolution": [24, 16]},
        "lights": [
            {"type": "point", "position": list(pts[0]) if light_inside else [1, 2, 3], "intensity": [1, 1, 1], "shadows": True},
            {"type": "directional", "direction": [0.2, 1, 0.3], "intensity": [1, 1, 1], "shadows": True},
        ],
        "hair": {"strands": [{"points": [list(p) for p in pts], "radius": radius}], "material": {"model": "karis", "scatter": 0.5}},
        "meshes": [{"type": "sphere", "center": [0, 0, -1], "radius": 0.5}],
        "render": {"shadow_map_size": 64},
    }
    try:
        s = hs.Scene.from_dict(d)
    except hs.SceneError:
        return
    for model in ("exponential", "opacity"):
        s.render["shadow_model"] = model
        _check(hs.render(s))


def _fuzz(target: str, corpus: str, seconds: int, tmp_path, *flags: str) -> None:
    """Runs the atheris target `fuzz/<target>` for `seconds` from a copy of
    its seed corpus `fuzz/<corpus>`; any finding fails with its report."""
    here = pathlib.Path(__file__).parent / "fuzz"
    work = tmp_path / "corpus"
    shutil.copytree(here / corpus, work)
    # started from a small intermediate process: libFuzzer's memory limit reads getrusage's
    # ru_maxrss, which a child started by fork and exec inherits from its parent (this test
    # process, grown by the renders before it), and a grandchild does not
    hop = "import subprocess, sys; sys.exit(subprocess.run(sys.argv[1:]).returncode)"
    r = subprocess.run(
        [sys.executable, "-c", hop, sys.executable, str(here / target), str(work), f"-max_total_time={seconds}",
         *flags, f"-artifact_prefix={tmp_path}/"],
        capture_output=True, text=True, timeout=300,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Done" in r.stderr


@pytest.mark.slow  # 20 s of fuzzing by design, ~25 s with start-up
def test_06_fuzz_scene_loader(tmp_path):
    """The atheris target for 20 s from the seed corpus: no crash, no
    exception other than SceneError, no NaN pixel."""
    _fuzz("fuzz_scene.py", "corpus", 20, tmp_path, "-rss_limit_mb=4096")


@pytest.mark.slow  # 15 s of fuzzing by design, ~20 s with start-up
def test_08_fuzz_file_loaders(tmp_path):
    """The atheris target of the PNG, EXR, OBJ, strand-file and scene
    loaders for 15 s from its seed corpus (headers claiming huge sizes
    among the seeds), under a 3 GiB address-space cap: no abort, no
    exception other than the loaders' documented ones, results that match
    what the file declares."""
    _fuzz("fuzz_files.py", "corpus_files", 15, tmp_path, "-timeout=20")


@pytest.mark.slow  # 15 s of fuzzing by design, ~20 s with start-up
def test_09_fuzz_private_native_entry_points(tmp_path):
    """The atheris target of `hairshade._native` (the renderer with a
    scene dict mutated past the Python checks, the models' batch methods,
    image readers and writers, special functions) for 15 s: no Rust panic
    crossing into Python, no exception but ValueError, TypeError,
    OverflowError, MemoryError or OSError, no crash or hang (1.4 million
    runs in a 60 s session found nothing)."""
    _fuzz("fuzz_native.py", "corpus_native", 15, tmp_path, "-timeout=20", "-rss_limit_mb=4096")


def test_07_a_million_sub_pixel_strands_in_bounded_memory():
    """One million one-segment strands of radius 1e-4 (a hundredth of a
    pixel) over a 320x180 view, a shadowed light and an environment: no NaN,
    and the render's peak memory grows linearly with the segment count.
    Measured here (`fast`: opacity shadow maps, per-vertex shading; the
    process's own high-water mark): +405 MB for 1M segments, +171 MB for
    250k, i.e. ~312 bytes per segment (the strands copied in, projected
    segments and their culled copy, world segments, vertex colours, tile
    bins) plus ~93 MB (the opacity map's slabs and deposits at 1024²;
    with exponential maps +319 / +87 MB, ~10 MB fixed). The bound below
    allows 350 bytes per segment plus 110 MB. (Until the high-water mark
    was read from /proc, the child inherited the test process's through
    getrusage, which hid the growth: this test's earlier figure was ~150
    bytes per segment plus ~12 MB, and the render has since come to take
    about twice that per segment unseen.)"""
    script = pathlib.Path(__file__).parent / "million_strands.py"
    out = subprocess.run([sys.executable, str(script), "1000000"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    peak, before, fragments, non_finite, bad, estimate = (float(x) for x in out.stdout.split())
    assert fragments > 1e6 and non_finite == 0 and bad == 0
    assert peak - before < 350e-6 * 1e6 + 110, f"render grew the process by {peak - before:.0f} MB"
    # The render's own estimate, made before it allocates, bounds what it
    # took: measured 406 of 419 MiB (250k segments: 173 of 202). 5% over it
    # is left for what the estimate does not list (the allocator's slack,
    # the returned image); before it counted the culled copy of the
    # segments, it said 316 MB.
    assert peak - before <= 1.05 * estimate, f"grew {peak - before:.0f} MB, estimated {estimate:.0f} MB"
