"""Writes notebooks/lobes.ipynb, notebooks/runtime_vs_error.ipynb and
notebooks/presets.ipynb from the cells below (the notebooks are committed;
edit here and rerun to change them). With --execute they are run first
(nbclient, in notebooks/) and committed with their outputs, figures as small
PNGs (50 dpi). --only NAME writes that notebook alone.

    python scripts/make_notebooks.py --execute [--only presets]
"""

import sys

import nbformat as nbf

cells = []
md = lambda s: cells.append(nbf.v4.new_markdown_cell(s))  # noqa: E731
code = lambda s: cells.append(nbf.v4.new_code_cell(s))  # noqa: E731

md("""# Hair lobes: Karis's real-time model against its reference

`KarisHair` is UE4's `HairShading()` (Karis 2016); `DEonHair` is UE4's
`HairShadingRef()` with the same artist parameters (d'Eon 2011 M_p, N_p
integrated over the fiber offset h). This notebook plots both, lobe by lobe,
shows where and how much they differ, and what each artist parameter does.
Tangent T = +y; L at azimuth 0, V at azimuth φ; angles in degrees.""")

code("""import numpy as np
import matplotlib.pyplot as plt
import hairshade as hs
from hairshade import lobes, mapping

plt.rcParams["figure.dpi"] = 50  # small PNG outputs in the committed notebook

T = np.array([0.0, 1.0, 0.0])

def direction(theta_deg, phi=0.0):
    t, p = np.broadcast_arrays(np.deg2rad(theta_deg), phi)
    return np.stack([np.cos(t) * np.cos(p), np.sin(t), np.cos(t) * np.sin(p)], -1)

brown = (0.3, 0.15, 0.08)
karis = hs.KarisHair(base_color=brown, roughness=0.4, components=("R", "TT", "TRT"))
deon = hs.DEonHair(base_color=brown, roughness=0.4)""")

md("## Polar plots on the specular cone (θo = −θi), per lobe")
code("""theta_i = 30.0
phi = np.linspace(-np.pi, np.pi, 361)
L = direction(theta_i)
V = direction(-theta_i, phi)
k, d = karis.eval_lobes(L, V, T), deon.eval_lobes(L, V, T)
fig, axes = plt.subplots(1, 3, subplot_kw={"projection": "polar"}, figsize=(12, 4))
for ax, lobe in zip(axes, ("R", "TT", "TRT")):
    ax.plot(phi, d[lobe][:, 0], label="DEonHair (reference)")
    ax.plot(phi, k[lobe][:, 0], "--", label="KarisHair")
    ax.set_title(lobe)
axes[0].legend(loc="lower left", fontsize=8)
plt.tight_layout()""")

md("## (θo, φ) maps of the sum, and the error heat map")
code("""to = np.linspace(-89, 89, 90)
ph = np.linspace(0, np.pi, 91)
TO, PH = np.meshgrid(to, ph, indexing="ij")
V = direction(TO, PH).reshape(-1, 3)
L = direction(theta_i)
ks = karis.eval(L, V, T)[:, 0].reshape(TO.shape)
ds = deon.eval(L, V, T)[:, 0].reshape(TO.shape)
fig, axes = plt.subplots(1, 3, figsize=(14, 4))
for ax, img, title in zip(axes, (ds, ks, (ks - ds) / ds.max()), ("DEonHair", "KarisHair", "(Karis - DEon) / max DEon")):
    im = ax.imshow(img, origin="lower", aspect="auto", extent=(0, 180, -89, 89),
                   cmap="RdBu_r" if "-" in title else "magma",
                   vmin=-np.abs(img).max() if "-" in title else None, vmax=np.abs(img).max() if "-" in title else None)
    ax.set_xlabel("φ (deg)"); ax.set_ylabel("θo (deg)"); ax.set_title(title)
    fig.colorbar(im, ax=ax)
plt.tight_layout()""")

