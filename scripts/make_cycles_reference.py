"""Cycles references of hairshade scenes: two halves of different seeds,
their mean written as the reference, and what it took.

    python scripts/make_cycles_reference.py tests/data/dense/auburn_key.json \
        tests/data/cycles/auburn_key.exr --spp 1024 [--bounces 64]

The strands are drawn as the B-spline of their vertices unless ``--curve``
says otherwise: the Mitsuba references in tests/data were made that way.
Writes OUT (the mean of the halves, float32 RGB) and OUT with ``.json``
instead of ``.exr``: spp per half, bounces, Blender's version, the CPU,
the seconds each half took, the halves' relMSE (the reference's own noise)
and its mean per channel. Needs a Python with hairshade and bpy.

``--extend`` adds samples to an existing OUT of 2 x S spp: two renders of
new seeds, one of N = ``--spp`` samples, which with the existing mean (2S
spp) makes the first half, and one of 2S + N samples, the second half. OUT
becomes their mean (4S + 2N spp), its halves independent and of equal
samples, and its .json lists what each half is made of.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
import hairshade as hs  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, default=1024, help="samples per pixel of each half")
    ap.add_argument("--bounces", type=int, default=64)
    ap.add_argument("--seeds", type=int, nargs=2, default=[1, 2])
    ap.add_argument("--extend", action="store_true",
                    help="add samples to the existing OUT (see above): --spp is the first new render's samples")
    ap.add_argument("--curve", choices=["scene", "polyline", "bspline", "catmull_rom"], default="bspline",
                    help="how the strands are drawn (default bspline: the B-spline of the vertices, as the Mitsuba "
                         "references of tests/data were made; scene: the scene's hair.curve)")
    args = ap.parse_args()
    import bpy

    from hairshade import cycles
    from hairshade.demo import cpu_name

    scene = hs.Scene.load(args.scene)
    if args.curve != "scene":
        scene.curve = (args.curve, scene.curve[1])
    halves, seconds = [], []
    old = None
    if args.extend:
        with open(os.path.splitext(args.out)[0] + ".json") as f:
            old = json.load(f)
        # (references made before the .json named the curve drew the B-spline: hairshade.cycles had no other)
        old_curve = old.get("curve", "bspline")
        if old["bounces"] != args.bounces or old_curve != scene.curve[0]:
            raise SystemExit(f"{args.out}: rendered with {old['bounces']} bounces and curve {old_curve}, "
                             f"not {args.bounces} and {scene.curve[0]}")
        before = 2 * old["spp_per_half"]
        first_seed = max(old["seeds"]) + 1
        plan = [(first_seed, args.spp), (first_seed + 1, before + args.spp)]
    else:
        plan = [(seed, args.spp) for seed in args.seeds]
    for seed, spp in plan:
        t: dict[str, float] = {}
        halves.append(cycles.render(scene, spp=spp, max_bounces=args.bounces, seed=seed, timing=t))
        seconds.append(round(t["render_s"], 1))
        print(f"{args.scene}: seed {seed}, {spp} spp, {t['render_s']:.1f} s", flush=True)
    if old is not None:
        # the first half: the existing mean and the first new render, by their samples
        halves[0] = (before * hs.read_exr(args.out)[..., :3] + args.spp * halves[0]) / (before + args.spp)
    mean = 0.5 * (halves[0] + halves[1])
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    hs.write_exr(args.out, mean)
    spp_per_half = plan[1][1]
    seeds = [seed for seed, _ in plan]
    if old is not None:
        # the earlier renders' seconds count in the first half
        seconds[0] = round(seconds[0] + sum(old["seconds_per_half"]), 1)
        seeds = old["seeds"] + seeds
    info = dict(scene=os.path.relpath(args.scene, os.path.dirname(os.path.abspath(args.out))), spp_per_half=spp_per_half,
                seeds=seeds, bounces=args.bounces, curve=scene.curve[0], blender=bpy.app.version_string, cpu=cpu_name(),
                seconds_per_half=seconds, halves_rel_mse=float(hs.rel_mse(halves[0], halves[1])),
                mean_rgb=[float(x) for x in mean.reshape(-1, 3).mean(0)],
                halves_mean_rgb=[[float(x) for x in h.reshape(-1, 3).mean(0)] for h in halves])
    if old is not None:
        info["halves"] = [f"seeds {old['seeds']} ({before} spp, the earlier reference) and seed {plan[0][0]} "
                          f"({plan[0][1]} spp)", f"seed {plan[1][0]} ({plan[1][1]} spp)"]
        if old.get("blender") != info["blender"]:
            info["blender"] = f"{old.get('blender')} and {info['blender']}"
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(info, f, indent=1)
        f.write("\n")
    print(info)


if __name__ == "__main__":
    main()
