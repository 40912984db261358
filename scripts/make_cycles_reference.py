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
    for seed in args.seeds:
        t: dict[str, float] = {}
        halves.append(cycles.render(scene, spp=args.spp, max_bounces=args.bounces, seed=seed, timing=t))
        seconds.append(round(t["render_s"], 1))
        print(f"{args.scene}: seed {seed}, {args.spp} spp, {t['render_s']:.1f} s", flush=True)
    mean = 0.5 * (halves[0] + halves[1])
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    hs.write_exr(args.out, mean)
    info = dict(scene=os.path.relpath(args.scene, os.path.dirname(os.path.abspath(args.out))), spp_per_half=args.spp,
                seeds=args.seeds, bounces=args.bounces, curve=scene.curve[0], blender=bpy.app.version_string, cpu=cpu_name(),
                seconds_per_half=seconds, halves_rel_mse=float(hs.rel_mse(halves[0], halves[1])),
                mean_rgb=[float(x) for x in mean.reshape(-1, 3).mean(0)],
                halves_mean_rgb=[[float(x) for x in h.reshape(-1, 3).mean(0)] for h in halves])
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(info, f, indent=1)
        f.write("\n")
    print(info)


if __name__ == "__main__":
    main()
