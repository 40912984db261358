"""Per-lobe error tables of KarisHair against its reference DEonHair, and
against ChiangHair's far field with mapped parameters (``hairshade tables``).

Grid: theta_i in {-75, -50, -25, 0, 25, 50, 75} deg, theta_o in 11 steps
over [-85, 85] deg, phi at 13 midpoints of [0, pi] (phi = pi itself is
avoided: DEonHair's R width goes to 0 there, a delta); tangent +y.
Materials: 4 roughnesses x 4 base colors, default shift 0.035, specular 0.5
(R scale 1), backlit 1, no MS.

Per lobe and material:
- rel_l2: sqrt(sum (K - D)^2 / sum D^2) over grid and channels;
- rel_l2_core: the same over |theta_i|, |theta_o| <= 50 deg, away from the
  grazing angles where the Gaussian M_p departs most from d'Eon's;
- max_err: max |K - D| / max |D| (peak-normalized), with where it occurs.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import numpy as np

from ._progress import progress
from .deon import DEonHair
from .karis import KarisHair

ROUGHNESS = (0.25, 0.4, 0.6, 0.8)
COLORS = {
    "black": (0.05, 0.03, 0.02),
    "brown": (0.3, 0.15, 0.08),
    "auburn": (0.55, 0.25, 0.12),
    "blonde": (0.85, 0.7, 0.5),
}
LOBES = ("R", "TT", "TRT", "sum")


def grid() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(L, V, T, angles) with angles (theta_i, theta_o, phi) in degrees per pair."""
    ti = np.deg2rad(np.array([-75.0, -50.0, -25.0, 0.0, 25.0, 50.0, 75.0]))
    to = np.deg2rad(np.linspace(-85.0, 85.0, 11))
    ph = (np.arange(13) + 0.5) * np.pi / 13
    TI, TO, PH = np.meshgrid(ti, to, ph, indexing="ij")
    L = np.stack([np.cos(TI), np.sin(TI), np.zeros_like(TI)], -1).reshape(-1, 3)
    V = np.stack([np.cos(TO) * np.cos(PH), np.sin(TO), np.cos(TO) * np.sin(PH)], -1).reshape(-1, 3)
    ang = np.rad2deg(np.stack([TI, TO, PH], -1).reshape(-1, 3))
    return L, V, np.array([0.0, 1.0, 0.0]), ang


@dataclass
class Row:
    roughness: float
    color: str
    lobe: str
    rel_l2: float
    rel_l2_core: float
    max_err: float
    at_theta_i: float
    at_theta_o: float
    at_phi: float


def _rel_l2(approx: np.ndarray, ref: np.ndarray) -> float:
    den = np.sqrt((ref**2).sum())
    return float(np.sqrt(((approx - ref) ** 2).sum()) / den) if den > 0 else 0.0


def _compare(approx: np.ndarray, ref: np.ndarray, ang: np.ndarray) -> tuple[float, float, float, np.ndarray]:
    core = (np.abs(ang[:, 0]) <= 50) & (np.abs(ang[:, 1]) <= 50)
    peak = np.abs(ref).max()
    err = np.abs(approx - ref).max(axis=1)
    i = int(err.argmax())
    return _rel_l2(approx, ref), _rel_l2(approx[core], ref[core]), float(err[i] / peak) if peak > 0 else 0.0, ang[i]


def _rows(r: float, name: str, approx: dict[str, np.ndarray], ref: dict[str, np.ndarray], ang) -> list[Row]:
    out = []
    for lobe in LOBES:
        a = approx[lobe] if lobe != "sum" else approx["R"] + approx["TT"] + approx["TRT"]
        b = ref[lobe] if lobe != "sum" else ref["R"] + ref["TT"] + ref["TRT"]
        l2, core, mx, where = _compare(a, b, ang)
        out.append(Row(r, name, lobe, l2, core, mx, *map(float, where)))
    return out


