"""Heads of other styles and lights than the generator's straight hair, with
path-traced references: held-out checks of the renderer's presets.

    .venv/bin/python scripts/held_out_heads.py OUT_DIR [--spp 256] [--depth2-spp 0] [--variant V] [--heads a,b] [--seeds 1,2]
        [--curve bspline]

Each head starts from the procedural `head` generator's strands and is
reshaped in numpy (deterministic): `wavy_blond_rim` (waves across the
strand and clumps of ~40 strands pulled together, blond, key and rim
light), `curly_auburn_point` (helical curls, auburn, a point light and a
constant environment), `wavy_black_env` (waves, black, key light and
environment), `clumped_blond_key` (clumps, light blond, one key light),
`curly_blond_env` (curls, blond, environment and a weak key),
`wavy_ginger_back` (waves, ginger, backlight and a front fill),
`straight_brown_back` (the generator's straight hair, brown, backlight and
a dim environment). Writes OUT_DIR/NAME.txt (strands, `x y z r`), NAME.json (the
scene) and, unless --no-reference, NAME.exr: Mitsuba `path` (max_depth 64),
the mean of two halves of --spp samples each (--seeds, 1 and 2), whose relMSE
against each other is printed (the reference's own noise);
--depth2-spp also writes NAME_depth2.exr, the same at max_depth 2.

--curve is the geometry Mitsuba traces: "bspline" (the default, what the
cached NAME.exr references trace), the uniform B-spline of each strand's
vertices with its ends tripled; "polyline", the straight segments between
them that the rasterizer draws by default (the scenes' own `hair.curve`),
written as NAME_polyline.exr.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

import hairshade as hs
from hairshade.generate import generate

CAMERA = {"position": [0.25, 0.1, 2.3], "target": [0.0, -0.12, 0.0], "up": [0, 1, 0], "fov": 40,
          "resolution": [320, 180]}
HEAD = {"type": "sphere", "center": [0, 0, 0], "radius": 0.48, "albedo": [0.5, 0.4, 0.35]}
# The cached references (tests/data/held_out) were rendered with Mitsuba's
# hair at its default tilt, +2 degrees, which leans R towards the tip on
# these root-first strands: ChiangHair's -2 (src/fiber/chiang.rs, docs/tilt.md).
TILT = -2.0
MATERIALS = {
    "blond": {"model": "chiang", "eumelanin": 0.15, "pheomelanin": 0.1, "longitudinal_roughness": 0.3,
              "azimuthal_roughness": 0.4, "scale_tilt": TILT},
    "auburn": {"model": "chiang", "eumelanin": 0.5, "pheomelanin": 0.6, "longitudinal_roughness": 0.3,
               "azimuthal_roughness": 0.4, "scale_tilt": TILT},
    "black": {"model": "chiang", "eumelanin": 4.0, "pheomelanin": 0.1, "longitudinal_roughness": 0.25,
              "azimuthal_roughness": 0.35, "scale_tilt": TILT},
    "light_blond": {"model": "chiang", "eumelanin": 0.1, "pheomelanin": 0.15, "longitudinal_roughness": 0.28,
                    "azimuthal_roughness": 0.38, "scale_tilt": TILT},
    "ginger": {"model": "chiang", "eumelanin": 0.3, "pheomelanin": 1.1, "longitudinal_roughness": 0.27,
               "azimuthal_roughness": 0.35, "scale_tilt": TILT},
    "brown": {"model": "chiang", "eumelanin": 0.9, "pheomelanin": 0.3, "longitudinal_roughness": 0.3,
              "azimuthal_roughness": 0.4, "scale_tilt": TILT},
}


def _frame(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex, two unit vectors across the strand (tangent from the polyline)."""
    t = np.gradient(p, axis=1)
    t /= np.linalg.norm(t, axis=2, keepdims=True) + 1e-12
    up = np.where(np.abs(t[..., 1:2]) < 0.9, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    a = np.cross(t, up)
    a /= np.linalg.norm(a, axis=2, keepdims=True) + 1e-12
    return a, np.cross(t, a)


def strands(style: str, n: int, segments: int, seed: int) -> np.ndarray:
    """(n, segments + 1, 3) points of a reshaped generator head."""
    pts, _ = generate({"kind": "head", "strands": n, "segments": segments, "seed": seed})
    p = np.stack([np.asarray(x, dtype=np.float64) for x in pts])
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, segments + 1)[None, :, None]  # 0 at the root
    a, b = _frame(p)
    if style in ("wavy", "wavy_clumped"):
        phase = rng.uniform(0, 2 * np.pi, (n, 1, 1))
        p = p + 0.018 * s * np.sin(2 * np.pi * 3.0 * s + phase) * a
    if style in ("wavy_clumped", "clumped"):
        roots = p[:, 0]
        centres = roots[rng.choice(n, n // 40, replace=False)]
        clump = np.argmin(((roots[:, None] - centres[None]) ** 2).sum(-1), axis=1)
        mean = np.stack([p[clump == c].mean(0) if np.any(clump == c) else p[0] for c in range(len(centres))])
        p = p + 0.6 * s * (mean[clump] - p)
    if style == "curly":
        phase = rng.uniform(0, 2 * np.pi, (n, 1, 1))
        turn = 2 * np.pi * 5.0 * s + phase
        r = 0.014 * np.minimum(1.0, 4 * s)
        p = p + r * (np.cos(turn) * a + np.sin(turn) * b)
    return p


HEADS = {
    "wavy_blond_rim": dict(style="wavy_clumped", n=8000, segments=24, seed=11, material="blond", lights=[
        {"type": "directional", "direction": [0.5, 0.6, 0.6], "intensity": [1.5, 1.5, 1.5], "shadows": True},
        {"type": "directional", "direction": [-0.3, 0.5, -0.8], "intensity": [3.0, 3.0, 3.0], "shadows": True}]),
    "curly_auburn_point": dict(style="curly", n=6000, segments=40, seed=12, material="auburn", lights=[
        {"type": "point", "position": [0.8, 0.9, 1.2], "intensity": [6.0, 6.0, 6.0], "shadows": True},
        {"type": "environment", "radiance": [0.15, 0.15, 0.17]}]),
    "wavy_black_env": dict(style="wavy", n=8000, segments=24, seed=13, material="black", lights=[
        {"type": "directional", "direction": [0.2, 1.0, 0.4], "intensity": [3.0, 3.0, 3.0], "shadows": True},
        {"type": "environment", "radiance": [0.4, 0.4, 0.42]}]),
    "clumped_blond_key": dict(style="clumped", n=9000, segments=20, seed=14, material="light_blond", lights=[
        {"type": "directional", "direction": [0.4, 0.5, 0.8], "intensity": [3.0, 3.0, 3.0], "shadows": True}]),
    "curly_blond_env": dict(style="curly", n=6000, segments=40, seed=15, material="blond", lights=[
        {"type": "directional", "direction": [-0.4, 0.8, 0.5], "intensity": [1.5, 1.5, 1.5], "shadows": True},
        {"type": "environment", "radiance": [0.35, 0.35, 0.38]}]),
    "wavy_ginger_back": dict(style="wavy", n=8000, segments=24, seed=16, material="ginger", lights=[
        {"type": "directional", "direction": [0.1, 0.5, -1.0], "intensity": [4.0, 4.0, 4.0], "shadows": True},
        {"type": "directional", "direction": [0.3, 0.2, 1.0], "intensity": [1.2, 1.2, 1.2], "shadows": True}]),
    "straight_brown_back": dict(style="straight", n=10000, segments=16, seed=17, material="brown", lights=[
        {"type": "directional", "direction": [-0.2, 0.3, -1.0], "intensity": [5.0, 5.0, 5.0], "shadows": True},
        {"type": "environment", "radiance": [0.1, 0.1, 0.11]}]),
}


def write_head(out: str, name: str) -> str:
    h = HEADS[name]
    p = strands(h["style"], h["n"], h["segments"], h["seed"])
    lines = []
    for strand in p:
        lines.append("\n".join(f"{x:.6f} {y:.6f} {z:.6f} 0.0015" for x, y, z in strand))
    with open(os.path.join(out, f"{name}.txt"), "w") as f:
        f.write("\n\n".join(lines) + "\n")
    scene = {"hairshade_scene": 1, "camera": CAMERA, "meshes": [HEAD], "lights": h["lights"],
             "hair": {"file": f"{name}.txt", "material": MATERIALS[h["material"]]}, "render": {}}
    path = os.path.join(out, f"{name}.json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
    return path


def render_reference(scene: hs.Scene, path: str, spp: int, depth: int, seeds=(1, 2),
                     variant: str | None = None, curve: str | None = None) -> str:
    """Mitsuba `path` at max_depth DEPTH, two halves of SPP samples with the
    given seeds; writes their mean to PATH and returns a line saying what it
    took and the halves' relMSE (the reference's own noise) and means."""
    from hairshade import mitsuba as hm

    t = time.perf_counter()
    halves = [hm.render(scene, spp=spp, integrator="path", max_depth=depth, seed=s, passes=-(-spp // 1024),
                        progress=False, variant=variant, curve=curve) for s in seeds]
    hs.write_exr(path, (0.5 * (halves[0] + halves[1])).astype(np.float32))
    return (f"{os.path.splitext(os.path.basename(path))[0]}: {variant or hm.default_variant()}, 2 x {spp} spp "
            f"(seeds {seeds[0]}, {seeds[1]}), max_depth {depth}: halves relMSE {hs.rel_mse(halves[0], halves[1]):.2e}, "
            f"halves' means {halves[0].reshape(-1, 3).mean(0)} {halves[1].reshape(-1, 3).mean(0)}, "
            f"{time.perf_counter() - t:.0f} s")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel of each half")
    ap.add_argument("--heads", default=",".join(HEADS))
    ap.add_argument("--depth2-spp", type=int, default=0,
                    help="also write NAME_depth2.exr (max_depth 2: single scattering), halves of this many spp")
    ap.add_argument("--variant", help="Mitsuba variant (default: hairshade.mitsuba.default_variant())")
    ap.add_argument("--no-reference", action="store_true")
    ap.add_argument("--seeds", default="1,2", help="the two halves' seeds")
    ap.add_argument("--curve", default="bspline", choices=("bspline", "polyline"),
                    help="the strands' geometry in Mitsuba (polyline: written as NAME_polyline.exr)")
    a = ap.parse_args()
    seeds = tuple(int(x) for x in a.seeds.split(","))
    if len(seeds) != 2 or seeds[0] == seeds[1]:
        ap.error("--seeds: two different integers, such as 1,2")
    os.makedirs(a.out, exist_ok=True)
    for name in a.heads.split(","):
        if name not in HEADS:
            ap.error(f"--heads: among {', '.join(HEADS)}")
        path = write_head(a.out, name)
        if a.no_reference:
            continue
        scene = hs.Scene.load(path)
        tag = "_polyline" if a.curve == "polyline" else ""
        for depth, spp, suffix in ((64, a.spp, ""), (2, a.depth2_spp, "_depth2")):
            if spp >= 1:
                print(render_reference(scene, os.path.join(a.out, f"{name}{suffix}{tag}.exr"), spp, depth,
                                       seeds=seeds, variant=a.variant, curve=a.curve), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
