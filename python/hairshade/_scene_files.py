"""The files a scene names: read as regular files within a size limit
(never a FIFO or a device, never through a link swapped in after the
check), OBJ meshes, strand files (``.hair``, USD, the ``x y z r`` text
format), and the text format written back."""

from __future__ import annotations

import math
import os
import stat
from typing import Any

import numpy as np

from ._errors import SceneError
from ._scene_check import MAX_MAGNITUDE, _Ctx, _magnitude_error

#: Largest scene, strand or OBJ file read.
MAX_TEXT_BYTES = 256 << 20
#: Largest OBJ file read: parsed line by line at 0.074 s and 11 MB of peak
#: memory per MB of file (a 10 MB file of 200 000 triangles: 0.74 s, 107
#: MB), so 64 MiB takes about 5 s and 0.7 GB; a 250 MB file parsed for
#: minutes through gigabytes.
MAX_OBJ_BYTES = 64 << 20
#: Peak bytes of parsing an OBJ file per byte of it (measured 10.7, above).
OBJ_BYTES_PER_BYTE = 12



def show(line: str | bytes, limit: int = 80) -> str:
    """A line of a file for an error message: quoted and shortened when it
    is printable text, else only a note (file content that is not text is
    never echoed)."""
    if isinstance(line, bytes) or any(not (ch.isprintable() or ch == "\t") for ch in line):
        return "(content that is not text)"
    return repr(line if len(line) <= limit else line[:limit] + "...")


