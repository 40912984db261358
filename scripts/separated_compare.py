"""Two truths on heads whose fibers do not overlap (scripts/separated_heads.py):
Mitsuba's and Cycles' references against each other, and the quality presets
against both. Writes docs/separated.md and docs/separated.csv.

    python scripts/separated_compare.py [--out docs]
    python scripts/separated_compare.py --lights    # renders separated_lights.csv alone (needs bpy and mitsuba)
    python scripts/separated_compare.py --cut       # renders separated_cut.csv alone (needs bpy and mitsuba)
    python scripts/separated_compare.py --page      # writes separated.md again from the CSV files
    python scripts/separated_compare.py --raster    # the rasterizer's columns of those CSV files (and the B-splines') again
    python scripts/separated_compare.py --bspline   # renders separated_bspline.csv alone (needs bpy and mitsuba)

Per head: the relaxation (strands kept, overlap before and after); Cycles /
Mitsuba per channel, their relMSE and each one's noise (its halves' relMSE);
each preset's mean per channel over each truth, relMSE against each, the
multiple-scattering part (render minus the same render without multiple
scattering, over Mitsuba's max_depth 64 minus max_depth 2) and the frame
time (best of 2 after a frame that builds maps, lighting and volume solve).
With --lights: each head's direct light one light at a time (Mitsuba
max_depth 2, Cycles with no bounce, 2 x 256 spp; the rasterizer's accurate
preset without multiple scattering), and the wavy head's rim light at the
tilts +2, 0 and -2 degrees, into OUT/separated_lights.csv, which the
page's last section reads.
With --cut: for each head's lights other than the environment, at its own
tilt, both path tracers' direct light with every strand cut into pieces of
4 segments with a gap between them (`cut_strands`), and the rasterizer's
with traced shadows' ``own_strand`` "passes" over "shadows", into
OUT/separated_cut.csv. Cycles never lets a ray hit the curve it leaves
(`SELF_SKIP`): a strand cannot shadow itself there. Cut into pieces, a
strand's other pieces shadow it in Cycles as in Mitsuba; "passes" is
Cycles' rule in the rasterizer. Both say how much of the path tracers'
difference under the lights behind the hair that rule accounts for.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hairshade as hs  # noqa: E402
from doc_tables import write_csv, write_markdown  # noqa: E402
from separated_heads import HEADS, OUT as SEPARATED  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
#: Where Cycles skips a ray's own curve: kernel/device/cpu/bvh.h (Blender 5),
#: kernel_embree_is_self_intersection and the shadow filter: a hair hit's
#: primitive is its curve (curve_segments[prim].prim), and
#: intersection_skip_self_shadow drops hits on the ray's own (object, prim).
SELF_SKIP = ("Cycles `kernel/device/cpu/bvh.h`: a hair hit's primitive is its whole curve "
             "(`curve_segments[prim].prim`), and `intersection_skip_self_shadow` drops every hit on the curve "
             "the ray leaves")
#: Pieces of CUT_SEGMENTS segments, their inner ends pulled in by CUT_GAP
#: radii each (a gap of one radius between the pieces' caps): 3.75% of the
#: straight head's length (segments of 20 radii).
CUT_SEGMENTS, CUT_GAP = 4, 1.5
CYCLES = os.path.join(ROOT, "tests", "data", "cycles")
# (label, settings): the presets, and accurate with dual scattering
CONFIGS = (("fast", {"quality": "fast"}), ("balanced", {"quality": "balanced"}),
           ("accurate", {"quality": "accurate"}),
           ("accurate, dual", {"quality": "accurate", "multiple_scattering": "dual"}),
           ("accurate, volume 64 cells, 2^19 photons",
            {"quality": "accurate", "multiple_scattering": {"volume": {"resolution": 64, "photons": 1 << 19}}}))


def held_out_blond(out: str) -> str:
    """The range of the overlapping held-out blond heads' means over their
    truths' under `accurate` (volume.md's accuracy rows, `volume.csv`)."""
    path = os.path.join(out, "volume.csv")
    with open(path, newline="") as f:
        vals = [float(x) for r in csv.DictReader(f)
                if r["section"] == "accuracy" and r["config"] == "accurate, volume"
                and r["head"] in ("wavy_blond_rim", "clumped_blond_key") for x in r["ratio"].split("/")]
    if not vals:
        raise SystemExit(f"{path}: no accurate rows of the held-out blond heads (run scripts/volume_compare.py)")
    return f"{min(vals):.3f}-{max(vals):.3f}"


def mean(a: np.ndarray) -> np.ndarray:
    return a.reshape(-1, 3).mean(0)


def covered(name: str, direct: np.ndarray) -> np.ndarray:
    """The pixels that see hair or the head: where Mitsuba's direct light
    differs from the environment's radiance (0 without one) by more than 1%.
    Means over the whole image would count the environment seen behind the
    head, the same in every renderer, and pull every ratio towards 1."""
    spec = json.load(open(os.path.join(SEPARATED, f"{name}.json")))
    env = [np.asarray(x["radiance"], float) for x in spec["lights"] if x["type"] == "environment"]
    e = env[0] if env else np.zeros(3)
    return ~np.all(np.abs(direct - e) <= 0.01 * np.maximum(e, 1e-3), axis=2)


def fmt(v: np.ndarray) -> str:
    return "/".join(f"{x:.3f}" for x in v)


def mitsuba_noise(name: str) -> tuple[float, float]:
    """The halves relMSE of NAME.exr and NAME_depth2.exr (OUT/NAME.txt)."""
    found = {}
    for line in open(os.path.join(SEPARATED, f"{name}.txt")):
        m = re.match(r"(\S+): .*halves relMSE ([0-9.e+-]+),", line)
        if m:
            found[m.group(1)] = float(m.group(2))
    return found.get(name, float("nan")), found.get(f"{name}_depth2", float("nan"))


def frame(scene: hs.Scene, settings: dict) -> tuple[np.ndarray, float, float]:
    """The image, the best of 2 frames after a first, and the first (maps, lighting, volume solve)."""
    t0 = time.perf_counter()
    hs.render(scene, progress=False, **settings)
    first = time.perf_counter() - t0
    best = float("inf")
    for _ in range(2):
        t0 = time.perf_counter()
        img = hs.render(scene, progress=False, **settings)
        best = min(best, time.perf_counter() - t0)
    return img, best, first


def light_label(i: int, light: dict) -> str:
    """How the CSV files name a head's light."""
    return f"light {i} ({light['type']} {light.get('direction', '')})"


