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
import re
import resource
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

GIB = 1 << 30
PYTHON_DIR = str(Path(hs.__file__).resolve().parent.parent)

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


def scene(folder: Path, hair: dict | None = None, name: str = "s.json", **top) -> Path:
    """A minimal scene file in `folder` (camera at z = 3 looking at the origin)."""
    d = {"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "resolution": [32, 18]},
         "hair": hair if hair is not None else {}, **top}
    p = folder / name
    p.write_text(json.dumps(d))
    return p


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


# -- wrong results -----------------------------------------------------------------


def _base(**extra) -> dict:
    return {"hairshade_scene": 1,
            "camera": {"position": [0, 0, 1], "target": [0, 0, 0], "fov": 40, "resolution": [48, 32]},
            "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [2, 2, 2], "shadows": False}],
            **extra}


def test_07_near_plane_follows_the_hair_not_the_ground():
    """A strand 1 from the camera with and without a ground sphere of
    radius 1e4 (which used to put the near plane at 2, past the strand):
    the same segments reach the image and the hair pixels are equal."""
    hair = {"strands": [{"points": [[-0.2, 0, 0], [0.2, 0, 0]], "radius": 0.01}]}
    alone = hs.render(hs.Scene.from_dict(_base(hair=hair)), quality="fast", return_stats=True, progress=False)
    ground = _base(hair=hair, meshes=[{"type": "sphere", "center": [0, -1.0e4 - 1, 0], "radius": 1.0e4}])
    with_ground = hs.render(hs.Scene.from_dict(ground), quality="fast", return_stats=True, progress=False)
    assert alone[1]["segments_visible"] == with_ground[1]["segments_visible"] == 1
    hair_px = alone[0].sum(axis=2) > 0
    assert hair_px.sum() > 10
    np.testing.assert_array_equal(with_ground[0][hair_px], alone[0][hair_px])


def test_08_triangles_crossing_the_near_plane_are_clipped():
    """A floor of half-size 2e4 reaching under the camera (height 1,
    looking along -z): its triangles cross the near plane. Clipped, the
    floor fills the lower half of the image with the Lambertian radiance
    albedo/pi * E * cos(theta) (the same at every point of a flat floor
    under a directional light; 1e-4 relative: float32 shading), and the
    upper half stays background."""
    s = 2.0e4
    floor = [[-s, -1, -s], [s, -1, -s], [s, -1, s], [-s, -1, s]]
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        Path(d, "floor.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in floor) + "f 1 4 3 2\n")
        sc = _base(meshes=[{"type": "obj", "file": "floor.obj", "albedo": [0.5, 0.5, 0.5]}])
        sc["camera"] = {"position": [0, 0, 0], "target": [0, 0, -1], "fov": 60, "resolution": [48, 32]}
        img = hs.render(hs.Scene.from_dict(sc, base_dir=d), progress=False)
    expected = 0.5 / np.pi * 2.0 * (1 / np.sqrt(2))  # direction (0, 1, 1): cos theta = 1/sqrt(2)
    np.testing.assert_allclose(img[-8:], expected, rtol=1e-4)
    assert np.all(img[:8] == 0)


def test_08b_vertex_shading_of_a_strand_clipped_at_the_near_plane():
    """One segment from behind the camera to 1.5 in front, shaded per
    vertex: the clipped end is shaded where it lies (not interpolated from
    the vertex behind the camera, seen from the wrong side), and where the
    segment leaves a guard band twice the view (the near-plane end lay 1.6e6
    pixels off, where float32 projection had lost 0.9 % of the strand's
    pixels' radiance). So the single segment renders as the same strand
    split in two at its midpoint (whose vertices all lie in front):
    per-pixel totals equal to float32 rounding, per-vertex within 1 %
    (measured: 0.27 %; before, 1.40 against 0.32)."""
    a, b = np.array([-1.5, -0.3, 0.5]), np.array([0.3, -0.3, -1.5])
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 0], "target": [0, 0, -1], "fov": 60, "resolution": [64, 48]},
         "lights": [{"type": "directional", "direction": [0, 1, 0.3], "intensity": [3, 3, 3], "shadows": False}]}
    total = {}
    for n in (1, 2):
        d["hair"] = {"strands": [{"points": [(a + (b - a) * k / n).tolist() for k in range(n + 1)],
                                  "radius": 0.004}]}
        for shading in ("pixel", "vertex"):
            d["render"] = {"shading": shading}
            total[shading, n] = float(hs.render(hs.Scene.from_dict(d), progress=False).sum())
    assert total["pixel", 1] > 0.1
    assert total["pixel", 1] == pytest.approx(total["pixel", 2], rel=1e-5), total
    assert total["vertex", 1] == pytest.approx(total["vertex", 2], rel=1e-2), total


