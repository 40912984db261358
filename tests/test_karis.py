"""KarisHair (UE4 HairShading): term checks, components, parameters,
robustness, the environment variant. DEonHair (HairShadingRef) is in
tests/test_deon.py."""

from __future__ import annotations

import numpy as np
import pytest

import hairshade as hs
from helpers import edge_grid, uniform_sphere

T = np.array([0.0, 1.0, 0.0])


def world(theta, phi):
    theta, phi = np.broadcast_arrays(theta, phi)
    return np.stack([np.cos(theta) * np.cos(phi), np.sin(theta), np.cos(theta) * np.sin(phi)], -1)


def test_01_r_term_by_hand():
    """R at one configuration, computed here from the seed's formulas."""
    k = hs.KarisHair(components=("R",), roughness=0.5, specular=0.5)
    L = world(np.deg2rad(20.0), 0.0)
    V = world(np.deg2rad(-25.0), 0.6)
    sl, sv = L[1], V[1]
    Lp, Vp = L - sl * T, V - sv * T
    cos_phi = Lp @ Vp / np.sqrt((Lp @ Lp) * (Vp @ Vp) + 1e-4)
    chp = np.sqrt(np.clip(0.5 + 0.5 * cos_phi, 0, 1))
    a = -2 * 0.035
    shift = 2 * np.sin(a) * (np.cos(a) * chp * np.sqrt(1 - sv * sv) + np.sin(a) * sv)
    b = 0.25 * np.sqrt(2) * chp
    mp = np.exp(-0.5 * (sl + sv - shift) ** 2 / b**2) / (np.sqrt(2 * np.pi) * b)
    f0 = ((1 - 1.55) / (1 + 1.55)) ** 2
    fp = f0 + (1 - f0) * (1 - np.sqrt(np.clip(0.5 + 0.5 * V @ L, 0, 1))) ** 5
    expect = mp * 0.25 * chp * fp * 1.0
    np.testing.assert_allclose(k.eval(L, V, T), expect, rtol=1e-12)


def test_02_lobes_sum_to_eval_and_components_select():
    k = hs.KarisHair(scatter=0.6, base_color=(0.6, 0.4, 0.2))
    rng = np.random.default_rng(1)
    L, V = uniform_sphere(500, rng), uniform_sphere(500, rng)
    lobes = k.eval_lobes(L, V, T, shadow=0.5, global_scattering=[0.9, 0.8, 0.7], local_scattering=0.05)
    total = k.eval(L, V, T, shadow=0.5, global_scattering=[0.9, 0.8, 0.7], local_scattering=0.05)
    np.testing.assert_allclose(np.maximum(sum(lobes.values()), 0), total, rtol=1e-12, atol=1e-15)
    for name in ("R", "TT", "TRT"):
        only = hs.KarisHair(scatter=0.6, base_color=(0.6, 0.4, 0.2), components=(name,)).eval(L, V, T)
        np.testing.assert_allclose(only, np.maximum(lobes[name], 0), rtol=1e-12, atol=1e-300)


def test_03_ms_block_as_ue():
    """S = Global (S + Local) Visibility + KK; KK by hand."""
    c = np.array([0.6, 0.4, 0.2])
    k = hs.KarisHair(base_color=c, scatter=0.8)
    L = world(np.deg2rad(10.0), 0.3)
    V = world(np.deg2rad(-5.0), 2.0)
    single = hs.KarisHair(base_color=c, scatter=0.8, components=("R", "TT", "TRT")).eval(L, V, T)
    g, loc, vis, shadow = np.array([0.7, 0.8, 0.9]), np.array([0.01, 0.02, 0.03]), 0.6, 0.3
    kd = 1 - abs(T @ L)
    n = V - T * (V @ T)
    n /= np.linalg.norm(n)
    nol = np.clip((n @ L + 1) / 4, 0, 1)
    luma = c @ [0.3, 0.59, 0.11]
    kk = np.sqrt(c) * (1 / np.pi) * (nol + (kd - nol) * 0.33) * 0.8 * (c / luma) ** (1 - shadow)
    expect = g * (single + loc) * vis + kk
    got = k.eval(L, V, T, shadow=shadow, global_scattering=g, local_scattering=loc, opaque_visibility=vis)
    np.testing.assert_allclose(got, expect, rtol=1e-12)