def light_alone(spec: dict, light: dict, path: str, **hair) -> str:
    """Writes the scene SPEC lit by LIGHT alone to PATH (its hair's keys in
    HAIR replaced) and returns PATH."""
    s = json.loads(json.dumps(spec))
    s["lights"] = [light]
    s["hair"].update(hair)
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def path_traced_direct(sc: hs.Scene) -> tuple[np.ndarray, np.ndarray]:
    """Cycles' (no bounce) and Mitsuba's (max_depth 2) direct light on SC,
    each the mean of two seeds of 256 spp."""
    import hairshade.mitsuba as hm
    from hairshade import cycles

    c = 0.5 * sum(cycles.render(sc, spp=256, max_bounces=0, seed=k) for k in (1, 2))
    m = 0.5 * sum(hm.render(sc, spp=256, integrator="path", max_depth=2, seed=k, progress=False) for k in (1, 2))
    return c, m


def raster_direct(path: str, **settings) -> np.ndarray:
    """The rasterizer's direct light on the scene of PATH (`accurate`
    without multiple scattering), its mean per channel."""
    from hairshade.demo import preset_scene

    return mean(hs.render(preset_scene(path), quality="accurate", multiple_scattering="none", progress=False,
                          **settings))


def raster_rule_ratio(path: str) -> np.ndarray:
    """The rasterizer's direct light with Cycles' rule (traced shadows'
    ``own_strand`` "passes") over its own ("shadows")."""
    own = {o: raster_direct(path, shadows={"traced": {"own_strand": o}}) for o in ("shadows", "passes")}
    return own["passes"] / own["shadows"]