def test_09_karis_shadow_range_and_to_chiang_eta():
    """KarisHair's `shadow` outside [0, 1] (200 made a channel 0 and MS
    NaN) is refused; `mapping.to_chiang` keeps DEonHair's eta."""
    from hairshade import mapping

    k = hs.KarisHair()
    with pytest.raises(ValueError, match=r"shadow: must be in \[0.0, 1.0\], got 200"):
        k.eval_lobes([0, 0.2, 1.0], [0.3, -0.2, 0.9], [0, 1, 0], shadow=200)
    ms = k.eval_lobes([0, 0.2, 1.0], [0.3, -0.2, 0.9], [0, 1, 0], shadow=1.0)["MS"]
    assert np.all(np.isfinite(ms))
    assert mapping.chiang_params(hs.DEonHair(eta=3.0), fit=False)["eta"] == 3.0
    assert mapping.chiang_params(hs.KarisHair(), fit=False)["eta"] == 1.55


# -- validation ----------------------------------------------------------------------


@pytest.mark.parametrize("change, field, words", [
    (lambda d: d.update(hairshade_scene=True), "hairshade_scene", "expected version 1"),
    (lambda d: d["camera"].update(resolution=[48.5, 32]), "camera.resolution[0]", "expected an integer"),
    (lambda d: d.update(render={"transparency": {"mlab": {"layers": 4.5}}}), "render.transparency.mlab.layers",
     "integer"),
    (lambda d: d.update(hair={"material": {"model": "karis", "roughness": "0.5"}}), "hair.material", "roughness"),
    (lambda d: d.update(hair={"material": {"model": "deon", "h_samples": 2.5}}), "hair.material", "h_samples"),
    (lambda d: d.update(hair={"cards": [{"points": [[0, 0, 0], [0, 1, 0]], "width": 0.1,
                                         "alpha": {"bake": {}, "color": 1}}]}), "hair.cards[0].alpha", "color"),
    (lambda d: d.update(hair={"cards": [{"points": [[0, 0, 0], [0, 1, 0]], "width": 0.1,
                                         "alpha": {"bake": {}, "image": "a.png"}}]}), "hair.cards[0].alpha",
     "not both"),
    (lambda d: d.update(hair={"strands": [{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.01, "radii": [0, 0]}]}),
     "hair.strands[0]", "not both"),
    (lambda d: d.update(hair={"generate": {"kind": "head", "strands": 10.5}}), "hair.generate", "strands"),
    (lambda d: d.update(hair={"strands": [{"points": [[0, 0, 0], [0, "1", 0]]}]}), "hair.strands[0].points[1][1]",
     "expected a number"),
])
def test_10_strict_scene_validation(change, field, words):
    """Booleans, strings and fractions where numbers or integers belong,
    unknown keys and mutually exclusive keys: a SceneError naming the field."""
    d = _base()
    change(d)
    with pytest.raises(hs.SceneError) as e:
        hs.Scene.from_dict(d, source="t.json")
    msg = str(e.value)
    assert msg.startswith(f"t.json: {field}") and words in msg, msg
    assert msg.count("hair.generate") <= 1, msg


def test_11_api_type_errors_name_the_parameter():
    """Strings where numbers belong name the parameter (not Python's bare
    "could not convert string to float"); boolean arrays are not directions;
    HAIRSHADE_SIMD=bogus is refused at import with the allowed values."""
    with pytest.raises(TypeError, match="roughness: expected a number, got 'abc'"):
        hs.KarisHair(roughness="abc")
    with pytest.raises(TypeError, match="eta: expected a number"):
        hs.DEonHair(eta="1.5")
    with pytest.raises(TypeError, match="sigma_a: expected a number or 3 numbers"):
        hs.ChiangHair(sigma_a="0.5")
    with pytest.raises(TypeError, match="separable_r: expected True or False"):
        hs.KarisHair(separable_r=1)
    with pytest.raises(ValueError, match="wi: expected real numbers, got booleans"):
        hs.ChiangHair().eval(np.array([True, False, True]), [0, 0, 1.0])
    out = subprocess.run([sys.executable, "-c", "import hairshade"], capture_output=True, text=True, timeout=60,
                         env=dict(os.environ, PYTHONPATH=PYTHON_DIR, HAIRSHADE_SIMD="bogus"))
    assert out.returncode != 0 and "HAIRSHADE_SIMD" in out.stderr and "'avx2'" in out.stderr, out.stderr