@pytest.mark.parametrize("absorption", ["legacy", "chiang", "corrected"])
def test_04_tt_absorption_forms(absorption):
    """Legacy pow(C, .5 sqrt(1-(ha)^2)/cos td); UE's non-legacy exp(-sa 2|1-(ha)^2/cos td|);
    the corrected exp(-sa 2 sqrt(1-(ha)^2)/cos td): ratios of TT between colors
    follow the form (Fresnel and M/N factors cancel)."""
    kw = dict(legacy_absorption=absorption == "legacy", corrected_absorption=absorption == "corrected", components=("TT",))
    c1, c2 = np.array([0.5, 0.5, 0.5]), np.array([0.8, 0.3, 0.1])
    L = world(np.deg2rad(15.0), 0.0)
    V = world(np.deg2rad(-20.0), 2.7)
    t1 = hs.KarisHair(base_color=c1, **kw).eval(L, V, T)
    t2 = hs.KarisHair(base_color=c2, **kw).eval(L, V, T)
    sl, sv = L[1], V[1]
    ctd = np.cos(0.5 * abs(np.arcsin(sv) - np.arcsin(sl)))
    Lp, Vp = L - sl * T, V - sv * T
    cphi = Lp @ Vp / np.sqrt((Lp @ Lp) * (Vp @ Vp) + 1e-4)
    a = 1 / (1.19 / ctd + 0.36 * ctd)
    h = np.sqrt(0.5 + 0.5 * cphi) * (1 + a * (0.6 - 0.8 * cphi))
    ha2 = (h * a) ** 2
    sa = lambda c: hs.lobes.color_to_absorption(c)  # noqa: E731
    if absorption == "legacy":
        tp = lambda c: c ** (0.5 * np.sqrt(1 - ha2) / ctd)  # noqa: E731
    elif absorption == "chiang":
        tp = lambda c: np.exp(-sa(c) * 2 * abs(1 - ha2 / ctd))  # noqa: E731
    else:
        tp = lambda c: np.exp(-sa(c) * 2 * np.sqrt(1 - ha2) / ctd)  # noqa: E731
    np.testing.assert_allclose(t2 / t1, tp(c2) / tp(c1), rtol=1e-10)


def _asin_fast(x):
    """UE's asinFast written out: pi/2 - acosFast(x), with acosFast(|x|) =
    (-0.156583 |x| + pi/2) sqrt(1 - |x|) and pi - that for x < 0."""
    ax = np.minimum(np.abs(x), 1.0)
    acos = (-0.156583 * ax + np.pi / 2) * np.sqrt(1 - ax)
    return np.pi / 2 - np.where(x >= 0, acos, np.pi - acos)