def karis_vs_deon(progress_bar: bool = True) -> list[Row]:
    L, V, T, ang = grid()
    rows: list[Row] = []
    cases = [(r, name) for r in ROUGHNESS for name in COLORS]
    for r, name in progress(cases, desc="KarisHair vs DEonHair", enabled=progress_bar):
        c = COLORS[name]
        k = KarisHair(base_color=c, roughness=r, components=("R", "TT", "TRT")).eval_lobes(L, V, T)
        d = DEonHair(base_color=c, roughness=r).eval_lobes(L, V, T)
        rows += _rows(r, name, k, d, ang)
    return rows


def karis_vs_chiang(progress_bar: bool = True, fit: bool = True) -> tuple[list[Row], dict[str, dict]]:
    """KarisHair against ChiangHair's far field (R, TT, TRT) with parameters
    from :func:`hairshade.mapping.chiang_params`. Returns (rows, params)."""
    from .mapping import chiang_params

    from .chiang import ChiangHair

    L, V, T, ang = grid()
    rows: list[Row] = []
    params: dict[str, dict] = {}
    cases = [(r, name) for r in ROUGHNESS for name in COLORS]
    for r, name in progress(cases, desc="KarisHair vs ChiangHair", enabled=progress_bar):
        c = COLORS[name]
        k = KarisHair(base_color=c, roughness=r, components=("R", "TT", "TRT"))
        p = chiang_params(k, fit=fit)
        params[f"{name} r={r}"] = p
        ch = ChiangHair(**p).eval_far_lobes(L, V)
        rows += _rows(r, name, k.eval_lobes(L, V, T), ch, ang)
    return rows, params


def summary(rows: list[Row]) -> list[tuple[str, float, float, float, float, float]]:
    """Per lobe: (lobe, median rel_l2, worst rel_l2, median rel_l2_core,
    worst rel_l2_core, worst max_err) over the materials."""
    out = []
    for lobe in LOBES:
        sel = [x for x in rows if x.lobe == lobe]
        l2 = np.array([x.rel_l2 for x in sel])
        core = np.array([x.rel_l2_core for x in sel])
        mx = np.array([x.max_err for x in sel])
        out.append((lobe, float(np.median(l2)), float(l2.max()), float(np.median(core)), float(core.max()), float(mx.max())))
    return out


