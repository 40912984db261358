"""Multiple scattering through the hair volume against converged path tracing:
writes docs/volume.md and docs/volume.csv.

On every ChiangHair head of tests/data/dense and the three held-out heads of
scripts/held_out_heads.py (references in tests/data/held_out), each rendered
with the `accurate` preset under dual scattering and under volume
scattering, and with the `balanced` preset: the mean radiance per channel
as a ratio to the truth's, relMSE, and the multiple-scattering part alone
(the render minus the same render without multiple scattering, against the
truth minus Mitsuba at max_depth 2: `NAME_depth2.exr`, 2 x 512 spp). Then
the KarisHair demo and card heads; the white furnace (its error pixel by
pixel split into single and multiple scattering against Mitsuba's single
scattering of it, rendered here); the error against
grid resolution x photons; the cost of the solve, of a new view, and of a
36-view orbit.

    python scripts/volume_compare.py [--out docs] [--quick]
    python scripts/volume_compare.py --only transport     # docs/volume_transport.md
    python scripts/volume_compare.py --only cost          # the cost section of docs/volume.{md,csv}
    python scripts/volume_compare.py --only floor         # the convergence floor paragraph
    python scripts/volume_compare.py --only reference-noise   # the truths' noise in the MS part

`--only transport` runs one further section alone: the two transports
(`volume.transport`: photons through the fiber medium, or between the
fibers they really meet) over the grid's resolution on five heads, and in
the white furnace. `--only cost` and `--only floor` re-measure one part
of volume.md and write it in place of the old one; `--only reference-noise`
rewrites the section on the references' noise from volume.csv.
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import os
import pathlib
import platform
import sys
import tempfile
import time
import warnings

import numpy as np

import hairshade as hs

ROOT = pathlib.Path(__file__).resolve().parent.parent
DENSE = ROOT / "tests" / "data" / "dense"
HELD = ROOT / "tests" / "data" / "held_out"
sys.path.insert(0, str(ROOT / "scripts"))
import held_out_heads  # noqa: E402

CHIANG = ("auburn_key", "blond_back", "black_top", "brown_side", "blond_env", "ginger_two")
KARIS = ("demo_head", "card_head")
W, H = 320, 180
#: The curve every truth here traces: Mitsuba's `bsplinecurve` of the strands' vertices, ends tripled
#: (tests/data/dense/README.md, tests/data/held_out/README.md). The scene files draw the polyline through
#: the same vertices; a head is compared with its truth drawn as the truth's own curve, cut where a
#: segment's projected Manhattan length would pass 8 pixels (docs/curves.md: the bound past which finer
#: cutting changes the error little). The accuracy section also gives the scene files' polyline.
TRUTH_CURVE = {"bspline": {"pixels": 8}}
# the furnace's single scattering in Mitsuba: samples per half, two halves (the mean's noise per
# pixel, 0.0049 rms, is a ninth of the render's single-scattering error against it, 0.045:
# docs/volume.md); and the Gaussian (in pixels) the errors are smoothed over
FURNACE_SPP = 2048
SMOOTH_PX = 2


def cpu() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def mean(a: np.ndarray) -> np.ndarray:
    return a.reshape(-1, 3).mean(0)


def ratio(a: np.ndarray, b: np.ndarray) -> str:
    r = mean(a) / mean(b)
    return "/".join(f"{x:.3f}" for x in r)


def scene_without_settings(path: pathlib.Path, tmp: str, material: dict | None = None,
                           generate: dict | None = None, curve: dict | str | None = None) -> hs.Scene:
    """The scene of `path` with its render section emptied, so that the
    quality preset alone decides (and its material's keys in `material`,
    its generated groom's in `generate`, replaced; its strands drawn as
    `curve` when given: `hair.curve`)."""
    d = json.loads(path.read_text())
    d["render"] = {}
    hair = d["hair"]
    if curve is not None and not hair.keys() & {"cards", "generate_cards"}:
        hair["curve"] = curve
    if "file" in hair:
        hair["file"] = str((path.parent / hair["file"]).resolve())
    hair["material"].update(material or {})
    if generate:
        hair["generate"].update(generate)
    out = os.path.join(tmp, ("edited_" if material or generate or curve else "") + path.name)
    with open(out, "w") as f:
        json.dump(d, f)
    return hs.Scene.load(out)


def timed(scene, **kw):
    t = time.perf_counter()
    img, st = hs.render(scene, W, H, return_stats=True, **kw)
    return img, st, time.perf_counter() - t


def heads(tmp: str) -> list[tuple[str, pathlib.Path, pathlib.Path]]:
    """(name, scene file, reference directory) of every ChiangHair head
    with a truth and its max_depth-2 render."""
    out = [(n, DENSE / f"{n}.json", DENSE) for n in CHIANG]
    for n in held_out_heads.HEADS:
        if (HELD / f"{n}.exr").exists() and (HELD / f"{n}_depth2.exr").exists():
            out.append((n, pathlib.Path(held_out_heads.write_head(tmp, n)), HELD))
        else:
            print(f"{n}: no reference in {HELD}, left out", flush=True)
    return out


def accuracy(tmp: str, rows: list, md: list) -> None:
    md += ["## Accuracy: ChiangHair heads", "",
           "Mean radiance per channel as a ratio to the truth (R/G/B), relMSE, and the multiple-scattering "
           "part alone (render minus the same render without multiple scattering, over the truth minus "
           "Mitsuba at max_depth 2; for dual, the render without it reads dual's coarser environment count grid), "
           "and the single scattering (the render without multiple scattering) over "
           "Mitsuba's max_depth 2: what of the error is not the multiple scattering's. Targets: `accurate` within "
           "5% per channel, relMSE <= 3e-3, MS part within 10%; `balanced` within 10% and relMSE <= 5e-3. "
           "Each head is drawn as the curve its truth traces (`hair.curve: {\"bspline\": {\"pixels\": 8}}`: "
           "the B-spline of the strands' vertices, ends tripled); the next table draws the scene files' own "
           "polyline through the same vertices.", "",
           "| head | preset, multiple scattering | mean / truth | relMSE | MS part / truth's | single / max_depth 2 "
           "| frame s |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    polyline = ["", "The same heads drawn as their scene files' polyline (`accurate`, volume): the geometry "
                "differs from the truth's by the B-spline's cut corners, so this is not the method's error alone.",
                "", "| head | mean / truth | relMSE | single / max_depth 2 | frame s |", "| --- | --- | --- | --- | --- |"]
    for name, path, refdir in heads(tmp):
        ref = hs.read_exr(str(refdir / f"{name}.exr"))
        depth2 = hs.read_exr(str(refdir / f"{name}_depth2.exr"))
        poly = scene_without_settings(path, tmp)
        img, _, dt = timed(poly, quality="accurate", multiple_scattering="volume")
        none = hs.render(poly, W, H, quality="accurate", multiple_scattering="none")
        e, single = hs.rel_mse(img, ref), ratio(none, depth2)
        rows.append(dict(section="accuracy polyline", head=name, config="accurate, volume", ratio=ratio(img, ref),
                         relmse=f"{e:.2e}", single_ratio=single, seconds=f"{dt:.2f}"))
        polyline.append(f"| {name} | {ratio(img, ref)} | {e:.2e} | {single} | {dt:.2f} |")
        print(f"{name:20s} polyline {ratio(img, ref)} relMSE {e:.2e} single {single} {dt:.2f}s", flush=True)
        sc = scene_without_settings(path, tmp, curve=TRUTH_CURVE)
        base, _, _ = timed(sc, quality="accurate", multiple_scattering="none")
        balanced_none = hs.render(sc, W, H, quality="balanced", multiple_scattering="none")
        # dual scattering reads the environment's fiber counts from a grid at a quarter of the density
        # resolution, the others at half (env_light::grid_resolution): its render without multiple
        # scattering halves the density resolution to read the same grid (without an environment there is
        # no grid, and the option is refused)
        try:
            dual_none = hs.render(sc, W, H, quality="accurate", multiple_scattering="none",
                                  density_resolution=sc.options(quality="accurate")["density_resolution"] // 2)
        except hs.SceneError:
            dual_none = base
        for label, kw in (("accurate, dual", dict(quality="accurate", multiple_scattering="dual")),
                          ("accurate, volume", dict(quality="accurate", multiple_scattering="volume")),
                          ("balanced (the default)", dict(quality="balanced"))):
            img, st, dt = timed(sc, **kw)
            none = balanced_none if label.startswith("balanced") else dual_none if label.endswith("dual") else base
            ms = ratio(img - none, ref - depth2)
            single = ratio(none, depth2)
            e = hs.rel_mse(img, ref)
            rows.append(dict(section="accuracy", head=name, config=label, ratio=ratio(img, ref), relmse=f"{e:.2e}",
                             ms_ratio=ms, single_ratio=single, seconds=f"{dt:.2f}"))
            md.append(f"| {name} | {label} | {ratio(img, ref)} | {e:.2e} | {ms} | {single} | {dt:.2f} |")
            print(f"{name:20s} {label:18s} {ratio(img, ref)} relMSE {e:.2e} MS {ms} single {single} {dt:.2f}s",
                  flush=True)
    md += polyline + [""]


# The references' own noise, as measured when they were rendered: relMSE
# between two independent halves of the max_depth-64 truth and of the
# max_depth-2 render (tests/data/dense/README.md, tests/data/held_out/README.md).
HALVES_RELMSE = {
    "auburn_key": (9.8e-5, 1.1e-4), "blond_back": (1.1e-3, 9.8e-4), "black_top": (7.6e-5, 2.9e-4),
    "blond_env": (6.2e-4, 5.0e-4), "brown_side": (1.5e-4, 2.7e-4), "ginger_two": (5.9e-4, 8.7e-4),
    "wavy_blond_rim": (6.4e-4, 5.1e-4), "curly_auburn_point": (4.9e-4, 3.7e-4), "wavy_black_env": (3.0e-4, 5.8e-4),
    "clumped_blond_key": (6.3e-4, 2.0e-4), "curly_blond_env": (1.1e-3, 5.5e-4), "wavy_ginger_back": (3.9e-4, 4.6e-4),
    "straight_brown_back": (2.0e-4, 3.8e-4),
}


def ms_part_noise(ref: np.ndarray, depth2: np.ndarray, halves: tuple[float, float]) -> np.ndarray:
    """Standard error per channel of the truth's multiple-scattering mean
    (the truth's mean less the max_depth-2 render's), over that mean. A
    reference that is the mean of two halves whose relMSE is h has, per
    pixel, variance h (r^2 + 0.01) / 4 (relMSE's weighting, taken as the
    same relative noise in every pixel); pixels are independent (Mitsuba's
    box filter); the two renders are independent."""
    var = sum(h * (img[..., :3].reshape(-1, 3).astype(np.float64) ** 2 + 0.01) / 4
              for img, h in ((ref, halves[0]), (depth2, halves[1])))
    n = var.shape[0]
    ms = mean(ref) - mean(depth2)
    return np.sqrt(var.sum(0)) / n / ms


def reference_noise(rows: list, md: list) -> None:
    """The section on how well each truth knows its multiple-scattering
    part (from the accuracy section's `accurate, volume` rows among
    `rows`): its share of the truth, its standard error, and whether the
    accurate preset's miss or hit of the 10% target stands beyond twice
    that error (two halves of a reference differ by about twice the
    standard error of their mean)."""
    md += ["## The references' noise in the multiple-scattering part", "",
           "This section alone: `--only reference-noise` (it reads the accuracy rows of volume.csv). The "
           "multiple-scattering part is the truth less Mitsuba's max_depth 2; where it is a small share of the "
           "image, both renders' noise is large against it. Per channel (R/G/B): the part's share of the truth's "
           "mean; the standard error of its mean over the part (each reference's noise from the relMSE of its two "
           "halves, taken as the same relative noise in every pixel; box-filtered pixels are independent); the "
           "`accurate` volume render's part over it (the accuracy table); and per channel whether that ratio is "
           "resolved against the 10% target: `met` or `missed` where |ratio - 1| is below or above 0.1 by more "
           "than twice the standard error, `noise` where it is not.", "",
           "| head | MS share of the truth | standard error / MS | accurate MS / truth's | verdict |",
           "| --- | --- | --- | --- | --- |"]
    fmt = lambda a: "/".join(f"{x:.3f}" for x in a)  # noqa: E731
    for r in (r for r in rows if r["section"] == "accuracy" and r["config"] == "accurate, volume"):
        name = r["head"]
        refdir = DENSE if (DENSE / f"{name}.exr").exists() else HELD
        ref = hs.read_exr(str(refdir / f"{name}.exr"))
        depth2 = hs.read_exr(str(refdir / f"{name}_depth2.exr"))
        share = (mean(ref) - mean(depth2)) / mean(ref)
        se = ms_part_noise(ref, depth2, HALVES_RELMSE[name])
        ms = np.array([float(x) for x in r["ms_ratio"].split("/")])
        off = np.abs(ms - 1)
        verdict = ["met" if o + 2 * e * m < 0.1 else "missed" if o - 2 * e * m > 0.1 else "noise"
                   for o, e, m in zip(off, se, ms)]
        md.append(f"| {name} | {fmt(share)} | {fmt(se)} | {r['ms_ratio']} | {'/'.join(verdict)} |")
    md.append("")


def karis(tmp: str, rows: list, md: list) -> None:
    md += ["## KarisHair: the demo and card heads", "",
           "The truth renders the ChiangHair that `hairshade.mapping` fits to the KarisHair material "
           "(`tests/data/dense/README.md`); demo_head's strands drawn as the truth's B-spline (card_head has "
           "cards).", "",
           "| head | multiple scattering | mean / truth | relMSE | frame s |", "| --- | --- | --- | --- | --- |"]
    for name in KARIS:
        ref = hs.read_exr(str(DENSE / f"{name}.exr"))
        sc = scene_without_settings(DENSE / f"{name}.json", tmp, curve=TRUTH_CURVE)
        for ms in ("karis", "dual", "volume"):
            img, st, dt = timed(sc, quality="accurate", multiple_scattering=ms)
            e = hs.rel_mse(img, ref)
            rows.append(dict(section="karis", head=name, config=ms, ratio=ratio(img, ref), relmse=f"{e:.2e}",
                             seconds=f"{dt:.2f}"))
            md.append(f"| {name} | {ms} | {ratio(img, ref)} | {e:.2e} | {dt:.2f} |")
            print(f"{name:20s} {ms:18s} {ratio(img, ref)} relMSE {e:.2e} {dt:.2f}s", flush=True)
    md.append("")


def furnace(tmp: str, rows: list, md: list, quick: bool) -> None:
    d = json.loads((DENSE / "blond_env.json").read_text())
    d["meshes"] = []
    d["lights"] = [{"type": "environment", "radiance": [1.0, 1.0, 1.0]}]
    d["hair"]["material"].update(eumelanin=0.0, pheomelanin=0.0)
    d["render"] = {}
    white = os.path.join(tmp, "furnace.json")
    json.dump(d, open(white, "w"))
    d["hair"]["material"].update(eumelanin=8.0)
    black = os.path.join(tmp, "furnace_black.json")
    json.dump(d, open(black, "w"))
    # hair pixels: where near-black fibers hide at least 70% of the white environment
    mask = hs.render(hs.Scene.load(black), W, H, quality="accurate", multiple_scattering="none").mean(-1) < 0.3
    md += ["## Energy: the white furnace", "",
           "White fibers (no absorption) under a white constant environment, no head: every hair pixel should "
           f"be 1. Hair pixels: {int(mask.sum())} (near-black fibers hide at least 70% of the environment there). "
           "`accurate`; the volume also with more photons than its 2^21 a light.",
           "", "| multiple scattering | mean | 5th / 95th percentile | within 2% | min | max | non-finite |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    sc = hs.Scene.load(white)
    # (label, multiple scattering, the volume's photons a light: 2^21 is `accurate`'s)
    configs = [("none", "none", 0), ("dual", "dual", 0), ("volume", "volume", 21),
               ("volume, 2^22 photons", {"volume": {"photons": 1 << 22}}, 22)]
    if not quick:
        configs.append(("volume, 2^24 photons", {"volume": {"photons": 1 << 24}}, 24))
    images = {}
    for label, ms, _ in configs:
        img = hs.render(sc, W, H, quality="accurate", multiple_scattering=ms)
        images[label] = img.mean(-1)
        v = images[label][mask]
        within = 100 * np.mean(np.abs(v - 1) < 0.02)
        p5, p95 = np.percentile(v, [5, 95])
        bad = int((~np.isfinite(img)).sum())
        rows.append(dict(section="furnace", config=label, ratio=f"{v.mean():.3f}", within=f"{within:.1f}"))
        md.append(f"| {label} | {v.mean():.3f} | {p5:.3f} / {p95:.3f} | {within:.1f}% | {img.min():.3f} | "
                  f"{img.max():.3f} | {bad} |")
        print(f"furnace {label}: mean {v.mean():.3f} within 2% {within:.1f}%", flush=True)
    # Where the volume's error lies: a hair pixel's multiple scattering should be 1 minus its single
    # scattering (the render without it, the environment seen between the fibers included).
    single = images["none"][mask]
    edges = (0.0, 0.1, 0.2, 0.4, 1.01)
    md += ["", "The volume's multiple scattering over what it should be (1 minus the render without it), "
           "by the pixel's single scattering (in parentheses: the share of the hair pixels). Where the rows "
           "agree across photon counts, these means are a bias of the method, not the photons' noise; the "
           "pixels' spread about them is partly noise (below).", "",
           "| photons | " + " | ".join(f"single {a:.1f}-{min(b, 1.0):.1f}" for a, b in zip(edges, edges[1:])) + " |",
           "| --- |" + " --- |" * (len(edges) - 1)]
    volumes = [c for c in configs if c[2]]
    for label, _, photons in volumes:
        ms_part = images[label][mask] - single
        cells = []
        for a, b in zip(edges, edges[1:]):
            sel = (single >= a) & (single < b)
            cells.append(f"{ms_part[sel].mean() / (1 - single[sel]).mean():.3f} ({100 * sel.mean():.0f}%)"
                         if sel.any() else "–")
        md.append(f"| 2^{photons} | " + " | ".join(cells) + " |")
    md.append("")
    furnace_parts(sc, mask, images, volumes, md)


def furnace_parts(sc: hs.Scene, mask: np.ndarray, images: dict, volumes: list, md: list) -> None:
    """The furnace's error pixel by pixel, split into its two parts against
    Mitsuba's single scattering (path, max_depth 2, in two halves), and the
    multiple scattering's error split into noise and a floor by its fall
    with the photons."""
    from scipy.ndimage import gaussian_filter

    from hairshade.mitsuba.scene import render as mitsuba_render

    halves = [mitsuba_render(sc, spp=FURNACE_SPP, integrator="path", max_depth=2, width=W, height=H, seed=s,
                             progress=False).mean(-1) for s in (0, 1)]
    truth_single = (halves[0] + halves[1]) / 2
    weight = gaussian_filter(mask.astype(float), SMOOTH_PX)

    def smoothed_std(e: np.ndarray) -> float:
        # the error averaged over a few pixels (Gaussian, over hair pixels only): what varies at the
        # scale of the volume's cells (about 5 pixels here) rather than from strand to strand
        s = gaussian_filter(np.where(mask, e, 0.0), SMOOTH_PX) / np.maximum(weight, 1e-6)
        return float(s[mask].std())

    def row(label: str, e: np.ndarray) -> tuple[str, float]:
        v = e[mask]
        sm = smoothed_std(e)
        return (f"| {label} | {v.mean():+.4f} | {np.sqrt(np.mean(v ** 2)):.4f} | {sm:.4f} | "
                f"{100 * np.mean(np.abs(v) < 0.02):.1f}% |", sm)

    single = images["none"]
    md += ["Where the spread comes from, pixel by pixel: the render without multiple scattering against "
           f"Mitsuba's single scattering (`path`, max_depth 2, 2 x {FURNACE_SPP} spp; its mean over the hair "
           f"pixels {truth_single[mask].mean():.4f}, the render's {single[mask].mean():.4f}), and the volume's "
           "multiple scattering (the render less the one without it) against 1 minus Mitsuba's single "
           "scattering. Smoothed: the standard deviation of the error averaged over a Gaussian of "
           f"{SMOOTH_PX} pixels, what varies at the scale of the volume's cells.", "",
           "| part | mean error | rms | smoothed std | within 2% |", "| --- | --- | --- | --- | --- |"]
    md.append(row("Mitsuba's own noise (its halves' difference / 2)", (halves[0] - halves[1]) / 2)[0])
    md.append(row("single scattering", single - truth_single)[0])
    spread = {}
    for label, _, photons in volumes:
        ms_error = images[label] - single - (1 - truth_single)
        text, spread[photons] = row(f"multiple scattering, 2^{photons} photons", ms_error)
        md.append(text)
    for label, _, photons in volumes:
        md.append(row(f"total, 2^{photons} photons", images[label] - 1)[0])
    # noise falls as 1/sqrt(photons), a floor does not: s(N)^2 = floor^2 + noise(2^20)^2 * 2^20 / N, from
    # the fewest and the most photons
    lo, hi = min(spread), max(spread)
    k = 2.0 ** (lo - hi)
    noise2 = (spread[lo] ** 2 - spread[hi] ** 2) / (1 - k)
    floor = np.sqrt(max(spread[lo] ** 2 - noise2, 0.0))
    md += ["", f"The smoothed multiple-scattering error is {spread[lo]:.4f} at 2^{lo} photons and "
           f"{spread[hi]:.4f} at 2^{hi}. Noise falls as one over the square root of the photons, a bias does "
           f"not: fitted to those two, the noise is {np.sqrt(max(noise2, 0.0)) * 2 ** ((lo - 20) / 2):.4f} at "
           f"2^20 photons and the floor {floor:.4f}. Both are larger than the 2% the target allows, and so is "
           "the single scattering's error (the environment's 32 directions, each dimmed by its fiber count "
           "rather than by the strands a ray meets).", ""]


CONVERGENCE_HEADS = ("blond_env", "blond_back")
#: The convergence grid (cells a side, photons a light); its last pair is the finest, the floor's.
CONVERGENCE_CELLS = (32, 48, 64, 96)
CONVERGENCE_PHOTONS = (1 << 16, 1 << 18, 1 << 20, 1 << 22)


def convergence_head(name: str, tmp: str):
    """A convergence head's truth, its max_depth-2 render, the scene drawn as
    the truth's B-spline, and `accurate` without multiple scattering."""
    ref = hs.read_exr(str(DENSE / f"{name}.exr"))
    depth2 = hs.read_exr(str(DENSE / f"{name}_depth2.exr"))
    sc = scene_without_settings(DENSE / f"{name}.json", tmp, curve=TRUTH_CURVE)
    return ref, depth2, sc, hs.render(sc, W, H, quality="accurate", multiple_scattering="none")


