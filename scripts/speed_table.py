"""Frame time against error for the quality presets, at 320x180 and
1280x720, and what each speed-up of the accurate path costs, in one run.

    python scripts/speed_table.py [--out docs] [--repeats 2] [--heads a,b]

Each head of tests/data/dense (its settings reduced to ``quality`` alone,
as in scripts/quality_table.py) at each preset and resolution: the best of
``--repeats`` frames after one that builds the shadow maps, the lighting
and the volume solve (a camera move), its ratio to the fast preset's frame
in the same run, and its error against the converged path-traced truth:
the head's 320x180 truth, or the demo head's shipped 640x360 one, with
the 1280x720 image averaged over 4x4 or 2x2 pixels to its size. Then, at 1280x720, the speed-ups one at a time against
what they replace: split shading of every strand against per-fragment
shading (balanced),
per-vertex shading against per-fragment (fast), vertices shaded when a
tile first needs them against all in view before the tiles (fast; exact:
relMSE 0), the level of detail
``lod: "auto"`` against every strand drawn (fast), hair culled behind 2% transmittance rather than
0.1% (fast), guide-strand lighting at a tenth of the
strands (balanced, docs/guides.md), and traced shadows decided at the
strand vertices (``shadows.traced.vertices``, balanced; ChiangHair's near
field traces its own probes, so only the KarisHair heads change), each
with the relMSE between the two images.
Writes docs/speed.md and docs/speed.csv.
"""

from __future__ import annotations

import argparse
import csv
import pathlib
import sys
import time

import numpy as np

import hairshade as hs
from hairshade.bench_render import render_switched

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from quality_table import DENSE, HEADS, cpu, preset_scene  # noqa: E402

from hairshade import options  # noqa: E402

SIZES = ((320, 180), (1280, 720))


def timed(scene: hs.Scene, repeats: int, off: tuple[str, ...] = (), **settings) -> tuple[np.ndarray, float]:
    """The image and the best of `repeats` frames, after one that builds
    what the lighting needs (`off`: exact speed-ups switched off)."""
    def frame() -> np.ndarray:
        return render_switched(scene, off=off, **settings) if off else hs.render(scene, progress=False, **settings)
    img = frame()
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        frame()
        best = min(best, time.perf_counter() - t)
    return img, best


def ratio(img: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return img.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0)


def truths(name: str) -> list[np.ndarray]:
    """The head's converged truths: its 320x180 one, and for the demo head
    (the scene of `hairshade.demo`, camera and all) the shipped 640x360."""
    out = [hs.read_exr(DENSE / f"{name}.exr")[..., :3]]
    if name == "demo_head":
        from hairshade.demo import demo_truth
        out.append(demo_truth()[0])
    return out


def against(img: np.ndarray, truth: np.ndarray) -> np.ndarray | None:
    """`img` box-averaged to the truth's size where that divides it (each
    truth pixel the mean of k x k rendered ones), else None."""
    (h, w), (th, tw) = img.shape[:2], truth.shape[:2]
    if h % th or w % tw or h // th != w // tw:
        return None
    k = h // th
    return img[..., :3].reshape(th, k, tw, k, 3).mean((1, 3))


def scene_at(name: str, width: int, height: int) -> hs.Scene:
    """The dense head `name` with its settings reduced to `quality` alone,
    at `width` x `height`."""
    scene = preset_scene(name)
    scene.camera["width"], scene.camera["height"] = width, height
    return scene


def measure(heads: tuple[str, ...], repeats: int):
    presets, speedups = [], []
    for name in heads:
        refs = truths(name)
        for w, h in SIZES:
            scene = scene_at(name, w, h)
            fast_s = None
            for q in options.QUALITIES:
                img, s = timed(scene, repeats, quality=q)
                fast_s = s if q == "fast" else fast_s
                row = dict(head=name, model=scene.model, size=f"{w}x{h}", quality=q, frame_s=s,
                           per_fast=s / fast_s)
                # the largest truth this size averages down to (its error then
                # counts what the rendering misses at the truth's pixels)
                for truth in sorted(refs, key=lambda t: -t.size):
                    small = against(img, truth)
                    if small is not None:
                        r = ratio(small, truth)
                        row.update(rel_mse=hs.rel_mse(small, truth), ratio_r=r[0], ratio_g=r[1], ratio_b=r[2],
                                   truth=f"{truth.shape[1]}x{truth.shape[0]}")
                        break
                presets.append(row)
                print(f"{name:11s} {w}x{h} {q:9s} {s:.3f} s ({s / fast_s:.1f}x fast)"
                      + (f" relMSE {row['rel_mse']:.2e}" if "rel_mse" in row else ""), flush=True)
            if (w, h) != SIZES[-1]:
                continue
            for what, quality, base, fast in (
                ("split shading", "balanced", dict(shading="pixel"), dict(shading="split", guides=1.0)),
                ("vertex shading", "fast", dict(shading="pixel"), dict(shading="vertex")),
                ("vertices on demand", "fast", dict(off=("vertices_on_demand",)), dict()),
                ("lod auto", "fast", dict(lod=1.0), dict()),
                ("hair culled at 2%", "fast",
                 dict(transparency={"mlab": {**options.PRESETS["fast"]["transparency"]["mlab"],
                                             "cull_transmittance": 1e-3}}), dict()),
                ("guides 1/10", "balanced", dict(guides=1.0), dict(guides=0.1)),
                ("traced at vertices", "balanced", dict(shadows={"traced": {"vertices": False}}),
                 dict(shadows={"traced": {"vertices": True}})),
            ):
                if what == "traced at vertices" and scene.model != "karis":
                    continue  # (the near field's probes: the same image)
                a, ta = timed(scene, repeats, quality=quality, **base)
                b, tb = timed(scene, repeats, quality=quality, **fast)
                r = ratio(b, a)
                speedups.append(dict(head=name, size=f"{w}x{h}", speedup=what, quality=quality, before_s=ta,
                                     after_s=tb, rel_mse=hs.rel_mse(b, a), mean_off=float(np.abs(r - 1).max())))
                print(f"{name:11s} {what:14s} {ta:.3f} -> {tb:.3f} s, relMSE {speedups[-1]['rel_mse']:.1e}",
                      flush=True)
    return presets, speedups


