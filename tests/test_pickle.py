"""Every model survives pickling (and so multiprocessing and joblib): the
copy has the same parameters and evaluates bit-identically (it is rebuilt
from the same parameters by the same native constructor)."""

from __future__ import annotations

import multiprocessing
import operator
import pickle

import numpy as np
import pytest

import hairshade as hs

RNG = np.random.default_rng(13)
A, B, C = (RNG.normal(size=(257, 3)) for _ in range(3))

MODELS = [
    hs.ChiangHair(eumelanin=0.4, pheomelanin=0.3, longitudinal_roughness=0.2, scale_tilt=-3.0, eta=1.6, i0="mitsuba"),
    hs.ChiangHair(sigma_a=[0.2, 0.5, 1.0], azimuthal_roughness=0.6, int_ior=1.52, ext_ior=1.33),
    hs.KarisHair(base_color=(0.5, 0.3, 0.1), roughness=0.35, scatter=0.3, components=("R", "TRT", "MS"),
                 legacy_absorption=False, corrected_absorption=True),
    hs.DEonHair(base_color=(0.2, 0.4, 0.6), roughness=0.6, h_samples=8, h_offset=0.25, components=("TT", "TRT")),
]


def _evals(m: object) -> list[np.ndarray]:
    """Each model's main evaluations, f32 and f64 (the f32 ones run the vector kernels)."""
    out = []
    for dt in (np.float64, np.float32):
        a, b, c = A.astype(dt), B.astype(dt), C.astype(dt)
        if isinstance(m, hs.ChiangHair):
            out += [m.eval(a, b), m.pdf(a, b)]
        else:
            out.append(m.eval(a, b, c))  # type: ignore[attr-defined]
    return out


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_01_round_trip_same_params_bit_identical_eval(model):
    for protocol in (2, pickle.HIGHEST_PROTOCOL):
        copy = pickle.loads(pickle.dumps(model, protocol=protocol))
        assert type(copy) is type(model)
        assert copy.params == model.params
        assert repr(copy) == repr(model)
        for x, y in zip(_evals(model), _evals(copy)):
            assert x.dtype == y.dtype and np.array_equal(x, y)


def test_02_chiang_derived_values_survive():
    m = MODELS[1]
    copy = pickle.loads(pickle.dumps(m))
    assert np.array_equal(copy.sigma_a, m.sigma_a) and copy.variances == m.variances
    assert copy.params["eta"] == 1.52 / 1.33


def test_03_multiprocessing_workers_evaluate_the_same():
    """Models sent to spawned worker processes (pickled there and back)."""
    ctx = multiprocessing.get_context("spawn")
    a, b, t = A.astype(np.float32), B.astype(np.float32), C.astype(np.float32)
    with ctx.Pool(2) as pool:
        chiang = pool.map(operator.methodcaller("eval", a, b), MODELS[:2])
        real_time = pool.map(operator.methodcaller("eval", a, b, t), MODELS[2:])
    for m, got in zip(MODELS[:2], chiang):
        assert np.array_equal(got, m.eval(a, b))
    for m, got in zip(MODELS[2:], real_time):
        assert np.array_equal(got, m.eval(a, b, t))
