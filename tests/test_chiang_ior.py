"""ChiangHair takes Mitsuba's ``int_ior`` / ``ext_ior`` (eta = int_ior /
ext_ior, Mitsuba's defaults 1.55 and 1.000277), and gives Mitsuba's `hair`
values for the same dictionary."""

from __future__ import annotations

import numpy as np
import pytest

import hairshade as hs
from hairshade.validation import direction_pairs, well_conditioned


def test_01_int_ext_ior_is_eta_exactly():
    wi, wo = direction_pairs(50, 3)
    for int_ior, ext_ior in ((1.6, 1.0), (1.55, 1.33), (2.0, 1.2)):
        a = hs.ChiangHair(int_ior=int_ior, ext_ior=ext_ior)
        b = hs.ChiangHair(eta=int_ior / ext_ior)
        assert a.params == b.params
        assert np.array_equal(a.eval(wi, wo), b.eval(wi, wo))


def test_02_defaults_are_mitsubas():
    assert hs.ChiangHair().params["eta"] == 1.55  # eta's own default
    assert hs.ChiangHair(int_ior=1.55).params["eta"] == 1.55 / 1.000277  # Mitsuba's default exterior: air
    assert hs.ChiangHair(ext_ior=1.0).params["eta"] == 1.55


@pytest.mark.parametrize("kwargs, names", [
    (dict(eta=1.5, int_ior=1.6), "eta and int_ior"),
    (dict(eta=1.5, ext_ior=1.1), "eta and ext_ior"),
    (dict(eta=1.5, int_ior=1.6, ext_ior=1.1), "eta and int_ior, ext_ior"),
])
def test_03_eta_with_mitsubas_names_is_an_error_naming_them(kwargs, names):
    with pytest.raises(ValueError, match=names):
        hs.ChiangHair(**kwargs)


@pytest.mark.parametrize("kwargs, match", [
    (dict(int_ior=0.0), "int_ior: must be finite and > 0"),
    (dict(ext_ior=float("nan")), "ext_ior: must be finite and > 0"),
    (dict(int_ior="keratin"), "int_ior: expected a number"),
    (dict(int_ior=1.0, ext_ior=1.0), "eta"),  # relative IOR 1: the model's own range check
])
def test_04_bad_iors_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        hs.ChiangHair(**kwargs)


@pytest.mark.mitsuba
def test_05_same_dict_as_mitsubas_hair():
    """The parameters of a Mitsuba `hair` dictionary, given unchanged.
    Tolerance: on well-conditioned pairs Mitsuba's float32 evaluation
    differs from hairshade's f64 (with Mitsuba's I0) by at most 2.5e-5
    relative (README's validation table, `hairshade validate`); 1e-4 leaves
    4x for these parameter sets. Values below 1e-4 of the maximum are
    compared absolutely at that level, as in the validation table."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    wi, wo = direction_pairs(60, 7)
    sel = well_conditioned(wi)
    wi, wo = wi[sel], wo[sel]
    wi = wi / np.linalg.norm(wi, axis=1, keepdims=True)
    wo = wo / np.linalg.norm(wo, axis=1, keepdims=True)
    for d in ({"int_ior": 1.6, "ext_ior": 1.33, "eumelanin": 0.8, "pheomelanin": 0.3},
              {"int_ior": 1.5, "eumelanin": 0.3},  # ext_ior: Mitsuba's default
              {"ext_ior": 1.1, "longitudinal_roughness": 0.4, "azimuthal_roughness": 0.5}):
        b = mi.load_dict({"type": "hair", **d})
        si = mi.SurfaceInteraction3f()
        ref = np.empty((len(wi), 3))
        for i in range(len(wi)):
            si.wi = mi.Vector3f(wi[i])
            ref[i] = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(wo[i])))
        # Mitsuba's default tilt, +2 degrees its way, is ChiangHair's -2 (docs/tilt.md)
        ours = hs.ChiangHair(i0="mitsuba", scale_tilt=-2.0, **d).eval(wi, wo)
        floor = 1e-4 * np.abs(ref).max()
        err = np.abs(ours - ref) / np.maximum(np.abs(ref), floor)
        assert err.max() <= 1e-4, (d, err.max())
