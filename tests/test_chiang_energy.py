"""Energy and sampling tests of ChiangHair, after pbrt-v4's and Mitsuba's hair tests.

With sigma_a = 0 the attenuations sum to 1 (f + (1-f)^2 (1 + f + f^2/(1-f)) = 1)
and every M_p and N_p is a normalized density, so the directional albedo
integral of `eval` over the sphere is exactly 1 in the exact-I0 mode: the
white furnace checks the normalization of the whole model.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import hairshade as hs
from helpers import from_angles, stratified_sphere, uniform_sphere

BETAS = [0.1, 0.3, 0.5, 0.7, 0.9]
PAIRS_25 = [(bm, bn) for bm in BETAS for bn in BETAS]


def _albedo(model, wi, n_y=768, n_phi=1536, seed=0):
    """Stratified (jittered) estimate of the integral of eval over the sphere."""
    d, dw = stratified_sphere(n_y, n_phi, np.random.default_rng(seed))
    return model.eval(wi, d).sum(axis=0) * dw


@pytest.mark.parametrize("beta_m,beta_n", PAIRS_25)
def test_01_white_furnace_uniform(beta_m, beta_n):
    """sigma_a = 0: albedo 1 +- 0.01 per channel (stratified uniform sampling).
    The stratified estimate's own error at the sharpest lobes (beta = 0.1)
    measures below 2e-3."""
    m = hs.ChiangHair(sigma_a=0.0, longitudinal_roughness=beta_m, azimuthal_roughness=beta_n)
    rng = np.random.default_rng(int(beta_m * 100 + beta_n * 10))
    for wi in uniform_sphere(2, rng):
        a = _albedo(m, wi, seed=int(rng.integers(1 << 30)))
        assert np.all(np.abs(a - 1) <= 0.01), (wi, a)


@pytest.mark.parametrize("beta_m,beta_n", [(0.1, 0.1), (0.3, 0.3), (0.9, 0.5), (0.5, 0.9)])
def test_02_white_furnace_importance_sampled(beta_m, beta_n):
    """sigma_a = 0: mean of f/pdf over sampled directions is 1 +- 0.003."""
    m = hs.ChiangHair(sigma_a=0.0, longitudinal_roughness=beta_m, azimuthal_roughness=beta_n)
    rng = np.random.default_rng(3)
    n = 200_000
    wi = uniform_sphere(n, rng)
    _, w, pdf = m.sample(wi, rng.random(n), rng.random((n, 2)))
    assert np.mean(pdf > 0) > 0.999
    assert np.all(np.abs(w.mean(axis=0) - 1) <= 0.003), w.mean(axis=0)


@pytest.mark.parametrize("beta_m,beta_n", [(0.2, 0.3), (0.5, 0.5), (0.9, 0.9)])
def test_03_sample_weights_equal_albedo(beta_m, beta_n):
    """Lobes are chosen by their attenuation, so for a gray absorption every
    sample's weight f/pdf equals the directional albedo sum_p A_p: 1 for
    sigma_a = 0, and the stratified albedo integral for sigma_a = 0.5.
    Tolerance 1e-3 (the stratified integral's error measures < 3e-4 here)."""
    rng = np.random.default_rng(11)
    for sigma in (0.0, 0.5):
        m = hs.ChiangHair(sigma_a=sigma, longitudinal_roughness=beta_m, azimuthal_roughness=beta_n)
        for wi in uniform_sphere(3, rng):
            n = 20_000
            _, w, pdf = m.sample(wi, rng.random(n), rng.random((n, 2)))
            ok = pdf > 0
            assert ok.mean() > 0.999
            target = 1.0 if sigma == 0 else _albedo(m, wi)[0]
            assert np.all(np.abs(w[ok] - target) <= 1e-3 * target), (sigma, wi, target, w[ok].min(), w[ok].max())


@pytest.mark.parametrize("beta_m,beta_n", [(0.2, 0.3), (0.3, 0.3), (0.6, 0.6), (0.9, 0.3)])
def test_04_sampling_consistency(beta_m, beta_n):
    """Integral of f * Li with Li(w) = w.z^2, by importance sampling and by
    stratified uniform sampling, agree within 5% (pbrt-v4's test)."""
    m = hs.ChiangHair(sigma_a=0.25, longitudinal_roughness=beta_m, azimuthal_roughness=beta_n)
    rng = np.random.default_rng(5)
    for wi in uniform_sphere(3, rng):
        n = 100_000
        wo, w, pdf = m.sample(wi, rng.random(n), rng.random((n, 2)))
        est_is = (w * (wo[:, 2:3] ** 2)).mean(axis=0)
        d, dw = stratified_sphere(512, 1024, rng)
        est_u = (m.eval(wi, d) * d[:, 2:3] ** 2).sum(axis=0) * dw
        assert np.all(np.abs(est_is - est_u) <= 0.05 * est_u), (wi, est_is, est_u)


def test_05_offset_plus_minus_one():
    """wi at h = +-1 (grazing the silhouette): finite, non-negative, no crash."""
    m = hs.ChiangHair()
    th = np.deg2rad(np.array([-89.9, -45.0, 0.0, 30.0, 89.9]))
    for h in (1.0, -1.0):
        # h = -x/|xz| = +-1  <=>  x = -+|xz|, z = 0
        wi = np.stack([-h * np.cos(th), np.sin(th), np.zeros_like(th)], -1)
        wo = uniform_sphere(len(th), np.random.default_rng(0))
        for f in (m.eval(wi, wo), m.pdf(wi, wo), m.eval_far(wi, wo)):
            assert np.all(np.isfinite(f)) and np.all(f >= 0)
        rng = np.random.default_rng(1)
        wo_s, w, pdf = m.sample(wi, rng.random(len(th)), rng.random((len(th), 2)))
        assert np.all(np.isfinite(wo_s)) and np.all(np.isfinite(w)) and np.all(pdf >= 0)


# -- chi-square goodness of fit of sample() against pdf() ----------------------

CHI2_CASES = [
    # (beta_m, beta_n, sigma_a, theta_i deg, h)
    (0.3, 0.3, [0.25, 0.9, 2.5], 20.0, 0.3),
    (0.2, 0.3, [0.0, 0.0, 0.0], -50.0, -0.7),
    (0.5, 0.5, [0.5, 0.5, 0.5], 60.0, 0.0),
    (0.7, 0.8, [0.1, 0.3, 1.0], 0.0, 0.95),
    (0.3, 0.6, [1.3 * 0.419 + 0.2 * 0.187, 1.3 * 0.697 + 0.2 * 0.4, 1.3 * 1.37 + 0.2 * 1.05], -10.0, 0.5),
]


def _bin_probabilities(m, wi, n_y, n_phi, order=6):
    """Integral of pdf over each (y, phi) bin by a tensor Gauss-Legendre rule
    (dw = dy dphi on the sphere)."""
    x, w = np.polynomial.legendre.leggauss(order)
    y_edges = np.linspace(-1, 1, n_y + 1)
    p_edges = np.linspace(-np.pi, np.pi, n_phi + 1)
    yc = (0.5 * (y_edges[:-1, None] + y_edges[1:, None]) + 0.5 * (y_edges[1] - y_edges[0]) * x).ravel()
    pc = (0.5 * (p_edges[:-1, None] + p_edges[1:, None]) + 0.5 * (p_edges[1] - p_edges[0]) * x).ravel()
    wy = np.tile(w, n_y) * 0.5 * (y_edges[1] - y_edges[0])
    wp = np.tile(w, n_phi) * 0.5 * (p_edges[1] - p_edges[0])
    Y, P = np.meshgrid(yc, pc, indexing="ij")
    r = np.sqrt(np.clip(1 - Y * Y, 0, None))
    d = np.stack([r * np.cos(P), Y, r * np.sin(P)], -1).reshape(-1, 3)
    pdf = m.pdf(wi, d).reshape(n_y * order, n_phi * order) * wy[:, None] * wp[None, :]
    return pdf.reshape(n_y, order, n_phi, order).sum(axis=(1, 3))


@pytest.mark.parametrize("case", range(len(CHI2_CASES)))
def test_06_chi2_sample_against_pdf(case):
    beta_m, beta_n, sigma_a, theta_deg, h = CHI2_CASES[case]
    m = hs.ChiangHair(sigma_a=sigma_a, longitudinal_roughness=beta_m, azimuthal_roughness=beta_n)
    wi = from_angles(np.deg2rad(theta_deg), np.pi / 2 + np.arcsin(h))
    n_y, n_phi, n = 40, 80, 400_000
    prob = _bin_probabilities(m, wi, n_y, n_phi)
    assert abs(prob.sum() - 1) < 2e-3, prob.sum()  # pdf integrates to 1
    rng = np.random.default_rng(100 + case)
    wo, _, pdf = m.sample(wi, rng.random(n), rng.random((n, 2)))
    wo = wo[pdf > 0]
    iy = np.clip(((wo[:, 1] + 1) / 2 * n_y).astype(int), 0, n_y - 1)
    ip = np.clip(((np.arctan2(wo[:, 2], wo[:, 0]) + np.pi) / (2 * np.pi) * n_phi).astype(int), 0, n_phi - 1)
    observed = np.bincount(iy * n_phi + ip, minlength=n_y * n_phi).astype(float)
    expected = prob.ravel() * len(wo)
    # Pool the bins with fewer than 5 expected samples into one.
    small = expected < 5
    obs, exp = observed[~small], expected[~small]
    if small.any():
        obs = np.append(obs, observed[small].sum())
        exp = np.append(exp, expected[small].sum())
    exp *= obs.sum() / exp.sum()
    chi2 = ((obs - exp) ** 2 / exp).sum()
    dof = len(obs) - 1
    p_value = stats.chi2.sf(chi2, dof)
    # Significance 0.01, Sidak-corrected for the number of cases.
    alpha = 1 - (1 - 0.01) ** (1 / len(CHI2_CASES))
    assert p_value > alpha, f"chi2={chi2:.1f} dof={dof} p={p_value:.2e}"