def convergence(tmp: str, rows: list, md: list, quick: bool) -> None:
    md += ["## Convergence: grid resolution x photons", "",
           "blond_env and blond_back, `accurate` with volume scattering, drawn as the truth's B-spline; relMSE "
           "against the truth, and the "
           "multiple-scattering part's mean over the truth's. `accurate` solves 2^21 photons a light on 96 cells "
           "a side.", "",
           "| head | cells a side | photons per light | relMSE | MS part / truth's | solve s |",
           "| --- | --- | --- | --- | --- | --- |"]
    floors = []
    for name in CONVERGENCE_HEADS:
        ref, depth2, sc, none = convergence_head(name, tmp)
        errors = {}
        for res in ((48,) if quick else CONVERGENCE_CELLS):
            for photons in (CONVERGENCE_PHOTONS[:2] if quick else CONVERGENCE_PHOTONS):
                img, st, dt = timed(sc, quality="accurate",
                                    multiple_scattering={"volume": {"resolution": res, "photons": photons}})
                e = hs.rel_mse(img, ref)
                errors[res, photons] = e
                ms = ratio(img - none, ref - depth2)
                rows.append(dict(section="convergence", head=name, config=f"{res}/{photons}", relmse=f"{e:.2e}",
                                 ms_ratio=ms, seconds=f"{st['volume_ms'] / 1000:.2f}"))
                md.append(f"| {name} | {res} | {photons} | {e:.2e} | {ms} | {st['volume_ms'] / 1000:.2f} |")
                print(f"convergence {name} {res} {photons}: {e:.2e} MS {ms}", flush=True)
        finest = max(errors)
        floors.append(floor_of(name, ref, depth2, none, errors[finest], finest))
    md += ["", floor_text(floors), ""]


