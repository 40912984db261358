"""The pieces of the hair lobes, elementwise over numpy arrays (float64),
for analysis: each exact form beside the fit that replaces it in KarisHair.

Angles in radians; ``cos_phi`` is the cosine of the azimuth difference.
All functions broadcast their arguments like numpy ufuncs.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from . import _native

__all__ = [
    "deon_mp", "gaussian_mp", "gaussian_detector", "logistic",
    "eta_prime", "eta_prime_fit", "h_tt", "h_tt_fit",
    "d_tt", "d_tt_fit", "d_trt", "d_trt_fit",
    "schlick_fresnel", "asin_fast", "color_to_absorption",
]


def _call(name: str, *args: npt.ArrayLike) -> np.ndarray:
    arrs = np.broadcast_arrays(*[np.asarray(a, dtype=np.float64) for a in args])
    shape = arrs[0].shape
    out = _native.lobe(name, [np.ascontiguousarray(a).reshape(-1) for a in arrs])
    return out.reshape(shape)


def deon_mp(sin_theta_i: npt.ArrayLike, sin_theta_o: npt.ArrayLike, v: npt.ArrayLike) -> np.ndarray:
    """d'Eon 2011 M_p, a density over sin(theta_o): exact, stable for any v > 0."""
    return _call("deon_mp", sin_theta_i, sin_theta_o, v)


def gaussian_mp(beta: npt.ArrayLike, x: npt.ArrayLike) -> np.ndarray:
    """Karis's Gaussian M_p: exp(-x^2/(2 beta^2)) / (sqrt(2 pi) beta), x = sin(theta_i) + sin(theta_o) - alpha."""
    return _call("gaussian", beta, x)


def gaussian_detector(beta: npt.ArrayLike, phi: npt.ArrayLike) -> np.ndarray:
    """The Gaussian of width beta wrapped around the circle (UE's reference N_p detector)."""
    return _call("gaussian_detector", beta, phi)


def logistic(phi: npt.ArrayLike, s: npt.ArrayLike, mu: npt.ArrayLike) -> np.ndarray:
    """Logistic distribution D(phi, s, mu) (Pekelis et al. 2015)."""
    return _call("logistic", phi, s, mu)


def eta_prime(eta: npt.ArrayLike, cos_theta_d: npt.ArrayLike) -> np.ndarray:
    """Bravais modified index sqrt(eta^2 - sin^2 theta_d) / cos theta_d."""
    return _call("eta_prime", eta, cos_theta_d)


def eta_prime_fit(cos_theta_d: npt.ArrayLike) -> np.ndarray:
    """Karis's fit for eta = 1.55: 1.19 / cos theta_d + 0.36 cos theta_d."""
    return _call("eta_prime_fit", cos_theta_d)


def h_tt(cos_phi: npt.ArrayLike, a: npt.ArrayLike) -> np.ndarray:
    """Exact TT offset cos(phi/2) / sqrt(1 + a^2 - 2 a sin(phi/2)), a = 1/eta'."""
    return _call("h_tt", cos_phi, a)


def h_tt_fit(cos_phi: npt.ArrayLike, a: npt.ArrayLike) -> np.ndarray:
    """Karis's fit (1 + a (0.6 - 0.8 cos phi)) cos(phi/2)."""
    return _call("h_tt_fit", cos_phi, a)


def d_tt(phi: npt.ArrayLike) -> np.ndarray:
    """TT distribution D(phi, 0.35, pi), phi in [0, pi]."""
    return _call("d_tt", phi)


def d_tt_fit(cos_phi: npt.ArrayLike) -> np.ndarray:
    """Karis's fit exp(-3.65 cos phi - 3.98)."""
    return _call("d_tt_fit", cos_phi)


def d_trt(phi: npt.ArrayLike) -> np.ndarray:
    """TRT distribution 3/4 D(phi, 0.15, 0), phi in [0, pi]."""
    return _call("d_trt", phi)


def d_trt_fit(cos_phi: npt.ArrayLike) -> np.ndarray:
    """Karis's fit exp(17 cos phi - 16.78)."""
    return _call("d_trt_fit", cos_phi)


def schlick_fresnel(eta: npt.ArrayLike, x: npt.ArrayLike) -> np.ndarray:
    """F0 + (1 - F0)(1 - x)^5, F0 = ((1 - eta)/(1 + eta))^2."""
    return _call("schlick", eta, x)


def asin_fast(x: npt.ArrayLike) -> np.ndarray:
    """UE's asinFast (Eberly degree-1 acos), absolute error up to 9e-3 rad."""
    return _call("asin_fast", x)


def color_to_absorption(color: npt.ArrayLike, beta_n: npt.ArrayLike = 0.3) -> np.ndarray:
    """Chiang 2016 eq. 9: sigma_a (per unit radius) for a hair color."""
    return _call("color_to_absorption", color, beta_n)

