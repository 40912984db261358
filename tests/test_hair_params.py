"""Blender's and pbrt-v4's hair parameters (hairshade.hair_params,
ChiangHair.from_blender / from_pbrt, ChiangHair's coat): the formulas
against transcriptions of the renderers' source, exact identities, and
Cycles' own single-fiber renders (cached in tests/data/cycles/fibers.json
by scripts/cycles_fibers.py)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import hairshade as hs
from helpers import uniform_sphere

DATA = Path(__file__).parent / "data" / "cycles"


def poly(b):
    """Chiang et al. 2016 eq. 9's denominator, term by term."""
    return 5.969 - 0.215 * b + 2.532 * b * b - 10.73 * b**3 + 5.574 * b**4 + 0.245 * b**5


def test_01_blender_direct_coloring_defaults():
    """Blender's node defaults (Direct coloring, Color (0.017513, 0.005763,
    0.002059), both roughnesses 0.3, IOR 1.55, Offset 2 degrees)."""
    c = hs.ChiangHair.from_blender()
    want = [(math.log(x) / poly(0.3)) ** 2 for x in (0.017513, 0.005763, 0.002059)]
    np.testing.assert_allclose(c.sigma_a, want, rtol=1e-12)
    p = c.params
    assert (p["longitudinal_roughness"], p["azimuthal_roughness"], p["eta"], p["scale_tilt"], p["coat"]) == \
           (0.3, 0.3, 1.55, 2.0, 0.0)


def test_02_blender_melanin_as_cycles_computes_it():
    """Cycles (svm/closure.h): m' = -ln(max(1 - m, 1e-4)), split by
    redness, Cycles' own coefficients, plus the tint's absorption."""
    m, red, tint, bn = 0.7, 0.3, (0.9, 0.8, 0.7), 0.45
    c = hs.ChiangHair.from_blender(parametrization="melanin", melanin=m, melanin_redness=red, tint=tint,
                                   radial_roughness=bn)
    mp = -math.log(1 - m)
    want = [mp * (1 - red) * e + mp * red * ph + (math.log(t) / poly(bn)) ** 2
            for e, ph, t in zip((0.506, 0.841, 1.653), (0.343, 0.733, 1.924), tint)]
    np.testing.assert_allclose(c.sigma_a, want, rtol=1e-12)
    # melanin 1: the 1e-4 floor, -ln(1e-4) = 9.21
    full = hs.ChiangHair.from_blender(parametrization="melanin", melanin=1.0, melanin_redness=0.0)
    np.testing.assert_allclose(full.sigma_a, -math.log(1e-4) * np.array([0.506, 0.841, 1.653]), rtol=1e-12)


def test_03_random_amounts_need_the_strands_random_number():
    base = dict(parametrization="melanin", melanin=0.5, roughness=0.4, radial_roughness=0.3)
    with pytest.raises(ValueError, match="random_color and random_roughness vary per strand: pass random="):
        hs.ChiangHair.from_blender(random_color=0.5, **base)
    mid = hs.ChiangHair.from_blender(random_color=0.5, random_roughness=0.5, random=0.5, **base)
    assert mid.params == hs.ChiangHair.from_blender(**base).params  # factors of 1 at random 0.5
    hi = hs.ChiangHair.from_blender(random_color=0.4, random_roughness=0.2, random=1.0, **base)
    # factors 1 + 2 (1 - 0.5) x: melanin 0.5 * 1.4, roughnesses * 1.2
    np.testing.assert_allclose(hi.sigma_a, -math.log(1 - 0.7) * np.array([0.343, 0.733, 1.924]), rtol=1e-12)
    assert hi.params["longitudinal_roughness"] == pytest.approx(0.48)
    assert hi.params["azimuthal_roughness"] == pytest.approx(0.36)


