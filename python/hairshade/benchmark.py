"""Run time against error for the BSDF models (``hairshade bench``).

Every row: a model variant, its precision and thread count, evaluations per
second (best of ``repeats``, all rows measured in one run, interleaved per
repeat), and its error: relative L2 over the error-table grid
(:func:`hairshade.tables.grid`, brown hair, roughness 0.4) against the
model's converged f64 reference:

- KarisHair (all lobes and each lobe alone) against DEonHair converged
  (the approximation error);
- DEonHair with ``h_samples`` in {4, 8, 16, 32, 64} against its converged
  quadrature;
- ChiangHair near and far field against their own f64 evaluation (the f32
  rounding; f64 rows have error 0 by definition); its far-field table
  (``eval_far(fast=True)``) against the converged f64 far field;
- Mitsuba's ``hair`` against ChiangHair's f64 near field with Mitsuba's I0
  (float32 arithmetic; the exact-I0 difference is reported by
  ``hairshade validate``), timed the fastest honest ways, each calling
  Mitsuba's ``BSDF.eval`` directly (see :func:`mitsuba_cases`): "numpy to
  numpy" (contiguous float32 columns into drjit, the result back into
  numpy) and "data resident" (inputs already in drjit arrays; the timer stops
  after ``dr.eval`` and ``dr.sync_thread``), with ``llvm_ad_rgb`` (JIT, SIMD,
  all cores) and, where a GPU is present, ``cuda_ad_rgb``.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from . import _native
from ._progress import progress
from .chiang import ChiangHair
from .deon import DEonHair
from .karis import KarisHair
from .tables import COLORS, grid

ROUGHNESS = 0.4
# Seconds between timed calls. drjit's worker threads keep spinning for a
# while after a Mitsuba call; a call timed right after one shares the cores
# with them (measured: hairshade's ChiangHair at 102 M pairs/s right after
# Mitsuba's call, 184 M/s after a 20 ms pause, in one run). The pause lets
# every library's threads go idle before the next case.
PAUSE_S = 0.02


def timed(fn: Callable[[], Any]) -> float:
    """Seconds one call of ``fn`` takes, after a pause of ``PAUSE_S``."""
    time.sleep(PAUSE_S)
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _rel_l2(a: np.ndarray, ref: np.ndarray) -> float:
    den = np.sqrt((ref**2).sum())
    return float(np.sqrt(((a - ref) ** 2).sum()) / den) if den > 0 else 0.0


def _random_pairs(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(2, n, 3))
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    return v[0], v[1]


def bsdf_runtime_vs_error(n: int = 1 << 20, repeats: int = 3, fast: bool = False, variant: str | None = None,
                          progress_bar: bool = True) -> list[dict[str, Any]]:
    """Rows of (model, variant, precision, threads, evals_per_s, rel_l2_error)."""
    L, V, T, _ = grid()
    color = COLORS["brown"]
    deon_ref = DEonHair(base_color=color, roughness=ROUGHNESS).eval_lobes(L, V, T)
    deon_sum = deon_ref["R"] + deon_ref["TT"] + deon_ref["TRT"]
    wi, wo = _random_pairs(n)
    T1 = np.array([0.0, 1.0, 0.0])
    n_slow = max(256, n >> 8)  # DEonHair is ~1000x slower: fewer pairs, same rate estimate
    wi_s, wo_s = wi[:n_slow], wo[:n_slow]
    cases: list[tuple[dict[str, Any], Callable[[], Any], int, float]] = []

    def add(model: str, var: str, precision: str, fn: Callable[[], Any], count: int, err: float) -> None:
        cases.append((dict(model=model, variant=var, precision=precision), fn, count, err))

    for prec, dt in (("f32", np.float32), ("f64", np.float64)):
        a, b, t = wi.astype(dt), wo.astype(dt), T1.astype(dt)
        for lobes in (("R", "TT", "TRT"), ("R",), ("TT",), ("TRT",)):
            k = KarisHair(base_color=color, roughness=ROUGHNESS, components=lobes)
            ref = sum(deon_ref[x] for x in lobes)
            err = _rel_l2(k.eval(L.astype(dt), V.astype(dt), T.astype(dt)).astype(np.float64), ref)
            add("KarisHair", "+".join(lobes), prec, lambda k=k, a=a, b=b, t=t: k.eval(a, b, t), n, err)
        kms = KarisHair(base_color=color, roughness=ROUGHNESS, scatter=0.3)
        add("KarisHair", "R+TT+TRT+MS", prec, lambda k=kms, a=a, b=b, t=t: k.eval(a, b, t), n, float("nan"))
        c = ChiangHair(longitudinal_roughness=0.3, azimuthal_roughness=0.3)
        c_ref = c.eval(L, V)
        add("ChiangHair", "near field", prec, lambda c=c, a=a, b=b: c.eval(a, b), n,
            _rel_l2(c.eval(L.astype(dt), V.astype(dt)).astype(np.float64), c_ref))
        cf_ref = c.eval_far(L, V)
        m = max(256, n >> 6)
        add("ChiangHair", "far field", prec, lambda c=c, a=a[:m], b=b[:m]: c.eval_far(a, b), m,
            _rel_l2(c.eval_far(L.astype(dt), V.astype(dt)).astype(np.float64), cf_ref))
        # the table of eval_far(fast=True) (what the renderer shades with), built before timing
        add("ChiangHair", "far field table", prec, lambda c=c, a=a, b=b: c.eval_far(a, b, fast=True), n,
            _rel_l2(c.eval_far(L.astype(dt), V.astype(dt), fast=True).astype(np.float64), cf_ref))
    if not fast:
        for hs_n in (4, 8, 16, 32, 64, None):
            d = DEonHair(base_color=color, roughness=ROUGHNESS, h_samples=hs_n)
            err = 0.0 if hs_n is None else _rel_l2(sum(d.eval_lobes(L, V, T).values()), deon_sum)
            add("DEonHair", "converged" if hs_n is None else f"h_samples={hs_n}", "f64",
                lambda d=d: d.eval(wi_s, wo_s, T1), n_slow, err)
    cm = ChiangHair(longitudinal_roughness=0.3, azimuthal_roughness=0.3, i0="mitsuba")
    for var, path, fn in mitsuba_cases(cm, wi, wo, variant):
        add("Mitsuba hair", f"{var} {path}", "f32", fn, n, mitsuba_error(cm, var, L, V))

    rows: list[dict[str, Any]] = []
    for threads in ("all", "1"):
        _native.set_single_threaded(threads == "1")
        try:
            # Mitsuba's own thread pool is not ours to limit: its rows run in the all-threads pass only
            run = [threads == "all" or meta["model"] != "Mitsuba hair" for meta, _, _, _ in cases]
            for (_, fn, _, _), on in zip(cases, run):  # warm-up (JIT compilation, thread pools)
                if on:
                    fn()
            best = [np.inf] * len(cases)
            for _ in progress(range(repeats), desc=f"bench ({threads} threads)", enabled=progress_bar):
                for i, (_, fn, _, _) in enumerate(cases):
                    if not run[i]:
                        continue
                    best[i] = min(best[i], timed(fn))
        finally:
            _native.set_single_threaded(False)
        for (meta, _, count, err), t in zip(cases, best):
            if meta["model"] == "Mitsuba hair" and threads == "1":
                continue
            rows.append(dict(**meta, threads=threads if meta["model"] != "Mitsuba hair" else "mitsuba",
                             evals_per_s=count / t, rel_l2_error=err))
    return rows


MITSUBA_PATHS = ("numpy to numpy", "data resident")


def mitsuba_cases(model: ChiangHair, wi: np.ndarray, wo: np.ndarray,
                  variant: str | None = None) -> list[tuple[str, str, Callable[[], Any]]]:
    """(variant, path, timed call) of Mitsuba's own ``hair.eval`` on the
    pairs (wi, wo), for ``llvm_ad_rgb`` (or ``variant``) and ``cuda_ad_rgb``
    when a GPU is present (skipped otherwise):

    - "numpy to numpy": the float32 columns of wi and wo (contiguous, made
      before timing) into drjit ``Vector3f``, ``eval``, and the (3, N)
      result back into numpy;
    - "data resident": wi and wo already in drjit arrays (evaluated before
      timing); ``eval`` then ``dr.eval`` and ``dr.sync_thread`` so the
      kernel has run when the timer stops.
    """
    from .mitsuba import default_variant, hair_dict

    import drjit as dr
    import mitsuba as mi

    variants = [variant or default_variant()]
    if "cuda_ad_rgb" in mi.variants() and "cuda_ad_rgb" not in variants:
        try:
            mi.set_variant("cuda_ad_rgb")
            dr.eval(mi.Float(1.0))  # raises without a usable GPU
            variants.append("cuda_ad_rgb")
        except Exception:  # no GPU or no CUDA driver: no cuda rows
            pass
    cols = [np.ascontiguousarray(a[:, k], dtype=np.float32) for a in (wi, wo) for k in range(3)]
    cases: list[tuple[str, str, Callable[[], Any]]] = []
    for var in variants:
        if var.startswith("scalar"):
            continue  # a Python loop per pair: not a batch evaluation
        mi.set_variant(var)
        bsdf = mi.load_dict(hair_dict(model))
        ctx = mi.BSDFContext()

        def numpy_to_numpy(var: str = var, bsdf: Any = bsdf, ctx: Any = ctx) -> np.ndarray:
            mi.set_variant(var)
            si = dr.zeros(mi.SurfaceInteraction3f, len(cols[0]))
            si.wi = mi.Vector3f(cols[0], cols[1], cols[2])
            return np.array(bsdf.eval(ctx, si, mi.Vector3f(cols[3], cols[4], cols[5])))

        si = dr.zeros(mi.SurfaceInteraction3f, len(cols[0]))
        si.wi = mi.Vector3f(cols[0], cols[1], cols[2])
        wo_dr = mi.Vector3f(cols[3], cols[4], cols[5])
        dr.eval(si, wo_dr)
        dr.sync_thread()

        def resident(var: str = var, bsdf: Any = bsdf, ctx: Any = ctx, si: Any = si, wo_dr: Any = wo_dr) -> Any:
            mi.set_variant(var)
            v = bsdf.eval(ctx, si, wo_dr)
            dr.eval(v)
            dr.sync_thread()
            return v

        cases += [(var, MITSUBA_PATHS[0], numpy_to_numpy), (var, MITSUBA_PATHS[1], resident)]
    return cases


def mitsuba_error(model: ChiangHair, variant: str, L: np.ndarray, V: np.ndarray) -> float:
    """Relative L2 of Mitsuba's ``hair`` (``variant``) against ``model`` in f64 on (L, V)."""
    from .mitsuba import MitsubaHair

    return _rel_l2(MitsubaHair(model, variant).eval(L, V), model.eval(L, V))


