"""``hairshade demo``: the demo head rendered with each quality preset
beside its converged path-traced truth, with each preset's error and frame
time, then Mitsuba 3 timed at the ``balanced`` preset's error.

The truth ships with the package (``examples/strand_head_truth.npz``):
``examples/strand_head.json`` at 640×360, Mitsuba 3.9.1 ``path`` with
max_depth 64 on the ChiangHair that :mod:`hairshade.mapping` fits to the
head's KarisHair, two halves whose relMSE against each other is 1.2e-3
(stored as float16: relMSE 1.1e-8 against the float32 original). So the
errors printed are errors, not the noise of a quick reference. Even a
perfect KarisHair renderer keeps the two models' difference against it.
It was rendered with ``cuda_ad_rgb``, whose curves render a single fiber
1.5-1.8% darker than the exact computation and scatter less from fiber
to fiber (``docs/mitsuba_backends.md``; on the dense heads cuda was
0.2-4.5% darker than ``llvm_ad_rgb``). On this head the reference
backend agrees with it: ``scripts/demo_truth.py`` with ``llvm_ad_rgb``
(2 x 4096 spp, halves relMSE 2.8e-3) gives means 1.0018 / 1.0006 /
1.0002 of it, relMSE 2.1e-3 between the two (the llvm render's noise), so
the less noisy cuda render stays the truth.

Mitsuba renders the same scene once at ``mitsuba_spp`` (default 32),
loaded once and timed through drjit (render and read-back). Its error
against the truth follows relMSE ≈ C/spp + floor: the floor is the
truth's own noise (1.2e-3; a fit of Mitsuba's errors from 1 to 1024 spp,
``docs/equal_error_ladder.csv``, gives 1.3e-3). From that render, the spp
that reaches the ``balanced`` preset's error is estimated, and with it the
time Mitsuba needs there; ``mitsuba_equal=True`` renders at that spp and
measures it instead of estimating it. Last, Mitsuba renders with the spp
that fits in ``balanced``'s frame time, for the picture: truth | fast |
balanced | accurate | Mitsuba in balanced's time, error and time under
each (``out/demo_presets.png``).

For another scene or size there is no shipped truth: Mitsuba renders a
reference at ``mitsuba_spp``, and the errors are against it (said so).
"""

from __future__ import annotations

import json
import math
import os
import platform
import time

import numpy as np

from . import _native, options
from .render import rel_mse, render, write_exr, write_png
from .scene import Scene

EXAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "examples")
SCENE = os.path.join(EXAMPLES, "strand_head.json")
TRUTH = os.path.join(EXAMPLES, "strand_head_truth.npz")


def demo_truth() -> tuple[np.ndarray, dict]:
    """The demo head's converged truth at 640×360 -> ((360, 640, 3)
    float32, what it is: renderer, noise)."""
    with np.load(TRUTH) as z:
        return z["truth"].astype(np.float32), json.loads(str(z["meta"]))


def cpu_name() -> str:
    """The CPU's model name, its logical cores and the vector level the
    kernels run at."""
    name = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    name = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{name}, {os.cpu_count()} logical cores, {_native.simd_level()}"


def preset_scene(path: str | os.PathLike, width: int | None = None, height: int | None = None) -> Scene:
    """The scene with its render settings reduced to what no preset sets
    (so that ``quality`` decides them), at ``width`` x ``height`` when
    given."""
    scene = Scene.load(path)
    drop = (*options.GROUPS, *options.PRESET_SETTINGS, "quality")
    scene.render = {k: v for k, v in scene.render.items() if k not in drop}
    if width is not None and height is not None:
        scene.camera["width"], scene.camera["height"] = width, height
    return scene


def _frame(scene: Scene, quality: str) -> tuple[np.ndarray, float, float]:
    """(image, first frame's time, best of two frames after it)."""
    t = time.perf_counter()
    img = render(scene, quality=quality, progress=False)
    first = time.perf_counter() - t
    best = math.inf
    for _ in range(2):
        t = time.perf_counter()
        render(scene, quality=quality, progress=False)
        best = min(best, time.perf_counter() - t)
    return img, first, best


def _ratio(img: np.ndarray, ref: np.ndarray) -> str:
    r = img.reshape(-1, 3).mean(0) / np.maximum(ref.reshape(-1, 3).mean(0), 1e-12)
    return "/".join(f"{x:.2f}" for x in r)


def equal_spp(spp: int, rel: float, target: float, floor: float) -> int:
    """The spp at which a path tracer whose render at ``spp`` has error
    ``rel`` reaches ``target``, by relMSE = C/spp + floor."""
    if not rel > target > floor:
        raise ValueError(f"target: expected between floor {floor:g} and the render's relMSE {rel:g}, got {target:g}")
    return max(1, math.ceil(spp * (rel - floor) / (target - floor)))