# -- command line ----------------------------------------------------------------------


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hairshade", *args], capture_output=True, text=True, timeout=120,
                          cwd=cwd, env=dict(os.environ, PYTHONPATH=PYTHON_DIR))


def test_12_cli_outputs_and_compare_guards(tmp_path):
    """`render -o out.png --png` writes one PNG (not EXR bytes); an unknown
    extension and `--exposure nan` are refused; `compare` of NaN images
    exits non-zero naming the file; `compare` against a black reference
    reports FLIP as undefined instead of dying inside flip-evaluator."""
    scene(tmp_path, {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.05}]},
          lights=[{"type": "directional", "direction": [0, 0, 1], "intensity": [1, 1, 1]}])
    r = _cli("render", "s.json", "-o", "out.png", "--png", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "out.exr").exists() and r.stdout.count("out.png") == 1
    r = _cli("render", "s.json", "-o", "out.xyz", cwd=tmp_path)
    assert r.returncode == 2 and "out.xyz" in r.stderr and ".exr or .png" in r.stderr
    r = _cli("render", "s.json", "--exposure", "nan", cwd=tmp_path)
    assert r.returncode == 2 and "--exposure" in r.stderr
    nan = np.zeros((4, 4, 3), np.float32)
    nan[1, 1] = np.nan
    hs.write_exr(tmp_path / "nan.exr", nan)
    hs.write_exr(tmp_path / "black.exr", np.zeros((4, 4, 3), np.float32))
    hs.write_exr(tmp_path / "grey.exr", np.full((4, 4, 3), 0.5, np.float32))
    r = _cli("compare", "nan.exr", "nan.exr", cwd=tmp_path)
    assert r.returncode == 2 and "nan.exr: 1 pixel(s) not finite" in r.stderr
    r = _cli("compare", "grey.exr", "black.exr", cwd=tmp_path)
    assert r.returncode == 0 and "mean FLIP nan" in r.stdout and "black" in r.stderr, (r.stdout, r.stderr)
    # A uniform reference of 1e-10: FLIP's own exposure range comes out
    # reversed by rounding and it ends the process; contained in a child.
    hs.write_exr(tmp_path / "dim.exr", np.full((4, 4, 3), 1e-10, np.float32))
    r = _cli("compare", "grey.exr", "dim.exr", cwd=tmp_path)
    assert r.returncode == 0 and "FLIP failed" in r.stderr, (r.stdout, r.stderr)


@pytest.mark.parametrize("value", ["0", "-1", "abc", "100000", "2.5", ""])
def test_11b_thread_count_out_of_range_is_refused_at_import(value):
    """RAYON_NUM_THREADS was ignored when 0, negative or not a number, and
    100000 panicked when the pool started: each is refused at import with
    the range."""
    out = subprocess.run([sys.executable, "-c", "import hairshade"], capture_output=True, text=True, timeout=60,
                         env=dict(os.environ, PYTHONPATH=PYTHON_DIR, RAYON_NUM_THREADS=value))
    assert out.returncode != 0 and "RAYON_NUM_THREADS" in out.stderr and "[1, 1024]" in out.stderr, out.stderr
    assert "PanicException" not in out.stderr


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


def test_12b_nonsense_refused_before_work(tmp_path):
    """write_exr / write_png of an image without pixels wrote a file the
    readers refuse, and `bench --repeats 0` exited 0 with zeros: both are
    refused naming what is wrong."""
    for w in (hs.write_exr, hs.write_png):
        with pytest.raises(ValueError, match="image: expected at least one pixel, got 5x0"):
            w(str(tmp_path / "x.img"), np.zeros((5, 0, 3)))
    assert not (tmp_path / "x.img").exists()
    for arg in (["--repeats", "0"], ["--n", "-3"]):
        out = subprocess.run([sys.executable, "-m", "hairshade", "bench", *arg], capture_output=True, text=True,
                             timeout=60, env=dict(os.environ, PYTHONPATH=PYTHON_DIR))
        assert out.returncode == 2 and arg[0] in out.stderr and "expected a whole number >= 1" in out.stderr, out.stderr


