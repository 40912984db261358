"""Mitsuba's two backends against each other on hair: the mean radiance of
the same scene rendered by ``llvm_ad_rgb`` (Embree's round B-spline
curves) and ``cuda_ad_rgb`` (OptiX's), per path depth.

    python scripts/mitsuba_backends.py [--spp 512] [--depths 2,3,4,8,64] [--scenes a,b] [--out docs]

Scenes: a single straight fiber and two parallel fibers (a convex fiber
cannot be hit again by the light leaving it, so depth 2 and depth 64 must
agree on one fiber), and heads with a converged truth (tests/data/dense,
the held-out heads of scripts/held_out_heads.py). Each (scene, depth,
variant) is rendered twice with different seeds. Each variant's rows go to
OUT/mitsuba_backends_VARIANT.csv (the variants can run on different
machines: cuda on the GPU machine, llvm where libLLVM is), and
OUT/mitsuba_backends.md joins every such CSV in OUT: each backend's mean
RGB, the llvm / cuda ratio, and the two seeds' spread of the mean (its
noise).
"""

from __future__ import annotations

import argparse
import csv
import os
import pathlib
import sys
import tempfile
import time

import numpy as np

import hairshade as hs

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import held_out_heads  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
DENSE = ROOT / "tests" / "data" / "dense"
BLOND = {"model": "chiang", "eumelanin": 0.15, "pheomelanin": 0.1, "longitudinal_roughness": 0.3,
         "azimuthal_roughness": 0.4}


def fibers(n: int) -> hs.Scene:
    """n straight parallel fibers (radius 0.01, 0.025 apart) across the
    view, lit from the camera's upper left, before a black background."""
    strands = [{"points": [[-0.5, 0.025 * k, 0.0], [0.5, 0.025 * k, 0.0]], "radius": 0.01} for k in range(n)]
    return hs.Scene.from_dict({
        "hairshade_scene": 1,
        "camera": {"position": [0, 0.0125 * (n - 1), 1.2], "target": [0, 0.0125 * (n - 1), 0], "fov": 12,
                   "resolution": [160, 90]},
        "lights": [{"type": "directional", "direction": [-0.3, 0.5, 1.0], "intensity": [3, 3, 3]}],
        "hair": {"strands": strands, "material": BLOND}, "render": {}})


def _view(scene: hs.Scene) -> tuple:
    """(camera position, forward, right, up, tan of half the fov, unit
    direction to the light, its irradiance) of a fiber scene."""
    cam = scene.camera
    o = np.asarray(cam["position"], float)
    fwd = np.asarray(cam["target"], float) - o
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    light = np.asarray(scene.lights[0]["vector"], float)
    light /= np.linalg.norm(light)
    return (o, fwd, right, up, np.tan(np.radians(cam["fov"]) / 2), light,
            np.asarray(scene.lights[0]["intensity"], float))


def exact_one_fiber(samples: int = 16) -> np.ndarray:
    """Mean RGB of the one-fiber scene computed exactly: per pixel,
    samples x samples stratified rays (the box filter), each intersected
    analytically with the fiber's cylinder (the B-spline of a straight
    2-vertex strand, its ends out of view), shaded by ChiangHair.eval (the
    near field at the hit's offset h, cosine included, as Mitsuba's
    ``hair``) in the frame local y = tangent, z = normal, times the light's
    irradiance. One bounce is all a single convex fiber has."""
    scene = fibers(1)
    (w, h), r = (scene.camera["width"], scene.camera["height"]), 0.01
    o, fwd, right, up, th, light, irradiance = _view(scene)
    u = (np.arange(samples) + 0.5) / samples
    tangent = np.array([1.0, 0.0, 0.0])
    total = np.zeros(3)
    for j in range(h):
        py = ((1 - 2 * (j + u) / h) * th)[:, None, None]
        px = ((2 * (np.arange(w)[:, None] + u[None, :]) / w - 1) * th * w / h)[None]
        py, px = np.broadcast_arrays(py, px)
        d = fwd + px[..., None] * right + py[..., None] * up
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        # the cylinder y^2 + z^2 = r^2 around the x axis
        a = d[..., 1] ** 2 + d[..., 2] ** 2
        b = 2 * (o[1] * d[..., 1] + o[2] * d[..., 2])
        disc = b * b - 4 * a * (o[1] ** 2 + o[2] ** 2 - r * r)
        hit = disc > 0
        if not hit.any():
            continue
        d = d[hit]
        t = (-b[hit] - np.sqrt(disc[hit])) / (2 * a[hit])
        p = o + t[:, None] * d
        n = np.stack([np.zeros_like(t), p[:, 1], p[:, 2]], -1) / r
        x = np.cross(tangent, n)

        def local(v: np.ndarray) -> np.ndarray:
            v = np.broadcast_to(v, n.shape)
            return np.stack([(v * x).sum(-1), v @ tangent, (v * n).sum(-1)], -1)

        total += (scene.hair.eval(local(-d), local(light)) * irradiance).sum(0)
    return total / (w * h * samples * samples)


