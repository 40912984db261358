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


def exact_one_fiber(samples: int = 16) -> np.ndarray:
    """Mean RGB of the one-fiber scene computed exactly: per pixel,
    samples x samples stratified rays (the box filter), each intersected
    analytically with the fiber's cylinder (the B-spline of a straight
    2-vertex strand, its ends out of view), shaded by ChiangHair.eval (the
    near field at the hit's offset h, cosine included, as Mitsuba's
    ``hair``) in the frame local y = tangent, z = normal, times the light's
    irradiance. One bounce is all a single convex fiber has."""
    scene = fibers(1)
    cam, (w, h), r = scene.camera, (scene.camera["width"], scene.camera["height"]), 0.01
    o = np.asarray(cam["position"], float)
    fwd = np.asarray(cam["target"], float) - o
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    th = np.tan(np.radians(cam["fov"]) / 2)
    light = np.asarray(scene.lights[0]["vector"], float)
    light /= np.linalg.norm(light)
    irradiance = np.asarray(scene.lights[0]["intensity"], float)
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
    exact = exact_one_fiber()
    with open(out / "mitsuba_backends_exact.csv", "w") as f:
        f.write("scene,depth,r,g,b\n" + f"one_fiber,1,{exact[0]:.9g},{exact[1]:.9g},{exact[2]:.9g}\n")
    (out / "mitsuba_backends.md").write_text(markdown(out, mi.__version__, " ".join(sys.argv[1:])))
    return 0


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
        e = next(csv.DictReader(open(exact_csv)))
        ex = np.array([float(e[c]) for c in "rgb"])
        lines += ["", "The one-fiber scene computed exactly (`exact_one_fiber`: analytic ray-cylinder hits, "
                  "ChiangHair's near field at each hit, 16×16 stratified samples per pixel): "
                  + " / ".join(f"{x:.5g}" for x in ex) + "."]
        for v in variants:
            r = runs[v].get(("one_fiber", 2))
            if r:
                lines.append(f"- {v} / exact at depth 2: "
                             + " / ".join(f"{float(r[c]) / x:.4f}" for c, x in zip("rgb", ex)) + ".")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