def test_14b_numpy_numbers_and_exact_bounds_in_messages(tmp_path):
    """numpy's scalars are numbers (`layers=np.int64(8)` was refused as
    "expected a number"; np.bool_ still is), a value past the 1e18 bound is
    printed as it was given (1.0000001e18 read "got 1e+18"), and
    read_exr's max_pixels below 1 is refused by name (-1 raised a bare
    OverflowError)."""
    d = json.loads((Path(hs.__file__).parent / "examples" / "single_strand.json").read_text())
    s = hs.Scene.from_dict(d)
    want = hs.render(s, width=32, height=18, transparency={"mlab": {"layers": 8}}, progress=False)
    got = hs.render(s, width=32, height=18, transparency={"mlab": {"layers": np.int64(8)}}, progress=False)
    np.testing.assert_array_equal(got, want)
    # the value as numpy prints it: np.True_ (numpy 2), True (numpy 1.x)
    with pytest.raises(hs.SceneError, match=f"layers: expected a number, got {re.escape(repr(np.bool_(True)))}$"):
        hs.render(s, width=32, height=18, transparency={"mlab": {"layers": np.bool_(True)}}, progress=False)
    e = json.loads(json.dumps(d))
    e["camera"]["fov"] = np.float32(40.0)
    assert hs.Scene.from_dict(e).camera["fov"] == 40.0
    e["camera"]["position"][0] = 1.0000001e18
    with pytest.raises(hs.SceneError, match=r"camera.position\[0\]: must be at most 1e\+18 .* got 1.0000001e\+18"):
        hs.Scene.from_dict(e)
    path = tmp_path / "one.exr"
    hs.write_exr(str(path), np.ones((2, 2, 3), np.float32))
    for bad in (-1, 0, 2.5, True):
        with pytest.raises(ValueError, match="max_pixels: expected a whole number >= 1 or None"):
            hs.read_exr(path, max_pixels=bad)
    assert hs.read_exr(path, max_pixels=np.int64(4)).shape == (2, 2, 3)


def test_15b_demo_sizes_refused_by_name_and_every_option_documented():
    """`demo --width 3` failed with "got 0" (its warm-up renders at a
    quarter of the size, now at least 1 pixel); sizes and spp below 1 are
    refused naming the option, before any work, and every option of
    `demo` has help text."""
    env = dict(os.environ, PYTHONPATH=PYTHON_DIR)
    for arg in ("--width", "--height", "--spp"):
        out = subprocess.run([sys.executable, "-m", "hairshade", "demo", arg, "0"], capture_output=True, text=True,
                             timeout=60, env=env)
        assert out.returncode == 2 and f"argument {arg}: expected a whole number >= 1, got 0" in out.stderr, out.stderr
    out = subprocess.run([sys.executable, "-m", "hairshade", "demo", "--help"], capture_output=True, text=True,
                         timeout=60, env=env)
    options = [line.split()[0] for line in out.stdout.splitlines() if line.strip().startswith("--")]
    assert set(options) == {"--scene", "--out", "--width", "--height", "--spp", "--mitsuba-equal", "--exposure"}, options
    for line in out.stdout.splitlines():
        if line.strip().startswith("--"):
            assert len(line.split()) > 2, f"no help: {line}"


def test_16b_eval_env_refuses_coefficients_float32_cannot_carry():
    """KarisHair.eval_env in float32 with SH 3e38 returned inf (the
    coefficient, 3.5x the radiance, overflowed float32): refused naming
    `sh`; 1e30 and below stay finite, and float64 takes the same input."""
    k = hs.KarisHair()
    v, t = np.array([[0, 0, 1.0]], np.float32), np.array([[1, 0, 0.0]], np.float32)
    with pytest.raises(ValueError, match="sh: in float32 the coefficients must be at most 1e\\+30"):
        k.eval_env(v, t, [3e38] * 3)
    assert np.isfinite(k.eval_env(v, t, np.full((9, 3), 1e30))).all()
    assert np.isfinite(k.eval_env(v.astype(np.float64), t.astype(np.float64), [3e38] * 3)).all()