def test_05_fast_asin_changes_only_cos_theta_d():
    """asinFast enters the model only through cos theta_d, which R and the
    Kajiya-Kay term do not use: with it R and MS (= KK at the default global
    scattering, local scattering and visibility) are bit-identical, and TT
    and TRT change by exactly the ratio of their theta_d factors (M_p and
    N_p cancel), computed here from the seed's formulas with asinFast
    written out: TT's (1 - f)^2 C^(sqrt(1 - (ha)^2)/(2 cos td)) with eta', h
    and f = F(cos td sqrt(1 - h^2)) from cos td; TRT's (1 - f)^2 f
    C^(0.8/cos td) with f = F(cos td / 2)."""
    rng = np.random.default_rng(3)
    L, V = uniform_sphere(2000, rng), uniform_sphere(2000, rng)
    c = np.array([0.6, 0.4, 0.2])
    exact = hs.KarisHair(base_color=c, scatter=0.5).eval_lobes(L, V, T)
    fast = hs.KarisHair(base_color=c, scatter=0.5, fast_asin=True).eval_lobes(L, V, T)
    np.testing.assert_array_equal(fast["R"], exact["R"])
    np.testing.assert_array_equal(fast["MS"], exact["MS"])
    sl, sv = L[:, 1], V[:, 1]
    Lp, Vp = L - sl[:, None] * T, V - sv[:, None] * T
    cphi = (Lp * Vp).sum(1) / np.sqrt((Lp * Lp).sum(1) * (Vp * Vp).sum(1) + 1e-4)
    f0 = ((1 - 1.55) / (1 + 1.55)) ** 2
    fresnel = lambda x: f0 + (1 - f0) * (1 - x) ** 5  # noqa: E731

    def theta_d_factors(asin):
        ctd = np.cos(0.5 * np.abs(asin(sv) - asin(sl)))
        a = 1 / (1.19 / ctd + 0.36 * ctd)
        h = np.sqrt(0.5 + 0.5 * cphi) * (1 + a * (0.6 - 0.8 * cphi))
        f = fresnel(ctd * np.sqrt(np.clip(1 - h * h, 0, None)))
        tt = ((1 - f) ** 2)[:, None] * c ** (0.5 * np.sqrt(np.clip(1 - (h * a) ** 2, 0, None)) / ctd)[:, None]
        f = fresnel(0.5 * ctd)
        trt = ((1 - f) ** 2 * f)[:, None] * c ** (0.8 / ctd)[:, None]
        return {"TT": tt, "TRT": trt}

    before, after = theta_d_factors(np.arcsin), theta_d_factors(_asin_fast)
    for lobe in ("TT", "TRT"):
        ratio = after[lobe] / before[lobe]
        # f64 rounding of the two evaluations and of the ratio (pow with
        # exponents ~1): measured 2.4e-14 (TT) and 2.7e-15 (TRT) relative.
        np.testing.assert_allclose(fast[lobe], exact[lobe] * ratio, rtol=1e-12, atol=0, err_msg=lobe)
        # Not vacuous: asinFast's error (up to 9e-3 rad) moves these lobes
        # by up to 1.9 % (TT) and 1.6 % (TRT) on this set.
        assert np.abs(ratio - 1).max() > 5e-3, lobe


@pytest.mark.parametrize("model", ["karis", "karis_f32", "env"])
def test_06_no_nan_or_negative_on_edge_grid(model):
    L, V = edge_grid()
    for r in (0.0, 1 / 255, 0.3, 1.0):
        for c in ((0, 0, 0), (1, 1, 1), (0.3, 0.15, 0.08)):
            if model.startswith("karis"):
                m = hs.KarisHair(base_color=c, roughness=r, scatter=1.0, legacy_absorption=(r != 0.3))
                args = (L, V, T) if model == "karis" else (L.astype(np.float32), V.astype(np.float32), T.astype(np.float32))
                out = m.eval(*args, shadow=0.2)
            else:
                out = hs.KarisHair(base_color=c, roughness=r).eval_env(V, T, np.ones((9, 3)))
            assert np.all(np.isfinite(out)), (model, r, c)
            assert np.all(out >= 0), (model, r, c)