def markdown(rows: list[Row], title: str) -> str:
    lines = [f"## {title}", ""]
    lines += summary_markdown(rows)
    lines += ["", "| roughness | color | lobe | rel L2 | rel L2 (|θ| ≤ 50°) | max err | at (θi, θo, φ) deg |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for x in rows:
        lines.append(
            f"| {x.roughness:.2f} | {x.color} | {x.lobe} | {x.rel_l2:.3f} | {x.rel_l2_core:.3f} | {x.max_err:.3f} |"
            f" ({x.at_theta_i:.0f}, {x.at_theta_o:.0f}, {x.at_phi:.0f}) |"
        )
    return "\n".join(lines) + "\n"


def summary_markdown(rows: list[Row]) -> list[str]:
    lines = [
        "| lobe | median rel L2 | worst rel L2 | median rel L2, \\|θ\\| ≤ 50° | worst, \\|θ\\| ≤ 50° | worst max err |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for lobe, a, b, c, d, e in summary(rows):
        lines.append(f"| {lobe} | {a:.3f} | {b:.3f} | {c:.3f} | {d:.3f} | {e:.3f} |")
    return lines


def write(path_md: str, path_json: str, deon_rows: list[Row], chiang_rows: list[Row] | None, chiang_params: dict | None) -> None:
    text = ["# KarisHair error tables", "", "Generated by `hairshade tables`; see `python/hairshade/tables.py` for the grid and the", "error definitions (rel L2 over the grid, max error normalized by the reference's peak).", ""]
    text.append(markdown(deon_rows, "KarisHair vs DEonHair (UE4 HairShadingRef, converged)"))
    if chiang_rows is not None:
        text.append(markdown(chiang_rows, "KarisHair vs ChiangHair far field (mapped parameters)"))
    with open(path_md, "w") as f:
        f.write("\n".join(text))
    data = {"karis_vs_deon": [asdict(x) for x in deon_rows]}
    if chiang_rows is not None:
        data["karis_vs_chiang"] = [asdict(x) for x in chiang_rows]
        data["chiang_params"] = chiang_params
    with open(path_json, "w") as f:
        json.dump(data, f, indent=1)


def fit_quality() -> dict[str, float]:
    """The slides' fit claims, re-measured (f64, dense grids):

    - eta_prime_max_rel_err: max |fit/exact - 1| of eta' for eta = 1.55 over
      theta_d in [0, 89.9] deg; eta_prime_ok_up_to_deg: largest theta_d such
      that the error stays below the claimed 0.68% on [0, theta_d];
    - int_N_R_fit, int_D_TT_fit, int_D_TRT_fit: integrals over phi in
      [-pi, pi] of 1/4 cos(phi/2), exp(-3.65 cos phi - 3.98), exp(17 cos phi - 16.78);
      int_D_TT, int_D_TRT: the same for the logistic forms they replace,
      D(phi, 0.35, pi) and 3/4 D(phi, 0.15, 0);
    - int_M_gauss_beta_<b>: integral of the Gaussian M_p over sin(theta_o) in
      [-1, 1] at theta_i = 0, alpha = 0 (mass lost to truncation).
    """
    from . import lobes

    out: dict[str, float] = {}
    td = np.deg2rad(np.linspace(0.0, 89.9, 20001))
    c = np.cos(td)
    err = np.abs(lobes.eta_prime_fit(c) / lobes.eta_prime(1.55, c) - 1)
    out["eta_prime_max_rel_err"] = float(err.max())
    bad = np.nonzero(err >= 0.0068)[0]
    out["eta_prime_ok_up_to_deg"] = float(np.rad2deg(td[bad[0] - 1])) if bad.size else 89.9
    # Composite Gauss-Legendre over [-pi, pi] (smooth periodic integrands).
    x, w = np.polynomial.legendre.leggauss(64)
    edges = np.linspace(-np.pi, np.pi, 65)
    a, b = edges[:-1, None], edges[1:, None]
    phi = (0.5 * (a + b) + 0.5 * (b - a) * x).ravel()
    wt = (0.5 * (b - a) * w).ravel()
    out["int_N_R_fit"] = float((wt * 0.25 * np.cos(phi / 2)).sum())
    out["int_D_TT_fit"] = float((wt * lobes.d_tt_fit(np.cos(phi))).sum())
    out["int_D_TT"] = float((wt * lobes.d_tt(np.abs(phi))).sum())
    out["int_D_TRT_fit"] = float((wt * lobes.d_trt_fit(np.cos(phi))).sum())
    out["int_D_TRT"] = float((wt * lobes.d_trt(np.abs(phi))).sum())
    # sin(theta_o) over [-1, 1]: the same composite rule, scaled.
    s = phi / np.pi
    ws = wt / np.pi
    for beta in (0.05, 0.25, 0.5, 1.0, 2.0):
        out[f"int_M_gauss_beta_{beta}"] = float((ws * lobes.gaussian_mp(beta, s)).sum())
    return out


def deon_sampling_error(h_samples: int = 16, progress_bar: bool = False) -> dict[str, float]:
    """Relative L2 error of DEonHair's UE-style stratified estimate with
    ``h_samples`` offsets against the converged quadrature, on the table grid
    (brown, roughness 0.25 / 0.6), per lobe (worst of the two roughnesses)."""
    L, V, T, _ = grid()
    out = {lobe: 0.0 for lobe in ("R", "TT", "TRT")}
    for r in progress((0.25, 0.6), desc=f"DEonHair h_samples={h_samples}", enabled=progress_bar):
        ref = DEonHair(base_color=COLORS["brown"], roughness=r).eval_lobes(L, V, T)
        est = DEonHair(base_color=COLORS["brown"], roughness=r, h_samples=h_samples).eval_lobes(L, V, T)
        for lobe in out:
            out[lobe] = max(out[lobe], _rel_l2(est[lobe], ref[lobe]))
    return out