CAMERA = {"position": [0, 0, 3], "target": [0, 0, 0], "resolution": [32, 18]}
LIGHT = {"type": "directional", "direction": [1, 1, 1], "intensity": [3, 3, 3], "shadows": True}


def test_17_messages_show_keys_and_names_as_visible_text(tmp_path):
    """A zero-width space, an ANSI escape or a right-to-left override in a
    key, and a newline in an output name, reach the terminal escaped
    (\\u200b, \\x1b, \\u202e, \\n): SceneError escapes its whole text, the
    CLI its file names. A NUL in a file name is refused by name; a key given
    twice in one JSON object is an error naming it (json kept the last)."""
    strand = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    for key, shown in (("qua\u200blity", "qua\\u200blity"), ("\x1b[31mred", "\\x1b[31mred"),
                       ("a\u202eb", "a\\u202eb")):
        with pytest.raises(hs.SceneError) as e:
            hs.Scene.from_dict({"hairshade_scene": 1, "camera": CAMERA, "hair": strand, "render": {key: 1}})
        assert shown in str(e.value) and str(e.value).isprintable(), str(e.value)
    with pytest.raises(hs.SceneError, match=r"s\\x00\.json: the file name contains a NUL character"):
        hs.Scene.load(str(tmp_path / "s\x00.json"))
    dup = tmp_path / "dup.json"
    dup.write_text('{"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40, '
                   '"fov": 50}, "hair": {}}')
    with pytest.raises(hs.SceneError, match="the key 'fov' appears twice"):
        hs.Scene.load(str(dup))
    p = scene(tmp_path, strand)
    out = subprocess.run([sys.executable, "-m", "hairshade", "render", str(p), "-o", str(tmp_path / "a\nfake: line.exr")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "a\\nfake: line.exr" in out.stdout and "\nfake" not in out.stdout, out.stdout


def test_18_command_line_refuses_before_writing(tmp_path):
    """`compare --png x.txt` is refused (it wrote a PNG named x.txt), and
    `--exposure 1000` before the EXR is written (it was refused after, or
    not at all with -o NAME.exr); an existing output is replaced with a
    note; a render that does not fit in memory is one line, no traceback."""
    strand = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    p = scene(tmp_path, strand)
    run = lambda *a, **k: subprocess.run([sys.executable, "-m", "hairshade", *a], capture_output=True,  # noqa: E731
                                         text=True, timeout=120, cwd=tmp_path, **k)
    assert run("render", str(p), "-o", "a.exr").returncode == 0
    r = run("compare", "a.exr", "a.exr", "--no-flip", "--png", "x.txt")
    assert r.returncode == 2 and "--png: x.txt" in r.stderr and not (tmp_path / "x.txt").exists(), r.stderr
    r = run("render", str(p), "-o", "b.exr", "--exposure", "1000")
    assert r.returncode == 2 and "--exposure" in r.stderr and "[-100, 100]" in r.stderr
    assert not (tmp_path / "b.exr").exists()
    r = run("render", str(p), "-o", "a.exr")
    assert r.returncode == 0 and "note: replacing a.exr" in r.stderr
    cap = lambda: resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))  # noqa: E731
    r = run("render", str(p), "--width", "16384", "--height", "16384", "-o", "big.exr", preexec_fn=cap)
    assert r.returncode == 2 and r.stderr.startswith("error: out of memory: render: needs about"), r.stderr
    assert "Traceback" not in r.stderr


def test_19_numbers_in_messages_are_short_and_complex_points_refused():
    """A value far out of range is printed in exponent form (1e39 was
    printed with 40 digits, f64::MAX with 309); complex points are refused
    (they lost their imaginary part silently)."""
    strand = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    with pytest.raises(hs.SceneError, match=r"render\.shadows\.exponential\.density: must be finite \(as a float32\), "
                                            r"got 1e39$"):
        hs.Scene.from_dict({"hairshade_scene": 1, "camera": CAMERA, "hair": strand, "lights": [LIGHT],
                            "render": {"shadows": {"exponential": {"density": 1e39}}}})
    with pytest.raises(ValueError, match=r"roughness: must be in \[0, 1\], got 1\.7976931348623157e308"):
        hs.KarisHair(roughness=1.7976931348623157e308)
    with pytest.raises(hs.SceneError, match="points: expected real numbers, got complex ones"):
        hs.Scene.from_arrays(np.array([[0, 0, 0], [0, 1, 0]], complex), 0.01, [0, 2])


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


