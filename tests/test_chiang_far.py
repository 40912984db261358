"""Far field: ChiangHair.eval_far is eval averaged over the fiber offset h."""

from __future__ import annotations

import numpy as np
import pytest

import hairshade as hs
from helpers import rot_y, stratified_sphere, uniform_sphere


def brute_force_far(model, wi, wo, panels=2000, nodes=8):
    """1/2 * integral of eval over h in [-1, 1], through the public eval: for
    each node gamma the pair is rotated about the tangent so that wi sits at
    offset h = sin(gamma) (azimuth pi/2 + gamma), Gauss-Legendre in gamma with
    the Jacobian cos(gamma)."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    edges = np.linspace(-np.pi / 2, np.pi / 2, panels + 1)
    a, b = edges[:-1, None], edges[1:, None]
    g = (0.5 * (a + b) + 0.5 * (b - a) * x).ravel()
    wt = (0.5 * (b - a) * w).ravel() * np.cos(g) * 0.5
    psi = np.pi / 2 + g - np.arctan2(wi[2], wi[0])
    return (wt[:, None] * model.eval(rot_y(wi, psi), rot_y(wo, psi))).sum(axis=0)


@pytest.mark.parametrize("beta_n", [0.05, 0.1, 0.3, 0.6, 1.0])
def test_01_far_field_equals_brute_force_average(beta_n):
    """Converged to <= 1e-6 relative at the default quadrature order (the
    reference uses 16 000 nodes; measured: 6e-11 at beta_n = 0.3, 4e-7 at 1)."""
    m = hs.ChiangHair(azimuthal_roughness=beta_n, sigma_a=[0.1, 0.4, 1.2], scale_tilt=3.0)
    rng = np.random.default_rng(int(beta_n * 1000))
    for wi, wo in zip(uniform_sphere(5, rng), uniform_sphere(5, rng)):
        ref = brute_force_far(m, wi, wo)
        got = m.eval_far(wi, wo)
        assert np.all(np.abs(got - ref) <= 1e-6 * ref), (wi, wo, got, ref)


def test_02_far_field_invariant_under_rotation_about_tangent():
    m = hs.ChiangHair()
    rng = np.random.default_rng(2)
    wi, wo = uniform_sphere(200, rng), uniform_sphere(200, rng)
    base = m.eval_far(wi, wo)
    for psi in (0.4, 2.0, -1.3, np.pi):
        r = m.eval_far(rot_y(wi, psi), rot_y(wo, psi))
        np.testing.assert_allclose(r, base, rtol=1e-11, atol=0)


def test_03_far_field_white_furnace():
    """sigma_a = 0: the h-average of albedo 1 is 1."""
    m = hs.ChiangHair(sigma_a=0.0, longitudinal_roughness=0.5, azimuthal_roughness=0.5)
    d, dw = stratified_sphere(160, 320, np.random.default_rng(4))
    for wi in uniform_sphere(2, np.random.default_rng(5)):
        a = m.eval_far(wi, d).sum(axis=0) * dw
        assert np.all(np.abs(a - 1) <= 0.01), a


def test_04_far_field_f32_close_to_f64():
    m = hs.ChiangHair()
    rng = np.random.default_rng(6)
    wi, wo = uniform_sphere(500, rng), uniform_sphere(500, rng)
    f64 = m.eval_far(wi, wo)
    f32 = m.eval_far(wi.astype(np.float32), wo.astype(np.float32))
    assert f32.dtype == np.float32
    mask = f64 > 1e-4 * f64.max()
    # Inputs rounded to f32 move theta by ~6e-8 rad; M_p's log-derivative is
    # at most ~kappa ~ 50 here, and 400 terms accumulate rounding: 1e-4.
    assert np.max(np.abs(f32 - f64)[mask] / f64[mask]) < 1e-4


def test_05_far_field_of_a_dark_backlit_fiber_is_the_near_fields_average():
    """Transmission through a strongly absorbing fiber (Blender's melanin
    0.9, redness 1: σa 4.4 per radius in blue) comes mostly from the edges,
    where the path inside is short: the far field still equals the near
    field averaged over h (200 000 offsets, midpoint rule) within 1e-4."""
    m = hs.ChiangHair.from_blender(parametrization="melanin", melanin=0.9, melanin_redness=1.0, roughness=0.3,
                                   radial_roughness=0.3)
    t = np.array([1.0, 0.0, 0.0])
    cam, light = np.array([0.0, 0.0, 1.0]), np.array([0.25, 0.35, -0.9]) / np.linalg.norm([0.25, 0.35, -0.9])
    n_h = 200_000
    h = (np.arange(n_h) + 0.5) / n_h * 2 - 1
    g = np.arcsin(h)
    normals = np.stack([np.zeros_like(g), np.sin(g), np.cos(g)], axis=1)
    xs = np.cross(t, normals)

    def local(v):
        return np.stack([xs @ v, np.full(n_h, v @ t), normals @ v], axis=1)

    near = m.eval(local(cam), local(light)).mean(axis=0)
    far = m.eval_far(local(cam)[n_h // 2], local(light)[n_h // 2])
    np.testing.assert_allclose(far, near, rtol=1e-4)
