"""Hostile files, huge inputs and slow work: every case ends in a Python
exception that names the file or the field, or in a correct image, within
seconds and under a memory cap; none aborts the interpreter or hangs.

Each group of cases runs in one child process (``run_cases``) whose
address space is capped with ``RLIMIT_AS`` and whose run time is bounded
by a timeout: an abort ("memory allocation of N bytes failed"), an
out-of-memory kill or a hang fails the test and names the case that was
running. A case is a snippet that either raises (its exception's type and
message are compared) or stores its result in ``result``.

The caps: the interpreter with numpy and hairshade imported maps ~220 MB
(``VmSize`` measured after the first batch call starts the thread pool),
so 1.5 GiB leaves every legitimate case room while any of the reproducers
(which asked for 4 GB to 40 GB) fails fast.
"""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import sys
import textwrap
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

import hairshade as hs
from helpers import PYTHON_DIR
from helpers import write_scene as scene

GIB = 1 << 30

PRELUDE = """
import json, os, resource, sys, traceback
resource.setrlimit(resource.RLIMIT_AS, ({cap}, {cap}))
import numpy as np
import hairshade as hs
from hairshade import _native
CASES = json.loads(sys.argv[1])
for name, code in CASES:
    print(json.dumps({{"start": name}}), flush=True)
    ns = {{"np": np, "hs": hs, "_native": _native, "os": os, "result": None}}
    try:
        exec(code, ns)
        out = {{"case": name, "ok": repr(ns["result"])[:400]}}
    except BaseException as e:
        out = {{"case": name, "exc": type(e).__name__, "msg": str(e)[:2000]}}
    print(json.dumps(out), flush=True)
"""


def run_cases(cases: dict[str, str], cap: int = 3 * GIB // 2, timeout: float = 60, env: dict | None = None,
              cwd: str | None = None) -> dict[str, dict]:
    """Runs each snippet in one child process under an address-space cap;
    returns {case: {"exc": type name, "msg": message} or {"ok": repr}}."""
    items = [(k, textwrap.dedent(v)) for k, v in cases.items()]
    e = dict(os.environ, PYTHONPATH=PYTHON_DIR, **(env or {}))
    try:
        r = subprocess.run([sys.executable, "-c", PRELUDE.format(cap=cap), json.dumps(items)], capture_output=True,
                           text=True, timeout=timeout, env=e, cwd=cwd)
    except subprocess.TimeoutExpired as t:
        out = t.stdout.decode() if isinstance(t.stdout, bytes) else (t.stdout or "")
        raise AssertionError(f"timed out after {timeout} s; last lines:\n{out[-1500:]}") from None
    results, started = {}, None
    for line in r.stdout.splitlines():
        d = json.loads(line)
        if "start" in d:
            started = d["start"]
        else:
            results[d.pop("case")] = d
    assert r.returncode == 0 and len(results) == len(items), (
        f"child ended with status {r.returncode} during case {started!r}:\n{r.stderr[-3000:]}")
    return results


def expect(results: dict[str, dict], case: str, exc: str | tuple[str, ...], *words: str) -> None:
    """The case raised `exc` with every one of `words` in its message."""
    r = results[case]
    excs = (exc,) if isinstance(exc, str) else exc
    assert r.get("exc") in excs, f"{case}: expected {excs}, got {r}"
    for w in words:
        assert w in r["msg"], f"{case}: {w!r} not in message {r['msg']!r}"