def rerender_raster(out: str) -> None:
    """The rasterizer's columns of separated_lights.csv, separated_cut.csv
    and separated_bspline.csv again, the path tracers' kept (after a change
    of the renderer). A
    light's raster / Mitsuba divides by the Mitsuba mean its row holds
    (mitsuba_e3: four digits, 2e-4 of the value at worst)."""
    import shutil
    import tempfile

    lights_csv, cut_csv = os.path.join(out, "separated_lights.csv"), os.path.join(out, "separated_cut.csv")
    lights, cut = list(csv.DictReader(open(lights_csv))), list(csv.DictReader(open(cut_csv)))
    for name in HEADS:
        for label, tilt, path in light_scenes(name):
            r = raster_direct(path)
            os.remove(path)
            for row in lights:
                if (row["head"], row["light"], float(row["tilt"])) == (name, label, tilt):
                    m = np.array([float(x) for x in row["mitsuba_e3"].split("/")]) / 1e3
                    row["raster"] = fmt(r / m)
                    print(row, flush=True)
        spec = json.load(open(os.path.join(SEPARATED, f"{name}.json")))
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copy(os.path.join(SEPARATED, spec["hair"]["file"]), os.path.join(tmp, "whole.hair"))
            for i, light in enumerate(spec["lights"]):
                for row in cut:
                    if (row["head"], row["light"]) == (name, light_label(i, light)):
                        path = light_alone(spec, light, os.path.join(tmp, "whole.json"), file="whole.hair")
                        row["raster_passes"] = fmt(raster_rule_ratio(path))
                        print(row, flush=True)
    write_csv(lights_csv, lights)
    write_csv(cut_csv, cut)
    bs_csv = os.path.join(out, "separated_bspline.csv")
    if not os.path.exists(bs_csv):
        return
    bs = list(csv.DictReader(open(bs_csv)))
    for name in HEADS:
        spec = json.load(open(os.path.join(SEPARATED, f"{name}.json")))
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copy(os.path.join(SEPARATED, spec["hair"]["file"]), tmp)
            for i, light in enumerate(spec["lights"]):
                for row in bs:
                    if (row["head"], row["light"]) == (name, light_label(i, light)):
                        path = light_alone(spec, light, os.path.join(tmp, "scene.json"), curve=row["curve"])
                        r = raster_direct(path)
                        m = np.array([float(x) for x in row["mitsuba_e3"].split("/")]) / 1e3
                        row.update(raster=fmt(r / m), raster_passes=fmt(raster_rule_ratio(path)), raster_e3=fmt(r * 1e3))
                        print(row, flush=True)
    write_csv(bs_csv, bs)


def light_scenes(name: str) -> list[tuple[str, float, str]]:
    """(label, tilt, scene file) for each of NAME's lights alone, at its own
    tilt, and the wavy head's rim light at +2, 0 and -2 degrees."""
    import tempfile

    spec = json.load(open(os.path.join(SEPARATED, f"{name}.json")))
    cases = [(i, spec["hair"]["material"]["scale_tilt"]) for i in range(len(spec["lights"]))]
    if name == "sep_wavy_blond_rim":
        cases += [(1, 0.0), (1, -2.0)]
    out = []
    for i, tilt in cases:
        s = json.loads(json.dumps(spec))
        s["lights"] = [spec["lights"][i]]
        s["hair"]["material"]["scale_tilt"] = tilt
        f = tempfile.NamedTemporaryFile("w", suffix=".json", dir=SEPARATED, delete=False)  # beside its strands
        json.dump(s, f)
        f.close()
        out.append((light_label(i, spec["lights"][i]), tilt, f.name))
    return out


def cut_strands(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray, k: int = CUT_SEGMENTS,
                gap: float = CUT_GAP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every strand cut into strands of K segments; a piece's ends where it
    was cut are pulled in along its end segment by GAP times the radius
    there, so that no two pieces touch."""
    P, R, O = [], [], [0]
    for a, b in zip(offsets[:-1].astype(int), offsets[1:].astype(int)):
        for st in range(a, b - 1, k):
            en = min(st + k, b - 1)
            q, r = points[st:en + 1].astype(np.float64), radii[st:en + 1]
            if st > a:
                d = q[1] - q[0]
                q[0] += d / np.linalg.norm(d) * gap * r[0]
            if en < b - 1:
                d = q[-1] - q[-2]
                q[-1] -= d / np.linalg.norm(d) * gap * r[-1]
            P.append(q)
            R.append(r)
            O.append(O[-1] + len(q))
    return np.concatenate(P).astype(np.float32), np.concatenate(R), np.asarray(O, np.uint32)


def render_cut(out: str) -> None:
    """separated_cut.csv: per light (the environment left out), at the head's
    own tilt: the two path tracers' direct light with the strands cut into
    pieces (their whole strands' are separated_lights.csv's), and the
    rasterizer's with ``own_strand`` "passes" over "shadows" on whole strands."""
    import shutil
    import tempfile

    from hairshade.hairfile import read_hair, write_hair

    rows = []
    for name in HEADS:
        spec = json.load(open(os.path.join(SEPARATED, f"{name}.json")))
        with tempfile.TemporaryDirectory() as tmp:
            src = os.path.join(SEPARATED, spec["hair"]["file"])
            shutil.copy(src, os.path.join(tmp, "whole.hair"))
            write_hair(os.path.join(tmp, "cut.hair"), *cut_strands(*read_hair(src)))
            for i, light in enumerate(spec["lights"]):
                if light["type"] == "environment":
                    continue
                paths = {hair: light_alone(spec, light, os.path.join(tmp, f"{hair}.json"), file=f"{hair}.hair")
                         for hair in ("whole", "cut")}
                c, m = path_traced_direct(hs.Scene.load(paths["cut"]))
                rows.append(dict(head=name, light=light_label(i, light), cycles_cut=fmt(mean(c) / mean(m)),
                                 raster_passes=fmt(raster_rule_ratio(paths["whole"]))))
                print(rows[-1], flush=True)
    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "separated_cut.csv"), rows)


