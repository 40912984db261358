"""Guide-strand lighting (`render.guides`): error against shading every
strand and against the path-traced truth, with the per-vertex lighting time
and the frame time, at 1/4, 1/10 and 1/30 of the strands. Writes
docs/guides.md, docs/guides.csv and docs/guides.png.

    python scripts/guide_lighting.py [--repeats 3]

Heads: the dense heads and the demo head of tests/data/dense at their own
resolution (320x180), against their converged Mitsuba references. Presets:
`fast` with its per-vertex shading (guides giving everything, RE4's way, or
only the scattered terms), and `balanced` with its split shading (the guides
give the terms read at vertices).
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hairshade as hs  # noqa: E402
from doc_tables import write_csv, write_markdown  # noqa: E402
from hairshade.demo import cpu_name, preset_scene  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
DENSE = os.path.join(ROOT, "tests", "data", "dense")
HEADS = ["auburn_key", "black_top", "blond_back", "brown_side", "blond_env", "ginger_two", "demo_head"]
FRACTIONS = {"1/4": 0.25, "1/10": 0.1, "1/30": 1 / 30}
# (preset, guide_terms or None under split shading)
MODES = [("fast", "all"), ("fast", "scattered"), ("balanced", None)]


def timed(scene, repeats: int, **kw):
    """The image and stats of a render after a warm-up (maps, lighting and
    guides built), with the best frame and vertex-shading times of
    ``repeats`` more, and the warm-up's guide-choosing time."""
    _, cold = hs.render(scene, progress=False, return_stats=True, **kw)
    best = (np.inf, np.inf)
    for _ in range(repeats):
        t = time.perf_counter()
        img, st = hs.render(scene, progress=False, return_stats=True, **kw)
        best = min(best, (time.perf_counter() - t, st["vertex_ms"]))
    return img, st, best[0] * 1e3, best[1], cold["guides_ms"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(ROOT, "docs"))
    ap.add_argument("--picture-only", action="store_true", help="draw guides.png alone")
    ap.add_argument("--held-out", metavar="DIR", help="the balanced preset with and without guides on the held-out "
                    "heads whose scenes scripts/held_out_heads.py DIR --no-reference wrote (guides_held_out.md)")
    ap.add_argument("--markdown-only", action="store_true",
                    help="rewrite guides.md from the guides.csv already in --out (no rendering)")
    args = ap.parse_args()
    if args.held_out:
        _held_out(args)
        return
    if args.picture_only:
        scene = preset_scene(os.path.join(DENSE, "auburn_key.json"))
        kw = dict(quality="fast", shading="vertex", progress=False)
        pictures = {"full": hs.render(scene, **kw)}
        for terms in ("all", "scattered"):
            pictures[terms] = hs.render(scene, guides=0.1, guide_choice="every", guide_terms=terms, **kw)
        _picture(pictures, os.path.join(args.out, "guides.png"))
        return
    if args.markdown_only:
        with open(os.path.join(args.out, "guides.csv")) as fh:
            rows = [{k: (float(v) if k.startswith("rel_mse") else v) for k, v in r.items()}
                    for r in csv.DictReader(fh)]
        _markdown(rows, args, os.path.join(args.out, "guides.md"))
        return
    rows = []
    pictures = {}
    for name in HEADS:
        scene = preset_scene(os.path.join(DENSE, f"{name}.json"))
        truth = hs.read_exr(os.path.join(DENSE, f"{name}.exr"))[..., :3]
        for preset, terms in MODES:
            shading = "vertex" if preset == "fast" else "split"
            base_kw = dict(quality=preset, shading=shading, guides=1.0)  # every strand (balanced has 1/10)
            full, st, frame, vms, _ = timed(scene, args.repeats, **base_kw)
            if terms != "scattered":  # the scattered rows share the 'all' rows' full render
                rows.append(dict(head=name, preset=preset, shading=shading, terms="-", choice="-", fraction="1",
                                 guides=0, strands=st["strands_drawn"], rel_mse_full=0.0,
                                 rel_mse_truth=hs.rel_mse(full, truth), mean_full="1/1/1",
                                 vertex_ms=round(vms, 1), frame_ms=round(frame, 1), guides_ms=0.0))
                print(rows[-1], flush=True)
            for choice in ("every", "clusters"):
                for label, f in FRACTIONS.items():
                    kw = dict(base_kw, guides=f, guide_choice=choice)
                    if terms:
                        kw["guide_terms"] = terms
                    img, st, frame, vms, gms = timed(scene, args.repeats, **kw)
                    ratio = img.reshape(-1, 3).mean(0) / full.reshape(-1, 3).mean(0)
                    rows.append(dict(head=name, preset=preset, shading=shading, terms=terms or "split",
                                     choice=choice, fraction=label, guides=st["guide_strands"],
                                     strands=st["strands_drawn"], rel_mse_full=hs.rel_mse(img, full),
                                     rel_mse_truth=hs.rel_mse(img, truth),
                                     mean_full="/".join(f"{x:.3f}" for x in ratio), vertex_ms=round(vms, 1),
                                     frame_ms=round(frame, 1), guides_ms=round(gms, 1)))
                    print(rows[-1], flush=True)
                    if name == "auburn_key" and preset == "fast" and choice == "every" and label == "1/10":
                        pictures[terms] = img
            if name == "auburn_key" and preset == "fast" and terms == "all":
                pictures["full"] = full
        # level of detail and guides together: half the strands, a tenth of those guiding
        kw = dict(quality="fast", shading="vertex", lod=0.5)
        full, *_ = timed(scene, 1, **kw)
        img, st, frame, vms, gms = timed(scene, args.repeats, guides=0.1, guide_terms="all", **kw)
        rows.append(dict(head=name, preset="fast", shading="vertex, lod 0.5", terms="all", choice="every",
                         fraction="1/10", guides=st["guide_strands"], strands=st["strands_drawn"],
                         rel_mse_full=hs.rel_mse(img, full), rel_mse_truth=hs.rel_mse(img, truth),
                         mean_full="/".join(f"{x:.3f}" for x in img.reshape(-1, 3).mean(0)
                                            / full.reshape(-1, 3).mean(0)),
                         vertex_ms=round(vms, 1), frame_ms=round(frame, 1), guides_ms=round(gms, 1)))
        print(rows[-1], flush=True)
    os.makedirs(args.out, exist_ok=True)
    write_csv(os.path.join(args.out, "guides.csv"), rows)
    _picture(pictures, os.path.join(args.out, "guides.png"))
    _markdown(rows, args, os.path.join(args.out, "guides.md"))