# -- hostile files ---------------------------------------------------------------


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def png_bytes(width: int, height: int, idat: bytes = b"") -> bytes:
    """A PNG (8-bit RGBA) whose header claims `width` x `height`."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(idat)) + _chunk(b"IEND", b"")


def exr_claiming(path: Path, width: int, height: int) -> None:
    """A small valid EXR whose data window is then rewritten to `width` x `height`."""
    hs.write_exr(path, np.full((4, 4, 3), 0.5, np.float32))
    data = bytearray(path.read_bytes())
    key = b"dataWindow\x00box2i\x00"
    i = data.index(key) + len(key) + 4  # the attribute's size, then x0 y0 x1 y1
    data[i:i + 16] = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    path.write_bytes(bytes(data))


def test_01_image_headers_claiming_huge_sizes(tmp_path):
    """The 68-byte PNG claiming 100000^2 pixels and the 2 KB EXR claiming
    60000^2 (40 GB and 43 GB as float32): refused from their headers in
    read_png/read_exr, as card alpha textures and in `hairshade compare`;
    a header within the pixel limit but beyond what the file's bytes can
    hold is refused too."""
    (tmp_path / "huge.png").write_bytes(png_bytes(100_000, 100_000))
    (tmp_path / "big.png").write_bytes(png_bytes(16_000, 16_000))  # 2^28 > 2.6e8 px, 1 GB, in ~60 bytes
    exr_claiming(tmp_path / "huge.exr", 60_000, 60_000)
    exr_claiming(tmp_path / "big.exr", 8_000, 8_000)
    assert len((tmp_path / "huge.png").read_bytes()) < 100 and len((tmp_path / "huge.exr").read_bytes()) < 2048
    for name in ("huge.png", "huge.exr"):
        scene(tmp_path, {"cards": [{"points": [[0, 0, 0], [0, 1, 0]], "width": 0.1, "alpha": {"image": name}}]},
              name=f"{name}.json")
    r = run_cases({
        "png": f"_native.read_png({str(tmp_path / 'huge.png')!r})",
        "exr": f"hs.read_exr({str(tmp_path / 'huge.exr')!r})",
        "png_small_file": f"_native.read_png({str(tmp_path / 'big.png')!r})",
        "exr_small_file": f"hs.read_exr({str(tmp_path / 'big.exr')!r})",
        "card_png": f"hs.Scene.load({str(tmp_path / 'huge.png.json')!r})",
        "card_exr": f"hs.Scene.load({str(tmp_path / 'huge.exr.json')!r})",
        "limit_is_configurable": f"_native.read_exr({str(tmp_path / 'big.exr')!r}, 1000)",
    })
    expect(r, "png", "ValueError", "huge.png", "100000x100000", "limit")
    expect(r, "exr", "ValueError", "huge.exr", "60000x60000", "limit")
    expect(r, "png_small_file", "ValueError", "big.png", "truncated or corrupt")
    expect(r, "exr_small_file", "ValueError", "big.exr", "truncated or corrupt")
    expect(r, "card_png", "SceneError", "hair.cards[0].alpha", "huge.png", "limit")
    expect(r, "card_exr", "SceneError", "hair.cards[0].alpha", "huge.exr", "limit")
    expect(r, "limit_is_configurable", "ValueError", "big.exr", "limit of 1000")
    out = subprocess.run([sys.executable, "-m", "hairshade", "compare", str(tmp_path / "huge.exr"),
                          str(tmp_path / "huge.exr")], capture_output=True, text=True, timeout=60,
                         env=dict(os.environ, PYTHONPATH=PYTHON_DIR))
    assert out.returncode == 2 and "huge.exr" in out.stderr and "limit" in out.stderr, out


def test_02_unreadable_and_unsafe_files_name_the_file(tmp_path):
    """Non-UTF-8 scene, OBJ and strand files; a folder given as a file; a
    401-digit integer; JSON nested 100000 deep; NaN in an alpha EXR; files
    outside the scene's folder (refused unless allowed); /dev/zero and
    /proc/self/environ even when allowed (not regular / not text, never
    echoed)."""
    latin1 = b'{"hairshade_scene": 1, "x": "caf\xe9"}'
    (tmp_path / "latin1.json").write_bytes(latin1)
    (tmp_path / "bad.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 \xff\n")
    (tmp_path / "bad.txt").write_bytes(b"0 0 0 0.01\n\xfe 1 0 0.01\n")
    (tmp_path / "folder").mkdir()
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    nan = np.full((4, 4, 3), 0.5, np.float32)
    nan[2, 1] = np.nan
    hs.write_exr(tmp_path / "nan.exr", nan)
    sub = tmp_path / "sub"
    sub.mkdir()
    (tmp_path / "outside.txt").write_text("0 0 0 0.01\n0 1 0 0.01\n")
    card = lambda img: {"cards": [{"points": [[0, 0, 0], [0, 1, 0]], "width": 0.1, "alpha": {"image": img}}]}  # noqa: E731
    scenes = {
        "obj": scene(tmp_path, meshes=[{"type": "obj", "file": "bad.obj"}], name="obj.json"),
        "strands": scene(tmp_path, {"file": "bad.txt"}, name="strands.json"),
        "folder": scene(tmp_path, {"file": "folder"}, name="folder.json"),
        "nan_alpha": scene(tmp_path, card("nan.exr"), name="nan.json"),
        "escape": scene(sub, {"file": "../outside.txt"}, name="escape.json"),
        "absolute": scene(sub, {"file": "/proc/self/environ"}, name="abs.json"),
        "dev_zero": scene(sub, {"file": "/dev/zero"}, name="zero.json"),
    }
    (tmp_path / "huge_int.json").write_text(
        '{"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, ' + "9" * 401 + "]}}")
    load = lambda p, **k: f"hs.Scene.load({str(p)!r}{''.join(f', {a}={v}' for a, v in k.items())})"  # noqa: E731
    r = run_cases({
        "utf8": load(tmp_path / "latin1.json"),
        "dir_scene": load(tmp_path / "folder"),
        "deep": load(tmp_path / "deep.json"),
        "huge_int": load(tmp_path / "huge_int.json"),
        **{k: load(p) for k, p in scenes.items()},
        "escape_allowed": f"result = {load(scenes['escape'], allow_outside=True)}.strand_count",
        "environ_allowed": load(scenes["absolute"], allow_outside=True),
        "dev_zero_allowed": load(scenes["dev_zero"], allow_outside=True),
    }, env={"HAIRSHADE_FUZZ_SECRET": "s3cr3t-value"})
    expect(r, "utf8", "SceneError", "latin1.json", "not UTF-8", f"byte {latin1.index(0xE9)}")
    expect(r, "dir_scene", "SceneError", "folder", "is a folder")
    expect(r, "deep", "SceneError", "deep.json", "nested too deeply")
    expect(r, "huge_int", "SceneError", "camera.target[2]", "401 digits")
    expect(r, "obj", "SceneError", "meshes[0].file", "bad.obj", "not UTF-8")
    expect(r, "strands", "SceneError", "hair.file", "bad.txt", "not UTF-8")
    expect(r, "folder", "SceneError", "hair.file", "is a folder")
    expect(r, "nan_alpha", "SceneError", "hair.cards[0].alpha", "nan.exr", "not finite", "x=1, y=2")
    expect(r, "escape", "SceneError", "hair.file", "outside the scene's folder", "allow_outside")
    expect(r, "absolute", "SceneError", "hair.file", "outside the scene's folder")
    assert r["escape_allowed"] == {"ok": "1"}
    # /proc files are regular files; this one is not text and is not echoed.
    expect(r, "environ_allowed", "SceneError", "hair.file", "environ")
    assert "s3cr3t" not in r["environ_allowed"]["msg"] and "PATH" not in r["environ_allowed"]["msg"]
    expect(r, "dev_zero_allowed", "SceneError", "hair.file", "/dev/zero", "not a regular file")


# -- huge inputs -----------------------------------------------------------------


def test_03_huge_allocations_raise_memory_error(tmp_path):
    """Under the issue's 2.5 GiB cap: eval on 6e7 float64 pairs (1.44 GB of
    input, then 1.44 GB of output), a 16384^2 render (6 GiB), two shadowed
    lights with 8192^2 opacity maps (7 GiB each) and `generate` with 2e6
    strands x 256 segments (84 GiB at the measured 176 B/vertex):
    MemoryError naming what was too big, before any of it is allocated;
    the process goes on working afterwards."""
    strands = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    lights = [{"type": "directional", "direction": [1, 1, 1], "intensity": [3, 3, 3], "shadows": True},
              {"type": "directional", "direction": [-1, 1, 1], "intensity": [3, 3, 3], "shadows": True}]
    scene(tmp_path, strands, name="big_render.json")
    scene(tmp_path, strands, name="opacity.json", lights=lights,
          render={"shadow_model": "opacity", "shadow_map_size": 8192})
    scene(tmp_path, {"generate": {"kind": "head", "strands": 2_000_000, "segments": 256}}, name="gen.json")
    # 1.6 TB at the measured 84 B a baked vertex (grew for minutes before)
    scene(tmp_path, {"generate_cards": {"cards": 200_000, "alpha": {"bake": {"fibers": 4096}}}}, name="cards.json")
    r = run_cases({
        "cards": f"hs.Scene.load({str(tmp_path / 'cards.json')!r})",
        "eval": """
            wo = np.zeros((60_000_000, 3)); wo[:, 2] = 1
            hs.ChiangHair().eval(np.array([1.0, 0, 0]), wo)""",
        "render_16k": f"hs.render(hs.Scene.load({str(tmp_path / 'big_render.json')!r}), width=16384, height=16384)",
        "opacity_8k": f"hs.render(hs.Scene.load({str(tmp_path / 'opacity.json')!r}))",
        "generate": f"hs.Scene.load({str(tmp_path / 'gen.json')!r})",
        "still_works": "result = float(hs.ChiangHair().eval([0, 0.2, 1.0], [0.3, -0.2, 0.9]).sum() > 0)",
    }, cap=5 * GIB // 2)
    # refused against the memory available before it is reserved (the
    # system may grant a reservation it cannot back: filled, it was killed)
    expect(r, "eval", "MemoryError", "output array of 180000000 values", "GiB available")
    expect(r, "render_16k", "MemoryError", "image (framebuffer and tiles)", "GiB available")
    expect(r, "opacity_8k", "MemoryError", "shadow maps", "shadow_map_size")
    expect(r, "generate", ("MemoryError", "SceneError"), "2000000 strands of 256 segments", "GiB")
    expect(r, "cards", "MemoryError", "hair.generate_cards: 200000 cards, 819200000 baked fibers", "GiB available")
    assert r["still_works"] == {"ok": "1.0"}


def test_04_shadow_map_cache_is_bounded_in_bytes(tmp_path):
    """Two shadowed lights with 1536^2 opacity maps (283 MB each, 566 MB
    together): the cache keeps what fits in its 512 MiB, one map. Measured
    as the process's mapped size (VmSize: large buffers are mappings of
    their own, freed on drop) after the render and `del`, against the size
    after two warm-up renders with 16^2 maps (thread pool and allocator
    arenas already set up): measured 283.1 MB, one map's 283.1 MB (without
    the byte bound both maps stay: 566 MB). Slack: 16 MB. One malloc arena
    (MALLOC_ARENA_MAX=1): a worker thread that first allocates during the
    measured render would otherwise reserve an arena of its own (64 MiB of
    address space, seen once as 334 MiB held on a 2-core machine)."""
    lights = [{"type": "directional", "direction": [1, 1, 1], "intensity": [3, 3, 3], "shadows": True},
              {"type": "directional", "direction": [-1, 1, 1], "intensity": [3, 3, 3], "shadows": True}]
    p = scene(tmp_path, {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}, lights=lights,
              render={"shadow_model": "opacity", "shadow_map_size": 1536})
    r = run_cases({"held": f"""
        import gc
        size = lambda: next(int(l.split()[1]) * 1024 for l in open('/proc/self/status') if l.startswith('VmSize'))
        s = hs.Scene.load({str(p)!r})
        warm = hs.Scene.load({str(p)!r})
        warm.render["shadow_map_size"] = 16
        hs.render(warm, width=32, height=18)
        hs.render(warm, width=32, height=18)
        before = size()
        img = hs.render(s, width=32, height=18)
        del img, s
        gc.collect()
        result = size() - before"""}, cap=3 * GIB, env={"MALLOC_ARENA_MAX": "1"})
    held = int(r["held"]["ok"])
    one_map = 1536**2 * (2 * 4 + 12 * 4 + 4 * 16)
    assert one_map <= held < one_map + (16 << 20), f"{held / 2**20:.0f} MiB held after the render"


# -- hangs -------------------------------------------------------------------------


def test_05_values_beyond_float32_and_unbounded_work_are_refused(tmp_path):
    """A radius of 1e39 (inf in float32: the shadowed render never
    returned), light intensity 1e300, SH 1e300, points 1e39, a background of
    1e39, DEonHair(h_samples=10**9): refused, naming the field."""
    light = {"type": "directional", "direction": [1, 1, 1], "intensity": [3, 3, 3], "shadows": True}
    strand = lambda **k: {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01, **k}]}  # noqa: E731
    cases = {
        "radius": scene(tmp_path, strand(radius=1e39), name="r.json", lights=[light]),
        "intensity": scene(tmp_path, strand(), name="i.json", lights=[{**light, "intensity": [1e300, 1, 1]}]),
        "sh": scene(tmp_path, strand(), name="sh.json",
                    lights=[{"type": "environment", "sh": [[1e300, 0, 0]] + [[0, 0, 0]] * 8}]),
        "points": scene(tmp_path, strand(points=[[0, 0, 0], [0, 1e39, 0]]), name="p.json"),
        "background": scene(tmp_path, strand(), name="b.json", render={"background": [1e39, 0, 0]}),
    }
    r = run_cases({**{k: f"hs.Scene.load({str(p)!r})" for k, p in cases.items()},
                   "h_samples": "hs.DEonHair(h_samples=10**9)"}, timeout=30)
    expect(r, "radius", "SceneError", "hair.strands[0].radius", "1e+39")
    expect(r, "intensity", "SceneError", "lights[0].intensity[0]")
    expect(r, "sh", "SceneError", "lights[0].sh[0][0]")
    expect(r, "points", "SceneError", "hair.strands[0].points[1][1]")
    expect(r, "background", "SceneError", "render.background", "float32")
    expect(r, "h_samples", "ValueError", "h_samples", "1048576")


def _interrupt_after(code: str, delay: float, timeout: float = 20) -> tuple[float, str]:
    """Runs `code` in a child, sends SIGINT `delay` s after it printed
    'go'; returns (seconds from the signal to the child's exit, stderr)."""
    prog = "import numpy as np, hairshade as hs\n" + textwrap.dedent(code)
    p = subprocess.Popen([sys.executable, "-c", prog], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, PYTHONPATH=PYTHON_DIR))
    assert p.stdout.readline().strip() == "go"
    time.sleep(delay)
    t = time.perf_counter()
    p.send_signal(signal.SIGINT)
    try:
        _, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        p.kill()
        raise AssertionError("the batch ignored Ctrl-C") from None
    return time.perf_counter() - t, err


