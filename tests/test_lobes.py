"""hairshade.lobes: the d'Eon M_p against scipy, normalization, and the
Karis fits' stated quality (Karis 2016), measured independently here."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, special

import hairshade as hs
from hairshade import lobes, tables


def _mp_scipy(si, so, v):
    """d'Eon M_p = exp((1 - si so)/v) I0(ci co / v) / (v e^{2/v} - v), with
    scipy's ive in log space."""
    ci, co = np.sqrt(1 - si * si), np.sqrt(1 - so * so)
    x = ci * co / v
    log = (1 - si * so) / v + np.log(special.ive(0, x)) + x - (np.log(v) + 2 / v + np.log1p(-np.exp(-2 / v)))
    return np.exp(log)


@pytest.mark.parametrize("v", [1e-4, 1e-3, 1e-2, 0.1, 0.3, 1.0])
def test_01_deon_mp_matches_scipy(v):
    rng = np.random.default_rng(1)
    si = rng.uniform(-0.99, 0.99, 2000)
    so = np.clip(-si + rng.normal(0, 3 * np.sqrt(v), 2000), -0.999, 0.999)  # near the peak, where values matter
    ours = lobes.deon_mp(si, so, v)
    ref = _mp_scipy(si, so, v)
    mask = ref > 1e-300
    assert np.max(np.abs(ours[mask] - ref[mask]) / ref[mask]) <= 1e-9


@pytest.mark.parametrize("v", [1e-4, 1e-3, 1e-2, 0.1, 0.5, 1.0])
@pytest.mark.parametrize("sin_i", [-0.9, -0.3, 0.0, 0.6])
def test_02_deon_mp_integrates_to_one_over_sin_theta_o(v, sin_i):
    """Adaptive quadrature with the peak (sin_o = -sin_i) as a breakpoint."""
    f = lambda so: float(lobes.deon_mp(sin_i, so, v))  # noqa: E731
    total, err = integrate.quad(f, -1, 1, points=[-sin_i], limit=500, epsabs=0, epsrel=1e-11)
    assert abs(total - 1) <= 1e-6, (total, err)


def test_03_deon_mp_f32_finite_at_smallest_variance():
    """In f32 at v = 1e-4 (DEonHair roughness 0.1 gives v_R = B^2 = 1e-4 at
    phi = 0): finite and non-negative everywhere, also on and off the peak."""
    d = hs.DEonHair(roughness=0.1, components=("R",))
    th = np.deg2rad(np.linspace(-90, 90, 61))
    TI, TO, PH = np.meshgrid(th, th, np.linspace(0, np.pi, 5), indexing="ij")
    L = np.stack([np.cos(TI), np.sin(TI), 0 * TI], -1).reshape(-1, 3).astype(np.float32)
    V = np.stack([np.cos(TO) * np.cos(PH), np.sin(TO), np.cos(TO) * np.sin(PH)], -1).reshape(-1, 3).astype(np.float32)
    out = d.eval(L, V, np.float32([0, 1, 0]))
    assert out.dtype == np.float32
    assert np.all(np.isfinite(out)) and np.all(out >= 0) and out.max() > 0


def test_04_fit_quality_matches_the_slides():
    """Independent re-measurement of the slides' claims (trapezoid / quad
    here, the library uses Gauss-Legendre)."""
    fq = tables.fit_quality()
    # eta' fit, eta = 1.55: the slides claim < 0.68 %.
    td = np.deg2rad(np.linspace(0, 89.9, 50001))
    c = np.cos(td)
    exact = np.sqrt(1.55**2 - np.sin(td) ** 2) / c
    err = np.abs((1.19 / c + 0.36 * c) / exact - 1).max()
    assert err < 0.0068
    assert abs(err - fq["eta_prime_max_rel_err"]) < 1e-6
    # Integrals over phi of the fitted azimuthal distributions.
    q = lambda f: integrate.quad(f, -np.pi, np.pi, epsabs=1e-13, limit=200)[0]  # noqa: E731
    assert abs(q(lambda p: 0.25 * np.cos(p / 2)) - 1) < 1e-12
    d_tt_fit = q(lambda p: np.exp(-3.65 * np.cos(p) - 3.98))
    d_trt_fit = q(lambda p: np.exp(17 * np.cos(p) - 16.78))
    # Closed forms: integral of e^{k cos p} over the circle is 2 pi I0(k).
    assert abs(d_tt_fit - 2 * np.pi * special.iv(0, 3.65) * np.exp(-3.98)) < 1e-10
    assert abs(d_trt_fit - 2 * np.pi * special.iv(0, 17) * np.exp(-16.78)) < 1e-10
    assert abs(fq["int_D_TT_fit"] - d_tt_fit) < 1e-9 and abs(fq["int_D_TRT_fit"] - d_trt_fit) < 1e-9
    # The fits keep the logistic's mass within 2 % (TT) and 2 % of 3/4 (TRT).
    assert abs(d_tt_fit - 1) < 0.02 and abs(d_trt_fit - 0.75) < 0.02
    # Gaussian M_p: mass on [-1, 1] is erf(1/(beta sqrt 2)).
    for beta in (0.05, 0.25, 0.5, 1.0, 2.0):
        assert abs(fq[f"int_M_gauss_beta_{beta}"] - special.erf(1 / (beta * np.sqrt(2)))) < 1e-12


def test_05_exact_forms_against_definitions():
    rng = np.random.default_rng(2)
    phi = rng.uniform(0, np.pi, 500)
    a = rng.uniform(0.3, 0.8, 500)
    # h_TT: the exact offset solves Phi_TT(h) = phi (Phi = 2 gamma_t - 2 gamma_i + pi)
    # wherever TT reaches phi at all: phi >= Phi_TT(1) = 2 asin(a).
    h = lobes.h_tt(np.cos(phi), a)
    gi, gt = np.arcsin(np.clip(h, -1, 1)), np.arcsin(np.clip(h * a, -1, 1))
    resid = np.abs(np.abs(2 * gt - 2 * gi + np.pi) - phi)
    ok = phi > 2 * np.arcsin(a) + 1e-6
    assert ok.sum() > 100
    assert np.max(resid[ok]) < 1e-9
    # Logistic D integrates to ~1 over [-pi, pi] for s = 0.35 around pi.
    tot = integrate.quad(lambda p: float(lobes.logistic(p, 0.35, np.pi)), 0, 2 * np.pi)[0]
    assert abs(tot - 1) < 1e-3
    # Schlick at normal incidence is F0.
    assert abs(float(lobes.schlick_fresnel(1.55, 1.0)) - ((1 - 1.55) / (1 + 1.55)) ** 2) < 1e-15
    # asinFast stays within its documented 9e-3 rad.
    x = np.linspace(-1, 1, 10001)
    assert np.max(np.abs(lobes.asin_fast(x) - np.arcsin(x))) < 9.1e-3


def test_06_color_to_absorption_round_trip():
    """Chiang's map inverted: sqrt(sigma_a) * D(beta) = -ln(c)."""
    c = np.linspace(0.05, 1, 20)
    b = 0.3
    d = 5.969 - 0.215 * b + 2.532 * b**2 - 10.73 * b**3 + 5.574 * b**4 + 0.245 * b**5
    np.testing.assert_allclose(np.sqrt(lobes.color_to_absorption(c, b)) * d, -np.log(c), rtol=1e-12, atol=1e-15)
