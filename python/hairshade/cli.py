"""The ``hairshade`` command line.

    hairshade validate   ChiangHair against Mitsuba 3: lobe tables, furnace, throughput
    hairshade bench      run time against error beside Mitsuba: BSDFs, renders (CSV, plots)
    hairshade tables     KarisHair error tables against DEonHair and ChiangHair (docs/)
    hairshade render     render a scene file with the rasterizer (EXR, optional PNG)
    hairshade compare    relMSE and FLIP of an image against a reference, side-by-side PNG
    hairshade demo       the demo head: rasterizer and Mitsuba, times and errors (out/)
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

import numpy as np

from . import __version__, _extras
from ._errors import escaped

# What each command needs beyond numpy (import names; see _extras.EXTRAS).
# The Mitsuba bridge imports scipy (hairshade.mapping), which [mitsuba] installs.
MITSUBA = ["mitsuba", "drjit", "scipy"]


def _fmt(x: float) -> str:
    return "   n/a  " if x != x else f"{x:8.2e}"


def cmd_validate(args: argparse.Namespace) -> int:
    _extras.check(MITSUBA, "hairshade validate", ["mitsuba"])
    import mitsuba as mi

    from . import validation
    from .mitsuba import default_variant

    variant = args.variant or "scalar_rgb"
    print(f"hairshade {__version__} | Mitsuba {mi.__version__} ({variant}; fast variant: {default_variant()})")
    rows, n_sets, n_pairs = validation.chiang_vs_mitsuba(variant, progress_bar=not args.no_progress)
    print()
    print(f"ChiangHair vs Mitsuba `hair`: {n_sets} parameter sets x {n_pairs} direction pairs")
    print("max relative difference where Mitsuba > 1e-4 x its maximum; per (beta_m, beta_n),")
    print("worst over 3 absorptions x 3 tilts. 'cond': pairs where Mitsuba's f32 offset is")
    print("well conditioned (0.05 <= |h| <= 0.95, |wi.xz| >= 0.1).")
    print()
    print("beta_m beta_n | eval i0=mitsuba  all     cond | pdf all  | eval i0=exact all")
    for r in rows:
        print(
            f"{r.beta_m:6.2f} {r.beta_n:6.2f} | {'':12}{_fmt(r.eval_all)} {_fmt(r.eval_cond)} |"
            f" {_fmt(r.pdf_all)} | {_fmt(r.eval_exact_all)}"
        )
    worst_cond = max(r.eval_cond for r in rows)
    print(f"\nworst well-conditioned eval difference (i0=mitsuba): {worst_cond:.2e}  (target <= 1e-4)")
    print("i0=exact differs by the Bessel approximation in Mitsuba's M_p (up to ~0.6%).")

    print("\nWhite furnace (sigma_a = 0, ideal albedo 1): max |albedo - 1| over 4 directions")
    print("beta  | hairshade exact | hairshade i0=mitsuba | Mitsuba")
    for beta, e, m, mm in validation.white_furnace(args.variant):
        print(f"{beta:5.2f} | {_fmt(e):>15} | {_fmt(m):>20} | {_fmt(mm)}")

    print("\nThroughput, 2^20 pairs, all threads, best of 5 (evals/s):")
    tp = validation.throughput(variant=args.variant)
    base = tp["hairshade f32"]
    for k, v in tp.items():
        print(f"  {k:40s} {v / 1e6:8.2f} M/s   ({v / base:5.2f} x hairshade f32)")
    ok = worst_cond <= 1e-4
    print("\nvalidate:", "OK" if ok else "FAILED")
    return 0 if ok else 1


def cmd_bench(args: argparse.Namespace) -> int:
    from . import bench_render, benchmark
    from .references import REFERENCES

    if args.out:
        args.csv = args.csv or os.path.join(args.out, "bench_bsdf.csv")
        args.plot = args.plot or os.path.join(args.out, "bench_bsdf.png")
        args.render = not args.bsdf_only
    if args.bsdf_only and args.render_only:
        raise ValueError("--bsdf-only and --render-only exclude each other")
    steps = tuple(args.render_steps.split(",")) if args.render_steps else None
    if steps is not None and not bench_render.valid_steps(steps):
        raise ValueError(f"--render-steps: expected comma-separated names among {', '.join(bench_render.STEPS)}, "
                         f"got {args.render_steps!r}")
    renders = args.render or args.render_only or steps is not None
    _extras.check(MITSUBA, "hairshade bench", ["mitsuba"])
    if args.plot or args.out:
        _extras.check(["matplotlib"], "hairshade bench --plot/--out")
    if renders and not os.path.isdir(REFERENCES):
        raise ValueError(f"the rendering benchmark compares against the Mitsuba references in tests/data of a source "
                         f"checkout ({os.path.normpath(REFERENCES)} not found); use --bsdf-only")
    if args.out:
        os.makedirs(args.out, exist_ok=True)
    if not args.render_only:
        rows = benchmark.bsdf_runtime_vs_error(n=args.n, repeats=args.repeats, fast=args.fast, variant=args.variant,
                                               progress_bar=not args.no_progress)
        print(f"BSDF run time against error ({args.n} pairs, best of {args.repeats}; error: rel. L2 vs converged f64 reference)")
        print(f"{'model':14s} {'variant':28s} {'prec':4s} {'threads':8s} {'M evals/s':>10s} {'rel L2 err':>11s}")
        for r in rows:
            print(f"{r['model']:14s} {r['variant']:28s} {r['precision']:4s} {r['threads']:8s} "
                  f"{r['evals_per_s'] / 1e6:10.3f} {r['rel_l2_error']:11.3e}")
        if args.csv:
            benchmark.write_csv(rows, args.csv)
            print(f"wrote {args.csv}")
        if args.plot:
            benchmark.plot(rows, args.plot)
            print(f"wrote {args.plot}")
    if renders:
        rrows = bench_render.render_runtime_vs_error(fast=args.fast, repeats=min(args.repeats, 3),
                                                     progress_bar=not args.no_progress, steps=steps)
        print(bench_render.summary(rrows))
        if args.out:
            old = os.path.join(args.out, "bench_render.csv")
            if steps is not None and os.path.exists(old):
                # the other steps' rows of the earlier run stay
                rrows = bench_render.merge(bench_render.read_csv(old), rrows)
            for ext, fn in (("csv", bench_render.write_csv), ("png", bench_render.plot)):
                path = os.path.join(args.out, f"bench_render.{ext}")
                fn(rrows, path)
                print(f"wrote {path}")
    return 0


def cmd_tables(args: argparse.Namespace) -> int:
    import json
    import os

    if not args.no_chiang:
        _extras.check(["scipy"], "hairshade tables (the ChiangHair comparison; --no-chiang skips it)")
    from . import tables

    os.makedirs(args.out, exist_ok=True)
    show = not args.no_progress
    fq = tables.fit_quality()
    print("Fit quality (Karis 2016 claims, re-measured):")
    print(f"  eta' fit, eta = 1.55: max relative error {fq['eta_prime_max_rel_err'] * 100:.3f}% over theta_d in [0, 89.9] deg"
          f" (claim < 0.68%; holds up to {fq['eta_prime_ok_up_to_deg']:.1f} deg)")
    print(f"  integral over phi: N_R fit {fq['int_N_R_fit']:.4f} | D_TT fit {fq['int_D_TT_fit']:.4f} (logistic {fq['int_D_TT']:.4f})"
          f" | D_TRT fit {fq['int_D_TRT_fit']:.4f} (3/4 logistic {fq['int_D_TRT']:.4f})")
    print("  Gaussian M_p mass on sin(theta) in [-1, 1]: " + ", ".join(
        f"beta {k.split('_')[-1]}: {v:.4f}" for k, v in fq.items() if k.startswith("int_M_gauss")))
    samp = {n: tables.deon_sampling_error(n, progress_bar=show) for n in (4, 16, 64)}
    print("DEonHair stratified h_samples vs converged, rel L2 (worst of r = 0.25, 0.6):")
    for n, e in samp.items():
        print(f"  h_samples={n:3d}: " + ", ".join(f"{k} {v:.3f}" for k, v in e.items()))
    deon_rows = tables.karis_vs_deon(progress_bar=show)
    print("\nKarisHair vs DEonHair (UE4 HairShadingRef), 16 materials x 1001 directions:")
    print("\n".join(tables.summary_markdown(deon_rows)))
    chiang_rows, params = (None, None)
    if not args.no_chiang:
        chiang_rows, params = tables.karis_vs_chiang(progress_bar=show, fit=not args.no_fit)
        print("\nKarisHair vs ChiangHair far field (mapped parameters):")
        print("\n".join(tables.summary_markdown(chiang_rows)))
    md = os.path.join(args.out, "error_tables.md")
    js = os.path.join(args.out, "error_tables.json")
    tables.write(md, js, deon_rows, chiang_rows, params)
    with open(js) as f:
        data = json.load(f)
    data["fit_quality"] = fq
    data["deon_h_samples_rel_l2"] = {str(k): v for k, v in samp.items()}
    with open(js, "w") as f:
        json.dump(data, f, indent=1)
    print(f"\nwrote {md} and {js}")
    return 0


def _finite(text: str) -> float:
    """An argparse type: a finite float."""
    x = float(text)
    if not np.isfinite(x):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return x


def _exposure(text: str) -> float:
    """An argparse type: an exposure in stops, finite, in [-100, 100]."""
    x = _finite(text)
    if abs(x) > 100:
        raise argparse.ArgumentTypeError(f"expected a number of stops in [-100, 100], got {text!r}")
    return x


def _at_least_one(text: str) -> int:
    """An argparse type: a whole number >= 1."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r:.40}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {n}")
    return n