@pytest.mark.parametrize("call", [
    "hs.ChiangHair().eval_far(wi, wo)",
    "hs.DEonHair().eval(wi, wo, [0, 1.0, 0])",  # converged: ~1 ms a pair
    # 1000 pairs at the most offsets (2^20: about a second a pair): a batch
    # this small ran unpolled for 14 minutes
    "hs.DEonHair(h_samples=2**20).eval(wi[:1000], wo[:1000], [0, 1.0, 0])",
])
def test_06_batch_calls_stop_on_ctrl_c(call):
    """eval_far by quadrature and converged DEonHair on 3e6 pairs (minutes
    of work): Ctrl-C raises KeyboardInterrupt within a second (the batch
    checks every 50 ms and every 64 pairs; measured 0.08 to 0.16 s; 3 s
    allows for a loaded 2-core machine)."""
    dt, err = _interrupt_after(f"""
        wi = np.tile([[0.3, 0.2, 0.9]], (3_000_000, 1)); wo = np.tile([[0.1, -0.3, 0.8]], (3_000_000, 1))
        print("go", flush=True)
        {call}
        print("finished")""", delay=1.0)
    assert "KeyboardInterrupt" in err, err[-2000:]
    assert dt < 3.0, f"{dt:.2f} s from Ctrl-C to exit"


