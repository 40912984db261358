"""Blender's Principled Hair (Chiang) against ChiangHair.from_blender: single
straight fibers, lit by a directional light, rendered by Cycles with the
node's own inputs, by the hairshade rasterizer with
``ChiangHair.from_blender`` of the same inputs, and (without coat, which
Mitsuba's hair lacks) by Mitsuba through ``hairshade.mitsuba``. Writes
docs/cycles_fibers.md and docs/cycles_fibers.csv.

    python scripts/cycles_fibers.py [--spp 1024]

Needs a Python with hairshade, mitsuba and bpy (Blender 5 as a module,
Python 3.11). Also writes tests/data/cycles/fibers.json: Cycles' sums per
case and half, which tests/test_hair_params.py compares with the
rasterizer where bpy is absent.

A fiber of radius 0.01 runs across the whole image along x (past both
edges, so no end is seen); the camera looks at it from +z from far away. A
column of pixels then integrates the fiber's radiance over its whole width,
which is the far field (the average over the offset h) that the rasterizer
shades with, and the path tracers' near field summed over h: the image's
sum per channel is compared. Two lights: "front" (from the camera's side,
above: R and TRT) and "back" (from behind: TT). The Cycles fibers get the
node's inputs directly (Melanin parametrization, or Absorption
Coefficient), not hairshade's conversion.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
sys.path.insert(0, os.path.dirname(__file__))
import hairshade as hs  # noqa: E402
from hairshade import _extras  # noqa: E402
from doc_tables import write_csv, write_markdown  # noqa: E402

W, H = 128, 32
LIGHTS = {"front": [0.2, 0.55, 0.81], "back": [0.25, 0.35, -0.9]}
MATERIALS = [
    dict(parametrization="melanin", melanin=0.1, melanin_redness=0.0, roughness=0.3, radial_roughness=0.3),
    dict(parametrization="melanin", melanin=0.5, melanin_redness=0.5, roughness=0.3, radial_roughness=0.3),
    dict(parametrization="melanin", melanin=0.9, melanin_redness=1.0, roughness=0.3, radial_roughness=0.3),
    dict(parametrization="melanin", melanin=0.3, melanin_redness=0.8, roughness=0.2, radial_roughness=0.4),
    dict(parametrization="melanin", melanin=0.3, melanin_redness=0.8, roughness=0.5, radial_roughness=0.4),
    dict(parametrization="melanin", melanin=0.3, melanin_redness=0.8, roughness=0.8, radial_roughness=0.4),
    dict(parametrization="melanin", melanin=0.3, melanin_redness=0.8, roughness=0.4, radial_roughness=0.3,
         coat=0.5),
    dict(parametrization="melanin", melanin=0.3, melanin_redness=0.8, roughness=0.4, radial_roughness=0.3,
         offset=0.0),
    dict(parametrization="melanin", melanin=0.3, melanin_redness=0.8, roughness=0.4, radial_roughness=0.3,
         offset=3.0),
    dict(parametrization="absorption", absorption_coefficient=(0.2, 0.4, 0.9), roughness=0.3, radial_roughness=0.5),
]


def fiber_scene(material: dict, light: list[float]) -> hs.Scene:
    x = np.linspace(-3, 3, 65)
    pts = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    dist = 40.0
    fov = math.degrees(2 * math.atan(0.25 / dist))  # 0.5 units tall: the image spans x in [-1, 1]
    return hs.Scene.from_arrays(
        pts, 0.01, [0, len(x)], material={"model": "chiang", **material},
        camera={"position": [0, 0, dist], "target": [0, 0, 0], "fov": fov, "resolution": [W, H]},
        lights=[{"type": "directional", "direction": light, "intensity": [1, 1, 1], "shadows": False}],
        render={"transparency": {"coverage": {"samples": 64}}, "multiple_scattering": "none"})


def exact_sum(model: hs.ChiangHair, light: list[float]) -> np.ndarray:
    """The image sum the scene should have: ChiangHair's far field (its
    average over h, with the exact I0) at the view direction of 32 points
    per pixel column along the fiber, times the fiber's width in pixels."""
    L = np.asarray(light, float) / np.linalg.norm(light)
    xs = (np.arange(W * 32) + 0.5) / (W * 32) * 2 - 1  # the image spans x in [-1, 1] at z = 0
    V = np.stack([-xs, np.zeros_like(xs), np.full_like(xs, 40.0)], axis=1)
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    t, n = np.array([1.0, 0, 0]), np.array([0, 0, 1.0])
    x = np.cross(t, n)
    local = lambda v: np.stack([v @ x, v @ t, v @ n], axis=-1)  # noqa: E731
    f = model.eval_far(local(V), np.repeat(local(L)[None], len(V), axis=0))
    width_px = 0.02 / (0.5 / H)
    return width_px * f.sum(axis=0) / 32