def _lod(text: str) -> float | str:
    """--lod: 'auto' or a number (its range is checked by the renderer)."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'auto' or a fraction in (0, 1], got {text!r}") from None


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    """The render settings the command line sets: --quality, the methods
    (--transparency, --shadows, --multiple-scattering), --shading, --lod,
    and any setting by its path (--set transparency.coverage.samples=64)."""
    import json

    from . import options

    out: dict[str, Any] = {}
    for name in ("quality", "shading", "lod"):
        if getattr(args, name) is not None:
            out[name] = getattr(args, name)
    methods = {g: getattr(args, g) for g in options.GROUPS if getattr(args, g) is not None}
    group_opts: dict[str, dict[str, Any]] = {}
    for item in args.set or []:
        path, eq, text = item.partition("=")
        if not eq:
            raise ValueError(f"--set: expected PATH=VALUE, got {item!r:.80}")
        try:
            value = json.loads(text)
        except ValueError:
            value = text  # a bare word: a method's or a choice's name
        parts = path.split(".")
        if len(parts) == 3 and parts[0] in options.GROUPS:
            group, method, key = parts
            if methods.setdefault(group, method) != method:
                raise ValueError(f"--set {path}: the {group} method is {methods[group]!r}, not {method!r}")
            group_opts.setdefault(group, {})[key] = value
        elif len(parts) == 1:
            out[path] = value
        else:
            raise ValueError(f"--set: {path!r} is not a render setting (see docs/options.md)")
    if args.layers is not None:
        print("note: --layers is deprecated: use --set transparency.mlab.layers=N", file=sys.stderr)
        if methods.setdefault("transparency", "mlab") != "mlab":
            raise ValueError("--layers: applies to --transparency mlab only")
        group_opts.setdefault("transparency", {})["layers"] = args.layers
    for group, method in methods.items():
        out[group] = {method: group_opts[group]} if group in group_opts else method
    return out


def _scene_path(arg: str) -> str:
    """``arg``, or where it names a shipped example that is not a file here
    (``strand_head``, ``strand_head.json``, ``examples/strand_head.json``
    from a wheel), that example's path in the package (said on stderr)."""
    if os.path.exists(arg):
        return arg
    from . import examples

    name = os.path.basename(arg)
    name = name if name.endswith(".json") else name + ".json"
    for path in examples():
        if os.path.basename(path) == name:
            print(f"note: {arg} is not a file here: rendering the shipped example {path}", file=sys.stderr)
            return path
    return arg


