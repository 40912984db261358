"""From the real-time material to the production path-tracing model:
ChiangHair parameters closest to a KarisHair / DEonHair material.

The starting point is analytic:

- ``longitudinal_roughness``: Chiang's ``sqrt(v_R) = 0.726 b + 0.812 b^2 + 3.7 b^20``
  set equal to the Karis width ``beta_R = r^2`` (d'Eon's ``v = beta^2``);
- ``azimuthal_roughness``: the logistic whose standard deviation
  ``s pi / sqrt(3)`` equals the TT detector width ``r^2 / 2``;
- ``scale_tilt``: the shift in degrees (UE and ChiangHair both lean R
  towards the root, -T and -y);
- ``sigma_a = -ln(C) / 4`` per channel, which is exactly UE's reference
  absorption ``mu_a`` (``T = exp(-2 mu_a cos(gamma_t) / cos(theta_t))`` in both).

``fit=True`` (default) then refines (roughnesses, tilt, an absorption scale)
by least squares (beta_n kept >= 0.1): ChiangHair's far field (R + TT + TRT, ``eval_far_lobes``)
against DEonHair's (converged) on a (theta_i, theta_o, phi) grid, residuals
normalized by the target's peak per channel.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._extras import require
from .chiang import ChiangHair, azimuthal_scale
from .deon import DEonHair
from .karis import KarisHair

optimize = require("scipy.optimize", "hairshade.mapping")


def _grid() -> tuple[np.ndarray, np.ndarray]:
    ti = np.deg2rad([-60.0, -30.0, 0.0, 30.0, 60.0])
    to = np.deg2rad(np.linspace(-80.0, 80.0, 9))
    # Midpoints in phi: DEonHair's R lobe narrows to a delta at phi = pi
    # (width ~ cos(phi/2), UE's reference), which would dominate the fit.
    ph = (np.arange(7) + 0.5) * np.pi / 7
    TI, TO, PH = np.meshgrid(ti, to, ph, indexing="ij")
    L = np.stack([np.cos(TI), np.sin(TI), np.zeros_like(TI)], -1).reshape(-1, 3)
    V = np.stack([np.cos(TO) * np.cos(PH), np.sin(TO), np.cos(TO) * np.sin(PH)], -1).reshape(-1, 3)
    return L, V


def _material(material: KarisHair | DEonHair) -> tuple[np.ndarray, float, float, float]:
    """(base colour, roughness, shift, eta); KarisHair has no eta of its own
    and takes human hair's 1.55."""
    p = material.params
    eta = float(p.get("eta", 1.55))
    return np.asarray(p["base_color"], dtype=np.float64), float(p["roughness"]), float(p["shift"]), eta


def initial_chiang_params(material: KarisHair | DEonHair) -> dict[str, Any]:
    """The analytic mapping (no fit)."""
    color, r, shift, eta = _material(material)
    r = min(max(r, 1 / 255), 1.0)
    beta_r = r * r
    f = lambda b: 0.726 * b + 0.812 * b * b + 3.7 * b**20 - beta_r  # noqa: E731
    beta_m = optimize.brentq(f, 1e-6, 1.0) if f(1.0) > 0 else 1.0
    s_target = 0.5 * beta_r * np.sqrt(3) / np.pi
    g = lambda b: azimuthal_scale(b) - s_target  # noqa: E731
    beta_n = optimize.brentq(g, 1e-6, 1.0) if g(1e-6) < 0 < g(1.0) else (1e-3 if g(1e-6) >= 0 else 1.0)
    sigma_a = -0.25 * np.log(np.clip(color, 1e-4, 1.0))
    return dict(
        sigma_a=[float(x) for x in sigma_a],
        longitudinal_roughness=float(np.clip(beta_m, 1e-3, 1.0)),
        azimuthal_roughness=float(np.clip(beta_n, 1e-3, 1.0)),
        scale_tilt=float(np.rad2deg(shift)),
        eta=eta,
    )


def chiang_params(material: KarisHair | DEonHair, fit: bool = True, max_nfev: int = 60) -> dict[str, Any]:
    """ChiangHair keyword arguments closest to ``material`` (see the module doc)."""
    init = initial_chiang_params(material)
    if not fit:
        return init
    color, r, shift, eta = _material(material)
    L, V = _grid()
    T = np.array([0.0, 1.0, 0.0])
    target = DEonHair(base_color=color, roughness=r, shift=shift, eta=eta).eval(L, V, T)
    scale = np.maximum(target.max(axis=0), 1e-12)
    sa0 = np.array(init["sigma_a"])

    def model(x: np.ndarray) -> ChiangHair:
        return ChiangHair(
            sigma_a=sa0 * np.exp(x[3]),
            longitudinal_roughness=x[0],
            azimuthal_roughness=x[1],
            scale_tilt=x[2],
            eta=eta,
        )

    def residual(x: np.ndarray) -> np.ndarray:
        lobes = model(x).eval_far_lobes(L, V)
        ours = lobes["R"] + lobes["TT"] + lobes["TRT"]
        return ((ours - target) / scale).ravel()

    x0 = np.array([init["longitudinal_roughness"], init["azimuthal_roughness"], init["scale_tilt"], 0.0])
    # beta_n >= 0.1: below it the far-field quadrature (and the fit) gets
    # expensive for a few percent of fit quality.
    lo = np.array([1e-3, 0.1, -15.0, -3.0])
    hi = np.array([1.0, 1.0, 15.0, 3.0])
    res = optimize.least_squares(residual, np.clip(x0, lo, hi), bounds=(lo, hi), max_nfev=max_nfev, diff_step=1e-3)
    x = res.x
    return dict(
        sigma_a=[float(v) for v in sa0 * np.exp(x[3])],
        longitudinal_roughness=float(x[0]),
        azimuthal_roughness=float(x[1]),
        scale_tilt=float(x[2]),
        eta=eta,
    )


def to_chiang(material: KarisHair | DEonHair, fit: bool = True) -> ChiangHair:
    """The ChiangHair closest to ``material``."""
    return ChiangHair(**chiang_params(material, fit=fit))