def _picture(path: str, images: list[np.ndarray], labels: list[str], exposure: float | str) -> None:
    """The images side by side with a caption under each (matplotlib, the
    plot extra), or without captions where matplotlib is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        write_png(path, np.concatenate(images, axis=1), exposure=exposure)
        return
    from .render import tonemap

    h, w, _ = images[0].shape
    fig, axes = plt.subplots(1, len(images), figsize=(len(images) * w / 160, h / 160 + 0.6), dpi=160)
    for ax, img, label in zip(axes, images, labels):
        ax.imshow(tonemap(img, exposure=exposure), interpolation="nearest")
        ax.set_axis_off()
        ax.set_title(label, fontsize=7, y=-0.04, va="top")
    fig.subplots_adjust(left=0, right=1, top=1, bottom=0.17, wspace=0.02)
    fig.savefig(path)
    plt.close(fig)


def run(scene_path: str = SCENE, out: str = "out", width: int = 640, height: int = 360, mitsuba_spp: int = 32,
        mitsuba_equal: bool = False, exposure: float | str = 1.0, flip=None) -> dict:
    """Renders and prints the demo; writes its images into ``out``. Returns
    the numbers printed: {preset: {rel_mse, ratio, first_s, frame_s, flip}},
    and "mitsuba": {spp, rel_mse, seconds, load_s, equal_spp, equal_s}."""
    os.makedirs(out, exist_ok=True)
    scene = preset_scene(scene_path, width, height)
    shipped = os.path.abspath(scene_path) == os.path.abspath(SCENE) and (width, height) == (640, 360)
    print(f"demo: {os.path.relpath(scene_path)}, {scene.strand_count} strands, {width}x{height}; {cpu_name()}, "
          f"{_native.num_threads()} threads")
    from .mitsuba import LoadedScene

    mitsuba = LoadedScene(scene)
    result: dict = {}
    if shipped:
        truth, meta = demo_truth()
        print(f"truth: shipped with the package ({meta['renderer']}, {meta['material']}; its halves differ by relMSE "
              f"{meta['noise_halves_rel_mse']:.1e})")
        floor = float(meta["noise_halves_rel_mse"])
    else:
        print(f"truth: none shipped for this scene and size; Mitsuba renders a reference at {mitsuba_spp} spp, "
              "not converged: the errors below are against it, noise included")
        truth, _ = mitsuba.render(mitsuba_spp)
        floor = 0.0
    write_exr(os.path.join(out, "demo_truth.exr"), truth)
    shown = [truth]
    print(f"{'preset':9s} {'relMSE':>9s} {'FLIP':>7s}  mean/truth R/G/B   frame (first: maps, lighting, solve)")
    for q in options.QUALITIES:
        img, first, best = _frame(scene, q)
        write_exr(os.path.join(out, f"demo_{q}.exr"), img)
        write_png(os.path.join(out, f"demo_{q}.png"), img, exposure=exposure)
        f = flip(img, truth) if flip else math.nan
        result[q] = dict(rel_mse=rel_mse(img, truth), ratio=_ratio(img, truth), first_s=first, frame_s=best, flip=f)
        print(f"{q:9s} {result[q]['rel_mse']:9.2e} {f:7.4f}  {result[q]['ratio']:17s}  {best * 1e3:7.0f} ms "
              f"({first:.2f} s)")
        shown.append(img)
    labels = ["truth (path traced)"] + [f"{q}\nrelMSE {result[q]['rel_mse']:.1e}, {result[q]['frame_s']:.2f} s"
                                         for q in options.QUALITIES]
    if shipped:
        mitsuba.render(1)  # compiles the kernels: not timed
        img, secs = mitsuba.render(mitsuba_spp)
        e = rel_mse(img, truth)
        target = result["balanced"]["rel_mse"]
        m = dict(spp=mitsuba_spp, rel_mse=e, seconds=secs, load_s=mitsuba.load_s)
        print(f"Mitsuba {mitsuba.variant}, path tracing, {mitsuba_spp} spp: relMSE {e:.2e} in {secs:.1f} s "
              f"(+ {mitsuba.load_s:.1f} s loading)")
        if e > target > floor:
            n = equal_spp(mitsuba_spp, e, target, floor)
            m["equal_spp"] = n
            if mitsuba_equal:
                _, secs_n = mitsuba.render(n)
                m.update(equal_s=secs_n, equal_rel_mse=rel_mse(_, truth))
                print(f"Mitsuba at balanced's error ({target:.2e}): {n} spp, relMSE {m['equal_rel_mse']:.2e} in "
                      f"{secs_n:.1f} s, {secs_n / result['balanced']['frame_s']:.0f}x balanced's frame (measured)")
            else:
                m["equal_s"] = secs * n / mitsuba_spp
                print(f"Mitsuba at balanced's error ({target:.2e}): about {n} spp (from relMSE = C/spp + {floor:.1e}, "
                      f"the truth's noise), about {m['equal_s']:.0f} s: {m['equal_s'] / result['balanced']['frame_s']:.0f}x "
                      "balanced's frame (estimated from this render; --mitsuba-equal measures it)")
        else:
            print(f"Mitsuba at {mitsuba_spp} spp is already within balanced's error ({target:.2e})")
        # Mitsuba given balanced's frame time
        n_t = max(1, int(result["balanced"]["frame_s"] / (secs / mitsuba_spp)))
        img, secs_t = mitsuba.render(n_t)
        m.update(equal_time_spp=n_t, equal_time_s=secs_t, equal_time_rel_mse=rel_mse(img, truth))
        print(f"Mitsuba in balanced's time ({result['balanced']['frame_s']:.2f} s): {n_t} spp in {secs_t:.2f} s, "
              f"relMSE {m['equal_time_rel_mse']:.2e}")
        result["mitsuba"] = m
        shown.append(img)
        labels.append(f"Mitsuba, {n_t} spp\nrelMSE {m['equal_time_rel_mse']:.1e}, {secs_t:.2f} s")
        write_exr(os.path.join(out, "demo_mitsuba.exr"), img)
    picture = os.path.join(out, "demo_presets.png")
    _picture(picture, shown, labels, exposure)
    print(f"images in {out}/: demo_presets.png ({' | '.join(x.split(chr(10))[0] for x in labels)}), "
          "demo_<preset>.png/.exr, demo_truth.exr")
    return result
