"""The hostile cases of the robustness issue, each run in a child process
under a memory cap and a timeout, classified clean or not: writes
docs/hostile.md (and prints the table).

A case is a snippet run with numpy (`np`) and hairshade (`hs`) imported; it
is clean when its outcome is the one a careful library gives: the
exception its check names (with the field or parameter in the message),
or a correct result. Otherwise its outcome is what happened: an abort or a
signal death, a Rust panic in Python, a hang (past the timeout, or past
0.5 s after Ctrl-C where the case sends one), an unchecked memory blow-up,
a silent wrong result, or an unclear message.

    python scripts/hostile_table.py [--out docs]
    python scripts/hostile_table.py --pythonpath OLD --label before --json before.json

`--pythonpath` runs the cases against another build of the package (a
worktree of an earlier commit), `--json` keeps the outcomes, and
`--before before.json` puts an earlier run's outcomes beside this one's.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from typing import Any, Callable

ROOT = pathlib.Path(__file__).resolve().parent.parent
GIB = 1 << 30

PRELUDE = """
import json, os, resource, sys, time, warnings
resource.setrlimit(resource.RLIMIT_AS, ({cap}, {cap}))
import numpy as np
out = {{}}
try:
    import hairshade as hs
    from hairshade import _native
except BaseException as e:  # a setting refused at import
    out["exc"], out["msg"] = type(e).__name__, str(e)[:600]
    print("RESULT " + json.dumps(out), flush=True)
    sys.exit(0)
TMP = {tmp!r}
def scene_dict(**kw):
    d = {{"hairshade_scene": 1,
         "camera": {{"position": [0, 0.5, 2.5], "target": [0, 0.5, 0], "fov": 40, "resolution": [64, 36]}},
         "lights": [{{"type": "directional", "direction": [0.5, 0.7, 0.6], "intensity": [3, 3, 3]}}],
         "hair": {{"strands": [{{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.01}}]}}}}
    d.update(kw)
    return d
try:
{code}
    out["ok"] = True
except BaseException as e:
    out["exc"], out["msg"] = type(e).__name__, str(e)[:600]