md("Error per lobe over the same map (red channel), normalized by each lobe's reference peak:")
code("""kl, dl = karis.eval_lobes(L, V, T), deon.eval_lobes(L, V, T)
fig, axes = plt.subplots(1, 3, figsize=(14, 4))
for ax, lobe in zip(axes, ("R", "TT", "TRT")):
    err = (kl[lobe][:, 0] - dl[lobe][:, 0]).reshape(TO.shape) / dl[lobe][:, 0].max()
    m = np.abs(err).max()
    im = ax.imshow(err, origin="lower", aspect="auto", extent=(0, 180, -89, 89), cmap="RdBu_r", vmin=-m, vmax=m)
    ax.set_title(f"{lobe}: rel. L2 {np.linalg.norm(kl[lobe] - dl[lobe]) / np.linalg.norm(dl[lobe]):.2f}")
    ax.set_xlabel("φ (deg)"); ax.set_ylabel("θo (deg)")
    fig.colorbar(im, ax=ax)
plt.tight_layout()""")

md("## The fits inside KarisHair")
code("""fig, axes = plt.subplots(1, 4, figsize=(17, 3.6))
td = np.linspace(0, 89.9, 500); c = np.cos(np.deg2rad(td))
axes[0].plot(td, 100 * (lobes.eta_prime_fit(c) / lobes.eta_prime(1.55, c) - 1))
axes[0].axhline(0.68, ls=":", c="k"); axes[0].axhline(-0.68, ls=":", c="k")
axes[0].set_title("η' fit error (%)"); axes[0].set_xlabel("θd (deg)")
p = np.linspace(0, np.pi, 400)
for a in (0.55, 0.65, 0.75):
    axes[1].plot(np.rad2deg(p), lobes.h_tt(np.cos(p), a), label=f"exact a={a}")
    axes[1].plot(np.rad2deg(p), lobes.h_tt_fit(np.cos(p), a), "--")
axes[1].set_title("h_TT: exact (solid), fit (dashed)"); axes[1].set_xlabel("φ"); axes[1].set_ylim(0, 1.2); axes[1].legend(fontsize=7)
axes[2].plot(np.rad2deg(p), lobes.d_tt(p), label="D(φ, 0.35, π)"); axes[2].plot(np.rad2deg(p), lobes.d_tt_fit(np.cos(p)), "--", label="fit")
axes[2].set_title("D_TT"); axes[2].legend(fontsize=7)
axes[3].plot(np.rad2deg(p), lobes.d_trt(p), label="¾ D(φ, 0.15, 0)"); axes[3].plot(np.rad2deg(p), lobes.d_trt_fit(np.cos(p)), "--", label="fit")
axes[3].set_title("D_TRT"); axes[3].legend(fontsize=7)
plt.tight_layout()""")

md("Gaussian M_p against d'Eon's as the width grows (θi = 20°, α = 0):")
code("""so = np.linspace(-1, 1, 801); si = np.sin(np.deg2rad(20))
fig, ax = plt.subplots(figsize=(6, 3.6))
for beta in (0.1, 0.3, 0.6):
    line, = ax.plot(so, lobes.deon_mp(si, so, beta**2), label=f"d'Eon β={beta}")
    ax.plot(so, lobes.gaussian_mp(beta, si + so), "--", c=line.get_color())
ax.set_xlabel("sin θo"); ax.set_title("M_p: d'Eon (solid), Gaussian (dashed)"); ax.legend(fontsize=8)""")

md("## What each artist parameter does (KarisHair, full model with MS)")
code("""V = direction(np.linspace(-89, 89, 181), 2.6)  # near-forward scattering plane
L = direction(30.0)
base = dict(base_color=(0.55, 0.3, 0.15), roughness=0.4, scatter=0.3)
sweeps = {
    "roughness": [0.2, 0.4, 0.7],
    "shift": [-0.05, 0.035, 0.1],
    "specular": [0.2, 0.5, 1.0],
    "backlit": [0.0, 0.5, 1.0],
    "scatter": [0.0, 0.3, 1.0],
    "base_color": [(0.1, 0.06, 0.04), (0.55, 0.3, 0.15), (0.9, 0.75, 0.55)],
}
fig, axes = plt.subplots(2, 3, figsize=(15, 7))
for ax, (name, values) in zip(axes.ravel(), sweeps.items()):
    for v in values:
        m = hs.KarisHair(**{**base, name: v})
        ax.plot(np.linspace(-89, 89, 181), m.eval(L, V, T)[:, 0], label=f"{name}={v}")
    ax.set_title(name); ax.set_xlabel("θo (deg), φ = 149°"); ax.legend(fontsize=7)
plt.tight_layout()""")