def _held_out(args) -> None:
    """The balanced preset at guides 1, 1/4 and 1/10 on the held-out heads
    against their cached truths (tests/data/held_out): frame, relMSE
    against the truth and against guides 1, the mean over guides 1's."""
    from held_out_heads import HEADS as HELD

    truths = os.path.join(ROOT, "tests", "data", "held_out")
    lines = ["# Guide-strand lighting on the held-out heads", "",
             f"Generated by `python scripts/guide_lighting.py --held-out DIR --repeats {args.repeats}` on "
             f"{cpu_name()}, 2 threads, the scenes written by `scripts/held_out_heads.py DIR --no-reference`. "
             "The balanced preset with guides 1 (every strand's vertices), 1/4 and 1/10 (`every`, the preset's), "
             "320x180, against each head's cached Mitsuba truth (max_depth 64); frame: best of the repeats with "
             "shadow maps, lighting, volume and guides reused.", "",
             "| head | guides | frame (s) | relMSE vs truth | relMSE vs guides 1 | mean / guides 1 |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name in HELD:
        truth_path = os.path.join(truths, f"{name}.exr")
        if not os.path.exists(truth_path):
            continue
        scene = hs.Scene.load(os.path.join(args.held_out, f"{name}.json"))
        truth = hs.read_exr(truth_path)[..., :3]
        full = None
        for label, g in (("1", 1.0), ("1/4", 0.25), ("1/10", 0.1)):
            img, _, frame, _, _ = timed(scene, args.repeats, quality="balanced", guides=g)
            full = img if full is None else full
            ratio = img.reshape(-1, 3).mean(0) / full.reshape(-1, 3).mean(0)
            lines.append(f"| {name} | {label} | {frame / 1e3:.3f} | {hs.rel_mse(img, truth):.2e} | "
                         f"{hs.rel_mse(img, full):.1e} | {'/'.join(f'{x:.3f}' for x in ratio)} |")
            print(lines[-1], flush=True)
    write_markdown(os.path.join(args.out, "guides_held_out.md"), lines)


def _picture(p: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("every strand shaded", p["full"]), ("guides 1/10, all (RE4)", p["all"]),
              ("guides 1/10, scattered", p["scattered"])]
    # the same exposure for all three: the full render's 99.5th percentile at white
    exposure = -float(np.log2(np.percentile(p["full"], 99.5)))
    fig, ax = plt.subplots(1, 3, figsize=(12, 2.6))
    for a, (title, img) in zip(ax, panels):
        a.imshow(hs.tonemap(img, exposure=exposure))
        a.set_title(title, fontsize=9)
        a.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _markdown(rows: list, args, path: str) -> None:
    def fmt(r):
        return (f"| {r['head']} | {r['preset']} ({r['shading']}) | {r['terms']} | {r['choice']} | {r['fraction']} "
                f"| {r['guides']} / {r['strands']} | {r['rel_mse_full']:.2e} | {r['rel_mse_truth']:.2e} "
                f"| {r['mean_full']} | {r['vertex_ms']} | {r['frame_ms']} | {r['guides_ms']} |")

    lines = [
        "# Guide-strand lighting",
        "",
        f"Generated by `python scripts/guide_lighting.py --repeats {args.repeats}` on {cpu_name()}, 2 threads "
        "(data: `guides.csv`). Each head of `tests/data/dense` at its own 320x180 against its converged Mitsuba "
        "reference (max_depth 64). `render.guides` = f lights f of the strands (the guides) at their vertices; "
        "every other strand takes, at each vertex, the values of its 3 nearest guides (strands compared by their "
        "points at 0, 1/2 and 1 of their length, weighted by inverse squared distance) at the same fraction of "
        "their length (`src/raster/guides.rs`). `guide_choice`: every k-th strand, or the member nearest each "
        "centre of k-means clusters; `guides` may also list the guide strands' indices (a scene's own guides, "
        "such as simulation guides). Under per-vertex shading (`fast`), `guide_terms` `all` takes everything from "
        "the guides, as RE4's prototype did; `scattered` takes only what split shading reads at vertices (the "
        "environment, multiple scattering) and shades each vertex's lights' unscattered light with its own "
        "shadow. Under split shading (`balanced`) the guides give the terms read at vertices.",
        "",
        "Columns: relMSE against the same preset shading every strand (`full`) and against the truth; the mean "
        "per channel over the full render's; the per-vertex shading time (`vertex` shading: the guides' "
        "vertices and the gathering; split shading computes its vertex terms lazily inside the tiles, so only "
        "its frame time says what the guides save); the frame, best of the repeats with shadow maps, lighting "
        "and guides reused (a camera move); and the time to choose the guides and taps, paid once per geometry.",
        "",
        "![auburn_key, fast preset: every strand, guides giving everything, guides giving the scattered terms]"
        "(guides.png)",
        "",
        "What the rows say:",
        "",
        "- **Everything from the guides (RE4's way) darkens shadowed hair.** On the key-lit heads the image "
        "falls to 0.81-0.99 of the full mean with `every` at 1/4 to 1/30 of the strands, mostly lower with "
        "fewer guides, and with `clusters` at 1/30 to 0.67-0.95 (blond_env, lit mostly by its environment, keeps "
        "0.99). The strands the camera sees lie on the outside of the hair, lit more "
        "than the guides around them, most of which lie deeper; without shadows the same guides keep the mean "
        "within 1% (`tests/test_guides.py` 06). The picture above shows the flat, patchy look RE4 gave as its "
        "reason to leave the method out of the game. Per-vertex lighting is 2.5-19x faster, the frame "
        "1.4-6.4x; the error against the truth moves by less than the preset's own error on most heads, since "
        "the fast preset's error is large, but a 10-20% darkening is not a trade the presets take.",
        "- **Only the scattered terms from the guides** (`guide_terms: scattered`) is exact where nothing is "
        "scattered: with ChiangHair under `fast` (no multiple scattering) and lights alone, each strand shades "
        "its own lights and the image is the full one bit for bit (relMSE 0), so it saves nothing there. It "
        "pays where the environment is shaded as lights: blond_env's per-vertex lighting 3.4x faster at 1/10 "
        "(relMSE 1.1e-4 against the full render, the mean within 0.2%). On the demo head (KarisHair, "
        "environment through its SH lobes) it saves nothing.",
        "- **Under split shading (`balanced`)** the guides give the environment and multiple scattering read "
        "at vertices: relMSE against the full render 8e-7 to 1.1e-3 (the largest at 1/30 on backlit blond), the "
        "mean within 1% except blond_back with `clusters` at 1/30 (2.5%), and the error against the truth "
        "within 4% of itself on every head at 1/4 and 1/10 (up or down; within 7% at 1/30). The frame is 1.1-1.2x faster on the key-lit "
        "heads and 1.4-1.45x on blond_env and the demo head (their 32 environment directions per vertex) at 1/10. "
        "The `balanced` preset takes `every` at 1/10 for this; on the seven held-out heads (wavy, curly, clumped; "
        "`guides_held_out.md`) it keeps the error against the truth within 4.4% of itself (up or down) and the "
        "mean within 0.3%, the frame 1.15-1.74x faster.",
        "- `clusters` beats `every` at equal fraction in relMSE on most rows at 1/4 and 1/10, not in the mean, "
        "and costs 26-520 ms to choose (k-means, once per geometry) against 6-36 ms.",
        "- The level of detail composes: at `lod: 0.5` the guides are a tenth of the strands drawn.",
        "",
        "| head | preset (shading) | terms | choice | fraction | guides / strands | relMSE vs full | relMSE vs truth "
        "| mean / full | vertex (ms) | frame (ms) | choosing (ms) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    lines += [fmt(r) for r in rows]
    write_markdown(path, lines)


if __name__ == "__main__":
    main()
