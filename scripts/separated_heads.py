"""Heads whose fibers do not overlap, with path-traced references by
Mitsuba and Cycles: a truth for multiple scattering that does not depend
on how a path tracer treats interpenetrating tubes.

    .venv/bin/python scripts/separated_heads.py [--out tests/data/separated] [--heads a,b] [--reference SPP] [--depth2 SPP]
        [--seeds 1 2] [--merge DIR]

The `head` generator's strands, and those reshaped by `held_out_heads.py`,
overlap: 43-65% of their points lie inside another strand's tube
(`three_truths.overlap_fraction`). Where tubes interpenetrate, the two
path tracers disagree (docs/three_truths.md: an overlapping fiber pair
exchanges 12-26% of Mitsuba's fiber-to-fiber light in Cycles). No real
groom overlaps, so these heads are relaxed until no two segments of
different strands come closer than two radii:

- every segment pair of different strands closer than ``GAP`` (2.3 radii)
  is found exactly (candidates from a k-d tree of points spaced ``SPACING``
  along the segments, then the closest points of the two segments);
- each such pair is pushed apart along the line between its closest points,
  by ``OMEGA`` times half the shortfall each, shared between the segment's
  two vertices by their barycentric weights (position-based dynamics,
  corrections averaged per vertex);
- then each strand is walked from its root (fixed) and every segment
  gets its original length back (follow the leader), and no point is
  left inside the head sphere plus one radius;
- until no pair is closer than two radii (checked exactly), or
  ``MAX_ITERATIONS``; then the strands still in such a pair are left out
  greedily, the strand in the most pairs first (after 60 iterations,
  20-32% of the strands of these dense styles: GEOMETRY.relax.json says
  how many; more iterations keep more, at 5-8 s each on 2 cores).

The strands are drawn as their polyline (the scenes' default curve) by
the rasterizer and by both path tracers: the separation holds for the
polyline, and a B-spline of the same vertices cuts its corners and can
overlap again.

The relaxation is deterministic (numpy and scipy only, no random numbers)
and takes minutes; its strands are written as ``GEOMETRY.hair`` (float32)
beside the scenes, and the scenes read them. Writes OUT/GEOMETRY.hair,
OUT/NAME.json, and with --reference OUT/NAME.exr (Mitsuba `path`,
max_depth 64, `llvm_ad_rgb` unless --variant, the mean of two halves of
SPP samples, seeds 1 and 2), with --depth2 OUT/NAME_depth2.exr (max_depth
2), and OUT/NAME.txt with what each took and the halves' relMSE; --merge
DIR averages each OUT/NAME.exr with DIR/NAME.exr (the same spp rendered
with other --seeds) and notes their relMSE in OUT/NAME.txt. The Cycles
references: `scripts/make_cycles_reference.py OUT/NAME.json
tests/data/cycles/NAME.exr --spp 1024 --curve scene`.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import held_out_heads as ho  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
OUT = os.path.join(ROOT, "tests", "data", "separated")
RADIUS = 0.0015  # the held-out heads' fiber radius
GAP = 2.4  # pairs closer than GAP radii are pushed apart, to GAP radii ...
OMEGA = 1.8  # ... by OMEGA times the shortfall (over-relaxed)
SPACING = 0.004  # candidate points along the segments
MAX_ITERATIONS = 60
HEAD_RADIUS = ho.HEAD["radius"]

# geometry: the held-out generator's style, strands, segments and seed
GEOMETRIES = {
    "straight": dict(style="straight", n=10000, segments=16, seed=17),
    "wavy_clumped": dict(style="wavy_clumped", n=8000, segments=24, seed=11),
    "curly": dict(style="curly", n=6000, segments=40, seed=15),
}
# Materials with the physical tilt (+2 degrees: R leans towards the root, docs/tilt.md).
MATERIALS = {k: {**v, "scale_tilt": 2.0} for k, v in ho.MATERIALS.items()}
HEADS = {
    "sep_straight_blond_back": dict(geometry="straight", material="blond", lights=[
        {"type": "directional", "direction": [-0.2, 0.3, -1.0], "intensity": [5.0, 5.0, 5.0], "shadows": True},
        {"type": "environment", "radiance": [0.1, 0.1, 0.11]}]),
    "sep_wavy_blond_rim": dict(geometry="wavy_clumped", material="blond", lights=[
        {"type": "directional", "direction": [0.5, 0.6, 0.6], "intensity": [1.5, 1.5, 1.5], "shadows": True},
        {"type": "directional", "direction": [-0.3, 0.5, -0.8], "intensity": [3.0, 3.0, 3.0], "shadows": True}]),
    "sep_curly_blond_point": dict(geometry="curly", material="light_blond", lights=[
        {"type": "point", "position": [0.8, 0.9, 1.2], "intensity": [6.0, 6.0, 6.0], "shadows": True},
        {"type": "environment", "radiance": [0.25, 0.25, 0.27]}]),
    "sep_straight_brown_key": dict(geometry="straight", material="brown", lights=[
        {"type": "directional", "direction": [0.4, 0.5, 0.8], "intensity": [3.0, 3.0, 3.0], "shadows": True}]),
}


def segment_gaps(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray):
    """Closest points of segment pairs (a0 a1) and (b0 b1): the vector
    between them (a's minus b's) and their parameters s, t in [0, 1]
    (Ericson, Real-Time Collision Detection, 5.1.9)."""
    d1, d2, r = a1 - a0, b1 - b0, a0 - b0
    a, e = (d1 * d1).sum(1), (d2 * d2).sum(1)
    b, c, f = (d1 * d2).sum(1), (d1 * r).sum(1), (d2 * r).sum(1)
    tiny = 1e-300
    den = a * e - b * b
    s = np.where(den > 1e-14 * a * e, np.clip((b * f - c * e) / np.maximum(den, tiny), 0.0, 1.0), 0.0)
    t = (b * s + f) / np.maximum(e, tiny)
    s = np.where(t < 0.0, np.clip(-c / np.maximum(a, tiny), 0.0, 1.0),
                 np.where(t > 1.0, np.clip((b - c) / np.maximum(a, tiny), 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # a segment of zero length is its point
    s, t = np.where(a <= tiny, 0.0, s), np.where(e <= tiny, 0.0, t)
    s = np.where((e <= tiny) & (a > tiny), np.clip(-c / np.maximum(a, tiny), 0.0, 1.0), s)
    t = np.where((a <= tiny) & (e > tiny), np.clip(f / np.maximum(e, tiny), 0.0, 1.0), t)
    return a0 + d1 * s[:, None] - (b0 + d2 * t[:, None]), s, t


def close_pairs(p: np.ndarray, within: float):
    """Segment pairs of different strands closer than `within`, exactly:
    (pairs (k, 2) of flat segment indices, gap vectors, s, t, distances)."""
    from scipy.spatial import cKDTree

    n, m1, _ = p.shape
    a, b = p[:, :-1].reshape(-1, 3), p[:, 1:].reshape(-1, 3)
    length = np.linalg.norm(b - a, axis=1)
    count = np.maximum(1, np.ceil(length / SPACING)).astype(np.int64)
    seg = np.repeat(np.arange(len(a)), count)
    u = (np.arange(len(seg)) - (np.cumsum(count) - count)[seg] + 0.5) / count[seg]
    q = a[seg] + (b - a)[seg] * u[:, None]
    # two segments within `within` have candidate points within `within` + SPACING
    pairs = seg[cKDTree(q).query_pairs(within + SPACING, output_type="ndarray")]
    strand = np.repeat(np.arange(n), m1 - 1)
    pairs = pairs[strand[pairs[:, 0]] != strand[pairs[:, 1]]]
    pairs = np.unique(np.sort(pairs, axis=1), axis=0)
    d, s, t = segment_gaps(a[pairs[:, 0]], b[pairs[:, 0]], a[pairs[:, 1]], b[pairs[:, 1]])
    dist = np.linalg.norm(d, axis=1)
    keep = dist < within
    return pairs[keep], d[keep], s[keep], t[keep], dist[keep]


def separate(p: np.ndarray, radius: float = RADIUS, log=print) -> tuple[np.ndarray, np.ndarray, dict]:
    """The strands (n, m + 1, 3) relaxed until no two segments of different
    strands are closer than two radii (the module's docstring): the kept
    strands, which of the n were kept, and statistics."""
    p = p.astype(np.float64).copy()
    n, m1, _ = p.shape
    length = np.linalg.norm(np.diff(p, axis=1), axis=2)
    floor = HEAD_RADIUS + radius
    t0 = time.perf_counter()
    first = None
    for it in range(MAX_ITERATIONS + 1):
        pairs, d, s, t, dist = close_pairs(p, GAP * radius)
        overlapping = int((dist < 2 * radius).sum())
        first = overlapping if first is None else first
        if it % 10 == 0 or overlapping == 0:
            log(f"  iteration {it}: {overlapping} segment pairs closer than two radii, {len(pairs)} within {GAP}, "
                f"{time.perf_counter() - t0:.0f} s")
        if overlapping == 0 or it == MAX_ITERATIONS:
            break
        push = 0.5 * OMEGA * ((GAP * radius - dist) / np.maximum(dist, 1e-12))[:, None] * d
        delta = np.zeros((n * (m1 - 1), 2, 3))
        weight = np.zeros((n * (m1 - 1), 2))
        for seg, w, sign in ((pairs[:, 0], s, 1.0), (pairs[:, 1], t, -1.0)):
            scale = 1.0 / ((1.0 - w) ** 2 + w**2)  # the closest point moves by `push` exactly
            for end, we in ((0, 1.0 - w), (1, w)):
                np.add.at(delta[:, end], seg, sign * (scale * we)[:, None] * push)
                np.add.at(weight[:, end], seg, we)
        delta, weight = delta.reshape(n, m1 - 1, 2, 3), weight.reshape(n, m1 - 1, 2)
        move, total = np.zeros((n, m1, 3)), np.zeros((n, m1))
        move[:, :-1] += delta[:, :, 0]
        move[:, 1:] += delta[:, :, 1]
        total[:, :-1] += weight[:, :, 0]
        total[:, 1:] += weight[:, :, 1]
        move[:, 0] = 0.0  # roots stay
        p += move / np.maximum(total, 1.0)[..., None]
        for k in range(1, m1):  # follow the leader: lengths back, outside the head
            v = p[:, k] - p[:, k - 1]
            p[:, k] = p[:, k - 1] + v * (length[:, k - 1] / np.linalg.norm(v, axis=1))[:, None]
            rk = np.linalg.norm(p[:, k], axis=1)
            p[:, k] *= np.maximum(1.0, floor / rk)[:, None]
    # the strands still in an overlapping pair, left out: the one in the most pairs first
    strand = pairs[dist < 2 * radius] // (m1 - 1)
    dropped = []
    while len(strand):
        worst = np.bincount(strand.ravel(), minlength=n).argmax()
        dropped.append(int(worst))
        strand = strand[(strand != worst).all(axis=1)]
    keep = np.ones(n, bool)
    keep[dropped] = False
    p = p[keep]
    pairs, d, s, t, dist = close_pairs(p, GAP * radius)
    assert not np.any(dist < 2 * radius)
    stats = {"iterations": it, "overlapping_pairs_before": first, "overlapping_pairs_after_relaxing": overlapping,
             "strands_left_out": len(dropped), "strands": int(keep.sum()),
             "min_distance_radii": float(dist.min() / radius) if len(dist) else float(GAP),
             "seconds": time.perf_counter() - t0}
    return p, keep, stats


def write_geometry(out: str, name: str, log=print) -> dict:
    """Relaxes GEOMETRIES[name] and writes OUT/NAME.hair; returns the statistics."""
    import hairshade as hs
    from hairshade.hairfile import write_hair

    g = GEOMETRIES[name]
    p0 = ho.strands(g["style"], g["n"], g["segments"], g["seed"])
    p, keep, stats = separate(p0, log=log)
    n, m1, _ = p.shape
    points = p.reshape(-1, 3).astype(np.float32)
    radii = np.full(len(points), RADIUS, np.float32)
    offsets = (np.arange(n + 1) * m1).astype(np.uint32)
    write_hair(os.path.join(out, f"{name}.hair"), points, radii, offsets, info=f"hairshade separated {name}")
    import three_truths

    for key, q in (("overlap_before", p0), ("overlap_after", p)):
        k = len(q)
        s = hs.Scene.from_arrays(q.reshape(-1, 3).astype(np.float32), RADIUS,
                                 (np.arange(k + 1) * m1).astype(np.uint32))
        stats[key] = three_truths.overlap_fraction(s)
    moved = np.linalg.norm(p - p0[keep], axis=2) / RADIUS
    f32 = points.astype(np.float64).reshape(n, m1, 3)  # as written
    stats["min_distance_radii_float32"] = float(close_pairs(f32, GAP * RADIUS)[4].min() / RADIUS)
    stats["moved_radii_mean"], stats["moved_radii_max"] = float(moved.mean()), float(moved.max())
    return stats


def write_scene(out: str, name: str) -> str:
    h = HEADS[name]
    scene = {"hairshade_scene": 1, "camera": ho.CAMERA, "meshes": [ho.HEAD], "lights": h["lights"],
             "hair": {"file": f"{h['geometry']}.hair", "material": MATERIALS[h["material"]]}, "render": {}}
    path = os.path.join(out, f"{name}.json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")
    return path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=OUT)
    ap.add_argument("--heads", default=",".join(HEADS))
    ap.add_argument("--relax", action="store_true", help="relax the geometries again (else use OUT/*.hair)")
    ap.add_argument("--reference", type=int, default=0, metavar="SPP", help="Mitsuba max_depth 64, halves of SPP")
    ap.add_argument("--depth2", type=int, default=0, metavar="SPP", help="Mitsuba max_depth 2, halves of SPP")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--seeds", type=int, nargs=2, default=[1, 2], help="the halves' sampler seeds")
    ap.add_argument("--merge", metavar="DIR",
                    help="average each OUT/NAME.exr with DIR/NAME.exr (the same spp, other seeds) into OUT/NAME.exr")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    names = a.heads.split(",")
    for name in names:
        if name not in HEADS:
            ap.error(f"--heads: among {', '.join(HEADS)}")
    for geometry in sorted({HEADS[n]["geometry"] for n in names}):
        if a.relax or not os.path.exists(os.path.join(a.out, f"{geometry}.hair")):
            print(f"{geometry}: relaxing", flush=True)
            stats = write_geometry(a.out, geometry, log=lambda s: print(s, flush=True))
            with open(os.path.join(a.out, f"{geometry}.relax.json"), "w") as f:
                json.dump(stats, f, indent=1)
                f.write("\n")
            print(f"{geometry}: {stats}", flush=True)
    import hairshade as hs

    if a.merge:
        for name in names:
            other = os.path.join(a.merge, f"{name}.exr")
            if not os.path.exists(other):
                continue
            mine, theirs = hs.read_exr(os.path.join(a.out, f"{name}.exr")), hs.read_exr(other)
            line = (f"{name}: the mean of the reference above and {os.path.basename(other)} rendered with other "
                    f"seeds ({open(os.path.join(a.merge, f'{name}.txt')).read().strip()}): halves relMSE "
                    f"{hs.rel_mse(mine, theirs):.2e}, halves' means {mine.reshape(-1, 3).mean(0)} "
                    f"{theirs.reshape(-1, 3).mean(0)}")
            hs.write_exr(os.path.join(a.out, f"{name}.exr"), (0.5 * (mine + theirs)).astype(np.float32))
            with open(os.path.join(a.out, f"{name}.txt"), "a") as f:
                f.write(line + "\n")
            print(line, flush=True)
        return 0
    for name in names:
        path = write_scene(a.out, name)
        if not (a.reference or a.depth2):
            continue
        scene = hs.Scene.load(path)
        lines = []
        for depth, spp, suffix in ((64, a.reference, ""), (2, a.depth2, "_depth2")):
            if spp >= 1:
                lines.append(ho.render_reference(scene, os.path.join(a.out, f"{name}{suffix}.exr"), spp, depth,
                                                 seeds=a.seeds, variant=a.variant))
                print(lines[-1], flush=True)
        with open(os.path.join(a.out, f"{name}.txt"), "a") as f:
            f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
