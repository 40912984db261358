"""The demo head's truth, shipped with the package
(`python/hairshade/examples/strand_head_truth.npz`, read by `hairshade.demo`):
Mitsuba 3 `path` (max_depth 64) at 640x360 of `examples/strand_head.json`,
its KarisHair drawn as the ChiangHair that `hairshade.mapping` fits, the
mean of two halves of --spp samples each (--seeds, 1 and 2), stored as float16
with the halves' relMSE against each other (the truth's own noise) and the
renderer in its metadata.

    python scripts/demo_truth.py [--spp 2048] [--variant llvm_ad_rgb] [--seeds 1,2] [--out PATH]
    python scripts/demo_truth.py --merge A.npz B.npz [--out PATH]

--merge averages two truths written with the same --spp and other seeds
into one of twice the samples, whose halves are those two. The shipped
truth: two runs of 2 x 2048 spp on the GPU machine's CPUs (seeds 1,2 and
3,4; 222 s and 218 s on 16 cores of an Intel Xeon), merged.

The reference backend is `llvm_ad_rgb` (docs/mitsuba_backends.md: on hair
`cuda_ad_rgb` renders single scattering 1.5-1.8 % dark and light between
fibers ~20 % low). On 2 cores one sample per pixel takes ~0.27 s (AMD EPYC):
2 x 2048 spp about 20 minutes; the GPU machine's 16 CPU cores are ~8x
faster.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

import hairshade as hs
import hairshade.mitsuba as hm
from hairshade.demo import SCENE, TRUTH
from hairshade.render import rel_mse

W, H = 640, 360


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=2048, help="samples per pixel of each half")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", default=TRUTH)
    ap.add_argument("--seeds", default="1,2", help="the halves' seeds")
    ap.add_argument("--halves", help="also write the two halves (float32) to this .npz")
    ap.add_argument("--merge", nargs=2, metavar="NPZ", help="average two truths written by this script")
    a = ap.parse_args()
    if a.merge:
        return merge(a.merge, a.out)
    scene = hs.Scene.load(SCENE)
    t0 = time.time()
    halves = [hm.render(scene, spp=a.spp, integrator="path", max_depth=64, width=W, height=H, variant=a.variant,
                        seed=s, passes=-(-a.spp // 256), progress=False)
              for s in map(int, a.seeds.split(","))]
    if a.halves:
        np.savez_compressed(a.halves, a=halves[0].astype(np.float32), b=halves[1].astype(np.float32))
    noise = rel_mse(halves[0], halves[1])
    truth = 0.5 * (halves[0] + halves[1])
    import mitsuba as mi
    meta = {"scene": "examples/strand_head.json", "width": W, "height": H,
            "renderer": f"Mitsuba {mi.__version__} {a.variant}, path, max_depth 64, 2 x {a.spp} spp",
            "material": "the ChiangHair that hairshade.mapping fits to the scene's KarisHair",
            "noise_halves_rel_mse": float(noise)}
    save(a.out, truth, meta)
    print(f"{a.out}: halves relMSE {noise:.2e}, mean {truth.reshape(-1, 3).mean(0)}, {time.time() - t0:.0f} s",
          file=sys.stderr)
    return 0


def save(path: str, truth: np.ndarray, meta: dict) -> None:
    t16 = truth.astype(np.float16)
    meta["stored"] = f"float16 (relMSE {rel_mse(t16.astype(np.float32), truth):.1e} against the float32 original)"
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    np.savez_compressed(path, truth=t16, meta=json.dumps(meta))


def merge(paths: list[str], out: str) -> int:
    parts = [np.load(p) for p in paths]
    metas = [json.loads(str(z["meta"])) for z in parts]
    a, b = (z["truth"].astype(np.float32) for z in parts)
    renderer = metas[0]["renderer"].rsplit(", 2 x ", 1)
    spp = int(renderer[1].split()[0]) * 2
    meta = dict(metas[0], renderer=f"{renderer[0]}, 2 x {spp} spp", noise_halves_rel_mse=float(rel_mse(a, b)))
    save(out, 0.5 * (a + b), meta)
    print(f"{out}: halves relMSE {meta['noise_halves_rel_mse']:.2e}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