def cmd_render(args: argparse.Namespace) -> int:
    import time

    from .render import render, write_exr, write_png
    from .scene import Scene

    out = args.output or os.path.splitext(os.path.basename(args.scene))[0] + ".exr"
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".exr", ".png"):
        print(f"error: {out}: unknown output format {ext or '(no extension)'!r} (use .exr or .png)", file=sys.stderr)
        return 2
    scene = Scene.load(_scene_path(args.scene), allow_outside=args.allow_outside)
    t = time.perf_counter()
    img, stats = render(scene, width=args.width, height=args.height, return_stats=True, **_settings(args))
    dt = time.perf_counter() - t
    # The image itself in the format its name asks for; --png adds a preview
    # next to an EXR (a PNG output is the preview already).
    if os.path.exists(out):
        print(f"note: replacing {escaped(out)}", file=sys.stderr)
    (write_exr if ext == ".exr" else lambda p, im: write_png(p, im, exposure=args.exposure))(out, img)
    print(f"{escaped(args.scene)}: {img.shape[1]}x{img.shape[0]} in {dt * 1000:.0f} ms "
          f"({stats['segments_visible']} visible segments, {stats['fragments']} fragments, "
          f"{stats['strands_drawn']} strands drawn) -> {escaped(out)}")
    if args.png and ext == ".exr":
        png = os.path.splitext(out)[0] + ".png"
        write_png(png, img, exposure=args.exposure)
        print(f"preview -> {escaped(png)}")
    return 0


