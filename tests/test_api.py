"""The Python API contract: dtypes, shapes, broadcasting, errors, non-finite input."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import hairshade as hs
from hairshade import _native
from helpers import uniform_sphere

RNG = np.random.default_rng(0)
WI = uniform_sphere(64, RNG)
WO = uniform_sphere(64, RNG)


# -- dtypes ----------------------------------------------------------------------


def test_01_float32_in_float32_out():
    m = hs.ChiangHair()
    a, b = WI.astype(np.float32), WO.astype(np.float32)
    assert m.eval(a, b).dtype == np.float32
    assert m.pdf(a, b).dtype == np.float32
    assert m.eval_far(a, b).dtype == np.float32
    wo, w, p = m.sample(a, np.float32(RNG.random(64)), RNG.random((64, 2)).astype(np.float32))
    assert wo.dtype == w.dtype == p.dtype == np.float32


def test_02_float64_and_mixed_give_float64():
    m = hs.ChiangHair()
    assert m.eval(WI, WO).dtype == np.float64
    assert m.eval(WI.astype(np.float32), WO).dtype == np.float64
    assert m.eval(WI.tolist(), WO.tolist()).dtype == np.float64
    assert m.eval(np.ones((2, 3), dtype=np.int64), WO[:2]).dtype == np.float64


def test_03_f32_agrees_with_f64():
    """f32 evaluation is within 1e-4 relative of f64 where the value is
    significant. Measured on these 20k pairs: 2.1e-5 at beta = 0.2, 5.5e-6 at
    0.5 (and 1.4e-4 at 0.05, where the inputs' f32 rounding is amplified by
    kappa_TT ~ 3000 in M_p's exponent)."""
    rng = np.random.default_rng(9)
    wi, wo = uniform_sphere(20000, rng), uniform_sphere(20000, rng)
    for beta in (0.2, 0.5):
        m = hs.ChiangHair(longitudinal_roughness=beta, azimuthal_roughness=beta)
        a = m.eval(wi, wo)
        b = m.eval(wi.astype(np.float32), wo.astype(np.float32)).astype(np.float64)
        mask = a > 1e-4 * a.max()
        assert np.max(np.abs(a - b)[mask] / a[mask]) < 1e-4


# -- shapes --------------------------------------------------------------------------


def test_04_single_vectors_drop_the_leading_axis():
    m = hs.ChiangHair()
    assert m.eval(WI[0], WO[0]).shape == (3,)
    assert m.pdf(WI[0], WO[0]).shape == ()
    np.testing.assert_array_equal(m.eval(WI[0], WO[0]), m.eval(WI[:1], WO[:1])[0])


def test_05_broadcast_single_direction():
    m = hs.ChiangHair()
    full = m.eval(np.repeat(WI[:1], 64, axis=0), WO)
    np.testing.assert_array_equal(m.eval(WI[0], WO), full)
    np.testing.assert_array_equal(m.pdf(WI[0], WO), m.pdf(np.repeat(WI[:1], 64, axis=0), WO))


@pytest.mark.parametrize(
    "wi,wo,msg",
    [
        (np.zeros((4, 2)), np.zeros((4, 3)), r"wi: expected shape \(N, 3\)"),
        (np.zeros((4, 3)), np.zeros((5, 3)), r"do not broadcast"),
        (np.zeros((0, 3)), np.zeros((0, 3)), r"wi: expected shape"),
        (np.zeros((2, 3, 1)), np.zeros((2, 3)), r"wi: expected shape"),
        (np.array(["a", "b", "c"]), np.zeros(3), r"wi: expected real numbers"),
    ],
)
def test_06_bad_shapes_raise_value_error(wi, wo, msg):
    with pytest.raises(ValueError, match=msg):
        hs.ChiangHair().eval(wi, wo)


def test_07_sample_shape_errors():
    m = hs.ChiangHair()
    with pytest.raises(ValueError, match=r"u2: expected shape \(N, 2\) with N = 4"):
        m.sample(WI[:4], np.zeros(4), np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"wi: expected shape \(4, 3\)"):
        m.sample(WI[:5], np.zeros(4), np.zeros((4, 2)))


def test_08_non_contiguous_input():
    m = hs.ChiangHair()
    big = np.asfortranarray(np.concatenate([WI, WO], axis=1))
    np.testing.assert_array_equal(m.eval(big[:, :3], big[:, 3:]), m.eval(WI, WO))


# -- non-finite and degenerate input ----------------------------------------------


def test_09_non_finite_and_zero_directions_give_zero_without_leaking():
    m = hs.ChiangHair()
    wi = WI.copy()
    wi[3] = np.nan
    wi[5] = [np.inf, 0, 0]
    wi[7] = 0.0
    wo = WO.copy()
    wo[10] = [0.0, -np.inf, 1.0]
    bad = [3, 5, 7, 10]
    for f, ref in ((m.eval, m.eval(WI, WO)), (m.pdf, m.pdf(WI, WO)), (m.eval_far, m.eval_far(WI, WO))):
        out = f(wi, wo)
        assert np.all(np.isfinite(out))
        assert np.all(out[bad] == 0)
        good = np.setdiff1d(np.arange(64), bad)
        np.testing.assert_array_equal(out[good], ref[good])


def test_10_non_unit_directions_are_normalized():
    m = hs.ChiangHair()
    np.testing.assert_allclose(m.eval(WI * 7.5, WO * 1e-3), m.eval(WI, WO), rtol=1e-12)
    assert np.all(np.isfinite(m.eval(WI * 1e300, WO * 1e-300)))


def test_11_non_finite_random_numbers_give_failed_samples():
    m = hs.ChiangHair()
    u1 = RNG.random(8)
    u1[2] = np.nan
    wo, w, p = m.sample(WI[:8], u1, RNG.random((8, 2)))
    assert p[2] == 0 and np.all(w[2] == 0) and np.all(wo[2] == 0)
    assert np.all(p[np.arange(8) != 2] > 0)


# -- parameters --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs,name,range_text",
    [
        (dict(longitudinal_roughness=1.2), "longitudinal_roughness", r"\[0, 1\]"),
        (dict(longitudinal_roughness=np.nan), "longitudinal_roughness", r"\[0, 1\]"),
        (dict(azimuthal_roughness=-0.1), "azimuthal_roughness", r"\[0, 1\]"),
        (dict(eta=1.0), "eta", r"!= 1"),
        (dict(eta=0.0), "eta", r"> 0"),
        (dict(eta=np.inf), "eta", r"finite"),
        (dict(eumelanin=-1.0), "eumelanin", r">= 0"),
        (dict(pheomelanin=np.nan), "pheomelanin", r">= 0"),
        (dict(sigma_a=[0.1, -0.2, 0.3]), "sigma_a", r">= 0"),
        (dict(sigma_a=[0.1, 0.2]), "sigma_a", r"3 values"),
        (dict(sigma_a=0.5, eumelanin=1.0), "sigma_a", r"not both"),
        (dict(scale_tilt=120.0), "scale_tilt", r"\[-90, 90\]"),
        (dict(i0="bessel"), "i0", r"exact"),
    ],
)
def test_12_invalid_parameters(kwargs, name, range_text):
    with pytest.raises(ValueError, match=rf"^{name}: .*{range_text}"):
        hs.ChiangHair(**kwargs)


