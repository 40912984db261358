"""Dual scattering (`render.multiple_scattering = "dual"`, ChiangHair and
KarisHair): its tables against exact identities and the paper's equations, the option's
errors, and renders against the converged dense-hair references in
tests/data/dense (Mitsuba path tracing, max_depth 64)."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

import hairshade as hs

DENSE = pathlib.Path(__file__).parent / "data" / "dense"
ROUGH = (0.1, 0.3, 0.6, 0.9)
FIELDS = ("a_f", "a_b", "alpha_f", "beta_f2", "alpha_b", "beta_b2", "A_b", "delta_b", "sigma_b2")


def test_01_white_fiber_conserves_energy():
    # sigma_a = 0: the far field integrates to 1 over the sphere (Chiang's
    # model conserves energy at every h), so a_f + a_b = 1. The integrals
    # run over the f32 far-field table (96 Gauss-Legendre x 192 midpoint
    # nodes); measured worst |a_f + a_b - 1| over 16 roughness pairs:
    # 2.9e-6 at the interior nodes. Gate 1e-4. The end nodes (sin theta =
    # +-1, the direction along the fiber) have no cross-section and are
    # left out.
    for bm in ROUGH:
        for bn in ROUGH:
            d = hs.ChiangHair(sigma_a=0.0, longitudinal_roughness=bm, azimuthal_roughness=bn).dual_terms()
            s = (d["a_f"] + d["a_b"])[1:-1]
            assert np.abs(s - 1).max() < 1e-4, (bm, bn, np.abs(s - 1).max())


def test_02_terms_in_range_everywhere():
    # Over melanin 0..8 x pheomelanin x roughness: every term finite,
    # attenuations, widths and A_b >= 0, a_f + a_b <= 1 (+1e-4 of
    # quadrature error, see test 01).
    for eu in (0.0, 0.3, 1.3, 4.0, 8.0):
        for ph in (0.0, 0.9):
            for r in (0.1, 0.5, 0.9):
                d = hs.ChiangHair(eumelanin=eu, pheomelanin=ph, longitudinal_roughness=r,
                                  azimuthal_roughness=r).dual_terms()
                for k in FIELDS:
                    assert d[k].shape == (65, 3) and np.isfinite(d[k]).all(), k
                for k in ("a_f", "a_b", "beta_f2", "beta_b2", "A_b", "sigma_b2"):
                    assert (d[k] >= 0).all(), k
                assert (d["a_f"] + d["a_b"]).max() <= 1 + 1e-4


def test_03_derived_terms_follow_the_equations():
    # A_b, Delta_b, sigma_b^2 recomputed here in float64 from the table's
    # own a_f, a_b, alpha, beta (Zinke et al. 2008 eqs. 11-14, 16 with the
    # denominator a_b + a_b^3): they agree to float32 rounding (gate 1e-5
    # relative to the term's scale).
    d_b = 0.7
    d = hs.ChiangHair(eumelanin=0.3, pheomelanin=0.2).dual_terms(back_density=d_b)
    af, ab = d["a_f"], d["a_b"]
    q = 1 - af**2
    a_b = ab * af**2 / q + ab**3 * af**2 / q**3
    delta = d["alpha_b"] * (1 - 2 * ab**2 / q**2) + d["alpha_f"] * (2 * q**2 + 4 * af**2 * ab**2) / q**3
    s1 = np.sqrt(2 * d["beta_f2"] + d["beta_b2"])
    s3 = np.sqrt(2 * d["beta_f2"] + 3 * d["beta_b2"])
    sigma2 = ((1 + d_b * af**2) * (ab * s1 + ab**3 * s3) / (ab + ab**3)) ** 2
    for want, got in ((a_b, d["A_b"]), (delta, d["delta_b"]), (sigma2, d["sigma_b2"])):
        assert np.abs(want - got).max() < 1e-5 * max(1.0, np.abs(want).max())
    # back_density enters sigma_b only
    d0 = hs.ChiangHair(eumelanin=0.3, pheomelanin=0.2).dual_terms(back_density=0.0)
    np.testing.assert_array_equal(d0["A_b"], d["A_b"])
    assert (d0["sigma_b2"] <= d["sigma_b2"]).all() and (d0["sigma_b2"] < d["sigma_b2"]).any()


def _small(name: str, **render) -> hs.Scene:
    d = json.loads((DENSE / f"{name}.json").read_text())
    d["hair"]["generate"]["strands"] = 2000
    d["camera"]["resolution"] = [96, 54]
    d["render"].update(render)
    return hs.Scene.from_dict(d)


def test_04_option_errors():
    with pytest.raises(ValueError, match="multiple_scattering"):
        hs.render(_small("auburn_key"), multiple_scattering="karis")
    with pytest.raises(ValueError, match="multiple_scattering"):
        hs.render(_small("auburn_key"), multiple_scattering="volumetric")
    d = json.loads((DENSE / "auburn_key.json").read_text())
    d["hair"]["material"] = {"model": "deon"}
    d["hair"]["generate"]["strands"] = 200
    with pytest.raises(ValueError, match="multiple_scattering"):
        hs.render(hs.Scene.from_dict(d), width=32, height=18, multiple_scattering="dual")
    for key, bad in (
        ("dual_forward_density", 1.5),
        ("dual_back_density", -0.1),
        ("density_resolution", 4),
        ("dual_backscatter", "slab"),
    ):
        d = json.loads((DENSE / "auburn_key.json").read_text())
        d["render"][key] = bad
        with pytest.raises(hs.SceneError, match=key.replace("dual_", "")):
            hs.Scene.from_dict(d)


def test_05_dual_only_adds_light():
    # With the density shadow model both renders share the unscattered
    # light P0 = e^-n and dual adds the scattered terms (each >= 0), so no
    # pixel gets darker (f32 rounding: 1e-6 relative), blond hair gets
    # brighter, and nothing is NaN.
    for name in ("blond_back", "black_top"):
        none = hs.render(_small(name, shadow_model="density"), multiple_scattering="none")
        dual = hs.render(_small(name, shadow_model="density"), multiple_scattering="dual")
        assert np.isfinite(dual).all()
        assert (dual >= none - 1e-6 * none.max()).all(), name
        if name == "blond_back":
            assert dual.mean() > 1.2 * none.mean()


@pytest.mark.slow
def test_06_dual_against_path_tracing():
    # The measured state (docs: issue notes), gated so that it cannot
    # regress: blond backlit hair is mostly multiple scattering (Mitsuba
    # depth 2 vs 64: direct light is 38-57% per channel). Against the
    # converged reference (halves relMSE 1.1e-3), the rasterizer without
    # multiple scattering has relMSE 0.225 (default exponential shadows);
    # dual scattering with density shadows and d_f = d_b
    # = 1 brings it to 0.035 and the mean radiance from 0.90/1.07/1.36 of
    # the truth to 0.85/0.80/0.73 (hue). Gates: relMSE at most half of
    # 'none', every channel's mean within 30% of the truth.
    d = json.loads((DENSE / "blond_back.json").read_text())
    ref = hs.read_exr(str(DENSE / "blond_back.exr"))[..., :3]
    none = hs.render(hs.Scene.from_dict(d), multiple_scattering="none")
    d["render"].update(shadow_model="density", dual_forward_density=1.0, dual_back_density=1.0)
    dual = hs.render(hs.Scene.from_dict(d), multiple_scattering="dual")
    e_none, e_dual = hs.rel_mse(none, ref), hs.rel_mse(dual, ref)
    ratio = dual.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0)
    assert e_dual < 0.5 * e_none, (e_dual, e_none)
    assert np.abs(ratio - 1).max() < 0.3, ratio


# Coverage samples (the near field per sample), dual scattering (with the
# light the head reflects into the hair, render.sphere_bounce; d_f = 0.7,
# d_b = 1) and traced shadows against the converged references, measured
# (ratio = mean radiance per channel over the truth's; docs/dense_hair.md
# has every configuration):
#   scene        ratio R/G/B            relMSE    (with the light's visibility taken once per fragment)
#   auburn_key   0.963 0.934 0.954      1.79e-3   2.05e-3, 0.890/0.906/0.953
#   blond_back   1.019 0.983 0.945      1.41e-2   1.46e-2, 0.965/0.944/0.927
#   black_top    0.970 0.990 0.997      4.68e-3   4.63e-3, 0.925/0.940/0.945
#   brown_side   1.089 1.002 0.972      4.87e-3   5.10e-3, 0.955/0.962/0.992
#   ginger_two   0.963 0.947 0.956      5.36e-3   6.59e-3, 0.928/0.938/0.921
# (visibility per offset across the fiber made the single scattering right
# on every head, shade/near.rs; dual's constants were chosen against the
# darker one, so brown_side's red now runs over.)
# (the near field's relMSE is mostly its sampling noise at 16 samples: 64
# give black_top 1.4e-3.) The references' own noise (halves) is 8e-5 to
# 1.1e-3 relMSE (llvm_ad_rgb renders; docs/mitsuba_backends.md). Gates: relMSE at most 1.25x the measurement; every channel
# within 3 points of its measured deviation from the truth; and the hue
# kept: the largest over the smallest channel ratio at most 1.2 (measured
# up to 1.12, brown_side; the default render: up to 1.86, brown).
DENSE_COVERAGE = {
    "auburn_key": (1.79e-3, (0.963, 0.934, 0.954)),
    "blond_back": (1.41e-2, (1.019, 0.983, 0.945)),
    "black_top": (4.68e-3, (0.970, 0.990, 0.997)),
    "brown_side": (4.87e-3, (1.089, 1.002, 0.972)),
    "ginger_two": (5.36e-3, (0.963, 0.947, 0.956)),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(DENSE_COVERAGE))
def test_07_coverage_dual_traced_against_path_tracing(name):
    d = json.loads((DENSE / f"{name}.json").read_text())
    ref = hs.read_exr(str(DENSE / f"{name}.exr"))[..., :3]
    # per fragment and every strand: the scene's quality 'fast' shades per vertex, at its level of detail
    d["render"].update(transparency="coverage", multiple_scattering="dual", shadow_model="traced", shading="pixel",
                       lod=1.0)
    img = hs.render(hs.Scene.from_dict(d))
    rel = hs.rel_mse(img, ref)
    ratio = img.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0)
    e_max, measured = DENSE_COVERAGE[name]
    print(f"{name}: relMSE {rel:.3e}, ratio {np.round(ratio, 3)}")
    assert rel <= 1.25 * e_max, rel
    assert np.all(np.abs(ratio - 1) <= np.abs(np.array(measured) - 1) + 0.03), ratio
    assert ratio.max() / ratio.min() <= 1.2, ratio


def test_08_sphere_bounce():
    # The light the head reflects into the hair (render.sphere_bounce,
    # dual scattering) only adds light: every pixel at least its value
    # without it (f32 rounding: 1e-6 of the image's largest), the hair
    # over the head brighter, nothing NaN; a black head reflects nothing,
    # and the image is then the same bits as without it.
    for name in ("auburn_key", "black_top"):
        on = hs.render(_small(name, shadow_model="traced", multiple_scattering="dual", sphere_bounce=True))
        off = hs.render(_small(name, shadow_model="traced", multiple_scattering="dual", sphere_bounce=False))
        assert np.isfinite(on).all()
        assert (on >= off - 1e-6 * off.max()).all(), name
        assert on.mean() > 1.02 * off.mean(), (name, on.mean() / off.mean())
    d = json.loads((DENSE / "auburn_key.json").read_text())
    d["hair"]["generate"]["strands"] = 2000
    d["camera"]["resolution"] = [96, 54]
    d["meshes"][0]["albedo"] = [0, 0, 0]
    d["render"].update(shadow_model="traced", multiple_scattering="dual")
    on = hs.render(hs.Scene.from_dict(d))
    d["render"]["sphere_bounce"] = False
    assert np.array_equal(on, hs.render(hs.Scene.from_dict(d)))
    d["render"]["sphere_bounce"] = 1
    with pytest.raises(hs.SceneError, match="sphere_bounce"):
        hs.Scene.from_dict(d)


# Single scattering alone against path tracing at max_depth 2 (direct light;
# Mitsuba llvm, two halves of 128 spp: their means differ by ~1%, seeds 21
# and 22 at 64 spp by 1.4%). Measured on black_top, coverage
# samples + traced shadows, mean radiance per channel over Mitsuba's
# (docs/dense_hair.md, "Single scattering"): the far field once per fragment
# 0.910/0.899/0.896, the near field per sample 0.984/0.980/0.978 (two runs
# with other seeds agree to 1e-3). Measured again when the Mitsuba bridge
# began drawing a polyline scene's own polyline (every vertex tripled)
# instead of the B-spline of its vertices: far 0.918/0.908/0.904, near
# 1.042/1.044/1.043 (against the B-spline drawing, near 1.033: Mitsuba's
# polyline is 0.5% darker than its B-spline here). The far field assumes every offset across
# a fiber is seen; in dense hair the fibers in front hide part of the ones
# behind (top-lit black hair: R, brightest towards a fiber's edges). Gates:
# the halves' means within 2%; the near field within 5% per channel; the
# far field off by more than 6% in every channel (the test tells them
# apart). Backlit blond is not gated here: its direct light (TT through
# fibers) converges slowly in Mitsuba, two seed sets of 128 spp differed by
# 4% in the mean.
@pytest.mark.slow
@pytest.mark.mitsuba
def test_09_near_field_single_scattering_against_path_tracing():
    from hairshade import mitsuba as hm

    d = json.loads((DENSE / "black_top.json").read_text())
    scene = hs.Scene.from_dict(d)
    halves = [
        hm.render(scene, spp=128, integrator="path", max_depth=2, seed=s, passes=1, progress=False) for s in (21, 22)
    ]
    mean = lambda x: x.reshape(-1, 3).mean(0)  # noqa: E731
    assert np.abs(mean(halves[0]) / mean(halves[1]) - 1).max() < 0.02
    truth = mean(0.5 * (halves[0] + halves[1]))
    ratio = {}
    for near in (False, True):
        d["render"].update(transparency="coverage", multiple_scattering="none", shadow_model="traced", near_field=near,
                           shading="pixel", lod=1.0)
        ratio[near] = mean(hs.render(hs.Scene.from_dict(d))) / truth
    print({k: np.round(v, 3) for k, v in ratio.items()})
    assert np.abs(ratio[True] - 1).max() < 0.05, ratio
    assert np.abs(ratio[False] - 1).min() > 0.06, ratio


def _white_slab(backscatter: str) -> np.ndarray:
    """A slab of parallel white fibers (σa = 0), 20 fibers deep across its
    thickness, seen from above under a white constant environment."""
    r, thick, n = 0.0013, 0.05, 20.0
    s = np.sqrt(2 * r * thick / n)  # spacing: n = 2r·thick/s² fibers crossed
    rng = np.random.default_rng(1)
    ys = (np.arange(int(thick / s)) + 0.5) * s
    zs = (np.arange(int(1 / s)) + 0.5) * s - 0.5
    y, z = (a.ravel() for a in np.meshgrid(ys, zs, indexing="ij"))
    y = y + rng.uniform(-0.4 * s, 0.4 * s, y.size)
    z = z + rng.uniform(-0.5 * s, 0.5 * s, z.size)
    x = np.linspace(-0.5, 0.5, 4)
    pts = np.stack(
        [np.broadcast_to(x, (y.size, 4)), np.repeat(y[:, None], 4, 1), np.repeat(z[:, None], 4, 1)], -1
    ).reshape(-1, 3)
    scene = hs.Scene.from_arrays(
        pts.astype(np.float32),
        r,
        np.arange(y.size + 1) * 4,
        material={"model": "chiang", "eumelanin": 0.0, "pheomelanin": 0.0,
                  "longitudinal_roughness": 0.3, "azimuthal_roughness": 0.45},
        camera={"position": [0.0, 1.6, 0.3], "target": [0, 0, 0], "up": [1, 0, 0], "fov": 20, "resolution": [160, 160]},
        lights=[{"type": "environment", "radiance": [1, 1, 1]}],
        render={"transparency": "coverage", "multiple_scattering": "dual", "shadow_model": "traced",
                "dual_forward_density": 1.0, "dual_backscatter": backscatter},
    )
    return np.asarray(hs.render(scene, progress=False))[60:100, 60:100]


# 10: energy. A white slab in a white furnace scatters all the light it
# receives, so every pixel where it is opaque shows the environment's
# radiance. With the two-stream back scattering (d_f = 1) the streams of
# opposite directions sum to 1 (tests in src/fiber/dual/tests.rs); measured on
# this slab: 0.989 to 0.998 over the centre (the residual: the 32-direction
# quadrature and the two streams' different longitudinal spreads, ≤ 1.4%
# for one fiber in src/fiber/dual/tests.rs 06). Gate: every pixel within 2%, the
# issue's goal. Zinke's local A_b keeps 0.21 to 0.23 of it (what the fibers
# scatter back towards the light is lost beyond the neighbourhood): the
# test tells the two apart.
def test_10_white_slab_in_a_white_furnace():
    two = _white_slab("two_stream")
    assert np.abs(two - 1).max() < 0.02, (two.min(), two.max())
    local = _white_slab("local")
    assert local.max() < 0.5, local.max()


def _karis_small(**render) -> hs.Scene:
    d = json.loads((DENSE / "auburn_key.json").read_text())
    d["hair"]["material"] = {"model": "karis", "base_color": [0.45, 0.25, 0.12], "roughness": 0.45}
    d["hair"]["generate"]["strands"] = 2000
    d["camera"]["resolution"] = [96, 54]
    d["render"].update(render)
    return hs.Scene.from_dict(d)


def test_11_karis_terms_in_range_everywhere():
    # KarisHair's tables over base colour x roughness x specular: every
    # term finite, attenuations, widths and A_b >= 0, a_f + a_b <= 1 (the
    # model itself scatters up to 1.27 of the light for white hair with
    # specular 1: the table caps the sum at 1, f32 rounding 1e-6), and the
    # cap leaves absorbing hair alone (dark brown: measured sum <= 0.77).
    for color in ([1.0, 1.0, 1.0], [0.45, 0.25, 0.12], [0.0, 0.0, 0.0]):
        for r in (0.1, 0.45, 0.9):
            for spec in (0.5, 1.0):
                d = hs.KarisHair(base_color=color, roughness=r, specular=spec).dual_terms()
                for k in FIELDS:
                    assert d[k].shape == (65, 3) and np.isfinite(d[k]).all(), k
                for k in ("a_f", "a_b", "beta_f2", "beta_b2", "A_b", "sigma_b2"):
                    assert (d[k] >= 0).all(), k
                s = d["a_f"] + d["a_b"]
                assert s.max() <= 1 + 1e-6, (color, r, spec, s.max())
                if color[0] < 0.5 and r >= 0.45:
                    assert s.max() < 0.8
    with pytest.raises(ValueError, match="back_density"):
        hs.KarisHair().dual_terms(back_density=2.0)


def test_12_karis_dual_only_adds_light():
    # KarisHair under dual scattering, as test 05: with the density shadow
    # model `none` (R + TT + TRT shadowed by P0 = e^-n) and `dual` share the
    # single scattering and dual adds its scattered terms, so no pixel gets
    # darker (f32 rounding: 1e-6 relative), the hair gets brighter, and
    # nothing is NaN; Karis's own term gives another image.
    none = hs.render(_karis_small(shadow_model="density"), multiple_scattering="none")
    dual = hs.render(_karis_small(shadow_model="density"), multiple_scattering="dual")
    karis = hs.render(_karis_small(shadow_model="density"), multiple_scattering="karis")
    assert np.isfinite(dual).all()
    assert (dual >= none - 1e-6 * none.max()).all()
    assert dual.mean() > 1.05 * none.mean(), (dual.mean(), none.mean())
    assert np.abs(dual - karis).mean() > 0.01 * karis.mean()


@pytest.mark.slow
def test_13_karis_dual_on_the_demo_head_against_path_tracing():
    # The demo head (KarisHair; the truth is Mitsuba on the ChiangHair that
    # hairshade.mapping fits to it, 2 x 2048 spp, halves relMSE 5.5e-3),
    # with the scene's MLAB and shadow maps, measured (docs/dense_hair.md):
    #   karis (the model's own term)  1.093/1.084/1.048  relMSE 4.45e-2
    #   dual                          0.968/0.976/0.983  relMSE 6.62e-3
    # Dual's relMSE is within twice the reference's own noise, so the gate
    # is on what the reference resolves: dual at most half of karis's
    # relMSE (measured 0.15x) and every channel within 6% of the truth
    # (measured 3.2% at worst; karis: 9.3%).
    e_karis, e_dual, ratio = _karis_and_dual_against_truth("demo_head")
    assert e_dual < 0.5 * e_karis, (e_dual, e_karis)
    assert np.abs(ratio - 1).max() < 0.06, ratio


def _karis_and_dual_against_truth(name: str) -> tuple[float, float, np.ndarray]:
    """relMSE of a dense KarisHair scene rendered with `karis` and with
    `dual` against its reference, and dual's mean per channel over the
    truth's."""
    d = json.loads((DENSE / f"{name}.json").read_text())
    ref = hs.read_exr(str(DENSE / f"{name}.exr"))[..., :3]
    karis = hs.render(hs.Scene.from_dict(d), multiple_scattering="karis")
    dual = hs.render(hs.Scene.from_dict(d), multiple_scattering="dual")
    e_karis, e_dual = hs.rel_mse(karis, ref), hs.rel_mse(dual, ref)
    ratio = dual.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0)
    print(f"{name}: karis {e_karis:.3e}, dual {e_dual:.3e}, ratio {np.round(ratio, 3)}")
    return e_karis, e_dual, ratio