def test_06b_render_of_a_slow_model_stops_within_a_tile():
    """Converged DEonHair (about 1 ms a fragment and light) on 800 strands
    crossing a 32×32 image: each tile holds thousands of fragments,
    seconds of shading, and used to finish its tile before Ctrl-C took
    effect. Shading now returns at once after a cancel: KeyboardInterrupt
    within 3 s of the signal (a loaded 2-core machine; measured 0.04 s, and
    7.8 s before shading looked at the cancel flag)."""
    dt, err = _interrupt_after("""
        ys = np.linspace(-0.3, 0.3, 800)
        strands = [{"points": [[-1, y, -0.001 * i], [1, y, -0.001 * i]], "radius": 0.004} for i, y in enumerate(ys)]
        d = {"hairshade_scene": 1,
             "camera": {"position": [0, 0, 1], "target": [0, 0, 0], "fov": 40, "resolution": [32, 32]},
             "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [2, 2, 2], "shadows": False}],
             "hair": {"strands": strands, "material": {"model": "deon", "base_color": [0.4, 0.3, 0.2]}},
             "render": {"transparency": "sorted"}}
        s = hs.Scene.from_dict(d)
        print("go", flush=True)
        hs.render(s, progress=False)
        print("finished")""", delay=1.0)
    assert "KeyboardInterrupt" in err, err[-2000:]
    print(f"{dt:.2f} s from Ctrl-C to exit")
    assert dt < 3.0, f"{dt:.2f} s from Ctrl-C to exit"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_02b_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path):
    """A FIFO as the scene file, as hair.file and given to read_hair used to
    block in open() before the regular-file check: each is refused at once."""
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    t = time.perf_counter()
    with pytest.raises(hs.SceneError, match="not a regular file"):
        hs.Scene.load(str(fifo))
    d = {"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0]}, "lights": [],
         "hair": {"file": "pipe.hair"}}
    os.mkfifo(tmp_path / "pipe.hair")
    (tmp_path / "s.json").write_text(json.dumps(d))
    with pytest.raises(hs.SceneError, match="hair.file.*not a regular file"):
        hs.Scene.load(str(tmp_path / "s.json"))
    from hairshade.hairfile import read_hair
    with pytest.raises(ValueError, match="not a regular file"):
        read_hair(tmp_path / "pipe.hair")
    assert time.perf_counter() - t < 5


