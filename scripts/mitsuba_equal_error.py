"""Mitsuba 3 at equal error: for each head with a converged truth, the
samples per pixel at which Mitsuba's path tracer (max_depth 64) reaches
each quality preset's error, and its time, beside the preset's frame, in
one run.

    python scripts/mitsuba_equal_error.py [--variant cuda_ad_rgb] [--out docs] [--heads a,b] [--max-spp 1024]

Heads: tests/data/dense (320x180), the held-out heads of
scripts/held_out_heads.py whose truth is in tests/data/held_out, and the
demo head at 640x360 when --demo-truth (default
../shared/references/demo_head_640.exr) exists. Each preset renders its
head with the scene's settings reduced to ``quality`` alone (as in
scripts/quality_table.py); its time is the best of two frames after one
that builds the shadow maps, lighting and volume solve (a camera move).

Mitsuba is measured at its best: the scene is loaded once, through drjit
directly (``mi.render`` and the read-back of the image, timed together),
and each spp is rendered twice with different seeds after a warm-up
render, the faster of the two counting (the first may compile kernels).
The spp ladder doubles from 1 until Mitsuba's relMSE is below half the
best preset's. The equal-error spp of a preset interpolates the ladder in
log(spp)-log(relMSE); Mitsuba then renders at that spp (rounded up), timed
the same way, and its measured error is reported beside the preset's.
Writes OUT/equal_error.md and OUT/equal_error.csv.
"""

from __future__ import annotations

import argparse
import csv
import math
import pathlib
import sys
import tempfile
import time

import numpy as np

import hairshade as hs

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import held_out_heads  # noqa: E402
from quality_table import DENSE, HEADS, cpu, preset_scene  # noqa: E402

from hairshade import options  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
HELD = ROOT / "tests" / "data" / "held_out"
DEMO_TRUTH = ROOT.parent / "shared" / "references" / "demo_head_640.exr"


def heads(tmp: str, demo_truth: pathlib.Path) -> list[tuple[str, hs.Scene, np.ndarray]]:
    """(name, scene with its settings reduced to what no preset sets, truth)."""
    out = [(n, preset_scene(n), hs.read_exr(DENSE / f"{n}.exr")[..., :3]) for n in HEADS]
    for n in held_out_heads.HEADS:
        if (HELD / f"{n}.exr").exists():
            scene = hs.Scene.load(held_out_heads.write_head(tmp, n))
            scene.render = {}
            out.append((n, scene, hs.read_exr(HELD / f"{n}.exr")[..., :3]))
    if demo_truth.exists():
        from hairshade.demo import SCENE, preset_scene as reduced

        scene = reduced(SCENE, 640, 360)
        out.append(("demo_head_640", scene, hs.read_exr(demo_truth)[..., :3]))
    return out


def preset_rows(scene: hs.Scene, truth: np.ndarray) -> dict[str, tuple[float, float]]:
    """Per preset: (relMSE, best frame time)."""
    rows = {}
    for q in options.QUALITIES:
        img = hs.render(scene, quality=q, progress=False)
        best = math.inf
        for _ in range(2):
            t = time.perf_counter()
            hs.render(scene, quality=q, progress=False)
            best = min(best, time.perf_counter() - t)
        rows[q] = (hs.rel_mse(img, truth), best)
    return rows


class Mitsuba:
    """One head's Mitsuba scene, loaded once (hairshade.mitsuba.LoadedScene);
    timed renders after a warm-up that compiles the kernels."""

    def __init__(self, scene: hs.Scene, variant: str):
        from hairshade.mitsuba import LoadedScene

        self.loaded = LoadedScene(scene, variant, first_seed=2)
        self.load_s = self.loaded.load_s
        self.render(1)  # warm-up: compiles the kernels

    def render(self, spp: int) -> tuple[np.ndarray, float]:
        return self.loaded.render(spp)

    def measure(self, spp: int, truth: np.ndarray) -> tuple[float, float]:
        """(mean relMSE of two renders, the faster one's time)."""
        (a, ta), (b, tb) = self.render(spp), self.render(spp)
        return 0.5 * (hs.rel_mse(a, truth) + hs.rel_mse(b, truth)), min(ta, tb)