def _contained(fn: Any) -> tuple[Any, str]:
    """(fn(), "") run in a forked child, so that a library that ends the
    process (flip-evaluator exits on a degenerate exposure range) ends only
    the child: then (None, reason). Runs in-process where fork is missing."""
    if not hasattr(os, "fork"):
        return fn(), ""
    import pickle

    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: only computes and writes
        os.close(r)
        try:
            data = pickle.dumps(fn())
        except BaseException as e:  # noqa: BLE001 - reported to the parent
            data = pickle.dumps(e)
        with os.fdopen(w, "wb") as f:
            f.write(data)
        os._exit(0)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        data = f.read()
    _, status = os.waitpid(pid, 0)
    if not data:
        return None, f"it ended the process (status {os.waitstatus_to_exitcode(status)})"
    out = pickle.loads(data)
    if isinstance(out, BaseException):
        return None, f"{type(out).__name__}: {out}"
    return out, ""


def _flip(img: np.ndarray, ref: np.ndarray) -> tuple[float, str]:
    """(mean HDR-FLIP of ``img`` against ``ref``, why it is NaN or "").
    Needs flip-evaluator (the commands check for it before they start); a
    black reference, or flip-evaluator ending the process, gives NaN and
    the reason."""
    flip = _extras.require("flip_evaluator", "FLIP")
    if not np.max(ref) > 0:
        return float("nan"), "the reference is black (FLIP's exposure range is undefined)"
    f, why = _contained(lambda: float(flip.evaluate(np.maximum(ref, 0), np.maximum(img, 0), "HDR")[1]))
    return float("nan") if f is None else f, why and f"FLIP failed: {why}"


def _read_image(path: str, layer: str | None = None) -> np.ndarray:
    """An image for `compare`: an EXR as it is (linear; ``layer`` of a
    multilayer file), a PNG decoded from sRGB to linear (its alpha
    dropped); other names are an error."""
    from . import _native
    from .render import read_exr, srgb_to_linear

    ext = os.path.splitext(path)[1].lower()
    if ext == ".exr":
        return read_exr(path, layer=layer)
    if ext == ".png":
        w, h, data = _native.read_png(path, None)
        return srgb_to_linear(data.reshape(h, w, 4)[..., :3]).astype(np.float32)
    raise ValueError(f"{escaped(path)}: expected an .exr or .png image")