def test_05b_arrays_and_hair_files_take_the_scene_formats_bounds(tmp_path):
    """from_arrays and .hair files skipped the scene format's 1e18 bound: a
    radius of 1e300 became inf in float32 and the shadow-map build never
    ended. Both are refused, naming the value."""
    with pytest.raises(hs.SceneError, match=r"radii\[0\]: must be at most 1e\+18"):
        hs.Scene.from_arrays(np.array([[0, 0, 0], [0, 1, 0.0]]), 1e300, [0, 2])
    with pytest.raises(hs.SceneError, match=r"points\[1\]: must be at most 1e\+18"):
        hs.Scene.from_arrays(np.array([[0, 0, 0], [0, 1e19, 0.0]]), 0.01, [0, 2])
    from hairshade.hairfile import HEADER, POINTS, SEGMENTS, THICKNESS
    h = np.zeros(1, HEADER)
    h["magic"] = b"HAIR"
    h["strands"], h["points"] = 1, 2
    h["flags"] = SEGMENTS | POINTS | THICKNESS
    body = np.array([1], "<u2").tobytes() + np.array([0, 0, 0, 0, 3e38, 0], "<f4").tobytes()
    body += np.array([0.01, 0.01], "<f4").tobytes()
    (tmp_path / "big.hair").write_bytes(h.tobytes() + body)
    d = {"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0]}, "lights": [],
         "hair": {"file": "big.hair"}}
    (tmp_path / "s.json").write_text(json.dumps(d))
    with pytest.raises(hs.SceneError, match=r"hair.file.*point\[1\]: must be at most 1e\+18"):
        hs.Scene.load(str(tmp_path / "s.json"))


