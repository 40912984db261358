"""Shared test helpers: direction sets, rotations, brute-force integrals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import hairshade as hs

# The Mitsuba comparison set, shared with `hairshade validate`:
# direction_pairs(n_random, rng) draws from rng in place (a Generator passes
# through np.random.default_rng unchanged), as the copy that lived here did.
from hairshade.validation import direction_pairs  # noqa: F401

U32 = 2.0**-24  # unit roundoff of float32
# The folder holding the hairshade package these tests import: the
# PYTHONPATH of the child processes they start.
PYTHON_DIR = str(Path(hs.__file__).resolve().parent.parent)


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


def edge_grid() -> tuple[np.ndarray, np.ndarray]:
    """(L, V) for the far-field models' robustness tests: theta in {-90, -45,
    0, 45, 90} for both, phi in {0, pi/2, pi}, plus 50 random pairs with
    V = L and 50 with V = -L."""
    th = np.deg2rad([-90.0, -45.0, 0.0, 45.0, 90.0])
    ph = np.array([0.0, np.pi / 2, np.pi])
    TI, TO, PH = np.meshgrid(th, th, ph, indexing="ij")
    L = from_angles(TI, 0 * TI).reshape(-1, 3)
    V = from_angles(TO, PH).reshape(-1, 3)
    extra = uniform_sphere(50, np.random.default_rng(0))
    return np.concatenate([L, extra, extra]), np.concatenate([V, extra, -extra])


def rot_y(w: np.ndarray, psi: np.ndarray | float) -> np.ndarray:
    """Rotate w about the fiber tangent (y) by psi: adds psi to the azimuth."""
    c, s = np.cos(psi), np.sin(psi)
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    return np.stack([c * x - s * z, np.broadcast_to(y, np.shape(c * x)), s * x + c * z], -1)


def offset_h(wi: np.ndarray) -> np.ndarray:
    """h = sin(gamma_i) = -x / |xz| in Mitsuba's hair frame."""
    return -wi[..., 0] / np.hypot(wi[..., 0], wi[..., 2])


def pinhole_rays(camera: dict, xs: np.ndarray, ys: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The eye and the unit directions of a scene camera's rays through
    image points (xs, ys) in pixels (y down), as the renderer's pinhole
    (vertical fov, up = +y): the reference the exact tests trace."""
    eye = np.asarray(camera["position"], float)
    fwd = np.asarray(camera["target"], float) - eye
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    th = np.tan(np.radians(camera["fov"]) / 2)
    d = (fwd + right * ((2 * xs / width - 1) * th * width / height)[..., None]
         + up * ((1 - 2 * ys / height) * th)[..., None])
    return eye, d / np.linalg.norm(d, axis=-1, keepdims=True)


def write_scene(folder: Path, hair: dict | None = None, name: str = "s.json", **top) -> Path:
    """A minimal scene file in `folder` (camera at z = 3 looking at the origin)."""
    d = {"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "resolution": [32, 18]},
         "hair": hair if hair is not None else {}, **top}
    p = folder / name
    p.write_text(json.dumps(d))
    return p
