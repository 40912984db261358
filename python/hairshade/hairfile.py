"""Cem Yuksel's binary ``.hair`` format (the format of the public hair model
sets, cemyuksel.com/research/hairmodels), read into flat strand arrays.

Layout, little-endian:

- a 128-byte header: ``"HAIR"``; uint32 strand count; uint32 total point
  count; uint32 flags; uint32 default segment count; float32 default
  thickness; float32 default transparency; 3 float32 default color; 88 bytes
  of free-form information;
- then, each only when its flag bit is set, in this order: segments
  (uint16 per strand, bit 0: a strand has segments + 1 points; without the
  array every strand has the default count), points (3 float32 per point,
  bit 1; required here), thickness (float32 per point, bit 2; else the
  default), transparency (float32 per point, bit 3), color (3 float32 per
  point, bit 4).

Thickness is the fiber's diameter: the radius is half of it. Transparency
and color are read past (the scene's material decides the shading).
"""

from __future__ import annotations

import os

import numpy as np

HEADER = np.dtype([
    ("magic", "S4"), ("strands", "<u4"), ("points", "<u4"), ("flags", "<u4"), ("segments", "<u4"),
    ("thickness", "<f4"), ("transparency", "<f4"), ("color", "<f4", 3), ("info", "S88"),
])
assert HEADER.itemsize == 128
SEGMENTS, POINTS, THICKNESS, TRANSPARENCY, COLOR = 1, 2, 4, 8, 16


def read_hair(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (M, 3) float32, radii (M,) float32, offsets (S + 1,) uint32)
    of a ``.hair`` file. Raises ValueError naming the file and the problem
    (bad magic, truncated arrays, counts that disagree, non-finite values)."""
    from .scene import MAX_TEXT_BYTES, read_bytes

    path = os.fspath(path)
    # a regular file within the scene format's size limit, opened without blocking
    return parse_hair(read_bytes(path, MAX_TEXT_BYTES, lambda msg: ValueError(f"{path}: {msg}")), path)


def parse_hair(data: bytes, path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`read_hair` of a file's bytes (``path`` names it in errors)."""
    if len(data) < HEADER.itemsize or data[:4] != b"HAIR":
        raise ValueError(f"{path}: not a .hair file (expected the 'HAIR' header)")
    h = np.frombuffer(data, HEADER, count=1)[0]
    n_strands, n_points, flags = int(h["strands"]), int(h["points"]), int(h["flags"])
    pos = HEADER.itemsize

    def take(dtype: str, count: int, what: str) -> np.ndarray:
        nonlocal pos
        size = np.dtype(dtype).itemsize * count
        if pos + size > len(data):
            raise ValueError(f"{path}: the {what} array is truncated ({len(data) - pos} of {size} bytes)")
        a = np.frombuffer(data, dtype, count=count, offset=pos)
        pos += size
        return a

    # The header's counts against the file's size, before anything is
    # allocated from them: the points array (12 bytes a point) must be in
    # the file, and every strand has at least 2 points.
    if flags & POINTS and 12 * n_points > len(data) - pos:
        raise ValueError(f"{path}: the header claims {n_points} points ({12 * n_points} bytes), "
                         f"but the file holds {len(data) - pos} bytes after its header")
    if n_strands > n_points // 2:
        raise ValueError(f"{path}: the header claims {n_strands} strands for {n_points} points "
                         "(a strand needs at least 2)")
    if flags & SEGMENTS:
        segments = take("<u2", n_strands, "segments").astype(np.int64)
    else:
        segments = np.full(n_strands, int(h["segments"]), dtype=np.int64)
    if not flags & POINTS:
        raise ValueError(f"{path}: the file has no points array (flags {flags:#x})")
    counts = segments + 1
    if int(counts.sum()) != n_points:
        raise ValueError(f"{path}: the strands' segment counts give {int(counts.sum())} points, the header says {n_points}")
    if np.any(segments < 1):
        raise ValueError(f"{path}: strand {int(np.argmax(segments < 1))} has no segment (a strand needs 2 points)")
    points = take("<f4", 3 * n_points, "points").reshape(n_points, 3).astype(np.float32)
    if flags & THICKNESS:
        radii = 0.5 * take("<f4", n_points, "thickness").astype(np.float32)
    else:
        radii = np.full(n_points, 0.5 * float(h["thickness"]), dtype=np.float32)
    if flags & TRANSPARENCY:
        take("<f4", n_points, "transparency")
    if flags & COLOR:
        take("<f4", 3 * n_points, "color")
    if not np.all(np.isfinite(points)):
        raise ValueError(f"{path}: point {int(np.argmin(np.isfinite(points).all(axis=1)))} is not finite")
    if not np.all(np.isfinite(radii)) or np.any(radii < 0):
        raise ValueError(f"{path}: thickness {int(np.argmin(np.isfinite(radii) & (radii >= 0)))} is not finite and >= 0")
    offsets = np.zeros(n_strands + 1, dtype=np.uint32)
    offsets[1:] = np.cumsum(counts)
    return points, radii, offsets


def write_hair(path: str | os.PathLike, points: np.ndarray, radii: np.ndarray, offsets: np.ndarray,
               info: str = "hairshade") -> None:
    """Writes strands (flat arrays, as :func:`read_hair` returns them) as a
    ``.hair`` file with per-strand segment counts and per-point thickness
    (twice the radius): reading it back gives the same float32 arrays, bit
    for bit. A strand may have at most 65 536 points (the format's uint16
    segment count)."""
    p = np.ascontiguousarray(points, dtype="<f4").reshape(-1, 3)
    r = np.ascontiguousarray(radii, dtype="<f4").reshape(-1)
    o = np.asarray(offsets, dtype=np.int64)
    counts = np.diff(o)
    if len(r) != len(p) or len(o) < 1 or o[0] != 0 or o[-1] != len(p) or np.any(counts < 2):
        raise ValueError("points, radii, offsets: expected flat strand arrays (offsets from 0 to the point "
                         "count, at least 2 points a strand)")
    if np.any(counts > 65536):
        raise ValueError(f"strand {int(np.argmax(counts > 65536))} has {int(counts.max())} points; "
                         "the .hair format holds at most 65 536 a strand")
    h = np.zeros(1, HEADER)
    h["magic"], h["strands"], h["points"] = b"HAIR", len(counts), len(p)
    h["flags"] = SEGMENTS | POINTS | THICKNESS
    h["segments"] = 1
    h["info"] = info.encode()[:88]
    with open(path, "wb") as f:
        f.write(h.tobytes())
        f.write((counts - 1).astype("<u2").tobytes())
        f.write(p.tobytes())
        f.write((2 * r).astype("<f4").tobytes())