@pytest.mark.parametrize("table", [(2**40, 2, 1.0), (2**62, 2**62, 1.0), (1, 100, 3.0), (48, 100, float("nan")),
                                   (1024, 8192, 3.0)])
def test_03b_far_field_table_sizes_are_bounded(table):
    """A table size given to eval_far was never checked: 2^40 nodes aborted
    the process (an allocation of 44 TB) and 2^62 panicked with a capacity
    overflow. It is refused before anything is allocated, naming `table`
    and its ranges."""
    a = np.array([0.3, 0.2, 0.9])
    with pytest.raises(ValueError, match=r"table: expected \(cos_theta nodes in \[2, 1024\]"):
        hs.ChiangHair()._native.eval_far(a, a, fast=True, table=table)


def test_20_hair_header_counts_checked_against_the_file_size(tmp_path):
    """A 152-byte `.hair` whose header claims 2^32 - 1 strands and points
    (a 32 GiB np.full before any size check) is refused from its header
    under a 1.5 GiB cap, naming the file; as is one claiming more strands
    than its points can make."""
    from hairshade.hairfile import HEADER

    cases = {}
    for name, strands, points in (("huge", 2**32 - 1, 2**32 - 1), ("strands", 2**32 - 1, 2)):
        h = np.zeros(1, HEADER)
        h["magic"], h["strands"], h["points"], h["flags"] = b"HAIR", strands, points, 0x2
        (tmp_path / f"{name}.hair").write_bytes(h.tobytes() + b"\0" * 24)
        p = scene(tmp_path, {"file": f"{name}.hair"}, name=f"{name}.json")
        cases[name] = f"hs.Scene.load({str(p)!r})"
    r = run_cases(cases, timeout=30)
    expect(r, "huge", "SceneError", "huge.hair", "claims 4294967295 points", "24 bytes")
    expect(r, "strands", "SceneError", "strands.hair", "4294967295 strands for 2 points")