def test_13_zero_roughness_is_the_documented_floor():
    a = hs.ChiangHair(longitudinal_roughness=0.0, azimuthal_roughness=0.0)
    b = hs.ChiangHair(longitudinal_roughness=1e-3, azimuthal_roughness=1e-3)
    np.testing.assert_array_equal(a.eval(WI, WO), b.eval(WI, WO))
    assert np.all(np.isfinite(a.eval(WI, WO)))


def test_14_melanin_maps_to_sigma_a():
    a = hs.ChiangHair(eumelanin=0.8, pheomelanin=0.5)
    b = hs.ChiangHair(sigma_a=a.sigma_a)
    np.testing.assert_allclose(a.eval(WI, WO), b.eval(WI, WO), rtol=1e-14)
    assert "eumelanin=0.8" in repr(a)


# -- threads ---------------------------------------------------------------------------


def test_15_gil_released_during_evaluation():
    """Another Python thread keeps running while a long evaluation is in Rust."""
    m = hs.ChiangHair(azimuthal_roughness=0.05)  # many far-field nodes: a long call
    wi, wo = uniform_sphere(4000, RNG), uniform_sphere(4000, RNG)
    done = threading.Event()
    ticks = 0

    def work():
        m.eval_far(wi, wo)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
    t.join()
    # With the GIL held for the whole call this loop would run a handful of
    # times (once per switch interval at best); released, it spins freely.
    assert ticks > 10_000, ticks


def test_16_a_pair_evaluates_to_the_same_bits_in_any_batch():
    """A pair's value depends on that pair only: not on its position in the
    batch (permuted), the batch's length (slices of 1, 7, 15, 977 pairs and
    the rest, so pairs land in vector tails and at lane boundaries of the f32
    kernels) or the thread count (hairshade's pool vs one thread). Exact
    equality: each pair is computed by the same scalar or lane-wise code
    (ARCHITECTURE, SIMD), so nothing may differ, not even rounding."""
    wi, wo = uniform_sphere(100_003, RNG), uniform_sphere(100_003, RNG)
    perm = RNG.permutation(len(wi))
    cuts = [0, 1, 8, 23, 1000, len(wi)]
    T = np.array([0.0, 1.0, 0.0])
    models = {
        "ChiangHair.eval": lambda a, b: hs.ChiangHair().eval(a, b),
        "ChiangHair.pdf": lambda a, b: hs.ChiangHair().pdf(a, b),
        "KarisHair.eval": lambda a, b: hs.KarisHair(scatter=0.3).eval(a, b, T.astype(a.dtype)),
    }
    for dtype in (np.float64, np.float32):
        a, b = wi.astype(dtype), wo.astype(dtype)
        for name, f in models.items():
            full = f(a, b)
            np.testing.assert_array_equal(f(a[perm], b[perm]), full[perm], err_msg=f"{name} {dtype.__name__}: permuted")
            sliced = np.concatenate([f(a[i:j], b[i:j]) for i, j in zip(cuts[:-1], cuts[1:])])
            np.testing.assert_array_equal(sliced, full, err_msg=f"{name} {dtype.__name__}: sliced")
            _native.set_single_threaded(True)
            try:
                one = f(a, b)
            finally:
                _native.set_single_threaded(False)
            np.testing.assert_array_equal(one, full, err_msg=f"{name} {dtype.__name__}: one thread")
