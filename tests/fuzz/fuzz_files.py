"""Fuzz target for the file loaders: PNG, EXR, OBJ, strand files and scene
JSON (atheris / libFuzzer), under a 3 GiB address-space cap.

The first input byte picks the loader; the rest is the file. For PNG and
EXR a flag byte comes first: when it is odd, the next 8 bytes are written
into the header as the claimed width and height (so that headers claiming
huge images, the cheapest way to an abort, are reached at once), one byte
picks the PNG bit depth and colour type, and the rest is the pixel data
(PNG: compressed into its IDAT chunk; EXR: written over the bytes after
the data window). Allowed outcomes:
a ValueError or OSError from the image readers, a SceneError from the
scene loader, or a result that is what the file says (an image of the
declared size with finite values; a scene whose arrays agree). Anything
else (another exception, an abort, an allocation past the cap, a hang
caught by libFuzzer's -timeout) is a finding.

    python tests/fuzz/fuzz_files.py tests/fuzz/corpus_files -max_total_time=60
"""

import os
import resource
import struct
import sys
import tempfile
import zlib

import atheris

resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))

with atheris.instrument_imports():
    import numpy as np

    import hairshade as hs
    from hairshade import _native

DIR = tempfile.mkdtemp(prefix="hairshade-fuzz-")
KINDS = ("png", "exr", "obj", "strands", "scene")


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def _png(width: int, height: int, depth: int, color: int, pixels: bytes) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, depth, color, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(pixels)) + _chunk(b"IEND", b"")


def _exr_base() -> bytes:
    path = os.path.join(DIR, "base.exr")
    hs.write_exr(path, np.linspace(0, 1, 4 * 4 * 3, dtype=np.float32).reshape(4, 4, 3))
    with open(path, "rb") as f:
        return f.read()


EXR = _exr_base()
WINDOW = EXR.index(b"dataWindow\x00box2i\x00") + len(b"dataWindow\x00box2i\x00") + 4


def _file(kind: str, body: bytes) -> str:
    """The image file `body` describes: a flag byte, then either the file
    itself (flag even) or width, height (two little-endian u32), a format
    byte and the pixel data (flag odd)."""
    flag, rest = (body[0], body[1:]) if body else (0, b"")
    if flag & 1 and len(rest) >= 9:
        w, h = struct.unpack("<II", rest[:8])
        sel, tail = rest[8], rest[9:]
        if kind == "png":
            body = _png(w, h, (1, 2, 4, 8, 16)[sel % 5], (0, 2, 3, 4, 6)[sel // 5 % 5], tail)
        else:
            # The data window is inclusive int32: x1 = w - 1, y1 = h - 1.
            patched = bytearray(EXR)
            patched[WINDOW:WINDOW + 16] = struct.pack("<iiii", 0, 0, (w & 0x7FFFFFFF) - 1, (h & 0x7FFFFFFF) - 1)
            end = min(len(patched), WINDOW + 16 + len(tail))
            patched[WINDOW + 16:end] = tail[: end - WINDOW - 16]
            body = bytes(patched)
    else:
        body = rest
    path = os.path.join(DIR, "f." + ("png" if kind == "png" else "exr"))
    with open(path, "wb") as f:
        f.write(body)
    return path


def _check_image(path: str, read, channels: int) -> None:
    try:
        w, h, d = read(path)
    except (ValueError, OSError):
        return
    if d.shape != (w * h * channels,):
        raise RuntimeError(f"image of {w}x{h} with {d.shape} values")
    # EXR holds any float (NaN included); PNG samples map into [0, 1].
    if channels == 4 and not (np.all(d >= 0) and np.all(d <= 1)):
        raise RuntimeError("PNG values outside [0, 1]")


def _load_scene(hair: dict, meshes: list | None = None) -> None:
    d = {"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "resolution": [16, 9]},
         "hair": hair, "meshes": meshes or []}
    try:
        s = hs.Scene.from_dict(d, base_dir=DIR, source="fuzz.json")
    except hs.SceneError:
        return
    if s.points.shape[0] != s.radii.shape[0] or s.offsets[-1] != s.points.shape[0]:
        raise RuntimeError("strand arrays disagree")
    if not (np.all(np.isfinite(s.points)) and np.all(s.radii >= 0)):
        raise RuntimeError("non-finite strand point or negative radius accepted")
    for m in s.obj_meshes:
        if not np.all(np.isfinite(m["triangles"])):
            raise RuntimeError("non-finite OBJ vertex accepted")


def one_input(data: bytes) -> None:
    if not data:
        return
    kind, body = KINDS[data[0] % len(KINDS)], data[1:]
    if kind == "png":
        _check_image(_file("png", body), _native.read_png, 4)
    elif kind == "exr":
        _check_image(_file("exr", body), _native.read_exr, 3)
    elif kind in ("obj", "strands"):
        name = "f.obj" if kind == "obj" else "f.txt"
        with open(os.path.join(DIR, name), "wb") as f:
            f.write(body)
        if kind == "obj":
            _load_scene({}, [{"type": "obj", "file": name}])
        else:
            _load_scene({"file": name})
    else:
        path = os.path.join(DIR, "scene.json")
        with open(path, "wb") as f:
            f.write(body)
        try:
            hs.Scene.load(path)
        except hs.SceneError:
            return


def main() -> None:
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