def test_26_shadow_maps_stop_on_ctrl_c():
    """Shadow maps polled no cancel flag: 400 triangles, each covering an
    8192² map (67 M texels), take minutes to draw, and Ctrl-C waited for
    them. The drawing polls it between segments, quads, triangles and rows:
    KeyboardInterrupt within 3 s of the signal (the bound of test 06 on a
    loaded 2-core machine; the render makes no other progress meanwhile)."""
    dt, err = _interrupt_after("""
        import os, tempfile
        obj = os.path.join(tempfile.mkdtemp(), "wall.obj")
        with open(obj, "w") as f:
            for i in range(400):
                z = -1 - 0.001 * i
                f.write(f"v -50 -50 {z}\\nv 50 -50 {z}\\nv 0 50 {z}\\nf {3 * i + 1} {3 * i + 2} {3 * i + 3}\\n")
        d = {"hairshade_scene": 1,
             "camera": {"position": [0, 0, 2], "target": [0, 0, 0], "fov": 40, "resolution": [32, 18]},
             "lights": [{"type": "directional", "direction": [0, 0, 1], "intensity": [2, 2, 2]}],
             "hair": {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]},
             "meshes": [{"type": "obj", "file": obj}],
             "render": {"shadows": {"opacity": {"map_size": 8192}}}}
        s = hs.Scene.from_dict(d, allow_outside=True)
        print("go", flush=True)
        hs.render(s, progress=False)
        print("finished")""", delay=1.0, timeout=120)
    assert "KeyboardInterrupt" in err, err[-2000:]
    print(f"{dt:.2f} s from Ctrl-C to exit")
    assert dt < 3.0, f"{dt:.2f} s from Ctrl-C to exit"