def test_21_a_stray_strand_far_away_leaves_the_hair_in_view():
    """One strand 1e5 away behind the hair (z = -1e5) took the near plane
    (1e-4 of the hair's far side) past the rest of the hair: 1736
    fragments fell to 0 and the image went black. The far side is the
    hair's 99th percentile distance: every fragment of the head stays."""
    from hairshade.generate import generate

    pts, _ = generate({"kind": "head", "strands": 200, "segments": 8, "seed": 1})
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 2.3], "target": [0, 0, 0], "fov": 40, "resolution": [64, 36]},
         "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [1, 1, 1]}],
         "hair": {"strands": [{"points": np.asarray(p).tolist(), "radius": 0.002} for p in pts]}, "render": {}}
    _, alone = hs.render(hs.Scene.from_dict(d), return_stats=True)
    d["hair"]["strands"].append({"points": [[0, 0, -1e5], [0, 0.1, -1e5]], "radius": 0.002})
    _, stray = hs.render(hs.Scene.from_dict(d), return_stats=True)
    assert alone["fragments"] > 1000
    assert stray["fragments"] >= alone["fragments"]


def test_22_overflowing_pixels_are_reported():
    """A background of 3e38 under coverage transparency overflows float32
    in 2303 of 2304 pixels; they become 0, are counted in the stats, and a
    RuntimeWarning says so (before, only the stats did, and the command
    line said nothing)."""
    from hairshade.generate import generate

    pts, _ = generate({"kind": "head", "strands": 100, "segments": 6, "seed": 1})
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 2.3], "target": [0, 0, 0], "fov": 40, "resolution": [48, 48]},
         "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [1, 1, 1]}],
         "hair": {"strands": [{"points": np.asarray(p).tolist(), "radius": 0.002} for p in pts]},
         "render": {"background": [3e38] * 3, "transparency": "coverage"}}
    with pytest.warns(RuntimeWarning, match=r"2303 of 2304 pixels overflowed"):
        img, st = hs.render(hs.Scene.from_dict(d), return_stats=True)
    assert st["non_finite_pixels"] == 2303 and np.all(np.isfinite(img))


def _line_scene(**camera) -> dict:
    """One vertical strand seen from +z, as a scene dict."""
    cam = {"position": [0, 0.5, 2.5], "target": [0, 0.5, 0], "fov": 40, "resolution": [32, 18], **camera}
    return {"hairshade_scene": 1, "camera": cam,
            "lights": [{"type": "directional", "direction": [0.5, 0.7, 0.6], "intensity": [3, 3, 3]}],
            "hair": {"strands": [{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.01}]}}


@pytest.mark.parametrize("camera, field, words", [
    # float32 cannot tell a target 1e-12 away from the position (the image was black)
    (dict(target=[0, 0.5, 2.5 - 1e-12]), "camera.target", "at least 0.001 x 2.5"),
    # the projected strand widths overflowed float32 (black)
    (dict(fov=1e-30), "camera.fov", "[0.001, 179]"),
    # 1e-6 rad from the viewing direction: the roll was float32's rounding
    (dict(up=[0, 1e-6, -1]), "camera.up", "parallel to the viewing direction"),
])
def test_23_cameras_float32_cannot_carry_are_refused(camera, field, words):
    """Degenerate cameras are refused by name, from a file and from a
    Scene edited after loading alike; each worked case next to a refused
    one (the bounds' derivation: ``scene.MIN_VIEW_SEPARATION``)."""
    with pytest.raises(hs.SceneError, match=rf"{field}: .*{re.escape(words)}"):
        hs.Scene.from_dict(_line_scene(**camera))
    sc = hs.Scene.from_dict(_line_scene())
    key, value = next(iter(camera.items()))
    sc.camera[key] = value
    with pytest.raises(hs.SceneError, match=rf"\(as edited\): {field}: .*{re.escape(words)}"):
        hs.render(sc)
    # the narrowest allowed fov still sees the strand: it fills the image
    img = hs.render(hs.Scene.from_dict(_line_scene(fov=1e-3)))
    assert np.all(img.sum(-1) > 0)