def test_07_environment_variant():
    """R x saturate(1 + V.L) (= 1 for the fake normal), no TT, beta + 0.2, times pi SH(n)."""
    k = hs.KarisHair(base_color=(0.5, 0.4, 0.3))
    rng = np.random.default_rng(5)
    V = uniform_sphere(200, rng)
    n = V - np.outer(V @ T, T)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    manual = hs.KarisHair(base_color=(0.5, 0.4, 0.3), backlit=0.0, area=0.2, components=("R", "TRT", "MS")).eval(n, V, T)
    rad = np.array([0.3, 0.6, 0.9])
    np.testing.assert_allclose(k.eval_env(V, T, rad), np.pi * rad * manual, rtol=1e-12)
    # Band-1 SH: radiance varies with n.
    sh = np.zeros((4, 3))
    sh[0] = 1.0
    sh[3] = 0.5  # x
    y00, y1 = 0.28209479177387814, 0.4886025119029199
    rad_n = (y00 * 1.0 + y1 * 0.5 * n[:, 0])[:, None] * np.ones(3)
    np.testing.assert_allclose(k.eval_env(V, T, sh), np.pi * rad_n * manual, rtol=1e-12)
    # A view along the tangent has no fake normal: 0.
    assert np.all(k.eval_env(T, T, rad) == 0)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        (dict(base_color=(1.2, 0.1, 0.1)), "base_color"),
        (dict(base_color=(np.nan, 0.1, 0.1)), "base_color"),
        (dict(base_color=(0.1, 0.1)), "base_color"),
        (dict(roughness=-0.1), "roughness"),
        (dict(roughness=1.5), "roughness"),
        (dict(specular=2.0), "specular"),
        (dict(scatter=np.inf), "scatter"),
        (dict(shift=0.5), "shift"),
        (dict(backlit=-1.0), "backlit"),
        (dict(area=3.0), "area"),
        (dict(components=("R", "XX")), "components"),
        (dict(components="TTT"), "components"),
    ],
)
def test_08_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}: "):
        hs.KarisHair(**kwargs)


def test_09_per_pair_inputs_shapes():
    k = hs.KarisHair(scatter=0.5)
    rng = np.random.default_rng(6)
    L, V = uniform_sphere(10, rng), uniform_sphere(10, rng)
    a = k.eval(L, V, T, shadow=np.linspace(0, 1, 10), global_scattering=np.full((10, 3), 0.5))
    b = np.stack([k.eval(L[i], V[i], T, shadow=s, global_scattering=0.5) for i, s in enumerate(np.linspace(0, 1, 10))])
    np.testing.assert_allclose(a, b, rtol=1e-14)
    with pytest.raises(ValueError, match=r"shadow: expected a scalar or \(10,\)"):
        k.eval(L, V, T, shadow=np.ones(3))
    with pytest.raises(ValueError, match=r"global_scattering: expected a scalar, \(3,\) or \(10, 3\)"):
        k.eval(L, V, T, global_scattering=np.ones((10, 2)))
    with pytest.raises(ValueError, match=r"do not broadcast"):
        k.eval(L, V[:5], T)


def test_10_nonfinite_inputs_give_zero_locally():
    k = hs.KarisHair(scatter=0.5)
    rng = np.random.default_rng(7)
    L, V = uniform_sphere(8, rng), uniform_sphere(8, rng)
    L[2] = np.nan
    shadow = np.ones(8)
    shadow[5] = np.inf
    out = k.eval(L, V, T, shadow=shadow)
    assert np.all(out[[2, 5]] == 0) and np.all(np.isfinite(out))
    ok = [0, 1, 3, 4, 6, 7]
    np.testing.assert_array_equal(out[ok], k.eval(L[ok], V[ok], T))


def test_11_float32_close_to_float64():
    k = hs.KarisHair(scatter=0.3)
    rng = np.random.default_rng(8)
    L, V = uniform_sphere(5000, rng), uniform_sphere(5000, rng)
    a = k.eval(L, V, T)
    b = k.eval(L.astype(np.float32), V.astype(np.float32), T.astype(np.float32))
    assert b.dtype == np.float32
    mask = a > 1e-4 * a.max()
    # Gaussian M_p exponents reach ~(2/B)^2/2 ~ 30 at r = 0.5: f32 rounding
    # of the arguments is amplified ~30x: 1e-4 leaves margin over the
    # measured 2e-5.
    assert np.max(np.abs(a - b)[mask] / a[mask]) < 1e-4