def read_bytes(path: str, limit: int, error: Any, nofollow: bool = False) -> bytes:
    """The content of the regular file ``path`` (at most ``limit`` bytes);
    ``error(message)`` builds the exception raised otherwise. Opened once,
    without blocking (a FIFO or a device would otherwise wait for a writer
    before the check that refuses it); with ``nofollow``, a path whose last
    part is a link is refused (a path resolved and checked before, which a
    link swapped in since would redirect)."""
    if "\x00" in path:
        raise error("the file name contains a NUL character")
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    if nofollow:
        flags |= getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
        with os.fdopen(fd, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                raise error("not a regular file")
            data = f.read(limit + 1)
    except FileNotFoundError:
        raise error("file not found") from None
    except IsADirectoryError:
        raise error("is a folder, not a file") from None
    except OSError as e:
        raise error(f"cannot read ({e.strerror or e})") from None
    if len(data) > limit:
        raise error(f"larger than the limit of {limit} bytes")
    return data


def read_text(path: str, limit: int, error: Any, nofollow: bool = False) -> str:
    """:func:`read_bytes` decoded as UTF-8 (an error names the offset of
    the first byte that is not)."""
    data = read_bytes(path, limit, error, nofollow)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(f"not UTF-8 text (byte {e.start})") from None


def _read_obj(path: str, c: _Ctx, field_path: str) -> np.ndarray:
    """Triangles (T, 3, 3) of an OBJ file's `v` and `f` lines (polygons fan-
    triangulated; texture/normal indices and everything else ignored)."""
    from . import _memory

    text = read_text(path, MAX_OBJ_BYTES, lambda msg: SceneError(f"{c.source}: {field_path}: {path}: {msg}"),
                     c.nofollow)
    _memory.check(len(text) * OBJ_BYTES_PER_BYTE, f"{c.source}: {field_path}: {path}",
                  "simplify the mesh")
    lines = text.splitlines()
    del text
    verts: list[list[float]] = []
    tris: list[list[int]] = []
    for n, line in enumerate(lines, 1):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        if parts[0] == "v":
            try:
                v = [float(x) for x in parts[1:4]]
            except ValueError:
                v = []
            if len(v) != 3 or not all(math.isfinite(x) and abs(x) <= MAX_MAGNITUDE for x in v):
                c.fail(field_path, f"{path}:{n}: expected 'v x y z' with finite numbers, got {show(line)}")
            verts.append(v)
        elif parts[0] == "f":
            try:
                idx = [int(x.split("/")[0]) for x in parts[1:]]
            except ValueError:
                c.fail(field_path, f"{path}:{n}: bad face {show(line)}")
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            if len(idx) < 3 or any(i < 0 or i >= len(verts) for i in idx):
                c.fail(field_path, f"{path}:{n}: face indices out of range in {show(line)}")
            tris += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    if not tris:
        c.fail(field_path, f"{path}: no faces")
    return np.asarray(verts, dtype=np.float32)[np.asarray(tris)]


def _flat_strands(pts: list[np.ndarray], rads: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Strands given as lists of per-strand points and radii, as flat
    float32 points (M, 3), radii (M,) and uint32 offsets (S + 1,)."""
    offsets = np.zeros(len(pts) + 1, dtype=np.uint32)
    offsets[1:] = np.cumsum([len(p) for p in pts]) if pts else []
    points = np.concatenate(pts).astype(np.float32) if pts else np.zeros((0, 3), np.float32)
    radii = np.concatenate(rads).astype(np.float32) if rads else np.zeros(0, np.float32)
    return points, radii, offsets


def _read_hair_file(path: str, c: _Ctx, name: str) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """A hair file's strands as lists of (points, radii): ``.hair``
    (binary, :mod:`hairshade.hairfile`) or the text format, by the extension
    of the ``name`` the scene gave (``path`` may be its resolved target)."""
    from .usd import is_usd

    if is_usd(name):
        return _read_usd_file(path, c)
    if not name.lower().endswith(".hair"):
        return _read_strand_file(path, c)
    from .hairfile import parse_hair

    # A regular file within the size limit, as every file a scene names.
    data = read_bytes(path, MAX_TEXT_BYTES, lambda msg: SceneError(f"{c.source}: hair.file: {path}: {msg}"),
                      c.nofollow)
    try:
        p, r, o = parse_hair(data, path)
    except ValueError as e:
        c.fail("hair.file", str(e))
    msg = _magnitude_error(p, r, f"{path}: point", f"{path}: radius")
    if msg:
        c.fail("hair.file", msg)
    return np.split(p.astype(np.float64), o[1:-1]), np.split(r.astype(np.float64), o[1:-1])


def _read_usd_file(path: str, c: _Ctx) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """A USD groom's strands (:func:`hairshade.usd.read_usd`, cubic curves
    subdivided to within a tenth of the fiber radius)."""
    from .usd import GroomError, read_usd

    try:
        g = read_usd(path)
    except GroomError as e:
        c.fail("hair.file", str(e))
    msg = _magnitude_error(g.points, g.radii, f"{path}: point", f"{path}: radius")
    if msg:
        c.fail("hair.file", msg)
    o = g.offsets.astype(np.int64)
    return np.split(g.points.astype(np.float64), o[1:-1]), np.split(g.radii.astype(np.float64), o[1:-1])


def _read_strand_file(path: str, c: _Ctx) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """`x y z r` per line, blank lines between strands, `#` comments."""
    lines = read_text(path, MAX_TEXT_BYTES, lambda msg: SceneError(f"{c.source}: hair.file: {path}: {msg}"),
                      c.nofollow).splitlines()
    pts: list[np.ndarray] = []
    rads: list[np.ndarray] = []
    cur: list[list[float]] = []

    def flush(line_no: int) -> None:
        if cur:
            if len(cur) < 2:
                c.fail("hair.file", f"{path}:{line_no}: a strand needs at least 2 vertices")
            a = np.array(cur, dtype=np.float64)
            pts.append(a[:, :3])
            rads.append(a[:, 3])
            cur.clear()

    for n, line in enumerate(lines, 1):
        s = line.split("#", 1)[0].strip()
        if not s:
            flush(n)
            continue
        parts = s.split()
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            c.fail("hair.file", f"{path}:{n}: expected 4 numbers 'x y z r', got {show(line)}")
        if len(vals) != 4 or not all(math.isfinite(v) and abs(v) <= MAX_MAGNITUDE for v in vals) or vals[3] < 0:
            c.fail("hair.file", f"{path}:{n}: expected 4 finite numbers 'x y z r' (at most {MAX_MAGNITUDE:g} "
                                f"in magnitude) with r >= 0, got {show(line)}")
        cur.append(vals)
    flush(len(lines))
    return pts, rads


def write_strand_file(path: str, points: np.ndarray, radii: np.ndarray, offsets: np.ndarray) -> None:
    """Writes strands in the `x y z r` text format (also Mitsuba's curve
    format): one vertex per line, a blank line after each strand."""
    rows = np.column_stack([np.asarray(points, dtype=np.float64).reshape(-1, 3),
                            np.asarray(radii, dtype=np.float64).reshape(-1)]).tolist()
    lines = ["%.7g %.7g %.7g %.7g" % tuple(r) for r in rows]
    for e in np.asarray(offsets[1:], dtype=np.int64) - 1:
        if e >= 0:
            lines[e] += "\n"
    with open(path, "w") as f:
        f.write("\n".join(lines))
        if lines:
            f.write("\n")
