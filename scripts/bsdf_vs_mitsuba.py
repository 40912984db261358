"""ChiangHair's vector kernel against Mitsuba's own ``hair.eval``, at each
SIMD level this CPU has, in one run.

    python scripts/bsdf_vs_mitsuba.py [--rounds 5] [--repeats 7] [--out docs]

Each round starts one child process per level (the CPU's best, then AVX2
where the CPU has more), in turn. A child evaluates the same 2^20 random
unit pairs (``hairshade.benchmark``'s, roughness 0.3/0.3) with hairshade's
f32 ``ChiangHair.eval`` (numpy in, numpy out, ``HAIRSHADE_SIMD`` set to the
level) and with Mitsuba's ``hair.eval`` (``llvm_ad_rgb``, data resident, as
``hairshade.benchmark.mitsuba_cases``), alternately, ``repeats`` times each
with a 20 ms pause before every call (``benchmark.PAUSE_S``), on all cores,
and reports the best of each. For the AVX2 level, Mitsuba's JIT is pinned to
the same instruction set: drjit-core's ``jit_llvm_set_target("haswell",
AVX2+FMA features, 8 lanes)``, called through ctypes; the table names the
CPU drjit then reports compiling for.

The ratio of each round comes from one process; the table gives every
round's rates and ratio, and their median. Where valgrind is installed, the
AVX2 kernel's instructions per pair are counted with callgrind (valgrind
cannot run AVX-512 code): instructions inside ``run_avx2`` over 2^16 pairs.

Writes OUT/bsdf_vs_mitsuba.md and OUT/bsdf_vs_mitsuba.csv.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import pathlib
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

AVX2_FEATURES = b"+avx,+avx2,+fma,+f16c,+bmi,+bmi2,+lzcnt,+popcnt,+sse4.2,+sse4.1,+ssse3,+sse3,+sse2,+sse,+cx16,+movbe"


def drjit_core():
    import ctypes

    import drjit as dr

    return ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))


def mitsuba_target_cpu() -> str:
    """The CPU drjit's LLVM backend compiles for (``jit_llvm_target_cpu()``)."""
    import ctypes

    cpu = drjit_core()._Z19jit_llvm_target_cpuv
    cpu.restype = ctypes.c_char_p
    return cpu().decode()


def pin_mitsuba_avx2() -> None:
    """Targets drjit's LLVM backend at AVX2 + FMA, 8 lanes."""
    import ctypes

    set_target = drjit_core()._Z19jit_llvm_set_targetPKcS0_j  # jit_llvm_set_target(const char*, const char*, uint32_t)
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    set_target(b"haswell", AVX2_FEATURES, 8)


def child(level: str, repeats: int) -> None:
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    from hairshade import _native
    from hairshade.benchmark import _random_pairs, mitsuba_cases, timed
    from hairshade.chiang import ChiangHair

    n = 1 << 20
    mi.set_variant("llvm_ad_rgb")
    dr.eval(mi.Float(1.0))
    if level == "avx2":
        pin_mitsuba_avx2()
    mitsuba_target = mitsuba_target_cpu()
    wi, wo = _random_pairs(n)
    a, b = wi.astype(np.float32), wo.astype(np.float32)
    c = ChiangHair(longitudinal_roughness=0.3, azimuthal_roughness=0.3)
    cm = ChiangHair(longitudinal_roughness=0.3, azimuthal_roughness=0.3, i0="mitsuba")
    resident = {path: fn for _, path, fn in mitsuba_cases(cm, wi, wo, "llvm_ad_rgb")}["data resident"]
    fns = {"hairshade": lambda: c.eval(a, b), "mitsuba": resident}
    for fn in fns.values():
        fn()  # warm-up: JIT compilation, thread pools
    best = {k: float("inf") for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            best[k] = min(best[k], timed(fn))
    print(json.dumps({"level": _native.simd_level(), "mitsuba_target": mitsuba_target,
                      "hairshade": n / best["hairshade"], "mitsuba": n / best["mitsuba"]}))


def instructions_per_pair(python: str) -> float | None:
    """Instructions per pair inside the AVX2 kernel (callgrind), or None without valgrind."""
    if shutil.which("valgrind") is None:
        return None
    n = 1 << 16
    code = ("import numpy as np; from hairshade.chiang import ChiangHair; "
            "from hairshade.benchmark import _random_pairs; "
            f"wi, wo = _random_pairs({n}); "
            "ChiangHair(longitudinal_roughness=0.3, azimuthal_roughness=0.3)"
            ".eval(wi.astype(np.float32), wo.astype(np.float32))")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cg.out")
        env = dict(os.environ, HAIRSHADE_SIMD="avx2", RAYON_NUM_THREADS="1")
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        "--toggle-collect=*chiang*simd*run_avx2*", python, "-c", code],
                       env=env, check=True, capture_output=True)
        with open(out) as f:
            for line in f:
                if line.startswith("summary:") or line.startswith("totals:"):
                    return int(line.split()[1]) / n
    return None


def cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default="docs")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child, args.repeats)
        return
    from hairshade import _native
    from hairshade._progress import progress

    best = _native.simd_level()
    levels = [best] + (["avx2"] if best == "avx512" else [])
    rows = []
    for r in progress(range(args.rounds), desc="rounds"):
        for level in levels:
            env = dict(os.environ, HAIRSHADE_SIMD=level)
            res = subprocess.run([sys.executable, __file__, "--child", level, "--repeats", str(args.repeats)],
                                 env=env, check=True, capture_output=True, text=True)
            d = json.loads(res.stdout.strip().splitlines()[-1])
            d["round"] = r + 1
            d["ratio"] = d["hairshade"] / d["mitsuba"]
            rows.append(d)
    ipp = instructions_per_pair(sys.executable)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "bsdf_vs_mitsuba.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["round", "level", "mitsuba_target", "hairshade_pairs_per_s", "mitsuba_pairs_per_s", "ratio"])
        for d in rows:
            w.writerow([d["round"], d["level"], d["mitsuba_target"], f"{d['hairshade']:.4g}", f"{d['mitsuba']:.4g}",
                        f"{d['ratio']:.3f}"])
    import mitsuba as mi

    lines = [
        "# ChiangHair's vector kernel beside Mitsuba's `hair.eval`",
        "",
        f"`python scripts/bsdf_vs_mitsuba.py --rounds {args.rounds} --repeats {args.repeats}` on "
        f"{cpu_name()}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}; Mitsuba {mi.__version__} "
        "`llvm_ad_rgb`, data resident. 2^20 random unit pairs, roughness 0.3/0.3; hairshade f32 "
        "`ChiangHair.eval`, numpy to numpy (output allocation included). Best of each child's repeats, "
        "all cores; one child process per level and round, so each ratio is from one process.",
        "",
        "| round | level | Mitsuba's target | hairshade M pairs/s | Mitsuba M pairs/s | ratio |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for d in rows:
        lines.append(f"| {d['round']} | {d['level']} | {d['mitsuba_target']} | {d['hairshade'] / 1e6:.1f} | "
                     f"{d['mitsuba'] / 1e6:.1f} | {d['ratio']:.2f} |")
    lines += ["", "Median ratio per level:", ""]
    for level in levels:
        ratios = [d["ratio"] for d in rows if d["level"] == level]
        lines.append(f"- {level}: {statistics.median(ratios):.2f} (range {min(ratios):.2f}-{max(ratios):.2f})")
    if ipp is not None:
        lines += ["", f"Instructions per pair in the AVX2 kernel (callgrind, 2^16 pairs, one thread): {ipp:.1f}."]
    (out / "bsdf_vs_mitsuba.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