print("RESULT " + json.dumps(out, default=float), flush=True)
"""


class Case:
    def __init__(self, name: str, kind: str, code: str, clean: Callable[[dict], bool], *, env: dict | None = None,
                 cap: int = 3 * GIB, timeout: float = 60, sigint_after: float | None = None):
        self.name, self.kind, self.code, self.clean = name, kind, textwrap.dedent(code).strip(), clean
        self.env, self.cap, self.timeout, self.sigint_after = env or {}, cap, timeout, sigint_after


def raised(exc: str | tuple[str, ...], *words: str) -> Callable[[dict], bool]:
    excs = (exc,) if isinstance(exc, str) else exc
    return lambda r: r.get("exc") in excs and all(w in r.get("msg", "") for w in words)


#: Seconds from Ctrl-C to the end of the work for a clean stop (the tests
#: allow more on a loaded machine).
STOP_LIMIT = 0.5


def stopped(r: dict) -> bool:
    """Stopped by Ctrl-C within STOP_LIMIT of the signal."""
    return r.get("exc") == "KeyboardInterrupt" and r.get("stop_s", 99) <= STOP_LIMIT


def result(test: Callable[[dict], bool]) -> Callable[[dict], bool]:
    return lambda r: r.get("ok") is True and test(r)


def cases(tmp: str) -> list[Case]:
    fifo = os.path.join(tmp, "fifo")
    if not os.path.exists(fifo):
        os.mkfifo(fifo)
    big_obj = os.path.join(tmp, "wall.obj")
    with open(big_obj, "w") as f:
        for i in range(400):
            z = -1 - 0.001 * i
            f.write(f"v -50 -50 {z}\nv 50 -50 {z}\nv 0 50 {z}\nf {3 * i + 1} {3 * i + 2} {3 * i + 3}\n")
    huge_obj = os.path.join(tmp, "huge.obj")
    with open(huge_obj, "wb") as f:
        f.write(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" + b"# padding\n" * (250_000_000 // 10))
    hair_claim = os.path.join(tmp, "claim.hair")
    import numpy as np
    from hairshade.hairfile import HEADER
    h = np.zeros(1, HEADER)
    h["magic"], h["strands"], h["points"], h["flags"] = b"HAIR", 2**32 - 1, 2**32 - 1, 0x2
    with open(hair_claim, "wb") as f:
        f.write(h.tobytes() + b"\0" * 24)
    stray = """
        from hairshade.generate import generate
        pts, _ = generate({"kind": "head", "strands": 200, "segments": 8, "seed": 1})
        d = scene_dict(hair={"strands": [{"points": np.asarray(p).tolist(), "radius": 0.002} for p in pts]})
        d["camera"] = {"position": [0, 0, 2.3], "target": [0, 0, 0], "fov": 40, "resolution": [64, 36]}
        _, alone = hs.render(hs.Scene.from_dict(d), return_stats=True)
        d["hair"]["strands"].append({"points": STRAY, "radius": 0.002})
        _, with_stray = hs.render(hs.Scene.from_dict(d), return_stats=True)
        out["alone"], out["with_stray"] = alone["fragments"], with_stray["fragments"]"""
    return [
        # -- abort and panic
        Case("eval_far table of 2^40 entries", "abort", """
            a = np.array([[0.3, 0.2, 0.9]])
            hs.ChiangHair()._native.eval_far(a.ravel(), a.ravel(), fast=True, table=(2**40, 2, 1.0))""",
             raised(("ValueError", "MemoryError"), "table")),
        Case("eval_far table of 2^62 x 2^62", "panic", """
            a = np.array([[0.3, 0.2, 0.9]])
            hs.ChiangHair()._native.eval_far(a.ravel(), a.ravel(), fast=True, table=(2**62, 2**62, 1.0))""",
             raised(("ValueError", "OverflowError", "MemoryError"), "table")),
        *[Case(f"RAYON_NUM_THREADS={v}", "panic" if v == "100000" else "message", """
            hs.render(hs.Scene.from_dict(scene_dict()))""",
               raised(("ValueError", "ImportError", "RuntimeError", "PanicException"), "RAYON_NUM_THREADS"),
             env={"RAYON_NUM_THREADS": v})
          for v in ("100000", "0", "-1", "abc")],
        # -- work that never ends or ignores Ctrl-C
        Case("from_arrays radius 1e300", "hang", """
            hs.render(hs.Scene.from_arrays(np.array([[0, 0, 0], [0, 1, 0.]]), 1e300, [0, 2]))""",
             raised("SceneError", "radii"), timeout=30),
        Case("Ctrl-C during 400 map-sized triangles at 8192", "hang", f"""
            d = scene_dict(meshes=[{{"type": "obj", "file": {big_obj!r}}}],
                           render={{"shadows": {{"exponential": {{"map_size": 8192}}}}}})
            s = hs.Scene.from_dict(d, allow_outside=True)
            print("go", flush=True)
            hs.render(s, progress=False)""",
             stopped, sigint_after=1.5, timeout=120),
        Case("Ctrl-C during DEonHair h_samples 2^20 on 1000 pairs", "hang", """
            wi = np.tile([[0.3, 0.2, 0.9]], (1000, 1)); wo = np.tile([[0.1, -0.3, 0.8]], (1000, 1))
            print("go", flush=True)
            hs.DEonHair(h_samples=2**20).eval(wi, wo, [0, 1.0, 0])""", stopped, sigint_after=1.5, timeout=60),
        Case("Ctrl-C during ChiangHair.sample of 5e7 pairs", "hang", """
            n = 50_000_000
            a, u1, u2 = np.tile(np.float32([0.3, 0.2, 0.9]), (n, 1)), np.full(n, 0.3, np.float32), np.full((n, 2), 0.6, np.float32)
            print("go", flush=True)
            hs.ChiangHair().sample(a, u1, u2)""", stopped, sigint_after=2.0, cap=8 * GIB,
             timeout=120),
        Case("Ctrl-C during an environment + dual scattering render", "hang", """
            from hairshade.generate import generate
            pts, _ = generate({"kind": "head", "strands": 20000, "segments": 24, "seed": 1})
            d = scene_dict(hair={"strands": [{"points": np.asarray(p).tolist(), "radius": 0.002} for p in pts]},
                           lights=[{"type": "directional", "direction": [0, 1, 1], "intensity": [2, 2, 2]},
                                   {"type": "environment", "radiance": [0.5, 0.5, 0.5]}],
                           render={"multiple_scattering": "dual", "quality": "accurate"})
            # (large enough to be still rendering when Ctrl-C comes, 2 s after the start)
            d["camera"] = {"position": [0, 0, 2.3], "target": [0, 0, 0], "fov": 40, "resolution": [2560, 1440]}
            s = hs.Scene.from_dict(d)
            print("go", flush=True)
            hs.render(s, progress=False)""", stopped, sigint_after=2.0, timeout=300),
        Case("Ctrl-C during hairshade bench --bsdf-only", "hang", """
            from hairshade.cli import main
            print("go", flush=True)
            out["rc"] = main(["bench", "--bsdf-only", "--out", TMP])""",
             lambda r: r.get("stop_s", 99) <= STOP_LIMIT and (r.get("exc") == "KeyboardInterrupt" or r.get("rc") == 130),
             sigint_after=2.0, timeout=300),
        Case("scene file is a FIFO", "hang", f"hs.Scene.load({fifo!r})", raised("SceneError", "regular file"),
             timeout=10),
        Case("hair.file is a FIFO", "hang", f"""
            hs.Scene.from_dict(scene_dict(hair={{"file": {fifo!r}}}), allow_outside=True)""",
             raised("SceneError", "hair.file", "regular file"), timeout=10),
        # -- memory
        Case("generate_cards 200 000 cards x 4096 fibers", "memory", """
            hs.Scene.from_dict(scene_dict(hair={"generate_cards": {"cards": 200000, "alpha": {"bake": {"fibers": 4096}}}}))""",
             raised("MemoryError", "generate_cards"), timeout=120),
        Case("a 250 MB OBJ", "memory", f"""
            hs.Scene.from_dict(scene_dict(meshes=[{{"type": "obj", "file": {huge_obj!r}}}]), allow_outside=True)""",
             raised(("SceneError", "MemoryError"), "meshes[0].file"), timeout=120),
        Case(".hair header claiming 2^32-1 strands", "memory", f"hs.Scene.from_dict(scene_dict(hair={{'file': {hair_claim!r}}}), allow_outside=True)",
             raised("SceneError", "claim.hair"), timeout=30),
        Case("BSDF output larger than the memory left", "memory", """
            wo = np.zeros((60_000_000, 3)); wo[:, 2] = 1
            hs.ChiangHair().eval(np.array([1.0, 0, 0]), wo)""", raised("MemoryError", "output array"),
             cap=5 * GIB // 2, timeout=60),
        # -- silent wrong or black images
        Case("a stray strand at z = -1e5", "wrong", stray.replace("STRAY", "[[0, 0, -1e5], [0, 0.1, -1e5]]") + """
        assert out["with_stray"] >= out["alone"] > 1000""", result(lambda r: True)),
        Case("a strand from x = -1e18 to 1e18", "wrong", stray.replace("STRAY", "[[-1e18, 0, -0.5], [1e18, 0, -0.5]]") + """
        assert out["with_stray"] >= out["alone"] > 1000""", result(lambda r: True)),
        Case("light direction [1e-40, 0, 0]", "wrong", """
            def img(direction):
                d = scene_dict(); d["lights"][0]["direction"] = direction
                return hs.render(hs.Scene.from_dict(d))
            assert np.array_equal(img([1e-40, 0, 0]), img([1, 0, 0]))""", result(lambda r: True)),
        Case("camera target 1e-12 from the position", "wrong", """
            d = scene_dict(); d["camera"]["target"] = [0, 0.5, 2.5 - 1e-12]
            img = hs.render(hs.Scene.from_dict(d)); assert img.max() > 0""", raised("SceneError", "camera.target")),
        Case("camera fov 1e-30", "wrong", """
            d = scene_dict(); d["camera"]["fov"] = 1e-30
            img = hs.render(hs.Scene.from_dict(d)); assert img.max() > 0""", raised("SceneError", "camera.fov")),
        Case("background 3e38 under coverage", "wrong", """
            d = scene_dict(render={"background": [3e38] * 3, "transparency": "coverage"})
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                hs.render(hs.Scene.from_dict(d))""", raised("RuntimeWarning", "overflowed")),
        Case("a duplicate JSON key", "wrong", f"""
            p = os.path.join(TMP, "dup.json")
            open(p, "w").write('{{"hairshade_scene": 1, "camera": {{"position": [0, 0, 3], "position": [0, 0, 2], "target": [0, 0, 0]}}}}')
            hs.Scene.load(p)""", raised("SceneError", "position", "twice")),
        # -- messages
        Case("a zero-width character in a key", "message", """
            d = scene_dict(); d["camera"]["fo\\u200bv"] = 40
            hs.Scene.from_dict(d)""", raised("SceneError", "fo\\u200bv")),
        Case("1.0000001e18 beyond 1e18", "message", """
            d = scene_dict(); d["camera"]["position"] = [0, 0, 1.0000001e18]
            hs.Scene.from_dict(d)""", lambda r: r.get("exc") == "SceneError" and "got 1e+18" not in r.get("msg", "")),
        Case("layers=np.int64(8)", "message", """
            hs.render(hs.Scene.from_dict(scene_dict()), transparency={"mlab": {"layers": np.int64(8)}})""",
             result(lambda r: True)),
        Case("shadow_density out of range", "message", """
            hs.render(hs.Scene.from_dict(scene_dict()), shadows={"exponential": {"density": -1.0}})""",
             lambda r: r.get("exc") == "SceneError" and "density" in r.get("msg", "") and len(r.get("msg", "")) < 300),
        Case("read_exr(max_pixels=-1)", "message", """
            p = os.path.join(TMP, "x.exr"); hs.write_exr(p, np.ones((2, 2, 3), np.float32))
            hs.read_exr(p, max_pixels=-1)""", raised("ValueError", "max_pixels")),
        Case("demo --width 3", "message", """
            import subprocess
            r = subprocess.run([sys.executable, "-m", "hairshade", "demo", "--width", "3", "--out", TMP],
                               capture_output=True, text=True, timeout=120)
            # a 3-pixel-wide demo, or a refusal naming the width (it said "got 0")
            assert (r.returncode == 0 or "width" in r.stderr) and "got 0" not in r.stderr, r.stderr[-300:]""",
             result(lambda r: True), timeout=180),
    ]


def run_case(c: Case, pythonpath: str, tmp: str) -> dict:
    prog = PRELUDE.format(cap=c.cap, tmp=tmp, code=textwrap.indent(c.code, "    "))
    env = dict(os.environ, PYTHONPATH=pythonpath, **c.env)
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-c", prog], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=env)
    r: dict[str, Any] = {}
    try:
        if c.sigint_after is not None:
            # the case prints "go" when its inputs are ready
            for line in p.stdout:
                if line.strip() == "go" or line.startswith("RESULT "):
                    break
            time.sleep(c.sigint_after)
            t_sig = time.perf_counter()
            p.send_signal(signal.SIGINT)
            stdout, stderr = p.communicate(timeout=c.timeout)
            r["stop_s"] = time.perf_counter() - t_sig
        else:
            stdout, stderr = p.communicate(timeout=c.timeout)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        return {"outcome": "hang", "seconds": c.timeout}
    r["seconds"] = time.perf_counter() - t0
    line = next((l for l in stdout.splitlines() if l.startswith("RESULT ")), None)
    if p.returncode < 0 or line is None:
        r["outcome"] = "abort" if "memory allocation" in stderr or p.returncode == -signal.SIGABRT else (
            f"killed ({signal.Signals(-p.returncode).name})" if p.returncode < 0 else "no result")
        r["stderr"] = stderr[-300:]
        if "KeyboardInterrupt" in stderr:
            r.update(exc="KeyboardInterrupt", outcome="")
    else:
        r.update(json.loads(line[len("RESULT "):]))
    if not r.get("outcome"):
        if c.clean(r):
            r["outcome"] = "clean"
        elif r.get("exc") == "PanicException":
            r["outcome"] = "panic"
        elif r.get("exc") == "KeyboardInterrupt" or r.get("rc") == 130:
            r["outcome"] = f"slow stop ({r.get('stop_s', 0):.1f} s)"
        elif r.get("exc") == "AssertionError":
            r["outcome"] = "wrong result"
        elif r.get("ok"):
            r["outcome"] = "returned without a word"
        else:
            msg = r.get("msg", "").splitlines()[0] if r.get("msg") else ""
            r["outcome"] = f"{r['exc']}: {msg[:90]}"
    # shown in a table: one line, characters visible
    r["outcome"] = r["outcome"].encode("ascii", "backslashreplace").decode().replace("|", "/")
    return r


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--pythonpath", default=str(ROOT / "python"))
    ap.add_argument("--label", default="after")
    ap.add_argument("--json", help="write the outcomes here (and no table)")
    ap.add_argument("--before", help="outcomes of an earlier run (--json) to show beside these")
    a = ap.parse_args()
    from hairshade.demo import cpu_name

    with tempfile.TemporaryDirectory() as tmp:
        results = {}
        for c in cases(tmp):
            r = run_case(c, a.pythonpath, tmp)
            results[c.name] = dict(kind=c.kind, **{k: v for k, v in r.items() if k in ("outcome", "stop_s", "seconds")})
            print(f"{c.kind:8s} {c.name:48s} {r['outcome']}", flush=True)
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(results, indent=1))
        return 0
    before = json.loads(pathlib.Path(a.before).read_text()) if a.before else {}
    kinds = list(dict.fromkeys(r["kind"] for r in results.values()))
    md = ["# The hostile cases, before and after", "",
          f"Generated by `python scripts/hostile_table.py` on {cpu_name()}: the reproductions "
          "of the robustness issue, each in a child process under a memory cap and a timeout (the script's docs "
          "say what counts as clean; a Ctrl-C case is clean when the work stops within 0.5 s of the signal). "
          "Before: the package as it was when the issue was filed (commit d9bac09, `--pythonpath` of a worktree "
          "build); after: this commit.", "",
          "| kind | cases | clean before | clean after |", "| --- | --- | --- | --- |"]
    for k in kinds + ["all"]:
        names = [n for n, r in results.items() if k in ("all", r["kind"])]
        cb = sum(before.get(n, {}).get("outcome") == "clean" for n in names)
        ca = sum(results[n]["outcome"] == "clean" for n in names)
        md.append(f"| {k} | {len(names)} | {cb if before else '-'} | {ca} |")
    md += ["", "| kind | case | before | after |", "| --- | --- | --- | --- |"]
    for n, r in results.items():
        def show(x: dict | None) -> str:
            x = x or {}
            o = x.get("outcome", "-")
            return f"{o} (stopped in {x['stop_s']:.2f} s)" if o == "clean" and "stop_s" in x else o
        md.append(f"| {r['kind']} | {n} | {show(before.get(n))} | {show(r)} |")
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "hostile.md").write_text("\n".join(md) + "\n")
    print(f"wrote {out / 'hostile.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