@pytest.mark.slow
def test_14_cards_under_dual_scattering_against_path_tracing():
    # The card head (KarisHair on 600 baked cards; the truth is Mitsuba on
    # the 16 800 fibers the cards stand for, with the ChiangHair fitted to
    # the material, 2 x 2048 spp, halves relMSE 4.7e-3), the scene's MLAB
    # and opacity shadow maps, measured (docs/dense_hair.md):
    #   karis (the model's own term)  1.050/1.056/1.037  relMSE 3.04e-2
    #   dual                          0.976/0.984/0.993  relMSE 1.12e-2
    #   dual without the cards' fibers in the grid: 1.048/1.063/1.061, 3.4e-2
    # Gates: every channel within the 15% (measured 2.4% at worst:
    # the gate is 5%, which the fiber-less grid's 6.3% fails) and dual at
    # most half of karis's relMSE (measured 0.37x).
    e_karis, e_dual, ratio = _karis_and_dual_against_truth("card_head")
    assert np.abs(ratio - 1).max() < 0.05, ratio
    assert e_dual < 0.5 * e_karis, (e_dual, e_karis)


def test_15_card_fibers_fill_the_density_grid():
    # Baked cards hand their fibers to the renderer's density grid: under
    # dual scattering the environment (shaded as directions, each dimmed by
    # the fibers crossed towards it; the key light's single scattering is
    # the shadow map's) reaches cards inside the head through other cards,
    # so the head is darker than when the same cards come without fibers
    # (no fiber count: an unshadowed environment; measured 0.61x), and no
    # pixel is NaN. Without dual scattering the fibers are not read: the
    # images are equal.
    d = json.loads((pathlib.Path(__file__).parent.parent / "examples" / "card_head.json").read_text())
    d["camera"]["resolution"] = [96, 54]
    images = {}
    for fibers in (True, False):
        for ms in ("dual", "karis"):
            scene = hs.Scene.from_dict(d)
            if not fibers:
                scene.cards["fibers"] = None
            images[fibers, ms] = hs.render(scene, multiple_scattering=ms)
    assert np.isfinite(images[True, "dual"]).all()
    # the hair's pixels: those that are not the background (the environment)
    hair = np.abs(images[True, "karis"] - np.array(d["lights"][1]["radiance"], np.float32)).max(-1) > 1e-3
    with_f, without = images[True, "dual"][hair].mean(), images[False, "dual"][hair].mean()
    print("with / without fibers:", with_f / without)
    assert with_f < 0.95 * without
    assert np.array_equal(images[True, "karis"], images[False, "karis"])
