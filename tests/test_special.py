"""Special functions against scipy (independent implementations)."""

import numpy as np
from scipy import special

from hairshade import _native


def test_01_i0e_matches_scipy_ive():
    x = np.concatenate([[0.0], np.logspace(-10, 4, 3000), np.linspace(17.5, 18.5, 1001), np.linspace(8.5, 9.5, 101)])
    ours = _native.i0e(x)
    ref = special.ive(0, x)
    rel = np.abs(ours - ref) / ref
    assert rel.max() <= 1e-12, (x[rel.argmax()], rel.max())


def test_02_log_i0_matches_scipy():
    """Where log(ive(x)) + x is itself accurate (x >= 1)."""
    x = np.concatenate([np.logspace(0, 6, 3000), np.linspace(17.5, 18.5, 1001)])
    ours = _native.log_i0(x)
    ref = np.log(special.ive(0, x)) + x
    assert (np.abs(ours - ref) / ref).max() <= 1e-12


def test_03_log_i0_continuous_at_switch():
    x = np.nextafter(18.0, [0.0, 100.0])
    a, b = _native.log_i0(np.array([x[0], 18.0, x[1]]))[[0, 2]]
    assert abs(a - b) / a < 1e-14


def test_04_mitsuba_log_i0_is_approximate():
    """Mitsuba's log I0 is off by up to ~1e-3 absolute just above 12 (it
    halves the 1/(8x) term): what the exact mode fixes."""
    x = np.linspace(12.01, 20, 50)
    err = np.abs(_native.log_i0(x, mitsuba=True) - (np.log(special.ive(0, x)) + x))
    assert 1e-4 < err.max() < 1e-2