def cmd_compare(args: argparse.Namespace) -> int:
    from .render import rel_mse, side_by_side, write_png

    if args.png and os.path.splitext(args.png)[1].lower() != ".png":
        print(f"error: --png: {escaped(args.png)}: the side-by-side picture is a PNG; name it NAME.png", file=sys.stderr)
        return 2

    if not args.no_flip:
        _extras.check(["flip_evaluator"], "hairshade compare (FLIP; --no-flip skips it)")
    a, b = _read_image(args.image, args.layer), _read_image(args.reference, args.reference_layer)
    if a.shape != b.shape:
        print(f"error: {args.image} is {a.shape[1]}x{a.shape[0]}, {args.reference} is {b.shape[1]}x{b.shape[0]}", file=sys.stderr)
        return 2
    for name, im in ((args.image, a), (args.reference, b)):
        bad = int(np.sum(~np.isfinite(im).all(axis=2)))
        if bad:
            print(f"error: {name}: {bad} pixel(s) not finite (NaN or inf); nothing to compare", file=sys.stderr)
            return 2
    f, why = (float("nan"), "") if args.no_flip else _flip(a, b)
    flip = "" if args.no_flip else f"  mean FLIP {f:.4f}"
    print(f"relMSE {rel_mse(a, b):.4e}{flip}  (mean radiance {a.mean():.4g} vs {b.mean():.4g})")
    if why:
        print(f"note: {why}", file=sys.stderr)
    if args.png:
        write_png(args.png, side_by_side(a, b), exposure=args.exposure)
        print(f"side by side [image | reference | error] -> {escaped(args.png)}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    _extras.check(MITSUBA + ["flip_evaluator"], "hairshade demo", ["mitsuba", "flip"])
    from . import demo

    demo.run(args.scene, args.out, args.width, args.height, args.spp, args.mitsuba_equal, args.exposure,
             flip=lambda img, ref: _flip(img, ref)[0])
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The command line: one subcommand per job."""
    p = argparse.ArgumentParser(prog="hairshade", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"hairshade {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    v = sub.add_parser("validate", help="compare ChiangHair with Mitsuba 3 and print tables")
    v.add_argument("--variant", default=None, help="Mitsuba variant for the lobe comparison (default scalar_rgb; llvm_ad_rgb elsewhere when available)")
    v.add_argument("--no-progress", action="store_true", help="no progress bar")
    v.set_defaults(func=cmd_validate)
    b = sub.add_parser("bench", help="run time against error beside Mitsuba (BSDFs; --render: renders)")
    b.add_argument("--n", type=_at_least_one, default=1 << 20, help="direction pairs (default 2^20)")
    b.add_argument("--repeats", type=_at_least_one, default=5, help="timed runs of each row, the best kept")
    b.add_argument("--variant", default=None,
                   help="Mitsuba variant to time beside hairshade (default llvm_ad_rgb where it runs, else scalar_rgb)")
    b.add_argument("--csv", default=None, help="write the results as CSV")
    b.add_argument("--plot", default=None, help="write the run time vs error plot (PNG)")
    b.add_argument("--fast", action="store_true", help="skip the slow DEonHair rows; small renders")
    b.add_argument("--render", action="store_true", help="also the rendering benchmark (frame times, Mitsuba spp sweep)")
    b.add_argument("--render-only", action="store_true", help="only the rendering benchmark")
    b.add_argument("--render-steps", default=None,
                   help="comma-separated steps of the rendering benchmark to run (frame, models, lod, error, dense, "
                        "strands, threads, skip; default all); with --out their rows replace those steps' rows "
                        "of the CSV there")
    b.add_argument("--bsdf-only", action="store_true", help="with --out: only the BSDF benchmark")
    b.add_argument("--out", default=None, help="write every CSV and plot (BSDF and rendering) into this folder")
    b.add_argument("--no-progress", action="store_true", help="no progress bar")
    b.set_defaults(func=cmd_bench)
    t = sub.add_parser("tables", help="KarisHair error tables against DEonHair and ChiangHair")
    t.add_argument("--out", default="docs", help="output folder (default docs/)")
    t.add_argument("--no-chiang", action="store_true", help="skip the ChiangHair comparison (its fits take ~2 min)")
    t.add_argument("--no-fit", action="store_true", help="analytic Chiang mapping only")
    t.add_argument("--no-progress", action="store_true", help="no progress bar")
    t.set_defaults(func=cmd_tables)
    r = sub.add_parser("render", help="render a scene file with the rasterizer")
    r.add_argument("scene", help="scene file (.json), or the name of a shipped example (strand_head, card_head, ...)")
    r.add_argument("-o", "--output", help="output image, .exr or .png (default: <scene>.exr)")
    r.add_argument("--png", action="store_true", help="also write an sRGB PNG preview")
    r.add_argument("--exposure", type=_exposure, default=0.0, help="PNG exposure in stops, in [-100, 100]")
    r.add_argument("--allow-outside", action="store_true",
                   help="let the scene read files outside its folder (default: only files inside it)")
    r.add_argument("--width", type=int, help="image width in pixels (default: the scene's)")
    r.add_argument("--height", type=int, help="image height in pixels (default: the scene's, or the aspect ratio's)")
    from . import options as _options

    r.add_argument("--quality", choices=_options.QUALITIES,
                   help=f"the preset the other settings refine (default: the scene's, else {_options.DEFAULT_QUALITY})")
    for group, (_, methods) in _options.GROUPS.items():
        r.add_argument(f"--{group.replace('_', '-')}", dest=group, choices=tuple(methods),
                       help=f"{group.replace('_', ' ')} method (default: the scene's, else the preset's)")
    r.add_argument("--set", action="append", metavar="PATH=VALUE",
                   help="any render setting by its path, e.g. transparency.coverage.samples=64 or "
                        "multiple_scattering.dual.backscatter=two_stream (values are JSON; see docs/options.md)")
    r.add_argument("--layers", type=int, help="deprecated: --set transparency.mlab.layers=N")
    r.add_argument("--shading", choices=("pixel", "vertex"), help="strands shaded per fragment or per vertex")
    r.add_argument("--lod", type=_lod, help="fraction of the strands drawn, in (0, 1], or 'auto'")
    r.set_defaults(func=cmd_render)
    c = sub.add_parser("compare", help="relMSE and FLIP of IMAGE against REFERENCE (EXR or PNG files)")
    c.add_argument("image", help="the image to measure (EXR, linear; or PNG, decoded from sRGB to linear)")
    c.add_argument("reference", help="the reference it is compared with (EXR or PNG, same size)")
    c.add_argument("--png", help="write a side-by-side PNG [image | reference | error]")
    c.add_argument("--exposure", type=_exposure, default=0.0,
                   help="exposure of the --png picture in stops, in [-100, 100] (default 0)")
    c.add_argument("--no-flip", action="store_true", help="relMSE only (FLIP needs hairshade[flip])")
    c.add_argument("--layer", help="the layer of a multilayer EXR IMAGE (e.g. ViewLayer.Combined; default: its "
                                   "only RGB or Combined layer)")
    c.add_argument("--reference-layer", help="the same for REFERENCE")
    c.set_defaults(func=cmd_compare)
    dm = sub.add_parser("demo", help="the demo head with each quality preset beside its converged truth, and Mitsuba "
                                     "at the balanced preset's error")
    dm.add_argument("--scene", default=os.path.join(os.path.dirname(__file__), "examples", "strand_head.json"),
                    help="scene file (default: the demo head, examples/strand_head.json)")
    dm.add_argument("--out", default="out", help="folder for the images (default out)")
    dm.add_argument("--width", type=_at_least_one, default=640, help="image width in pixels (default 640)")
    dm.add_argument("--height", type=_at_least_one, default=360, help="image height in pixels (default 360)")
    dm.add_argument("--spp", type=_at_least_one, default=32,
                    help="samples per pixel of Mitsuba's timed render (default 32; for another scene or size, of "
                         "the reference the presets are compared with)")
    dm.add_argument("--mitsuba-equal", action="store_true",
                    help="also render Mitsuba at the spp that reaches the balanced preset's error, and time it "
                         "(minutes on 2 cores; by default that time is estimated from the --spp render)")
    dm.add_argument("--exposure", type=_exposure, default=1.0, help="PNG exposure in stops, in [-100, 100] (default 1)")
    dm.set_defaults(func=cmd_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    if getattr(args, "n", 1) is not None and getattr(args, "n", 1) < 1:
        p.error("--n must be >= 1")
    np.seterr(all="ignore")
    try:
        return int(args.func(args))
    except (ValueError, OSError, _extras.MissingExtra) as e:  # SceneError is a ValueError
        print(f"error: {escaped(str(e))}", file=sys.stderr)
        return 2
    except MemoryError as e:
        print(f"error: out of memory{': ' + escaped(str(e)) if str(e) else ''}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
