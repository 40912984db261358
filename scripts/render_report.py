"""Numbers for the README's rendering section: rasterizer frame times,
MLAB against exact sorted transparency, and rasterizer (scene material,
environment included) against Mitsuba path tracing (ChiangHair fitted to
the material, full multiple scattering).

    .venv/bin/python scripts/render_report.py
"""

import time

import flip_evaluator as flip
import numpy as np

import hairshade as hs
from hairshade import mitsuba as hm

EX = "examples/"


def timed(f, repeats=3):
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return out, best


head = hs.Scene.load(EX + "strand_head.json")
hs.render(head, width=160, height=90, progress=False)
print("| scene | resolution | rasterizer ms/frame |")
print("| --- | --- | --- |")
cards = hs.Scene.load(EX + "card_head.json")
for w, h in ((640, 360), (1280, 720)):
    _, t = timed(lambda: hs.render(head, width=w, height=h, progress=False), repeats=2)
    _, tv = timed(lambda: hs.render(head, width=w, height=h, shading="vertex", progress=False), repeats=2)
    _, tc = timed(lambda: hs.render(cards, width=w, height=h, progress=False), repeats=2)
    print(f"| strand_head (25k strands x 16 segments) | {w}x{h} | {t * 1000:.0f} (vertex shading {tv * 1000:.0f}) |")
    print(f"| card_head (600 cards x 8 segments) | {w}x{h} | {tc * 1000:.0f} |")

exact = hs.render(head, width=320, height=180, transparency="sorted", progress=False)
for k in (1, 2, 4, 8):
    img = hs.render(head, width=320, height=180, transparency="mlab", layers=k, progress=False)
    print(f"MLAB {k} layers vs sorted (head, 320x180): relMSE {hs.rel_mse(img, exact):.2e}, "
          f"max abs {np.abs(img - exact).max():.3e}")

print("\n| scene | rasterizer | Mitsuba path, 64 spp | relMSE | mean FLIP |")
print("| --- | --- | --- | --- | --- |")
for name in ("single_strand", "backlit_bundle", "strand_head", "card_head"):
    s = hs.Scene.load(EX + name + ".json")
    w, h = (320, 180)
    a, ta = timed(lambda: hs.render(s, width=w, height=h, progress=False), repeats=1)
    t = time.perf_counter()
    b = hm.render(s, spp=64, integrator="path", width=w, height=h, progress=False)
    tb = time.perf_counter() - t
    rel, f = hs.rel_mse(a, b), float(flip.evaluate(b, a, "HDR")[1])
    print(f"| {name} ({w}x{h}) | {ta * 1000:.0f} ms | {tb:.1f} s | {rel:.3e} | {f:.3f} |")