def render_bspline(out: str) -> None:
    """separated_bspline.csv: the lights behind the hair (Cycles / Mitsuba
    above 1.03 on whole strands in separated_lights.csv) alone, at the
    head's own tilt, with the strands drawn as B-splines of their vertices
    (``hair.curve: "bspline"``) and as the polylines of the references:
    Cycles / Mitsuba, the rasterizer / Mitsuba and Cycles' rule in the
    rasterizer (2 x 256 spp, direct light). Mitsuba draws a polyline as a
    B-spline with every vertex tripled, one primitive a segment; a B-spline
    has no such joints."""
    import shutil
    import tempfile

    behind = {(r["head"], r["light"]) for r in csv.DictReader(open(os.path.join(out, "separated_lights.csv")))
              if max(float(x) for x in r["cycles"].split("/")) > 1.03}
    rows = []
    for name in HEADS:
        spec = json.load(open(os.path.join(SEPARATED, f"{name}.json")))
        for i, light in enumerate(spec["lights"]):
            if (name, light_label(i, light)) not in behind:
                continue
            with tempfile.TemporaryDirectory() as tmp:
                shutil.copy(os.path.join(SEPARATED, spec["hair"]["file"]), tmp)
                for curve in ("bspline", "polyline"):
                    path = light_alone(spec, light, os.path.join(tmp, "scene.json"), curve=curve)
                    c, m = path_traced_direct(hs.Scene.load(path))
                    r = raster_direct(path)
                    rows.append(dict(head=name, light=light_label(i, light), curve=curve,
                                     cycles=fmt(mean(c) / mean(m)), raster=fmt(r / mean(m)),
                                     raster_passes=fmt(raster_rule_ratio(path)), mitsuba_e3=fmt(mean(m) * 1e3),
                                     cycles_e3=fmt(mean(c) * 1e3), raster_e3=fmt(r * 1e3)))
                    print(rows[-1], flush=True)
    write_csv(os.path.join(out, "separated_bspline.csv"), rows)


