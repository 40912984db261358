"""Renders a converged path-traced reference of a dense hair scene into
tests/data/dense: Mitsuba 3 `path` with max_depth 64, two independent halves
(seeds 1 and 2 unless told) whose mean is the reference and whose relMSE against each
other is its noise (printed; goes in tests/data/dense/README.md).

    .venv/bin/python scripts/make_dense_reference.py NAME SCENE.json [--spp 1024] [--seeds 1 2] [--keep-halves DIR] [--width 320 --height 180]

Writes NAME.json (the scene at the reference's resolution) and NAME.exr.
KarisHair scenes are rendered with the ChiangHair that `hairshade.mapping`
fits to the material (as `hairshade demo` does).
"""

import argparse
import json
import os
import sys
import time

import numpy as np

import hairshade as hs
from hairshade import mitsuba as hm
from hairshade.render import rel_mse
from hairshade.scene import Scene

DENSE = os.path.join(os.path.dirname(__file__), "..", "tests", "data", "dense")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name")
    p.add_argument("scene")
    p.add_argument("--spp", type=int, default=1024, help="samples per pixel of each half")
    p.add_argument("--seeds", type=int, nargs=2, default=[1, 2], help="the halves' sampler seeds")
    p.add_argument("--keep-halves", metavar="DIR", help="also write the two halves to DIR (NAME.seedN.exr)")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=180)
    a = p.parse_args()
    with open(a.scene) as f:
        spec = json.load(f)
    spec.setdefault("camera", {})["resolution"] = [a.width, a.height]
    os.makedirs(DENSE, exist_ok=True)
    scene_path = os.path.join(DENSE, f"{a.name}.json")
    with open(scene_path, "w") as f:
        json.dump(spec, f, indent=2)
        f.write("\n")
    scene = Scene.load(scene_path)
    halves = []
    for seed in a.seeds:
        t = time.perf_counter()
        halves.append(hm.render(scene, spp=a.spp, integrator="path", max_depth=64, width=a.width,
                                height=a.height, seed=seed, progress=True))
        print(f"{a.name}: half {seed}, {hm.default_variant()}, {a.spp} spp, {time.perf_counter() - t:.0f} s")
    if a.keep_halves:
        os.makedirs(a.keep_halves, exist_ok=True)
        for seed, h in zip(a.seeds, halves):
            hs.write_exr(os.path.join(a.keep_halves, f"{a.name}.seed{seed}.exr"), h.astype(np.float32))
    ref = (0.5 * (halves[0] + halves[1])).astype(np.float32)
    hs.write_exr(os.path.join(DENSE, f"{a.name}.exr"), ref)
    print(f"{a.name}: halves relMSE {rel_mse(halves[0], halves[1]):.2e}, mean RGB {ref.reshape(-1, 3).mean(axis=0)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