def test_04_coat_gives_R_the_roughness_one_minus_coat_times_beta_m():
    """Exact identity: with coat c, R is R of (1 - c) beta_m and TT, TRT and
    the residual are those of beta_m (Cycles' m0_roughness)."""
    rng = np.random.default_rng(5)
    wi, wo = uniform_sphere(300, rng), uniform_sphere(300, rng)
    coated = hs.ChiangHair(longitudinal_roughness=0.5, coat=0.4).eval_far_lobes(wi, wo)
    smooth = hs.ChiangHair(longitudinal_roughness=0.3).eval_far_lobes(wi, wo)
    plain = hs.ChiangHair(longitudinal_roughness=0.5).eval_far_lobes(wi, wo)
    np.testing.assert_array_equal(coated["R"], smooth["R"])
    for k in ("TT", "TRT"):
        np.testing.assert_array_equal(coated[k], plain[k])
    assert not np.allclose(coated["R"], plain["R"])
    with pytest.raises(ValueError, match=r"coat: must be in \[0, 1\]"):
        hs.ChiangHair(coat=1.5)
    with pytest.raises(ValueError, match="coat: Mitsuba's hair has no coat"):
        pytest.importorskip("mitsuba")
        from hairshade.mitsuba import hair_dict

        hair_dict(hs.ChiangHair(coat=0.1))


def test_05_pbrt_defaults_and_clamps():
    """pbrt-v4 HairMaterial::Create: no absorption given is eumelanin 1.3
    (pbrt's coefficients 0.419, 0.697, 1.37), beta_m and beta_n 0.3
    clamped to [0.01, 1], eta 1.55, alpha 2 degrees, which tilts the other
    way from ChiangHair on the same curve: scale_tilt -2."""
    c = hs.ChiangHair.from_pbrt()
    np.testing.assert_allclose(c.sigma_a, [1.3 * 0.419, 1.3 * 0.697, 1.3 * 1.37], rtol=1e-12)
    p = c.params
    assert (p["longitudinal_roughness"], p["azimuthal_roughness"], p["eta"], p["scale_tilt"]) == (0.3, 0.3, 1.55, -2.0)
    assert hs.ChiangHair.from_pbrt(beta_m=0.0, beta_n=3.0).params["longitudinal_roughness"] == 0.01
    assert hs.ChiangHair.from_pbrt(beta_m=0.0, beta_n=3.0).params["azimuthal_roughness"] == 1.0
    # reflectance clamped to [0, 1], through the same polynomial with beta_n
    r = hs.ChiangHair.from_pbrt(reflectance=[1.5, 0.5, 0.25], beta_n=0.6)
    np.testing.assert_allclose(r.sigma_a, [0.0, (math.log(0.5) / poly(0.6)) ** 2, (math.log(0.25) / poly(0.6)) ** 2],
                               rtol=1e-12)
    assert hs.ChiangHair.from_pbrt(color=[0.5] * 3).params == hs.ChiangHair.from_pbrt(reflectance=[0.5] * 3).params
    e = hs.ChiangHair.from_pbrt(eumelanin=0.5, pheomelanin=2.0)
    np.testing.assert_allclose(e.sigma_a, 0.5 * np.array([0.419, 0.697, 1.37]) + 2.0 * np.array([0.187, 0.4, 1.05]),
                               rtol=1e-12)
    # sigma_a first, then reflectance, then melanin
    s = hs.ChiangHair.from_pbrt(sigma_a=[1, 2, 3], reflectance=[0.5] * 3, eumelanin=4)
    np.testing.assert_array_equal(s.sigma_a, [1, 2, 3])


def test_06_reflectance_round_trip():
    """sigma_from_reflectance inverted: exp(-sqrt(sigma) S(beta_n)) is the
    colour again."""
    from hairshade.hair_params import sigma_from_reflectance

    c = np.array([0.9, 0.3, 0.02])
    for b in (0.1, 0.3, 0.7, 1.0):
        np.testing.assert_allclose(np.exp(-np.sqrt(sigma_from_reflectance(c, b)) * poly(b)), c, rtol=1e-12)