def render_lights(out: str) -> None:
    """separated_lights.csv: direct light per light, in both path tracers and the rasterizer."""
    rows = []
    for name in HEADS:
        for label, tilt, path in light_scenes(name):
            c, m = path_traced_direct(hs.Scene.load(path))
            r = raster_direct(path)
            os.remove(path)
            rows.append(dict(head=name, light=label, tilt=tilt, cycles=fmt(mean(c) / mean(m)),
                             raster=fmt(r / mean(m)), mitsuba_e3=fmt(mean(m) * 1e3)))
            print(rows[-1], flush=True)
    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "separated_lights.csv"), rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "docs"))
    ap.add_argument("--lights", action="store_true", help="render separated_lights.csv and stop (bpy, mitsuba)")
    ap.add_argument("--cut", action="store_true", help="render separated_cut.csv and stop (bpy, mitsuba)")
    ap.add_argument("--page", action="store_true", help="write separated.md again from the CSV files alone")
    ap.add_argument("--bspline", action="store_true",
                    help="render separated_bspline.csv (the lights behind the hair on B-splines) and stop (bpy, mitsuba)")
    ap.add_argument("--raster", action="store_true",
                    help="render the rasterizer's columns of separated_lights.csv, separated_cut.csv and "
                         "separated_bspline.csv again, keep the path tracers', and stop")
    args = ap.parse_args()
    if args.page:
        page = open(os.path.join(args.out, "separated.md")).read()
        cpu = re.search(r"separated_compare.py` on (.+?); data", page).group(1)  # the run's CPU
        write_page(args.out, read_rows(os.path.join(args.out, "separated.csv")),
                   read_rows(os.path.join(args.out, "separated_heads.csv")), cpu)
        return
    for flag, run in (("cut", render_cut), ("raster", rerender_raster), ("bspline", render_bspline),
                      ("lights", render_lights)):
        if getattr(args, flag):
            run(args.out)
            return
    from hairshade.demo import cpu_name, preset_scene

    rows, heads = [], []
    for name, h in HEADS.items():
        mit_path, cyc_path = os.path.join(SEPARATED, f"{name}.exr"), os.path.join(CYCLES, f"{name}.exr")
        if not (os.path.exists(mit_path) and os.path.exists(cyc_path)):
            print(f"{name}: no Mitsuba or Cycles reference, left out", flush=True)
            continue
        mit, cyc = hs.read_exr(mit_path), hs.read_exr(cyc_path)
        mit2 = hs.read_exr(os.path.join(SEPARATED, f"{name}_depth2.exr"))
        info = json.load(open(os.path.join(CYCLES, f"{name}.json")))
        relax = json.load(open(os.path.join(SEPARATED, f"{h['geometry']}.relax.json")))
        m_noise, m2_noise = mitsuba_noise(name)
        cyc2_path = os.path.join(CYCLES, f"{name}_depth2.exr")  # Cycles with 0 bounces: direct light
        cyc2 = hs.read_exr(cyc2_path) if os.path.exists(cyc2_path) else None
        k = covered(name, mit2)
        cm = lambda a: a[k].mean(0)  # noqa: E731
        split = ("", "") if cyc2 is None else (fmt(cm(cyc2) / cm(mit2)),
                                                fmt((cm(cyc) - cm(cyc2)) / (cm(mit) - cm(mit2))))
        heads.append(dict(
            head=name, geometry=h["geometry"], strands=relax["strands"], left_out=relax["strands_left_out"],
            overlap_before=relax["overlap_before"], overlap_after=relax["overlap_after"],
            min_distance_radii=relax["min_distance_radii_float32"],
            cycles_over_mitsuba=fmt(cm(cyc) / cm(mit)), covered=float(k.mean()), rel_mse_cycles_mitsuba=hs.rel_mse(cyc, mit),
            cycles_noise=info["halves_rel_mse"], mitsuba_noise=m_noise, mitsuba_depth2_noise=m2_noise,
            cycles_halves_spread=float(np.max(np.abs(np.divide(*info["halves_mean_rgb"]) - 1))),
            cycles_spp=2 * info["spp_per_half"], cycles_seconds=sum(info["seconds_per_half"]),
            ms_share=fmt(1 - cm(mit2) / cm(mit)), direct_cycles_over_mitsuba=split[0],
            multiple_cycles_over_mitsuba=split[1]))
        print(heads[-1], flush=True)
        single = {}  # each preset's render without multiple scattering, once
        for label, settings in CONFIGS:
            scene = preset_scene(os.path.join(SEPARATED, f"{name}.json"))  # nothing cached from the row before
            img, secs, first = frame(scene, settings)
            q = settings["quality"]
            if q not in single:
                single[q] = cm(hs.render(scene, progress=False, quality=q, multiple_scattering="none"))
            ms = (cm(img) - single[q]) / (cm(mit) - cm(mit2))
            rows.append(dict(head=name, config=label, over_mitsuba=fmt(cm(img) / cm(mit)),
                             rel_mse_mitsuba=hs.rel_mse(img, mit), over_cycles=fmt(cm(img) / cm(cyc)),
                             rel_mse_cycles=hs.rel_mse(img, cyc), ms_part=fmt(ms), frame_s=round(secs, 3),
                             first_frame_s=round(first, 3)))
            print(rows[-1], flush=True)
    write_csv(os.path.join(args.out, "separated.csv"), rows)
    write_csv(os.path.join(args.out, "separated_heads.csv"), heads)
    write_page(args.out, rows, heads, cpu_name())


def read_rows(path: str) -> list[dict]:
    """A CSV file's rows with numbers as numbers."""
    def value(v: str):
        for kind in (int, float):
            try:
                return kind(v)
            except ValueError:
                pass
        return v
    return [{k: value(v) for k, v in r.items()} for r in csv.DictReader(open(path))]


def bspline_spread(out: str) -> float:
    """The most Cycles / Mitsuba departs from 1 on B-splines (separated_bspline.csv)."""
    return max(abs(float(x) - 1) for r in csv.DictReader(open(os.path.join(out, "separated_bspline.csv")))
               if r["curve"] == "bspline" for x in r["cycles"].split("/"))