def test_24_a_tiny_light_direction_is_a_direction():
    """[1e-40, 0, 0] rounded to zero in float32 and lit the hair from +z;
    it is normalized in float64 first: the same image as [1, 0, 0]."""
    d = _line_scene()
    d["lights"][0]["direction"] = [1e-40, 0, 0]
    tiny = hs.render(hs.Scene.from_dict(d))
    d["lights"][0]["direction"] = [1, 0, 0]
    unit = hs.render(hs.Scene.from_dict(d))
    d["lights"][0]["direction"] = [0, 0, 1]
    plus_z = hs.render(hs.Scene.from_dict(d))
    assert np.array_equal(tiny, unit)
    assert not np.allclose(unit, plus_z)


def test_25_a_scene_edited_after_loading_is_checked_again():
    """Scene fields changed after loading go through the scene file's
    checks before rendering (they reached the renderer unchecked: a zero
    light rendered, an unknown key was ignored); a changed material builds
    the hair model again."""
    cases = {
        "lights[0].vector: must not be zero": lambda s: s.lights[0].update(vector=[0, 0, 0]),
        "lights[0].directionx: unknown field": lambda s: s.lights[0].update(directionx=[0, 0, 1]),
        "camera.width: must be an integer in [1, 16384]": lambda s: s.camera.update(width=0),
        "spheres[0].radius: must be in (0": lambda s: s.spheres.append(dict(center=[0, 0, 0], radius=-1,
                                                                            albedo=[1, 1, 1])),
        "points[1]: must be finite": lambda s: setattr(s, "points", np.array([[0, 0, 0], [0, np.inf, 0]])),
        "hair.material: ": lambda s: s.material.update(roughness=7.0),
    }
    for words, edit in cases.items():
        sc = hs.Scene.from_dict(_line_scene())
        edit(sc)
        with pytest.raises(hs.SceneError, match=re.escape(words)):
            hs.render(sc)
    sc = hs.Scene.from_dict(_line_scene())
    karis = hs.render(sc)
    sc.material = {"model": "chiang", "eumelanin": 0.2}
    chiang = hs.render(sc)
    assert type(sc.hair).__name__ == "ChiangHair" and not np.allclose(karis, chiang)


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


@pytest.mark.parametrize("half_length", [1e6, 1e18])
def test_27_a_strand_far_longer_than_the_view_draws_its_visible_part(half_length):
    """A strand from x = -L to L behind the hair: at L = 1e18 it took the
    near plane (a percentile of vertex distances) and every other strand
    vanished; from L = 1e6 its pixel coordinates lost the line in float32
    and it drew nothing. The near plane now comes from the segments'
    nearest points, segments are clipped in float64 to a guard band twice
    the view, and shadow maps, density grids and the traced grid leave
    vertices beyond 16 times the 90th-percentile distance out of their box.
    The long strand draws the same pixels as one 200 units long; beside a
    head of 200 strands, the head's pixels it does not cross are those of
    the head alone (to float32 rounding)."""
    from hairshade.generate import generate

    cam = {"position": [0, 0.5, 2.5], "target": [0, 0.5, 0]}
    line = lambda x: np.array([[-x, 0.5, -0.5], [x, 0.5, -0.5]])  # noqa: E731
    shown = lambda img: img.sum(-1) > 0  # noqa: E731
    short = hs.render(hs.Scene.from_arrays(line(100.0), 0.01, [0, 2], camera=cam), 64, 36)
    long = hs.render(hs.Scene.from_arrays(line(half_length), 0.01, [0, 2], camera=cam), 64, 36)
    assert shown(short).sum() > 60 and np.array_equal(shown(long), shown(short))
    pts, _ = generate({"kind": "head", "strands": 200, "segments": 8, "seed": 1})
    head = np.vstack(pts) + [0, 0.5, 0]
    offsets = np.arange(0, len(head) + 1, 9)
    alone = hs.render(hs.Scene.from_arrays(head, 0.002, offsets, camera=cam), 64, 36)
    both = hs.render(hs.Scene.from_arrays(np.vstack([head, line(half_length)]), 0.002,
                                          np.append(offsets, len(head) + 2), camera=cam), 64, 36)
    mask = shown(alone) & ~shown(long)
    assert mask.sum() > 200 and np.allclose(both[mask], alone[mask], rtol=1e-5, atol=0)


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