def test_07_errors_name_the_input():
    with pytest.raises(TypeError, match="melanine: not an input of Blender's Principled Hair BSDF"):
        hs.ChiangHair.from_blender(melanine=0.3)
    with pytest.raises(ValueError, match="parametrization: expected 'absorption', 'melanin' or 'color'"):
        hs.ChiangHair.from_blender(parametrization="huang")
    with pytest.raises(ValueError, match=r"roughness: expected a finite number in \[0, 1\]"):
        hs.ChiangHair.from_blender(roughness=2)
    with pytest.raises(ValueError, match="reflectance and color are the same pbrt parameter"):
        hs.ChiangHair.from_pbrt(color=[0.5] * 3, reflectance=[0.5] * 3)
    with pytest.raises(ValueError, match="color: expected 3 finite numbers"):
        hs.ChiangHair.from_blender(color=[0.1, float("nan"), 0.1])


def test_08_single_fibers_against_cycles():
    """Cycles rendered each fiber with the Principled Hair node's own inputs
    (scripts/cycles_fibers.py, cached sums); the rasterizer renders
    ChiangHair.from_blender of them. The image sums agree per channel
    within the measured worst case, 1.14% (the darkest fiber lit from the
    camera's side, where R dominates; docs/cycles_fibers.md) plus Cycles'
    noise (at most 0.18%, blue of that fiber backlit): tolerance 2%."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "scripts"))
    import cycles_fibers as cf

    data = json.loads((DATA / "fibers.json").read_text())
    assert len(data["cases"]) == 2 * len(cf.MATERIALS)
    worst = 0.0
    for case in data["cases"]:
        model = hs.ChiangHair.from_blender(**case["inputs"])
        mat = {k: v for k, v in model.params.items() if v is not None}
        ours = hs.render(cf.fiber_scene(mat, cf.LIGHTS[case["light"]])).sum((0, 1))
        cyc = np.mean(case["cycles_halves"], axis=0)
        worst = max(worst, float(np.abs(ours / cyc - 1).max()))
    print(f"worst |hairshade / Cycles - 1| = {worst:.4f}")
    assert worst < 0.02


def test_09_mitsuba_dicts():
    """A Mitsuba hair dictionary, with its rgb values, named IORs and
    defaults: ChiangHair.from_mitsuba evaluates as Mitsuba does (1e-4, the
    BSDF validation's tolerance, in Mitsuba's I0 mode, on its well-
    conditioned pairs as in test_chiang_ior), and the bridge's own
    dictionary comes back to the same parameters."""
    mi = pytest.importorskip("mitsuba")
    from hairshade.mitsuba import hair_dict
    from hairshade.validation import direction_pairs, well_conditioned

    wi, wo = direction_pairs(60, 7)
    sel = well_conditioned(wi)
    wi, wo = wi[sel], wo[sel]
    wi = wi / np.linalg.norm(wi, axis=1, keepdims=True)
    wo = wo / np.linalg.norm(wo, axis=1, keepdims=True)
    mi.set_variant("scalar_rgb")
    for d in ({"type": "hair", "sigma_a": {"type": "rgb", "value": [0.3, 0.5, 0.9]}, "scale_tilt": 3.0},
              {"type": "hair", "eumelanin": 0.7, "int_ior": "amber", "ext_ior": "air",
               "longitudinal_roughness": 0.4}):
        ours = hs.ChiangHair.from_mitsuba(d)
        b = mi.load_dict(d)
        si = mi.SurfaceInteraction3f()
        ref = np.empty((len(wi), 3))
        for i in range(len(wi)):
            si.wi = mi.Vector3f(wi[i])
            ref[i] = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(wo[i])))
        got = hs.ChiangHair(**dict(ours.params, i0="mitsuba")).eval(wi, wo)
        floor = 1e-4 * np.abs(ref).max()
        assert (np.abs(got - ref) / np.maximum(np.abs(ref), floor)).max() <= 1e-4
        back = hs.ChiangHair.from_mitsuba(hair_dict(ours))
        assert back.params == ours.params
    with pytest.raises(ValueError, match="type: expected 'hair'"):
        hs.ChiangHair.from_mitsuba({"type": "diffuse"})
    with pytest.raises(ValueError, match="sigma_a: expected a number, 3 numbers or"):
        hs.ChiangHair.from_mitsuba({"type": "hair", "sigma_a": {"type": "spectrum", "value": 0.5}})
    with pytest.raises(ValueError, match="int_ior: 'glass' is not one of the media known here"):
        hs.ChiangHair.from_mitsuba({"type": "hair", "int_ior": "glass"})