def test_28_obj_files_are_bounded_by_their_parsing_cost(tmp_path):
    """An OBJ is parsed line by line at about 11 bytes of memory per byte
    and 0.07 s per megabyte of file (scene.MAX_OBJ_BYTES): one over
    64 MiB is refused by name before it is parsed (a 250 MB file parsed
    for minutes through gigabytes), and under a memory cap a file that
    fits the size limit but not the memory is a MemoryError naming it."""
    big = tmp_path / "big.obj"
    with open(big, "wb") as f:
        f.write(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        f.write(b"# padding\n" * ((64 << 20) // 10 + 1))
    scene(tmp_path, {"strands": [{"points": [[0, 0, 0], [0, 1, 0]]}]}, name="obj.json",
          meshes=[{"type": "obj", "file": "big.obj"}])
    r = run_cases({"big": f"hs.Scene.load({str(tmp_path / 'obj.json')!r})"}, timeout=30)
    expect(r, "big", "SceneError", "meshes[0].file", "big.obj", f"larger than the limit of {64 << 20} bytes")
    mid = tmp_path / "mid.obj"
    with open(mid, "wb") as f:
        f.write(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        f.write(b"# padding\n" * ((40 << 20) // 10))
    scene(tmp_path, {"strands": [{"points": [[0, 0, 0], [0, 1, 0]]}]}, name="mid.json",
          meshes=[{"type": "obj", "file": "mid.obj"}])
    # 0.5 GiB cap: about 0.3 GiB left after the interpreter, less than the 0.48 GB estimated
    r = run_cases({"mid": f"hs.Scene.load({str(tmp_path / 'mid.json')!r})"}, timeout=60, cap=GIB // 2)
    expect(r, "mid", "MemoryError", "meshes[0].file", "mid.obj", "GiB available")


def test_29_a_link_swapped_in_after_the_folder_check_is_not_followed(tmp_path):
    """A file a scene names is checked to lie inside the scene's folder
    (links resolved) and was then opened by its name: a link swapped in
    between led outside. The resolved path is what is opened, and its last
    part must not be a link: the swap is refused, a link inside the folder
    still reads."""
    from hairshade.scene import _Ctx, read_text

    folder, outside = tmp_path / "scene", tmp_path / "secret.txt"
    folder.mkdir()
    outside.write_text("0 0 0 0 1 0\n")
    (folder / "real.txt").write_text("0 0 0 0.01\n0 1 0 0.01\n")
    (folder / "link.txt").symlink_to(folder / "real.txt")
    p = scene(folder, {"file": "link.txt"})
    assert hs.Scene.load(p).strand_count == 1
    ctx = _Ctx(str(p), str(folder))
    checked = ctx.file("link.txt", "hair.file")
    assert checked == str((folder / "real.txt").resolve())
    (folder / "real.txt").unlink()
    (folder / "real.txt").symlink_to(outside)  # the swap, after the check
    with pytest.raises(hs.SceneError, match=r"hair.file: .*real.txt: cannot read"):
        read_text(checked, 1 << 20, lambda msg: hs.SceneError(f"hair.file: {checked}: {msg}"), ctx.nofollow)


@pytest.mark.slow  # about 3.5 minutes: 31 child processes, a 250 MB file, a 1280x720 render
def test_30_the_issue_reproductions_are_all_clean(tmp_path):
    """Every reproduction of scripts/hostile_table.py (the cases docs/hostile.md
    tabulates before and after) is clean on this build: the documented
    exception naming the field, or a correct result. Ctrl-C cases must stop
    within 3 s here (a loaded 2-core machine, as in test 06; the table's
    quiet run measured 0.07-0.31 s against its 0.5 s)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
    import hostile_table

    hostile_table.STOP_LIMIT = 3.0
    failed = {}
    for case in hostile_table.cases(str(tmp_path)):
        r = hostile_table.run_case(case, PYTHON_DIR, str(tmp_path))
        if r["outcome"] != "clean":
            failed[case.name] = r
    assert not failed, failed


def test_31_fibers_thicker_than_their_segments_are_long(tmp_path):
    """Found by the scene fuzzer (tests/fuzz/corpus/fat_radius_bundle.json):
    five strands of radius 4 on segments 0.05 long listed each capsule of
    the traced grid in millions of cells, 11 GB and 40 s. The grid's cells
    now grow until the capsules' boxes hold at most 2^26 entries: the scene
    renders under a 1.5 GiB cap within the timeout (measured 1.3 s, 410 MB
    peak)."""
    p = Path(__file__).parent / "fuzz" / "corpus" / "fat_radius_bundle.json"
    r = run_cases({"fat": f"""
img = hs.render(hs.Scene.from_dict(__import__("json").load(open({str(p)!r})), base_dir={str(tmp_path)!r}),
                width=16, height=9, progress=False)
result = bool(np.all(np.isfinite(img)))"""}, timeout=30)
    assert r["fat"] == {"ok": "True"}, r