def exact_two_fibers(samples: int = 16, directions: int = 32, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Mean RGB of the two-fiber scene's single scattering (depth 2) and of
    the light one fiber scatters into the other (the depth-3 term), from
    analytic ray-cylinder hits: per hit, the light unless the other fiber
    shadows it; and ``directions`` directions sampled from the fiber's
    ChiangHair (``sample``: weight = eval / pdf), each carrying the other
    fiber's direct light where it meets that fiber. A scattered ray leaves
    its own fiber (the fiber is a surface event, as in Mitsuba: one fiber's
    depth 2 and depth 64 agree)."""
    scene = fibers(2)
    c, r = scene.hair, 0.01
    w, h = scene.camera["width"], scene.camera["height"]
    centers = np.array([0.0, 0.025])
    o, fwd, right, up, th, light, irradiance = _view(scene)
    tangent = np.array([1.0, 0.0, 0.0])
    rng = np.random.default_rng(seed)

    def hit(org: np.ndarray, d: np.ndarray, j: int) -> np.ndarray:
        """Distance along each ray to fiber j's cylinder (inf: none)."""
        oy, oz = org[:, 1] - centers[j], org[:, 2]
        a = d[:, 1] ** 2 + d[:, 2] ** 2
        b = 2 * (oy * d[:, 1] + oz * d[:, 2])
        disc = b * b - 4 * a * (oy ** 2 + oz ** 2 - r * r)
        sq, a2 = np.sqrt(np.maximum(disc, 0)), np.where(a > 0, 2 * a, 1)
        t0, t1 = (-b - sq) / a2, (-b + sq) / a2
        t = np.where(t0 > 1e-9, t0, np.where(t1 > 1e-9, t1, np.inf))
        return np.where((disc > 0) & (a > 0), t, np.inf)

    def frame(p: np.ndarray, j: int) -> tuple[np.ndarray, np.ndarray]:
        n = np.stack([np.zeros(len(p)), p[:, 1] - centers[j], p[:, 2]], -1) / r
        return n, np.cross(tangent, n)

    def local(v: np.ndarray, n: np.ndarray, x: np.ndarray) -> np.ndarray:
        v = np.broadcast_to(v, n.shape)
        return np.stack([(v * x).sum(-1), v @ tangent, (v * n).sum(-1)], -1)

    u = (np.arange(samples) + 0.5) / samples
    single, between = np.zeros(3), np.zeros(3)
    for row in range(h):
        py = ((1 - 2 * (row + u) / h) * th)[:, None, None]
        px = ((2 * (np.arange(w)[:, None] + u[None, :]) / w - 1) * th * w / h)[None]
        py, px = np.broadcast_arrays(py, px)
        d = (fwd + px[..., None] * right + py[..., None] * up).reshape(-1, 3)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        org = np.broadcast_to(o, d.shape)
        ts = np.stack([hit(org, d, 0), hit(org, d, 1)])
        first, t = np.argmin(ts, 0), ts.min(0)
        for j in (0, 1):
            sel = np.isfinite(t) & (first == j)
            if not sel.any():
                continue
            p = org[sel] + t[sel, None] * d[sel]
            n, x = frame(p, j)
            wi = local(-d[sel], n, x)
            lit = ~np.isfinite(hit(p, np.broadcast_to(light, p.shape), 1 - j))
            single += (c.eval(wi, local(light, n, x)) * irradiance * lit[:, None]).sum(0)
            wi_k, p_k = np.repeat(wi, directions, 0), np.repeat(p, directions, 0)
            n_k, x_k = np.repeat(n, directions, 0), np.repeat(x, directions, 0)
            wo, weight, pdf = c.sample(wi_k, rng.random(len(wi_k)), rng.random((len(wi_k), 2)))
            v = wo[:, :1] * x_k + wo[:, 1:2] * tangent + wo[:, 2:3] * n_k
            tq = hit(p_k, v, 1 - j)
            g = np.isfinite(tq) & (pdf > 0)
            if not g.any():
                continue
            q = p_k[g] + tq[g, None] * v[g]
            nq, xq = frame(q, 1 - j)
            lit_q = ~np.isfinite(hit(q, np.broadcast_to(light, q.shape), j))
            f_q = c.eval(local(-v[g], nq, xq), local(light, nq, xq))
            between += (weight[g] * f_q * irradiance * lit_q[:, None]).sum(0) / directions
    n_rays = w * h * samples * samples
    return single / n_rays, between / n_rays


def scenes(tmp: str, names: list[str] | None) -> dict[str, hs.Scene]:
    out = {"one_fiber": fibers(1), "two_fibers": fibers(2)}
    for n in ("blond_back", "auburn_key"):
        out[n] = hs.Scene.load(DENSE / f"{n}.json")
    for n in ("wavy_blond_rim", "clumped_blond_key"):
        out[n] = hs.Scene.load(held_out_heads.write_head(tmp, n))
    return {k: v for k, v in out.items() if not names or k in names}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--depths", default="2,3,4,8,64")
    ap.add_argument("--scenes")
    ap.add_argument("--variants", default="llvm_ad_rgb,cuda_ad_rgb")
    ap.add_argument("--out", default=str(ROOT / "docs"))
    a = ap.parse_args()
    import mitsuba as mi

    from hairshade import mitsuba as hm

    variants = a.variants.split(",")
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        todo = scenes(tmp, a.scenes.split(",") if a.scenes else None)
        for v in variants:
            mi.set_variant(v)
            rows = []
            for name, scene in todo.items():
                for depth in (int(d) for d in a.depths.split(",")):
                    ms = mi.load_dict(hm.scene_dict(scene, os.path.join(tmp, "s.txt"), a.spp, "path", depth))
                    t = time.perf_counter()
                    m = [np.array(mi.render(ms, spp=a.spp, seed=s))[..., :3].reshape(-1, 3).mean(0) for s in (1, 2)]
                    mean, spread = 0.5 * (m[0] + m[1]), float((np.abs(m[0] - m[1]) / np.maximum(m[0] + m[1], 1e-12)).max())
                    rows.append(dict(scene=name, depth=depth, spp=a.spp, r=float(mean[0]), g=float(mean[1]),
                                     b=float(mean[2]), spread=spread, seconds=time.perf_counter() - t))
                    print(v, name, depth, np.round(mean, 6).tolist(), f"spread {spread:.1e}", flush=True)
            with open(out / f"mitsuba_backends_{v}.csv", "w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
    write_exact(out)
    (out / "mitsuba_backends.md").write_text(markdown(out, mi.__version__, " ".join(sys.argv[1:])))
    return 0


def write_exact(out: pathlib.Path) -> None:
    """OUT/mitsuba_backends_exact.csv: the exact values of the fiber scenes."""
    one = exact_one_fiber()
    two_single, two_between = exact_two_fibers()
    with open(out / "mitsuba_backends_exact.csv", "w") as f:
        f.write("scene,depth,r,g,b\n")
        for name, depth, v in (("one_fiber", 2, one), ("two_fibers", 2, two_single),
                               ("two_fibers", 3, two_single + two_between)):
            f.write(f"{name},{depth},{v[0]:.9g},{v[1]:.9g},{v[2]:.9g}\n")


def markdown(out: pathlib.Path, version: str, args: str) -> str:
    """The table of every variant's CSV in `out`, joined by scene and depth."""
    runs = {p.stem.removeprefix("mitsuba_backends_"): {(r["scene"], int(r["depth"])): r for r in csv.DictReader(open(p))}
            for p in sorted(out.glob("mitsuba_backends_*_rgb.csv"))}
    variants = sorted(runs)
    keys = list(dict.fromkeys(k for v in variants for k in runs[v]))
    lines = ["# Mitsuba's llvm and cuda backends on hair", "",
             f"Generated by `python scripts/mitsuba_backends.py` (this part: `{args}`), Mitsuba {version}; each "
             "variant's rows are in `mitsuba_backends_VARIANT.csv`.", "",
             "Mean RGB of each scene per path depth (`path`, max_depth), the mean of two seeds; spread = the two "
             "seeds' relative difference of the mean (largest channel), the noise of a ratio.", "",
             "| scene | depth | " + " | ".join(f"{v}: mean R/G/B (spp)" for v in variants)
             + (f" | {variants[0]} / {variants[1]} | spreads |" if len(variants) == 2 else " | spreads |"),
             "| --- | --- | " + " | ".join("---" for _ in variants) + (" | --- | --- |" if len(variants) == 2 else " | --- |")]
    for k in keys:
        rs = [runs[v].get(k) for v in variants]
        cells = [f"{float(r['r']):.4g} / {float(r['g']):.4g} / {float(r['b']):.4g} ({r['spp']})" if r else "—" for r in rs]
        extra = ""
        if len(variants) == 2:
            extra = (" | " + " / ".join(f"{float(rs[0][c]) / max(float(rs[1][c]), 1e-12):.4f}" for c in "rgb")
                     if all(rs) else " | —")
        spreads = " / ".join(f"{float(r['spread']):.1e}" if r else "—" for r in rs)
        lines.append(f"| {k[0]} | {k[1]} | " + " | ".join(cells) + extra + f" | {spreads} |")
    exact_csv = out / "mitsuba_backends_exact.csv"
    if exact_csv.exists():
        exact = {(r["scene"], int(r["depth"])): np.array([float(r[c]) for c in "rgb"]) for r in csv.DictReader(open(exact_csv))}
        lines += ["", "## Against the exact values", "",
                  "The fiber scenes computed exactly (`exact_one_fiber`, `exact_two_fibers`: analytic ray-cylinder "
                  "hits shaded by ChiangHair, 16×16 stratified samples per pixel; the light one fiber scatters "
                  "into the other with 32 directions sampled from ChiangHair per hit, two seeds agree to 0.6%), "
                  "and each backend's mean over them:", "",
                  "| scene | depth | exact R/G/B | " + " | ".join(f"{v} / exact" for v in variants) + " |",
                  "| --- | --- | --- | " + " | ".join("---" for _ in variants) + " |"]
        for (name, depth), ex in exact.items():
            cells = []
            for v in variants:
                r = runs[v].get((name, depth))
                cells.append(" / ".join(f"{float(r[c]) / x:.4f}" for c, x in zip("rgb", ex)) if r else "—")
            lines.append(f"| {name} | {depth} | " + " / ".join(f"{x:.5g}" for x in ex) + " | " + " | ".join(cells) + " |")
        if ("two_fibers", 2) in exact and ("two_fibers", 3) in exact:
            between = exact[("two_fibers", 3)] - exact[("two_fibers", 2)]
            cells = []
            for v in variants:
                a, b = runs[v].get(("two_fibers", 3)), runs[v].get(("two_fibers", 2))
                if a and b:
                    cells.append(f"{v} " + " / ".join(f"{(float(a[c]) - float(b[c])) / x:.3f}"
                                                      for c, x in zip("rgb", between)))
            lines += ["", "The light one fiber scatters into the other alone (depth 3 minus depth 2) over the exact "
                      "value: " + "; ".join(cells) + "."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
