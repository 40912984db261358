"""Frame time over thread counts: the demo head at 1280x720 with each
quality preset, with `lod: "auto"` and with per-fragment shading, at 1, 2, 4, ... threads,
in one run; and whether the image is the same at every thread count.

    python scripts/thread_scaling.py [--threads 1,2,4,8,16] [--out docs] [--repeats 2] [--name scaling]

Each thread count runs in a process of its own (RAYON_NUM_THREADS; the
pool is sized once per process), largest first. Per configuration: the
best of ``--repeats`` frames after one that builds the shadow maps, the
lighting and the volume solve (a camera move), and the SHA-1 of the
image's bytes. Of the best frame it also keeps the renderer's phase times
(``return_stats``: set-up, shadows, tiles, the tiles' own times summed),
the time spent outside the renderer's clock (the scene's conversion in and
the image's out), and the page faults it took: the second table says
where a thread count loses to perfect scaling. Writes OUT/NAME.md and
OUT/NAME.csv (NAME: --name, default scaling).

    python scripts/thread_scaling.py --ab RUNS.csv [--out docs] [--name scaling_ab]

summarizes an alternating before/after run (``scripts/gpu_checks.sh``
step ``before``): RUNS.csv holds this script's CSV rows of several runs,
each prefixed with its run's name (``before_1``, ``after_1``, ...); per
configuration and phase, the least and the median over each build's runs,
and the ratio of the least.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import os
import pathlib
import resource
import shlex
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCENE = ROOT / "python" / "hairshade" / "examples" / "strand_head.json"
# (label, render settings): the presets, and balanced with every sample shaded
CONFIGS = (("fast", {"quality": "fast"}), ("fast, lod: auto", {"quality": "fast", "lod": "auto"}),
           ("balanced", {"quality": "balanced"}),
           ("accurate", {"quality": "accurate"}), ("balanced, per-fragment shading", {"quality": "balanced",
                                                                                     "shading": "pixel"}))
# the renderer's phase times kept of each best frame (milliseconds; setup_ms includes vertex_ms)
PHASES = ("total_ms", "shadow_ms", "setup_ms", "vertex_ms", "tiles_ms", "tiles_busy_ms")


def child(repeats: int, width: int, height: int) -> None:
    import hairshade as hs
    from hairshade.demo import preset_scene

    for label, settings in CONFIGS:
        scene = preset_scene(SCENE, width, height)
        t = time.perf_counter()
        img = hs.render(scene, progress=False, **settings)
        first = time.perf_counter() - t
        best, phases = float("inf"), {}
        for _ in range(repeats):
            faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
            t = time.perf_counter()
            _, st = hs.render(scene, progress=False, return_stats=True, **settings)
            wall = time.perf_counter() - t
            if wall < best:
                best = wall
                phases = {k: st[k] for k in PHASES}
                phases["outside_ms"] = wall * 1e3 - st["total_ms"]
                phases["page_faults"] = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults
        print(json.dumps(dict(config=label, threads=hs.num_threads(), first_s=first, frame_s=best,
                              sha1=hashlib.sha1(img.tobytes()).hexdigest(), **phases)), flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", default="1,2,4,8,16")
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--name", default="scaling", help="the files' stem: OUT/NAME.md and OUT/NAME.csv")
    ap.add_argument("--ab", help="summarize the before/after runs of this CSV (see above) instead")
    ap.add_argument("--machine", help="with --ab: the machine the runs ran on (default: this one)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.ab:
        name = a.name if a.name != "scaling" else "scaling_ab"
        sys.path.insert(0, str(ROOT / "scripts"))
        from quality_table import cpu

        pathlib.Path(a.out, f"{name}.md").write_text(ab_markdown(pathlib.Path(a.ab), shlex.join(sys.argv[1:]),
                                                                 a.machine or cpu()))
        return 0
    width, height = (int(x) for x in a.size.split("x"))
    if a.child:
        child(a.repeats, width, height)
        return 0
    sys.path.insert(0, str(ROOT / "scripts"))
    from quality_table import cpu

    rows = []
    for n in sorted((int(x) for x in a.threads.split(",")), reverse=True):
        r = subprocess.run([sys.executable, __file__, "--child", "--repeats", str(a.repeats), "--size", a.size],
                           env=dict(os.environ, RAYON_NUM_THREADS=str(n)), capture_output=True, text=True)
        if r.returncode != 0:
            print(r.stderr[-3000:], file=sys.stderr)
            return 1
        for line in r.stdout.splitlines():
            d = json.loads(line)
            rows.append(d)
            print(f"{d['threads']:3d} threads  {d['config']:32s} {d['frame_s'] * 1e3:9.1f} ms  "
                  f"(first {d['first_s']:.2f} s)  {d['sha1'][:12]}", flush=True)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / f"{a.name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (out / f"{a.name}.md").write_text(markdown(rows, cpu(), " ".join(sys.argv[1:]), width, height, a.repeats))
    return 0


def markdown(rows: list[dict], cpu: str, args: str, width: int, height: int, repeats: int) -> str:
    threads = sorted({r["threads"] for r in rows})
    lines = [f"# Frame time over thread counts: {', '.join(map(str, threads))}", "",
             f"Generated by `python scripts/thread_scaling.py{' ' + args if args else ''}` on {cpu}.", "",
             f"The demo head (`examples/strand_head.json`, 25k strands, shadowed key light and environment) at "
             f"{width}×{height}: the best of {repeats} frames after one that builds the shadow maps, the lighting and the "
             "volume solve (a camera move), and in brackets the speed-up over one thread.", "",
             "| configuration | " + " | ".join(f"{n} thread{'s' if n > 1 else ''}" for n in threads) + " | same image |",
             "| --- | " + " | ".join("---" for _ in threads) + " | --- |"]
    for label, _ in CONFIGS:
        by = {r["threads"]: r for r in rows if r["config"] == label}
        if not by:
            continue
        base = by.get(1, by[min(by)])["frame_s"]
        cells = [f"{by[n]['frame_s'] * 1e3:.0f} ms ({base / by[n]['frame_s']:.1f}×)" if n in by else "—" for n in threads]
        same = "yes" if len({r["sha1"] for r in by.values()}) == 1 else "**no**"
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {same} |")
    lines += phase_table(rows, threads)
    return "\n".join(lines) + "\n"


def ab_markdown(path: pathlib.Path, args: str, machine: str) -> str:
    """The before/after summary of the runs in ``path`` (see the module's docs)."""
    runs: dict = {}
    header = None
    with open(path, newline="") as f:
        for row in csv.reader(f):
            if row[1:2] == ["config"]:
                header = row[1:]
                continue
            d = dict(zip(header, row[1:]))
            build = row[0].split("_")[0]
            runs.setdefault(d["config"], {}).setdefault(build, []).append(d)
    keys = [("frame_s", "frame"), ("total_ms", "renderer"), ("setup_ms", "set-up"), ("shadow_ms", "shadows"),
            ("tiles_ms", "tiles"), ("outside_ms", "outside"), ("page_faults", "page faults")]
    some = next(iter(runs.values()))
    threads = sorted({int(r["threads"]) for b in some.values() for r in b})
    lines = ["# Before and after, alternated in one run", "",
             f"`python scripts/thread_scaling.py {args}` over the runs of `scripts/gpu_checks.sh` step `before`: "
             f"each build's frame at {', '.join(map(str, threads))} threads in "
             f"{len(some.get('before', []))} processes each on {machine}, the builds alternated (before, after; after, before; "
             "...). Per configuration, the least and the median over a build's processes of each phase (ms; "
             "*outside*: the scene's conversion in and the image's out), and the ratio of the least. The "
             "same image: whether every process of both builds gave the same SHA-1.", "",
             "| configuration | what | before: least / median | after: least / median | after / before |",
             "| --- | --- | --- | --- | --- |"]
    for config, by in runs.items():
        if "before" not in by or "after" not in by:
            continue
        same = len({r["sha1"] for b in by.values() for r in b}) == 1
        for k, label in keys:
            scale = 1e3 if k == "frame_s" else 1.0
            v = {b: sorted(float(r[k]) * scale for r in by[b]) for b in ("before", "after")}
            med = {b: x[len(x) // 2] for b, x in v.items()}
            ratio = v["after"][0] / v["before"][0] if v["before"][0] > 0 else float("nan")
            what = label + ("" if k != "frame_s" else f" (same image: {'yes' if same else '**no**'})")
            lines.append(f"| {config} | {what} | {v['before'][0]:.1f} / {med['before']:.1f} | "
                         f"{v['after'][0]:.1f} / {med['after']:.1f} | {ratio:.3f} |")
    return "\n".join(lines) + "\n"


def phase_table(rows: list[dict], threads: list[int]) -> list[str]:
    """Where the most threads lose to perfect scaling: each phase's time at
    one thread and at the most, the tile pass's busy fraction (the tiles'
    own times over threads x its wall) and how much the tiles' own time
    grew, the time outside the renderer's clock, and the page faults."""
    n = max(threads)
    if n == 1 or 1 not in threads or "tiles_busy_ms" not in rows[0]:
        return []
    lines = ["", f"## Where {n} threads lose to perfect scaling", "",
             f"Phase times of the best frame (`return_stats`) at 1 and {n} threads, in ms. *Perfect* is one "
             f"thread's frame over {n}. *Busy*: the tiles' own times summed over {n} × the tile pass's wall "
             "(below 1: threads idle, waiting for the last tiles); *tile work*: the tiles' own times summed at "
             f"{n} threads over one thread's (above 1: each tile got slower, for memory bandwidth or "
             "contention). *Outside*: the scene's conversion in and the image's out, which one thread does. "
             "Set-up includes per-vertex shading.", "",
             f"| configuration | frame 1 / {n} | perfect | set-up 1 / {n} | shadows 1 / {n} | tiles 1 / {n} | busy | "
             f"tile work | outside 1 / {n} | page faults |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for label, _ in CONFIGS:
        by = {r["threads"]: r for r in rows if r["config"] == label}
        if 1 not in by or n not in by:
            continue
        a, b = by[1], by[n]

        def pair(k: str) -> str:
            return f"{float(a[k]):.0f} / {float(b[k]):.0f}"

        busy = float(b["tiles_busy_ms"]) / (n * float(b["tiles_ms"])) if float(b["tiles_ms"]) > 0 else float("nan")
        work = float(b["tiles_busy_ms"]) / float(a["tiles_busy_ms"]) if float(a["tiles_busy_ms"]) > 0 else float("nan")
        lines.append(f"| {label} | {float(a['frame_s']) * 1e3:.0f} / {float(b['frame_s']) * 1e3:.0f} | "
                     f"{float(a['frame_s']) * 1e3 / n:.0f} | {pair('setup_ms')} | {pair('shadow_ms')} | "
                     f"{pair('tiles_ms')} | {busy:.2f} | {work:.2f}× | {pair('outside_ms')} | "
                     f"{int(a['page_faults'])} / {int(b['page_faults'])} |")
    return lines


if __name__ == "__main__":
    sys.exit(main())
