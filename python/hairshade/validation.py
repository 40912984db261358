"""Validation of hairshade's models against Mitsuba 3, as printed by
``hairshade validate``: the numbers behind the README's tables."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ._progress import progress
from .chiang import ChiangHair

BETA_M = (0.2, 0.35, 0.5, 0.8)
BETA_N = (0.3, 0.5, 0.8)
ABSORPTIONS = {
    "melanin 1.3/0.2": dict(),
    "sigma_a 0": dict(sigma_a=[0.0, 0.0, 0.0]),
    "sigma_a (0.25,0.9,2.5)": dict(sigma_a=[0.25, 0.9, 2.5]),
}
TILTS = (0.0, 2.0, -6.0)


def direction_pairs(n_random: int = 500, seed: int | np.random.Generator = 12345) -> tuple[np.ndarray, np.ndarray]:
    """Uniform random pairs plus structured ones (theta up to +-89 degrees,
    delta-phi 0, pi and 0.7, wi at h = 0, +-0.5, +-0.999): n_random + 420
    pairs. ``seed`` is a seed or a Generator, which is drawn from
    in place (n_random wi, then n_random wo); the tests use
    this set too (tests/helpers.py)."""
    rng = np.random.default_rng(seed)  # a Generator passes through unchanged

    def sphere(n):
        v = rng.normal(size=(n, 3))
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    def ang(t, p):
        return np.array([np.cos(t) * np.cos(p), np.sin(t), np.cos(t) * np.sin(p)])

    th = np.deg2rad([-89.0, -60.0, -20.0, 0.0, 30.0, 75.0, 89.0])
    wi_s, wo_s = [], []
    for ti in th:
        for h in (0.0, 0.5, -0.5, 0.999, -0.999):
            phi_i = np.pi / 2 + np.arcsin(h)
            for to in th[::2]:
                for dphi in (0.0, np.pi, 0.7):
                    wi_s.append(ang(ti, phi_i))
                    wo_s.append(ang(to, phi_i + dphi))
    return np.concatenate([sphere(n_random), wi_s]), np.concatenate([sphere(n_random), wo_s])


def well_conditioned(wi: np.ndarray) -> np.ndarray:
    """Pairs whose fiber offset Mitsuba's float32 arithmetic resolves well:
    0.05 <= |h| <= 0.95 and |wi.xz| >= 0.1 (see tests/test_chiang_mitsuba.py)."""
    p = np.hypot(wi[:, 0], wi[:, 2])
    h = np.abs(wi[:, 0]) / p
    return (h >= 0.05) & (h <= 0.95) & (p >= 0.1)


def _max_rel(ours: np.ndarray, ref: np.ndarray, sel: np.ndarray | None = None) -> float:
    if ref.ndim == 1:
        ours, ref = ours[:, None], ref[:, None]
    if sel is not None:
        ours, ref = ours[sel], ref[sel]
    mask = ref > 1e-4 * ref.max(axis=0)
    return float((np.abs(ours - ref)[mask] / ref[mask]).max()) if mask.any() else 0.0


@dataclass
class BsdfRow:
    beta_m: float
    beta_n: float
    eval_all: float
    eval_cond: float
    pdf_all: float
    eval_exact_all: float


def chiang_vs_mitsuba(variant: str = "scalar_rgb", progress_bar: bool = True) -> tuple[list[BsdfRow], int, int]:
    """Max relative differences per (beta_m, beta_n), over absorptions x tilts.
    Returns (rows, parameter sets, direction pairs)."""
    from .mitsuba import MitsubaHair

    wi, wo = direction_pairs()
    cond = well_conditioned(wi)
    acc: dict[tuple[float, float], list[float]] = {}
    grid = list(itertools.product(BETA_M, BETA_N, ABSORPTIONS.values(), TILTS))
    for bm, bn, ab, tilt in progress(grid, desc="Chiang vs Mitsuba", enabled=progress_bar):
        kw = dict(longitudinal_roughness=bm, azimuthal_roughness=bn, scale_tilt=tilt, **ab)
        ours = ChiangHair(i0="mitsuba", **kw)
        ref_v, ref_p = MitsubaHair(ours, variant).eval_pdf(wi, wo)
        v, p = ours.eval(wi, wo), ours.pdf(wi, wo)
        e = ChiangHair(**kw).eval(wi, wo)
        r = [_max_rel(v, ref_v), _max_rel(v, ref_v, cond), _max_rel(p, ref_p), _max_rel(e, ref_v)]
        prev = acc.setdefault((bm, bn), [0.0] * 4)
        acc[(bm, bn)] = [max(a, b) for a, b in zip(prev, r)]
    rows = [BsdfRow(bm, bn, *vals) for (bm, bn), vals in acc.items()]
    return rows, len(grid), len(wi)


def white_furnace(variant: str | None = None, n_y: int = 384, n_phi: int = 768) -> list[tuple[float, float, float, float]]:
    """Albedo with sigma_a = 0 (ideal: 1) for hairshade exact, hairshade with
    Mitsuba's I0, and Mitsuba itself; worst channel over 4 incident directions.
    Rows: (beta, exact, mitsuba-I0, Mitsuba)."""
    from .mitsuba import MitsubaHair

    rng = np.random.default_rng(0)
    y = (np.arange(n_y)[:, None] + rng.random((n_y, n_phi))) / n_y * 2 - 1
    phi = (np.arange(n_phi)[None, :] + rng.random((n_y, n_phi))) / n_phi * 2 * np.pi
    r = np.sqrt(1 - y * y)
    d = np.stack([r * np.cos(phi), y, r * np.sin(phi)], -1).reshape(-1, 3)
    dw = 4 * np.pi / (n_y * n_phi)
    wis = np.array([[0.3, 0.2, 0.9], [-0.5, -0.6, 0.4], [0.1, 0.8, 0.2], [0.9, 0.0, 0.1]])
    rows = []
    for beta in (0.1, 0.2, 0.3, 0.5, 0.8):
        worst = []
        for model in (
            ChiangHair(sigma_a=0.0, longitudinal_roughness=beta, azimuthal_roughness=beta),
            ChiangHair(sigma_a=0.0, longitudinal_roughness=beta, azimuthal_roughness=beta, i0="mitsuba"),
        ):
            a = [model.eval(w, d).sum(axis=0) * dw for w in wis]
            worst.append(max(np.abs(np.array(a) - 1).max(axis=1)))
        mi = MitsubaHair(ChiangHair(sigma_a=0.0, longitudinal_roughness=beta, azimuthal_roughness=beta), variant)
        if mi.variant.startswith("scalar"):
            worst.append(float("nan"))  # too slow pair by pair; needs llvm_ad_rgb
        else:
            a = [mi.eval(np.broadcast_to(w / np.linalg.norm(w), d.shape), d).sum(axis=0) * dw for w in wis]
            worst.append(max(np.abs(np.array(a) - 1).max(axis=1)))
        rows.append((beta, *worst))
    return rows


def throughput(n: int = 1 << 20, repeats: int = 5, variant: str | None = None) -> dict[str, float]:
    """evals/s of ChiangHair.eval (f32, f64) and Mitsuba's hair eval on the
    same 2^20 random pairs, interleaved in one run; best of `repeats`.
    Mitsuba is called directly, numpy to numpy and data resident
    (:func:`hairshade.benchmark.mitsuba_cases`); each call follows a pause
    of ``benchmark.PAUSE_S``, so that none is timed while the threads of
    the call before it still spin."""
    from .benchmark import mitsuba_cases, timed

    rng = np.random.default_rng(1)
    v = rng.normal(size=(2, n, 3))
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    wi, wo = v
    wi32, wo32 = wi.astype(np.float32), wo.astype(np.float32)
    c = ChiangHair()
    cases = {
        "hairshade f32": lambda: c.eval(wi32, wo32),
        "hairshade f64": lambda: c.eval(wi, wo),
    }
    for var, path, fn in mitsuba_cases(c, wi, wo, variant):
        cases[f"Mitsuba {var} {path}"] = fn
    for f in cases.values():  # warm-up (JIT compilation, thread pools)
        f()
    best = {k: np.inf for k in cases}
    for _ in range(repeats):
        for k, f in cases.items():
            best[k] = min(best[k], timed(f))
    return {k: n / t for k, t in best.items()}
