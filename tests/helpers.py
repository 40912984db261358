"""Shared test helpers: direction sets, rotations, brute-force integrals."""

from __future__ import annotations

import numpy as np

U32 = 2.0**-24  # unit roundoff of float32


def uniform_sphere(n: int, rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def stratified_sphere(n_y: int, n_phi: int, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Jittered stratified directions, uniform in (y, phi) (y = sin theta is
    uniform for a uniform sphere). Returns (dirs, solid angle per sample)."""
    y = (np.arange(n_y)[:, None] + rng.random((n_y, n_phi))) / n_y * 2 - 1
    phi = (np.arange(n_phi)[None, :] + rng.random((n_y, n_phi))) / n_phi * 2 * np.pi
    r = np.sqrt(np.clip(1 - y * y, 0, None))
    d = np.stack([r * np.cos(phi), y, r * np.sin(phi)], -1).reshape(-1, 3)
    return d, 4 * np.pi / (n_y * n_phi)


def from_angles(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Hair frame: sin theta = y, phi = atan2(z, x)."""
    theta, phi = np.broadcast_arrays(theta, phi)
    return np.stack([np.cos(theta) * np.cos(phi), np.sin(theta), np.cos(theta) * np.sin(phi)], -1)


def rot_y(w: np.ndarray, psi: np.ndarray | float) -> np.ndarray:
    """Rotate w about the fiber tangent (y) by psi: adds psi to the azimuth."""
    c, s = np.cos(psi), np.sin(psi)
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    return np.stack([c * x - s * z, np.broadcast_to(y, np.shape(c * x)), s * x + c * z], -1)


def offset_h(wi: np.ndarray) -> np.ndarray:
    """h = sin(gamma_i) = -x / |xz| in Mitsuba's hair frame."""
    return -wi[..., 0] / np.hypot(wi[..., 0], wi[..., 2])


def direction_pairs(n_random: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Random pairs plus structured ones: theta on a grid up to +-89 degrees,
    delta-phi 0 and pi, and wi at h = 0, +-0.5, +-0.999."""
    wi_r, wo_r = uniform_sphere(n_random, rng), uniform_sphere(n_random, rng)
    th = np.deg2rad([-89.0, -60.0, -20.0, 0.0, 30.0, 75.0, 89.0])
    hs = np.array([0.0, 0.5, -0.5, 0.999, -0.999])
    wi_s, wo_s = [], []
    for ti in th:
        for h in hs:
            phi_i = np.pi / 2 + np.arcsin(h)  # puts wi at offset h (see rot_y)
            wi = from_angles(np.array(ti), np.array(phi_i))
            wi = wi * np.array([1.0, 1.0, 1.0])
            for to in th[::2]:
                for dphi in (0.0, np.pi, 0.7):
                    wi_s.append(wi)
                    wo_s.append(from_angles(np.array(to), np.array(phi_i + dphi)))
    return np.concatenate([wi_r, np.array(wi_s)]), np.concatenate([wo_r, np.array(wo_s)])