md("## The same material in the path-tracing model\n`mapping.to_chiang` gives ChiangHair parameters (analytic start, then a least-squares fit on the far field):")
code("""params = mapping.chiang_params(hs.KarisHair(base_color=brown, roughness=0.4))
print({k: np.round(v, 3) for k, v in params.items()})
chiang = hs.ChiangHair(**params)
L = direction(theta_i); V = direction(-theta_i, phi)
cl = chiang.eval_far_lobes(L, V)
plt.figure(figsize=(6, 3.6))
plt.plot(np.rad2deg(phi), deon.eval(L, V, T)[:, 0], label="DEonHair")
plt.plot(np.rad2deg(phi), karis.eval(L, V, T)[:, 0], "--", label="KarisHair")
plt.plot(np.rad2deg(phi), (cl["R"] + cl["TT"] + cl["TRT"])[:, 0], ":", label="ChiangHair far field (mapped)")
plt.xlabel("φ (deg), θo = −θi"); plt.legend(fontsize=8);""")

def write(path, cells):
    if "--only" in sys.argv and not path.endswith(f"/{sys.argv[sys.argv.index('--only') + 1]}.ipynb"):
        return
    nb = nbf.v4.new_notebook()
    nb["cells"] = cells
    nb["metadata"]["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    if "--execute" in sys.argv:
        from nbclient import NotebookClient

        NotebookClient(nb, timeout=900, resources={"metadata": {"path": "notebooks"}}).execute()
        nb["metadata"].pop("widgets", None)
    nbf.write(nb, path)
    print(f"wrote {path}")


write("notebooks/lobes.ipynb", cells)

# -- run time against error ------------------------------------------------------
cells = []
md("""# Run time against error

Each BSDF model's evaluation rate beside its error against its converged f64
reference (`hairshade bench`; see `python/hairshade/benchmark.py` for what
each error means), and each scene's render time beside its error against a
converged Mitsuba reference of the same scene with the same BSDF, Mitsuba's
own time and error from 1 to 256 spp, scaling with strand count and threads,
and what each skip saves (`python/hairshade/bench_render.py`). The full run
is one command, `hairshade bench --out docs` (docs/bench_bsdf.{csv,png},
docs/bench_render.{csv,png}); this notebook shows that committed result and
re-measures a fast subset (small batches and images, no DEonHair sweep) so
that it runs in the test suite. Numbers from the fast run are noisier than
the committed ones.""")
code("""import csv, os
import numpy as np
import matplotlib.pyplot as plt
from hairshade import benchmark

path = os.path.join("..", "docs", "bench_bsdf.csv") if os.path.exists(os.path.join("..", "docs")) else "docs/bench_bsdf.csv"
with open(path) as f:
    full = [dict(r, evals_per_s=float(r["evals_per_s"]), rel_l2_error=float(r["rel_l2_error"])) for r in csv.DictReader(f)]
print(f"{len(full)} rows from {path}")
for r in full:
    if r["threads"] in ("all", "mitsuba"):
        print(f"{r['model']:14s} {r['variant']:28s} {r['precision']:4s} {r['evals_per_s'] / 1e6:8.3f} M/s   err {r['rel_l2_error']:.2e}")""")
md("## The Pareto front (committed full run, all-threads rows)")
code("""import tempfile
from IPython.display import Image

png = os.path.join(tempfile.mkdtemp(), "bench_bsdf.png")
benchmark.plot([r for r in full if r["threads"] != "1"], png, dpi=60)
Image(png)""")
md("## Thread scaling (committed full run)")
code("""by = {}
for r in full:
    by.setdefault((r["model"], r["variant"], r["precision"]), {})[r["threads"]] = r["evals_per_s"]
for k, v in by.items():
    if "all" in v and "1" in v:
        print(f"{' '.join(k):40s} {v['all'] / v['1']:.2f}x on all threads")""")
md("## A fast re-measurement")
code("""rows = benchmark.bsdf_runtime_vs_error(n=1 << 14, repeats=1, fast=True, progress_bar=False)
for r in rows:
    if r["threads"] != "1":
        print(f"{r['model']:14s} {r['variant']:28s} {r['precision']:4s} {r['evals_per_s'] / 1e6:8.3f} M/s   err {r['rel_l2_error']:.2e}")""")
md("""## Rendering: time against error (committed full run)

Left: Mitsuba's spp sweep (a line per scene, labelled by spp) and the
rasterizer (a star) at the reference resolution. Right: frame time against
strand count at 1280x720.""")
code("""from hairshade import bench_render
rpath = path.replace("bench_bsdf.csv", "bench_render.csv")
rfull = bench_render.read_csv(rpath)
print(bench_render.summary(rfull))
png = os.path.join(tempfile.mkdtemp(), "bench_render.png")
bench_render.plot(rfull, png, dpi=60)
Image(png)""")
md("## A fast re-measurement of the rendering part")
code("""rfast = bench_render.render_runtime_vs_error(fast=True, repeats=1, progress_bar=False)
print(bench_render.summary(rfast))""")
write("notebooks/runtime_vs_error.ipynb", cells)

# -- the quality presets on a dense head --------------------------------------------
cells = []
md("""# The quality presets against path tracing

A dense head (10k strands, key light) rendered with each quality preset,
shown beside its converged path-traced truth (Mitsuba 3 `path`, max_depth
64, `tests/data/dense`), with each preset's error and frame time. Renders
are linear float32; `hs.show` displays one (sRGB, exposure in stops or
`"auto"`).""")
code("""import time
import numpy as np
import matplotlib.pyplot as plt
import hairshade as hs

plt.rcParams["figure.dpi"] = 50  # small PNG outputs in the committed notebook

scene = hs.Scene.load("../tests/data/dense/auburn_key.json")
scene.render = {}  # the presets decide every setting
truth = hs.read_exr("../tests/data/dense/auburn_key.exr")
hs.show(truth, exposure="auto")""")
md("## Each preset: image, error against the truth, frame time")
code("""rows = {}
for q in ("fast", "balanced", "accurate"):
    img = hs.render(scene, quality=q, progress=False)  # builds the shadow maps and lighting
    t = time.perf_counter()
    hs.render(scene, quality=q, progress=False)        # a frame that reuses them (a camera move)
    rows[q] = dict(img=img, seconds=time.perf_counter() - t, rel_mse=hs.rel_mse(img, truth),
                   ratio=img.reshape(-1, 3).mean(0) / truth.reshape(-1, 3).mean(0))
    print(f"{q:9s} relMSE {rows[q]['rel_mse']:.2e}  mean/truth {np.round(rows[q]['ratio'], 3)}  "
          f"{rows[q]['seconds'] * 1e3:.0f} ms")""")
code("""exposure = -np.log2(np.percentile(truth, 99.5))
hs.show(np.concatenate([truth] + [r["img"] for r in rows.values()], axis=1), exposure=exposure)""")
md("Left to right: the truth, `fast`, `balanced`, `accurate`.")
md("## Error against time")
code("""fig, ax = plt.subplots(figsize=(5, 3.5))
for q, r in rows.items():
    ax.loglog(r["seconds"], r["rel_mse"], "o")
    ax.annotate(q, (r["seconds"], r["rel_mse"]), textcoords="offset points", xytext=(6, 4))
ax.set_xlabel("frame time (s, this machine)")
ax.set_ylabel("relMSE against the truth")
ax.grid(True, which="both", alpha=0.3);""")
write("notebooks/presets.ipynb", cells)