def floor_of(name, ref, depth2, none, error, finest) -> str:
    """The finest setting's relMSE against the truth and the part of it the
    single scattering alone makes: its error against Mitsuba's max_depth 2
    weighted as relMSE weights the total's (by the truth), so that the two
    add up when the multiple scattering's error is independent of it."""
    part = float(np.mean((none - depth2) ** 2 / (ref ** 2 + 0.01)))
    return (f"{name}: {error:.2e} at {finest[0]} cells and 2^{finest[1].bit_length() - 1} photons, of which "
            f"the single scattering alone makes {part:.2e}")


def floor_text(floors: list) -> str:
    return ("The floor (this paragraph alone: `--only floor`): " + "; ".join(floors)
            + " (the render without multiple scattering against Mitsuba's max_depth 2, weighted by the truth as "
            "relMSE is). The single scattering's error is the near field "
            "sampled at the coverage samples' offsets and the rim's glints (a few pixels where light passes "
            "through the backlit fibers; `docs/single_resolution.md`), and does not fall with the grid or the "
            "photons. Coarse cells average the light over fibers deeper in the hair than those seen, so the "
            "multiple scattering rises towards the truth's as the cells shrink; fewer photons a cell then add "
            "noise, which more photons take away.")


def floor_only(tmp: str, out: pathlib.Path) -> None:
    """The convergence section's floor paragraph alone, written into an
    existing volume.md in place of its own (`--only floor`)."""
    floors = []
    for name in CONVERGENCE_HEADS:
        ref, depth2, sc, none = convergence_head(name, tmp)
        finest = (CONVERGENCE_CELLS[-1], CONVERGENCE_PHOTONS[-1])
        img = hs.render(sc, W, H, quality="accurate",
                        multiple_scattering={"volume": {"resolution": finest[0], "photons": finest[1]}})
        floors.append(floor_of(name, ref, depth2, none, hs.rel_mse(img, ref), finest))
        print(floors[-1], flush=True)
    page = (out / "volume.md").read_text().splitlines()
    at = [i for i, line in enumerate(page) if line.startswith("The floor")]
    if len(at) != 1:
        raise SystemExit(f"{out / 'volume.md'}: expected one floor paragraph, found {len(at)}")
    page[at[0]] = floor_text(floors)
    (out / "volume.md").write_text("\n".join(page) + "\n")