def equal_spp(ladder: list[tuple[int, float, float]], target: float) -> float | None:
    """The spp where the ladder's relMSE crosses `target` (log-log), or None
    when the ladder never gets there."""
    for (s0, e0, _), (s1, e1, _) in zip(ladder, ladder[1:]):
        if e0 >= target >= e1 and e0 > e1:
            f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(s0) + f * (math.log(s1) - math.log(s0)))
    if ladder and ladder[0][1] <= target:
        return float(ladder[0][0])
    return None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variant", default=None, help="Mitsuba variant (default: cuda_ad_rgb where it runs, else llvm_ad_rgb)")
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--heads", help="comma-separated names (default: all with a truth)")
    ap.add_argument("--max-spp", type=int, default=1024)
    ap.add_argument("--demo-truth", default=str(DEMO_TRUTH))
    a = ap.parse_args()
    import mitsuba as mi

    import hairshade.mitsuba as hm

    variant = a.variant or ("cuda_ad_rgb" if "cuda_ad_rgb" in mi.variants() and _cuda() else hm.default_variant())
    rows, ladders = [], []
    with tempfile.TemporaryDirectory() as tmp:
        todo = heads(tmp, pathlib.Path(a.demo_truth))
        if a.heads:
            todo = [h for h in todo if h[0] in a.heads.split(",")]
        for name, scene, truth in todo:
            presets = preset_rows(scene, truth)
            m = Mitsuba(scene, variant)
            ladder, spp = [], 1
            floor = 0.5 * min(e for e, _ in presets.values())
            while spp <= a.max_spp:
                e, t = m.measure(spp, truth)
                ladder.append((spp, e, t))
                ladders.append(dict(head=name, spp=spp, rel_mse=e, seconds=t))
                print(f"{name:20s} mitsuba {spp:5d} spp relMSE {e:.2e} {t * 1e3:8.1f} ms", flush=True)
                if e < floor:
                    break
                spp *= 2
            for q, (err, frame) in presets.items():
                s = equal_spp(ladder, err)
                row = dict(head=name, model=scene.model, width=scene.camera["width"], height=scene.camera["height"],
                           quality=q, rel_mse=err, frame_s=frame, mitsuba_load_s=m.load_s)
                if s is not None:
                    n = max(1, math.ceil(s))
                    me, mt = m.measure(n, truth)
                    row.update(mitsuba_spp=n, mitsuba_rel_mse=me, mitsuba_s=mt, ratio=mt / frame)
                else:
                    row.update(mitsuba_spp=f">{ladder[-1][0]}", mitsuba_rel_mse=ladder[-1][1], mitsuba_s=math.nan,
                               ratio=math.nan)
                rows.append(row)
                print(f"{name:20s} {q:9s} relMSE {err:.2e} frame {frame * 1e3:8.1f} ms | mitsuba {row['mitsuba_spp']} spp "
                      f"relMSE {row['mitsuba_rel_mse']:.2e} {row['mitsuba_s'] * 1e3:8.1f} ms", flush=True)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "equal_error.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(out / "equal_error_ladder.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(ladders[0]))
        w.writeheader()
        w.writerows(ladders)
    (out / "equal_error.md").write_text(markdown(rows, variant, " ".join(sys.argv[1:])))
    return 0


def _cuda() -> bool:
    try:
        import mitsuba as mi

        mi.set_variant("cuda_ad_rgb")
        return True
    except Exception:  # no CUDA driver or device
        return False


def gpu() -> str:
    try:
        import subprocess

        return subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                              text=True, timeout=20).stdout.strip() or "no GPU"
    except (OSError, subprocess.SubprocessError):
        return "no GPU"


def markdown(rows: list[dict], variant: str, args: str) -> str:
    import mitsuba as mi

    lines = [
        "# Mitsuba 3 at equal error", "",
        f"Generated by `python scripts/mitsuba_equal_error.py{' ' + args if args else ''}`.", "",
        f"hairshade: {cpu()}, {hs.num_threads()} threads. Mitsuba {mi.__version__} `{variant}`"
        f"{' on ' + gpu() if variant.startswith('cuda') else ''}, `path` max_depth 64, loaded once, timed through "
        "drjit directly (render and read-back), the faster of two seeds after a warm-up render.", "",
        "Each preset's relMSE against the converged truth; the spp at which Mitsuba reaches it (interpolated on a "
        "doubling ladder, rendered at that spp and measured again); Mitsuba's time there over the preset's frame "
        "(best of 2 after a frame that builds the maps, lighting and volume solve).", "",
        "| head | size | preset | relMSE | frame | Mitsuba spp | its relMSE | Mitsuba time | Mitsuba / preset |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        t = "—" if math.isnan(r["mitsuba_s"]) else f"{r['mitsuba_s'] * 1e3:.1f} ms"
        ratio = "—" if math.isnan(r["ratio"]) else f"{r['ratio']:.2f}×"
        lines.append(f"| {r['head']} | {r['width']}×{r['height']} | {r['quality']} | {r['rel_mse']:.2e} | "
                     f"{r['frame_s'] * 1e3:.1f} ms | {r['mitsuba_spp']} | {r['mitsuba_rel_mse']:.2e} | {t} | {ratio} |")
    ratios = {q: [r["ratio"] for r in rows if r["quality"] == q and not math.isnan(r["ratio"])]
              for q in options.QUALITIES}
    lines += ["", "Median Mitsuba / preset time at equal error: " + ", ".join(
        f"{q} {np.median(v):.2f}× ({len(v)} heads)" for q, v in ratios.items() if v) + ".", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