def markdown(presets, speedups, command: str) -> str:
    out = ["# Frame time against error", "",
           f"Generated by `{command}` on {cpu()}. Each dense head with its settings reduced to `quality` alone "
           "(as in docs/quality.md); frame: best of the repeats after one frame that builds the shadow maps, the "
           "lighting and the volume solve (a camera move), on every core of the machine. `/ fast`: the frame over "
           "the fast preset's in the same run (absolute times move between machines; ratios less). Error: "
           "relMSE against the converged path-traced truth, and the mean per channel over the truth's; the "
           "truths are 320x180 (the demo head's also 640x360, the one `hairshade demo` ships), and a 1280x720 "
           "image is averaged over 4x4 (2x2) pixels to the largest truth's size before it is compared: its "
           "error where the truth resolves it.", ""]
    for size in dict.fromkeys(r["size"] for r in presets):
        out += [f"## {size}", "", "| head | model | quality | frame (s) | / fast | relMSE | ratio R/G/B | truth |",
                "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r in (r for r in presets if r["size"] == size):
            err = (f"{r['rel_mse']:.2e} | {r['ratio_r']:.3f}/{r['ratio_g']:.3f}/{r['ratio_b']:.3f} | {r['truth']}"
                   if "rel_mse" in r else "– | – | –")
            out.append(f"| {r['head']} | {r['model']} | `{r['quality']}` | {r['frame_s']:.3f} | "
                       f"{r['per_fast']:.1f}x | {err} |")
        out.append("")
        out += ["| quality | frame (median) | / fast (median) |", "| --- | --- | --- |"]
        for q in options.QUALITIES:
            rows = [r for r in presets if r["size"] == size and r["quality"] == q]
            out.append(f"| `{q}` | {np.median([r['frame_s'] for r in rows]):.3f} s | "
                       f"{np.median([r['per_fast'] for r in rows]):.1f}x |")
        out.append("")
    out += ["## What each speed-up costs (1280x720)", "",
            "Each against what it replaces, in the same run: relMSE between the two images, and the largest "
            "change of a channel's mean. Split shading is in `balanced` and `accurate`, guide-strand lighting at a "
            "tenth of the strands in `balanced` (measured here on split shading of every strand), traced shadows "
            "decided at the strand vertices in `balanced` (KarisHair heads only: ChiangHair's near field traces its "
            "own probes, and its images do not change), vertex shading, its vertices shaded on demand (the exact "
            "speed-up `vertices_on_demand`, against every vertex in view shaded before the tiles) and hair culled "
            "behind 2% transmittance (rather than 0.1%) and the level of detail `lod: \"auto\"` (against every strand "
            "drawn; what each fraction costs: docs/lod_tradeoff.md) in `fast`.", "",
            "| head | speed-up | quality | before (s) | after (s) | speed | relMSE | mean off by |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in speedups:
        out.append(f"| {r['head']} | {r['speedup']} | `{r['quality']}` | {r['before_s']:.3f} | {r['after_s']:.3f} | "
                   f"{r['before_s'] / r['after_s']:.1f}x | {r['rel_mse']:.1e} | {100 * r['mean_off']:.2f}% |")
    return "\n".join(out) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs", help="folder for speed.md and speed.csv (default docs)")
    ap.add_argument("--repeats", type=int, default=2, help="timed frames per configuration, best kept (>= 1)")
    ap.add_argument("--heads", default=",".join(HEADS), help="comma-separated dense heads (default all)")
    a = ap.parse_args()
    if a.repeats < 1:
        ap.error("--repeats: expected a whole number >= 1")
    heads = tuple(h for h in a.heads.split(",") if h)
    unknown = [h for h in heads if h not in HEADS]
    if unknown:
        ap.error(f"--heads: unknown {', '.join(unknown)} (allowed: {', '.join(HEADS)})")
    presets, speedups = measure(heads, a.repeats)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    command = ("python scripts/speed_table.py" + (f" --out {a.out}" if a.out != "docs" else "")
               + (f" --repeats {a.repeats}" if a.repeats != 2 else "")
               + (f" --heads {','.join(heads)}" if heads != tuple(HEADS) else ""))
    (out / "speed.md").write_text(markdown(presets, speedups, command))
    keys = ["head", "model", "size", "quality", "frame_s", "per_fast", "rel_mse", "ratio_r", "ratio_g", "ratio_b",
            "truth"]
    with open(out / "speed.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=keys + ["speedup", "before_s", "after_s", "mean_off"], restval="")
        wr.writeheader()
        for r in presets + speedups:
            wr.writerow(r)
    print(f"wrote {out / 'speed.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