def reference_noise_only(out: pathlib.Path) -> None:
    """The references' noise section alone (`--only reference-noise`),
    from the accuracy rows of an existing volume.csv, written into
    volume.md in place of its own (or before the KarisHair section)."""
    with open(out / "volume.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    md: list = []
    reference_noise(rows, md)
    write_section(out / "volume.md", md, before="## KarisHair")


def write_section(path: pathlib.Path, md: list, before: str) -> None:
    """The section `md` (its first line the heading) written into the page
    at `path` in place of the section of that heading (up to the next
    `## ` heading or the end), or, where the page has none, before the
    line that starts with `before`."""
    page = path.read_text().splitlines()
    start = [i for i, line in enumerate(page) if line == md[0]]
    if start:
        end = next((i for i in range(start[0] + 1, len(page)) if page[i].startswith("## ")), len(page))
        page[start[0]:end] = md
    else:
        at = [i for i, line in enumerate(page) if line.startswith(before)]
        if len(at) != 1:
            raise SystemExit(f"{path}: expected one '{before}' line, found {len(at)}")
        page[at[0]:at[0]] = md
    path.write_text("\n".join(page) + "\n")


def cost_only(tmp: str, out: pathlib.Path) -> None:
    """The cost section alone (`--only cost`): written into an existing
    volume.md in place of its own (the last section), and its rows into
    volume.csv in place of the cost and orbit rows."""
    rows: list = []
    md: list = []
    cost(tmp, rows, md)
    write_section(out / "volume.md", md, before="## Cost")
    with open(out / "volume.csv", newline="") as f:
        old = [r for r in csv.DictReader(f) if r["section"] not in ("cost", "orbit")]
    keys = sorted({k for r in old + rows for k in r})
    with open(out / "volume.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, restval="")
        w.writeheader()
        w.writerows(old + rows)


TRANSPORT_HEADS = ("auburn_key", "black_top", "blond_back", "clumped_blond_key", "wavy_blond_rim")


def transport(tmp: str, rows: list, md: list) -> None:
    md += ["## The two transports over the grid's resolution", "",
           "`accurate` with volume scattering, 2^18 photons per light; `medium`: photons fly through the oriented "
           "fiber medium calibrated against the strands; `strands` (the default): between the fibers they really "
           "meet, traced through the strands (the transport of the reference, to the event's position within a "
           "fiber radius), the medium only holding the tallies, and each fiber reading only the light other "
           "strands scattered. The multiple-scattering part's mean over the "
           "truth's, relMSE against the truth, and the solve's time.", "",
           "| head | transport | cells a side | mean / truth | relMSE | MS part / truth's | solve s |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    by_name = {n: (p, d) for n, p, d in heads(tmp)}
    for name in TRANSPORT_HEADS:
        path, refdir = by_name[name]
        ref = hs.read_exr(str(refdir / f"{name}.exr"))
        depth2 = hs.read_exr(str(refdir / f"{name}_depth2.exr"))
        sc = scene_without_settings(path, tmp)
        none = hs.render(sc, W, H, quality="accurate", multiple_scattering="none")
        for tr in ("medium", "strands"):
            for res in (48, 96, 128):
                img, st, _ = timed(sc, quality="accurate",
                                   multiple_scattering={"volume": {"resolution": res, "transport": tr}})
                e = hs.rel_mse(img, ref)
                ms = ratio(img - none, ref - depth2)
                solve = st["volume_ms"] / 1000
                rows.append(dict(section="transport", head=name, config=f"{tr}/{res}", ratio=ratio(img, ref),
                                 relmse=f"{e:.2e}", ms_ratio=ms, seconds=f"{solve:.2f}"))
                md.append(f"| {name} | {tr} | {res} | {ratio(img, ref)} | {e:.2e} | {ms} | {solve:.2f} |")
                print(f"transport {name} {tr} {res}: {ratio(img, ref)} {e:.2e} MS {ms} solve {solve:.2f}s",
                      flush=True)
    md.append("")


def cost(tmp: str, rows: list, md: list) -> None:
    name = "blond_back"
    md += ["## Cost", "", f"This section alone: `--only cost`. {name} (10k strands x 16 segments, two directional "
           "lights), `accurate` and "
           "`balanced` as the scene file draws it (the polyline), and `balanced` drawn as the truth's B-spline "
           "(the accuracy section's curve), 320x180: solves best of 3 (a material's first solve once); frames without multiple "
           "scattering and with the solve reused alternated, 7 of each, medians (the ratio: the median of the "
           "7 pairs' ratios, which a shared machine's slow spells move less than two separate bests). The solve is kept while geometry, lights, material and settings "
           "stay: a new view reads it again. The fiber's response table is kept per material and the "
           "medium (built from the strands alone) per groom: the solve of a new light reads both, a "
           "material's first solve also builds the table, a groom's first solve also builds the medium (the "
           "same head grown from another seed; the last two columns). Targets: the solve at most 0.5 s per "
           "light; a new view at most 1.5x the same frame without multiple scattering.", "",
           "| preset | curve | solve s (per light) | frame without MS s | frame, solve reused s | ratio "
           "| first solve of a material s | first solve of a groom s |",
           "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    hair = json.loads((DENSE / f"{name}.json").read_text())["hair"]
    beta_m, seed = hair["material"]["longitudinal_roughness"], hair["generate"]["seed"]
    for k, (q, curve) in enumerate((("balanced", None), ("accurate", None), ("balanced", TRUTH_CURVE))):
        label = "B-spline, 8 px" if curve else "polyline"
        sc = scene_without_settings(DENSE / f"{name}.json", tmp, curve=curve)
        # a material of its own (roughness changed in the fourth digit), so that its table is built
        edited = scene_without_settings(DENSE / f"{name}.json", tmp, {
            "longitudinal_roughness": beta_m + 1e-4 * (k + 1)}, curve=curve)
        _, st_first, _ = timed(edited, quality=q, multiple_scattering="volume")
        first = st_first["volume_ms"] / 1000
        # a groom of its own (the generator's seed changed), so that its medium is built
        regroomed = scene_without_settings(DENSE / f"{name}.json", tmp, generate={"seed": seed + k + 1},
                                           curve=curve)
        _, st_groom, _ = timed(regroomed, quality=q, multiple_scattering="volume")
        groom = st_groom["volume_ms"] / 1000
        # solves of their own (the preset's photons changed by a few, so that no earlier solve is
        # reused), best of 3
        photons = sc.options(quality=q)["volume_photons"]
        solve = np.inf
        for extra in (1, 2, 3):
            ms = {"volume": {"photons": photons + extra + 10 * k}}
            _, st, _ = timed(sc, quality=q, multiple_scattering=ms)
            solve = min(solve, st["volume_ms"] / 1000)
        pairs = [(timed(sc, quality=q, multiple_scattering="none")[2], timed(sc, quality=q, multiple_scattering=ms)[2])
                 for _ in range(7)]
        t_none = float(np.median([p[0] for p in pairs]))
        t_vol = float(np.median([p[1] for p in pairs]))
        new_view = float(np.median([p[1] / p[0] for p in pairs]))
        rows.append(dict(section="cost", config=f"{q}, {label}", seconds=f"{solve:.2f}", ratio=f"{new_view:.2f}",
                         first_solve_seconds=f"{first:.2f}", groom_solve_seconds=f"{groom:.2f}"))
        md.append(f"| {q} | {label} | {solve:.2f} ({solve / len(sc.lights):.2f}) | {t_none:.2f} | {t_vol:.2f} | "
                  f"{new_view:.2f} | {first:.2f} ({first / len(sc.lights):.2f}) | "
                  f"{groom:.2f} ({groom / len(sc.lights):.2f}) |")
        print(f"cost {q} {label}: solve {solve:.2f}s (first {first:.2f}s, groom {groom:.2f}s) none {t_none:.2f}s "
              f"reused {t_vol:.2f}s", flush=True)
    # the orbit: auburn_key, its camera turned about the vertical through
    # the target in 36 steps; truths at view 0 and view 9 (90 degrees)
    name = "auburn_key"
    sc = scene_without_settings(DENSE / f"{name}.json", tmp)
    truths = {0: hs.read_exr(str(DENSE / f"{name}.exr")), 9: hs.read_exr(str(DENSE / f"{name}_view9.exr"))}
    cam = dict(sc.camera)
    target = np.array(cam["target"], float)
    pos = np.array(cam["position"], float) - target
    t0 = time.perf_counter()
    errors = {}
    ms = {"volume": {"photons": (1 << 18) + 3}}
    for k in range(36):
        a = 2 * np.pi * k / 36
        c, s = np.cos(a), np.sin(a)
        p = np.array([c * pos[0] + s * pos[2], pos[1], -s * pos[0] + c * pos[2]]) + target
        sc.camera = dict(cam, position=p.tolist())
        img = hs.render(sc, W, H, quality="balanced", multiple_scattering=ms)
        if k in truths:
            errors[k] = (hs.rel_mse(img, truths[k]), ratio(img, truths[k]))
    total = time.perf_counter() - t0
    for k, (e, r) in errors.items():
        rows.append(dict(section="orbit", head=name, config=f"view {k}", seconds=f"{total:.2f}", relmse=f"{e:.2e}",
                         ratio=r))
    md += ["", f"36-view orbit about {name} (`balanced`, volume scattering; one solve, then 35 views reading "
           f"it): {total:.1f} s in all, {total / 36:.2f} s a view. Against the truth at view 0 (the reference's "
           f"camera): relMSE {errors[0][0]:.2e}, mean {errors[0][1]}; at view 9 (turned 90 degrees, "
           f"`{name}_view9.exr`, Mitsuba path max_depth 64, 2 x 512 spp): relMSE {errors[9][0]:.2e}, mean "
           f"{errors[9][1]}.", ""]
    print(f"orbit: {total:.1f}s {errors}", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--quick", action="store_true", help="fewer convergence points")
    ap.add_argument("--only", choices=["transport", "floor", "cost", "reference-noise"],
                    help="transport: run that section alone, into docs/volume_transport.md; floor: the convergence "
                         "section's floor paragraph alone, written into docs/volume.md; cost: the cost section "
                         "alone, written into docs/volume.md and volume.csv; reference-noise: the section on the "
                         "references' noise in the multiple-scattering part, from volume.csv")
    a = ap.parse_args()
    warnings.simplefilter("ignore", DeprecationWarning)
    rows: list = []
    md = ["# Multiple scattering through the hair volume", "",
          f"Generated by `python scripts/volume_compare.py` on {cpu()}, {os.cpu_count()} cores "
          f"(SIMD {hs._native.simd_level()}). Truth: Mitsuba 3 `path`, max_depth 64 "
          "(`tests/data/dense/README.md`, `tests/data/held_out/README.md`).", ""]
    name = "volume"
    with tempfile.TemporaryDirectory() as tmp:
        if a.only == "floor":
            floor_only(tmp, pathlib.Path(a.out))
            return 0
        if a.only == "cost":
            cost_only(tmp, pathlib.Path(a.out))
            return 0
        if a.only == "reference-noise":
            reference_noise_only(pathlib.Path(a.out))
            return 0
        if a.only == "transport":
            name = "volume_transport"
            md[0] = "# Multiple scattering through the hair volume: the two transports"
            md[2] = md[2].replace("volume_compare.py`", "volume_compare.py --only transport`")
            transport(tmp, rows, md)
        else:
            accuracy(tmp, rows, md)
            reference_noise(rows, md)
            karis(tmp, rows, md)
            furnace(tmp, rows, md, a.quick)
            convergence(tmp, rows, md, a.quick)
            cost(tmp, rows, md)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.md").write_text("\n".join(md) + "\n")
    keys = sorted({k for r in rows for k in r})
    with open(out / f"{name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {out / (name + '.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