def pareto(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows not dominated in (speed up, error down), among those with an error."""
    pts = [r for r in rows if np.isfinite(r["rel_l2_error"])]
    return [r for r in pts if not any(
        (o["evals_per_s"] >= r["evals_per_s"] and o["rel_l2_error"] <= r["rel_l2_error"])
        and (o["evals_per_s"] > r["evals_per_s"] or o["rel_l2_error"] < r["rel_l2_error"]) for o in pts)]


def write_csv(rows: list[dict[str, Any]], path: str) -> None:
    keys = ["model", "variant", "precision", "threads", "evals_per_s", "rel_l2_error"]
    with open(path, "w") as f:
        f.write(",".join(keys) + "\n")
        for r in rows:
            f.write(",".join(str(r[k]) if not isinstance(r[k], float) else f"{r[k]:.6g}" for k in keys) + "\n")


MARKERS = {"KarisHair": "o", "ChiangHair": "s", "DEonHair": "D", "Mitsuba hair": "^"}


def plot(rows: list[dict[str, Any]], path: str, dpi: int = 130) -> None:
    """Evaluations per second against error: one colour per (model,
    variant, precision) in order of appearance (matplotlib's 20-colour
    table, then tab20b), a shape per model, filled on all threads (or
    Mitsuba's) and hollow on one; a legend beside the axes names each
    colour (no labels on the points, so none overlap); the Pareto front."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, ax = plt.subplots(figsize=(11, 5.5))
    floor = 1e-9  # errors of exactly 0 (f64 references) drawn at the floor
    colors = list(plt.get_cmap("tab20").colors) + list(plt.get_cmap("tab20b").colors)
    keys: dict[tuple[str, str, str], int] = {}
    for r in rows:
        if not np.isfinite(r["rel_l2_error"]):
            continue
        key = (r["model"], r["variant"], r["precision"])
        first = key not in keys
        c = colors[keys.setdefault(key, len(keys)) % len(colors)]
        hollow = r["threads"] == "1"
        ax.scatter(r["evals_per_s"], max(r["rel_l2_error"], floor), marker=MARKERS.get(r["model"], "v"), s=30,
                   facecolors="none" if hollow else [c], edgecolors=[c] if hollow else "none",
                   label=" ".join(key) if first else None)
    front = sorted(pareto(rows), key=lambda r: r["evals_per_s"])
    ax.plot([r["evals_per_s"] for r in front], [max(r["rel_l2_error"], floor) for r in front], "k--", lw=0.8,
            label="Pareto front")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("evaluations per second")
    ax.set_ylabel(f"relative L2 error vs converged f64 reference (0 drawn at {floor:g})")
    ax.grid(True, which="major", lw=0.3, alpha=0.5)
    handles, labels = ax.get_legend_handles_labels()
    for text, fill in (("filled: all threads (Mitsuba: its own)", "grey"), ("hollow: 1 thread", "none")):
        handles.append(Line2D([], [], ls="", marker="o", markerfacecolor=fill, markeredgecolor="grey"))
        labels.append(text)
    ax.legend(handles, labels, fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