def cycles_fiber(bpy, scene: hs.Scene, inputs: dict, spp: int, seed: int) -> np.ndarray:
    """Cycles' image with the Principled Hair node set from Blender inputs
    (not from hairshade's conversion)."""
    from hairshade import cycles

    sc = cycles.build(scene, spp=spp, max_bounces=0, seed=seed)
    node = next(n for m in bpy.data.materials if m.name.startswith("Hair")
                for n in m.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfHairPrincipled")
    node.parametrization = inputs["parametrization"].upper()
    names = {"melanin": "Melanin", "melanin_redness": "Melanin Redness", "roughness": "Roughness",
             "radial_roughness": "Radial Roughness", "coat": "Coat", "absorption_coefficient": "Absorption Coefficient"}
    values = {names[k]: v for k, v in inputs.items() if k in names}
    values["Offset"] = math.radians(inputs.get("offset", 2.0))
    values.setdefault("Coat", 0.0)
    values["IOR"] = 1.55
    values["Tint"] = (1.0, 1.0, 1.0, 1.0)
    for sock in node.inputs:
        if sock.name in values:
            v = values[sock.name]
            sock.default_value = list(v) + [1.0] * (len(sock.default_value) - len(v)) if isinstance(v, tuple) else v
    return cycles.render_built(sc)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "docs"))
    args = ap.parse_args()
    _extras.check(["bpy", "mitsuba"], "scripts/cycles_fibers.py")
    import bpy

    import hairshade.mitsuba as hm

    rows, cached = [], []
    for mat_in in MATERIALS:
        model = hs.ChiangHair.from_blender(**mat_in)
        mat = {k: v for k, v in model.params.items() if v is not None}
        for lname, light in LIGHTS.items():
            scene = fiber_scene(mat, light)
            t0 = time.perf_counter()
            halves = [cycles_fiber(bpy, scene, mat_in, args.spp // 2, seed) for seed in (1, 2)]
            t_cy = time.perf_counter() - t0
            cyc = 0.5 * (halves[0] + halves[1])
            ours = hs.render(scene)
            mi = None if model.params["coat"] else hm.render(scene, spp=args.spp, integrator="direct", progress=False)
            s_cy, s_ours = cyc.sum((0, 1)), ours.sum((0, 1))
            exact = exact_sum(model, light)
            noise = np.abs(halves[0].sum((0, 1)) / halves[1].sum((0, 1)) - 1) / 2  # of the mean of the two
            row = dict(material=", ".join(f"{k}={v}" for k, v in mat_in.items() if k != "parametrization"),
                       light=lname,
                       ours_over_cycles="/".join(f"{x:.4f}" for x in s_ours / s_cy),
                       mitsuba_over_cycles="" if mi is None else "/".join(f"{x:.4f}" for x in mi.sum((0, 1)) / s_cy),
                       cycles_noise="/".join(f"{x:.4f}" for x in noise), cycles_s=round(t_cy, 1),
                       ours_over_exact="/".join(f"{x:.4f}" for x in s_ours / exact),
                       cycles_over_exact="/".join(f"{x:.4f}" for x in s_cy / exact),
                       mitsuba_over_exact="" if mi is None else "/".join(f"{x:.4f}" for x in mi.sum((0, 1)) / exact))
            rows.append(row)
            cached.append(dict(inputs=mat_in, light=lname, cycles_halves=[h.sum((0, 1)).tolist() for h in halves]))
            print(row, flush=True)
    data = os.path.join(os.path.dirname(__file__), "..", "tests", "data", "cycles")
    os.makedirs(data, exist_ok=True)
    with open(os.path.join(data, "fibers.json"), "w") as f:
        json.dump(dict(blender=bpy.app.version_string, spp_per_half=args.spp // 2, cases=cached), f, indent=1)
        f.write("\n")
    os.makedirs(args.out, exist_ok=True)
    write_csv(os.path.join(args.out, "cycles_fibers.csv"), rows)
    lines = [
        "# Blender's Principled Hair against ChiangHair.from_blender",
        "",
        f"Generated by `python scripts/cycles_fibers.py --spp {args.spp}` (Blender {bpy.app.version_string}; data: "
        "`cycles_fibers.csv`). One straight fiber across the image, seen from the side; the image's sum per "
        "channel (R/G/B), so that every column integrates the fiber over its width. Cycles gets the node's own "
        "inputs; the rasterizer gets `ChiangHair.from_blender` of them; Mitsuba (no coat) the same ChiangHair "
        "through `hairshade.mitsuba`. Cycles noise: half the relative difference of its two halves' sums.",
        "",
        "| Blender inputs | light | hairshade / Cycles | Mitsuba / Cycles | Cycles noise |",
        "| --- | --- | --- | --- | --- |",
    ]
    lines += [f"| {r['material']} | {r['light']} | {r['ours_over_cycles']} | {r['mitsuba_over_cycles'] or '—'} | "
              f"{r['cycles_noise']} |" for r in rows]
    lines += [
        "",
        "## Against the exact value",
        "",
        "What the image should sum to, computed without a renderer: ChiangHair's far field (its average over "
        "h, exact I0) at 32 view directions per pixel column, times the fiber's width in pixels (`exact_sum`).",
        "",
        "| Blender inputs | light | hairshade / exact | Cycles / exact | Mitsuba / exact |",
        "| --- | --- | --- | --- | --- |",
    ]
    lines += [f"| {r['material']} | {r['light']} | {r['ours_over_exact']} | {r['cycles_over_exact']} | "
              f"{r['mitsuba_over_exact'] or '—'} |" for r in rows]
    lines += [
        "",
        "What the differences are:",
        "",
        "- The rasterizer reads a fiber 1.3 pixels wide 0.3-0.6% dark on every case, both lights: its "
        "geometry, not its shading (per-pixel and per-vertex shading give the same sums).",
        "- Cycles is up to 1.5% below the exact value where β_m = 0.3 and the light is in front (R and TRT): "
        "its I0 is a ten-term series (`bsdf_principled_hair_chiang.h`, `bessel_I0`) used below the asymptotic "
        "switch at x = 12, and a variance v = 0.085 puts the R lobe's argument cos θi cos θo / v just under 12, "
        "where ten terms fall 2% short. At β_m 0.2 (x above 12: the asymptotic form, the same in all) and "
        "0.5 or 0.8 (x below 10: the series converges) Cycles is within 0.2% of the exact value. Mitsuba's "
        "series has eleven terms: its share of the same gap is smaller.",
        "- Left unexplained: the darkest fiber backlit, in blue (transmission through σa 4.4 per radius): the "
        "rasterizer and Cycles agree (0.984 and 0.985 of the exact value) where Mitsuba is at 1.005; the far "
        "field there equals the near field averaged over h (`tests/test_chiang_far.py`, test 05).",
    ]
    write_markdown(os.path.join(args.out, "cycles_fibers.md"), lines)


if __name__ == "__main__":
    main()