def write_page(out: str, rows: list[dict], heads: list[dict], cpu: str) -> None:
    """docs/separated.md from the measured rows (and separated_lights.csv,
    separated_cut.csv where they were rendered)."""
    lines = [
        "# Two truths on hair whose fibers do not overlap",
        "",
        f"Generated by `python scripts/separated_compare.py` on {cpu}; data `separated.csv`, "
        "`separated_heads.csv`.",
        "",
        "The generator's heads overlap: 43-65% of their strand points lie inside another strand's tube, and there "
        "Mitsuba and Cycles disagree by up to 11% (`three_truths.md`). These heads were relaxed until no two "
        "segments of different strands come closer than two radii (`scripts/separated_heads.py`: position-based "
        "pushes between exact closest points of segment pairs, segment lengths kept, roots fixed, and the strands "
        "still overlapping after 60 iterations left out). Materials carry the physical +2° tilt. Mitsuba: `path`, "
        "max_depth 64, `llvm_ad_rgb` (`tests/data/separated/*.txt` say the samples, time and noise); Cycles: "
        "`scripts/make_cycles_reference.py`, Principled Hair (Chiang), 64 bounces.",
        "",
        "## The heads and their two truths",
        "",
        "Means here and below are over the pixels that see hair or the head (`covered`: where Mitsuba's direct "
        "light differs from the environment by more than 1%; " + ", ".join(
            f"{100 * r['covered']:.0f}%" for r in heads) + " of each image): over the whole image, the "
        "environment seen behind the head, the same in every renderer, pulls each ratio towards 1. relMSE is "
        "over the whole image, as everywhere in this project. "
        "Overlap: the share of points along the strands (8 a segment) inside another strand's tube, before and "
        "after relaxing. Noise: relMSE between a reference's two halves. MS share: the part of Mitsuba's mean "
        "that multiple scattering brings (1 − max_depth 2 / max_depth 64). Direct, multiple: Cycles with no "
        "bounce (`--bounces 0`, 2 × 512 spp) against Mitsuba's max_depth 2, and the rest (the multiple "
        "scattering) against the rest.",
        "",
        "| head | strands (left out) | overlap before → after | min gap / radius | Cycles / Mitsuba | relMSE "
        "(Cycles noise, Mitsuba noise) | Cycles halves' means apart | MS share | Cycles / Mitsuba: direct, "
        "multiple |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in heads:
        lines.append(f"| {r['head']} | {r['strands']} ({r['left_out']}) | {100 * r['overlap_before']:.0f}% → "
                     f"{100 * r['overlap_after']:.1f}% | {r['min_distance_radii']:.3f} | {r['cycles_over_mitsuba']} | "
                     f"{r['rel_mse_cycles_mitsuba']:.2e} ({r['cycles_noise']:.1e}, {r['mitsuba_noise']:.1e}) | "
                     f"{100 * r['cycles_halves_spread']:.2f}% | {r['ms_share']} | {r['direct_cycles_over_mitsuba']}, "
                     f"{r['multiple_cycles_over_mitsuba']} |")
    lines += [
        "",
        "## The presets against both",
        "",
        "Mean per channel as a ratio to each truth (R/G/B), relMSE against each, the multiple-scattering part "
        "over Mitsuba's, the frame (best of 2 after one that builds maps, lighting and the volume solve) and "
        "that first frame (the scene loaded afresh for each row; a volume solve of the same settings is kept "
        "from the row before: `balanced` and `accurate` share theirs).",
        "",
        "| head | configuration | / Mitsuba | relMSE vs Mitsuba | / Cycles | relMSE vs Cycles | MS part / Mitsuba's "
        "| frame s | first s |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append(f"| {r['head']} | {r['config']} | {r['over_mitsuba']} | {r['rel_mse_mitsuba']:.2e} | "
                     f"{r['over_cycles']} | {r['rel_mse_cycles']:.2e} | {r['ms_part']} | {r['frame_s']:.2f} | "
                     f"{r['first_frame_s']:.2f} |")
    lights_csv = os.path.join(out, "separated_lights.csv")
    if os.path.exists(lights_csv):
        lines += [
            "",
            "## Direct light, one light at a time",
            "",
            "Each light alone, direct light only: Mitsuba max_depth 2 (its mean, ×1e-3), Cycles with no bounce "
            "and the rasterizer's `accurate` without multiple scattering over it (`--lights`, 2 × 256 spp). The "
            "wavy head's rim light also at the tilts 0 and −2°. Lights alone, without an environment, leave the "
        "background black, so these means are the hair's and the head's (environment rows are left out).",
            "",
            "| head | light | tilt | Mitsuba (×1e-3) | Cycles / Mitsuba | rasterizer / Mitsuba |",
            "| --- | --- | --- | --- | --- | --- |",
        ]
        for r in csv.DictReader(open(lights_csv)):
            if "environment" in r["light"]:
                continue
            lines.append(f"| {r['head']} | {r['light']} | {float(r['tilt']):+.0f}° | {r['mitsuba_e3']} | "
                         f"{r['cycles']} | {r['raster']} |")
    cut_csv = os.path.join(out, "separated_cut.csv")
    cut = list(csv.DictReader(open(cut_csv))) if os.path.exists(cut_csv) and os.path.exists(lights_csv) else []
    if cut:
        tilt = {h: json.load(open(os.path.join(SEPARATED, f"{h}.json")))["hair"]["material"]["scale_tilt"]
                for h in HEADS}
        whole = {(r["head"], r["light"]): r["cycles"] for r in csv.DictReader(open(lights_csv))
                 if float(r["tilt"]) == tilt[r["head"]]}
        ch = lambda r: [float(x) for x in r.split("/")]  # noqa: E731
        lines += [
            "",
            "## Why Cycles is brighter under the lights behind the hair",
            "",
            f"{SELF_SKIP}. So in Cycles a strand never shadows itself. In Mitsuba every segment is a primitive of "
            "its own and shadows any other; in hairshade a shadow ray passes its own strand only until it leaves "
            "the strand's tube, and is blocked where it enters it again (`raster/traced.rs`, "
            "`SegmentGrid::occluded`). Under a light behind the hair, "
            "much of what a strand lets through to the camera lies in the shadow of the same strand's other "
            "parts (where it crosses the crown, or the wave before it). Two ways to see it (`--cut`), direct "
            "light only, one light at a time at the head's own tilt:",
            "",
            f"- both path tracers on the strands cut into pieces of {CUT_SEGMENTS} segments, with a gap of one "
            "radius between the pieces (`cut_strands`): a strand's other pieces then shadow it in Cycles too "
            "(2 × 256 spp; the whole strands' column is the table above);",
            "- the rasterizer with Cycles' rule, `shadows: {\"traced\": {\"own_strand\": \"passes\"}}`, over "
            "its own, on the whole strands.",
            "",
            "| head | light | Cycles / Mitsuba, whole strands | Cycles / Mitsuba, strands cut | "
            "hairshade, Cycles' rule / its own |",
            "| --- | --- | --- | --- | --- |",
        ]
        lines += [f"| {r['head']} | {r['light']} | {whole.get((r['head'], r['light']), '—')} | {r['cycles_cut']} | "
                  f"{r['raster_passes']} |" for r in cut]
        back = [r for r in cut if max(ch(whole.get((r["head"], r["light"]), "1/1/1"))) > 1.03]
        left = lambda r: max(w / p for w, p in zip(ch(whole[(r["head"], r["light"])]), ch(r["raster_passes"])))  # noqa: E731
        lines += [
            "",
            "Under the lights behind the hair (" + "; ".join(
                f"{r['head']} {r['light'].split(' (')[0]}: Cycles / Mitsuba {whole[(r['head'], r['light'])]} on "
                f"whole strands, {r['cycles_cut']} cut; Cycles' rule multiplies hairshade's direct light by "
                f"{r['raster_passes']}" for r in back) + "), Cycles' rule accounts for part of the difference; "
            "what it leaves (" + ", ".join(f"{100 * (left(r) - 1):.1f}% on {r['head']}" for r in back) + ") "
            "is the next section's. Under the other lights the rule changes hairshade's direct light by at most "
            f"{100 * max(abs(x - 1) for r in cut if r not in back for x in ch(r['raster_passes'])):.2f}%. "
            "Cutting the strands adds ends, and on the wavy head each piece keeps bends that Cycles still skips.",
        ]
        bs_csv = os.path.join(out, "separated_bspline.csv")
        bs = list(csv.DictReader(open(bs_csv))) if os.path.exists(bs_csv) else []
        if bs:
            get = lambda h, li, c: next(r for r in bs if (r["head"], r["light"], r["curve"]) == (h, li, c))  # noqa: E731
            ratio_e3 = lambda h, li, k: np.divide(ch(get(h, li, "polyline")[k]), ch(get(h, li, "bspline")[k]))  # noqa: E731
            pairs = sorted({(r["head"], r["light"]) for r in bs})
            lines += [
                "",
                "## The same lights on B-splines: Mitsuba's polylines shadow themselves at their joints",
                "",
                "Mitsuba draws these polylines as B-splines with every vertex tripled, a primitive a segment. "
                "The same strands drawn as the B-spline of their vertices (`hair.curve: \"bspline\"` in all "
                "three renderers; `--bspline`, 2 × 256 spp, direct light, the light alone):",
                "",
                "| head | light | curve | Cycles / Mitsuba | hairshade / Mitsuba | hairshade, Cycles' rule / its own |",
                "| --- | --- | --- | --- | --- | --- |",
            ]
            lines += [f"| {r['head']} | {r['light']} | {r['curve']} | {r['cycles']} | {r['raster']} | "
                      f"{r['raster_passes']} |" for r in bs]
            worst_bs = max(abs(x - 1) for h, li in pairs for x in ch(get(h, li, "bspline")["cycles"]))
            lines += [
                "",
                f"On B-splines the two path tracers agree within {100 * worst_bs:.1f}% under these lights, "
                "though Cycles never lets a strand shadow itself and Mitsuba does: a strand's own shadow is small "
                "there (hairshade's rule: " + ", ".join(
                    f"{get(h, li, 'bspline')['raster_passes']} on {h}" for h, li in pairs) + "). On the "
                "polylines Cycles is " + ", ".join(
                    f"{get(h, li, 'polyline')['cycles']} of Mitsuba on {h}" for h, li in pairs) + ". Going from "
                "the B-spline to the polyline, each renderer's image changes by (polyline / B-spline) " + "; ".join(
                    f"{h}: Mitsuba {fmt(ratio_e3(h, li, 'mitsuba_e3'))}, Cycles {fmt(ratio_e3(h, li, 'cycles_e3'))}, "
                    f"hairshade {fmt(ratio_e3(h, li, 'raster_e3'))}" for h, li in pairs) + ". Mitsuba's polylines "
                "lose more than the other two renderers' on every head: the shadows of their tripled-vertex "
                "joints (each segment a primitive of its own) on their neighbours, which a strand's tube does not "
                "cast. So under lights behind the hair Mitsuba's polyline references are too dark by a few "
                "percent, and the two path tracers agree where Mitsuba draws B-splines, as the dense and "
                "held-out references do. "
                "hairshade is " + ", ".join(
                    f"{get(h, li, 'bspline')['raster']} of Mitsuba's B-spline image on {h}" for h, li in pairs) + ".",
            ]

    spread = lambda key: max(abs(float(x) - 1) for r in heads for x in r[key].split("/") if x)  # noqa: E731
    acc = [r for r in rows if r["config"] == "accurate"]
    worst = lambda key: max(abs(float(x) - 1) for r in acc for x in r[key].split("/"))  # noqa: E731
    FINE = CONFIGS[-1][0]
    get = lambda h, c: next(r for r in rows if r["head"] == h and r["config"] == c)  # noqa: E731
    dev = lambda h, c: max(abs(float(x) - 1) for x in get(h, c)["over_mitsuba"].split("/"))  # noqa: E731
    lines += [
        "",
        "## What they say",
        "",
        f"- The two path tracers agree where fibers do not overlap: their means differ by at most "
        f"{100 * spread('cycles_over_mitsuba'):.1f}% per channel on these heads (on the generator's overlapping "
        "heads by up to 11%, `three_truths.md`). Where the split was rendered, the multiple scattering agrees "
        f"within {100 * spread('multiple_cycles_over_mitsuba'):.1f}%; what is left is in the direct light "
        f"(up to {100 * spread('direct_cycles_over_mitsuba'):.1f}%), and one light at a time (the last table) "
        "it is the lights behind the hair: under them Cycles' direct light is above Mitsuba's at every tilt, "
        "under the others the two are within 1%" + (
            ": Mitsuba's polylines shadow themselves at their joints, and Cycles' strands never shadow "
            "themselves (the two sections before); on B-splines the two agree within "
            f"{100 * bspline_spread(out):.1f}%."
            if os.path.exists(os.path.join(out, "separated_bspline.csv")) else
            ": Cycles' strands do not shadow themselves (the section before)." if cut else "."),
        f"- `accurate` is within {100 * worst('over_mitsuba'):.1f}% per channel of Mitsuba and "
        f"{100 * worst('over_cycles'):.1f}% of Cycles on every head, relMSE "
        f"{min(r['rel_mse_mitsuba'] for r in acc):.2e} to {max(r['rel_mse_mitsuba'] for r in acc):.2e} against "
        "Mitsuba. The blond heads are " + ", ".join(
            f"{r['over_mitsuba']} ({r['head']})" for r in acc if "blond" in r["head"]) + " of Mitsuba's means, "
        f"above the {held_out_blond(out)} of the overlapping held-out wavy_blond_rim and clumped_blond_key "
        "(`volume.md`, the same preset, drawn as their truths' B-splines): part of that is the references' light "
        "scattered inside interpenetrating tubes.",
        "- A coarser volume grid with fewer photons (64 cells, 2^19 photons): " + "; ".join(
            f"{h}: worst channel {100 * dev(h, 'accurate'):.1f}% → {100 * dev(h, FINE):.1f}%, relMSE "
            f"{get(h, 'accurate')['rel_mse_mitsuba']:.2e} → {get(h, FINE)['rel_mse_mitsuba']:.2e}"
            for h in dict.fromkeys(r["head"] for r in rows)) + " (against Mitsuba; its solve is in the first "
        "frame's time).",
    ]
    write_markdown(os.path.join(out, "separated.md"), lines)


if __name__ == "__main__":
    main()
