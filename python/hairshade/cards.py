"""Hair cards: ribbons along polylines with an alpha texture.

A card is ``{"points": [[x, y, z], ...], "width": w, "normal": [nx, ny, nz],
"alpha": {...}}``: the ribbon's width direction at each vertex is
``normalize(tangent x normal)``, u runs across the card (0 to 1), v along it
(0 at the first point, 1 at the last, by arc length), and the fiber tangent
is along v. ``alpha`` is either ``{"image": "file.png" | "file.exr"}`` (PNG:
its alpha channel when it has one, else its luminance; EXR: the mean of RGB;
rows run along v) or ``{"bake": {"fibers": 24, "fiber_width": 0.04,
"seed": 1}}``: the strands the card stands for, drawn into a 64 x 256
texture, thinning towards the tip.
"""

from __future__ import annotations

import functools
import os
from typing import Any, Callable

import numpy as np

BAKE_SIZE = (64, 256)  # (u, v) texels


def bake_fibers(fibers: int = 24, fiber_width: float = 0.04, seed: int = 1) -> np.ndarray:
    """The strands a baked card stands for: rows (u0, amplitude, frequency,
    phase, end) of fibers ``u(v) = u0 + amplitude sin(2 pi frequency v + phase)``
    for v in [0, end]."""
    return _bake_fibers(fibers, fiber_width, seed).copy()


@functools.lru_cache(maxsize=64)
def _bake_fibers(fibers: int, fiber_width: float, seed: int) -> np.ndarray:
    """:func:`bake_fibers`, computed once per parameters (cards of a head
    share a few seeds)."""
    if not (1 <= fibers <= 4096):
        raise ValueError(f"fibers: must be in [1, 4096], got {fibers}")
    if not (0 < fiber_width <= 1):
        raise ValueError(f"fiber_width: must be in (0, 1], got {fiber_width}")
    rng = np.random.default_rng(seed)
    out = np.empty((fibers, 5))
    for k in range(fibers):
        u0 = rng.uniform(0.1, 0.9)
        amp, freq, phase = rng.uniform(0.0, 0.05), rng.uniform(0.5, 2.0), rng.uniform(0, 2 * np.pi)
        out[k] = (u0, amp, freq, phase, rng.uniform(0.55, 1.0))
    out.flags.writeable = False
    return out


def bake_alpha(fibers: int = 24, fiber_width: float = 0.04, seed: int = 1) -> np.ndarray:
    """(256, 64) alpha: the fibers of :func:`bake_fibers`, each `fiber_width`
    wide (in u) with a linear falloff, combined as 1 - prod(1 - a)."""
    nu, nv = BAKE_SIZE
    u = (np.arange(nu) + 0.5) / nu
    v = (np.arange(nv) + 0.5) / nv
    alpha = np.zeros((nv, nu))
    for u0, amp, freq, phase, end in bake_fibers(fibers, fiber_width, seed):
        center = u0 + amp * np.sin(2 * np.pi * freq * v + phase)  # (nv,)
        d = np.abs(u[None, :] - center[:, None]) / (0.5 * fiber_width)
        a = np.clip(1 - d, 0, 1) * (v[:, None] <= end)
        alpha = 1 - (1 - alpha) * (1 - a)
    return alpha.astype(np.float32)


def card_fiber_strands(points: np.ndarray, width: float, normal: np.ndarray, bake: dict[str, Any],
                       samples: int = 24) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The baked card's fibers as world-space strands lying on the card:
    what the alpha texture stands for, as geometry (for renderers whose
    shadow rays ignore opacity). Fiber radius: a quarter of the fiber width,
    so that a solid fiber covers as much as the texture's tent profile."""
    p = np.asarray(points, dtype=np.float64)
    seg = np.diff(p, axis=0)
    lens = np.linalg.norm(seg, axis=1)
    v_knots = np.concatenate([[0.0], np.cumsum(lens)]) / lens.sum()
    t = np.vstack([seg[:1], seg[:-1] + seg[1:], seg[-1:]])
    b = np.cross(t, normal)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    n, fw, seed = _bake_params(bake)
    f = _bake_fibers(n, fw, seed)
    u0, amp, freq, phase, end = (f[:, k : k + 1] for k in range(5))
    # Every fiber at once: v = linspace(0, end, samples) per row.
    v = np.arange(samples) * (end / (samples - 1))
    v[:, -1] = end[:, 0]
    u = u0 + amp * np.sin(2 * np.pi * freq * v + phase)
    spine = np.stack([np.interp(v, v_knots, p[:, k]) for k in range(3)], -1)
    side = np.stack([np.interp(v, v_knots, b[:, k]) for k in range(3)], -1)
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    strands = spine + (u - 0.5)[..., None] * width * side
    r = np.full(samples, 0.25 * fw * width)
    return list(strands), [r.copy() for _ in range(len(f))]


#: Largest alpha image file read, in bytes.
MAX_IMAGE_BYTES = 1 << 30


def _bake_params(b: Any) -> tuple[int, float, int]:
    """(fibers, fiber_width, seed) of a ``bake`` spec, strictly typed."""
    if not isinstance(b, dict):
        raise ValueError(f"bake: expected an object, got {b!r:.80}")
    unknown = set(b) - {"fibers", "fiber_width", "seed"}
    if unknown:
        raise ValueError(f"bake.{sorted(unknown)[0]}: unknown field (allowed: fiber_width, fibers, seed)")
    out = []
    for key, default, kind in (("fibers", 24, int), ("fiber_width", 0.04, float), ("seed", 1, int)):
        v = b.get(key, default)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (kind is int and not isinstance(v, int)):
            raise ValueError(f"bake.{key}: expected {'an integer' if kind is int else 'a number'}, got {v!r:.80}")
        if kind is float and not np.isfinite(v):
            raise ValueError(f"bake.{key}: must be finite, got {v!r}")
        out.append(v)
    if not 0 <= out[2] < 2**63:
        raise ValueError(f"bake.seed: must be in [0, 2^63), got {out[2] if abs(out[2]) < 10**20 else '(a huge integer)'}")
    return int(out[0]), float(out[1]), int(out[2])


def load_alpha(spec: dict[str, Any], base_dir: str, resolve: Callable[[str], str] | None = None) -> np.ndarray:
    """The alpha texture an ``alpha`` spec names: ``{"image": file}`` or
    ``{"bake": {...}}`` (exactly one). ``resolve`` turns the image's name
    into a path (default: relative to ``base_dir``); the image must be a
    regular file of at most ``MAX_IMAGE_BYTES`` whose values are finite."""
    from . import _native

    if not isinstance(spec, dict):
        raise ValueError(f"expected an object, got {spec!r:.80}")
    unknown = set(spec) - {"image", "bake"}
    if unknown:
        raise ValueError(f"{sorted(unknown)[0]}: unknown field (allowed: bake, image)")
    if len(spec) != 1:
        raise ValueError("expected {'image': path} or {'bake': {...}}, not both")
    if "image" in spec:
        name = spec["image"]
        if not isinstance(name, str) or not name:
            raise ValueError(f"image: expected a file name, got {name!r:.80}")
        path = resolve(name) if resolve is not None else os.path.join(base_dir, name)
        try:
            st = os.stat(path)
        except FileNotFoundError:
            raise ValueError(f"image: {path}: file not found") from None
        except OSError as e:
            raise ValueError(f"image: {path}: cannot read ({e.strerror or e})") from None
        if not os.path.isfile(path):
            raise ValueError(f"image: {path}: not a regular file")
        if st.st_size > MAX_IMAGE_BYTES:
            raise ValueError(f"image: {path}: larger than the limit of {MAX_IMAGE_BYTES} bytes")
        if name.lower().endswith(".exr"):
            w, h, d = _native.read_exr(path)
            alpha = d.reshape(h, w, 3).mean(axis=2).astype(np.float32)
        else:
            w, h, d = _native.read_png(path)
            rgba = d.reshape(h, w, 4)
            if np.all(rgba[..., 3] == 1):
                alpha = (rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)).astype(np.float32)
            else:
                alpha = rgba[..., 3].astype(np.float32)
        bad = ~np.isfinite(alpha)
        if np.any(bad):
            y, x = (int(i[0]) for i in np.nonzero(bad))
            raise ValueError(f"image: {path}: {int(bad.sum())} texel(s) not finite (first at x={x}, y={y})")
        return alpha
    return bake_alpha(*_bake_params(spec["bake"]))


def card_quads(points: np.ndarray, width: float, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(corners (Q, 4, 3), uvs (Q, 4, 2), tangents (Q, 3)) of one card."""
    p = np.asarray(points, dtype=np.float64)
    seg = np.diff(p, axis=0)
    lens = np.linalg.norm(seg, axis=1)
    if np.any(lens == 0):
        raise ValueError("points: two consecutive points coincide")
    t_seg = seg / lens[:, None]
    t_vtx = np.vstack([t_seg[:1], t_seg[:-1] + t_seg[1:], t_seg[-1:]])
    t_vtx /= np.maximum(np.linalg.norm(t_vtx, axis=1, keepdims=True), 1e-12)
    b = np.cross(t_vtx, normal)
    nb = np.linalg.norm(b, axis=1)
    if np.any(nb < 1e-6):
        raise ValueError("normal: parallel to the card's direction at some point")
    b /= nb[:, None]
    v = np.concatenate([[0.0], np.cumsum(lens)]) / lens.sum()
    half = 0.5 * width * b
    c0, c1 = p[:-1] - half[:-1], p[:-1] + half[:-1]
    c2, c3 = p[1:] + half[1:], p[1:] - half[1:]
    corners = np.stack([c0, c1, c2, c3], axis=1)
    uvs = np.stack([
        np.stack([np.zeros_like(v[:-1]), v[:-1]], -1), np.stack([np.ones_like(v[:-1]), v[:-1]], -1),
        np.stack([np.ones_like(v[1:]), v[1:]], -1), np.stack([np.zeros_like(v[1:]), v[1:]], -1),
    ], axis=1)
    return corners, uvs, t_seg


def head_cards(spec: dict[str, Any]) -> list[dict[str, Any]]:
    """Cards along the spines of a procedural head (hairshade.generate's
    'head'), each facing out of the scalp: ``{"kind": "head", "cards": 400,
    "segments": 8, "width": 0.08, ...head parameters..., "alpha": {...}}``."""
    from .generate import generate

    s = dict(spec)
    width = s.pop("width", 0.08)
    alpha = s.pop("alpha", {"bake": {}})
    count = s.pop("cards", 400)
    s["strands"] = count
    s.setdefault("kind", "head")
    if s["kind"] != "head":
        raise ValueError(f"kind: expected 'head', got {s['kind']!r}")
    pts, _ = generate(s)
    center = np.asarray(s.get("center", [0.0, 0.0, 0.0]), dtype=np.float64)
    cards = []
    for k, p in enumerate(pts):
        normal = p[0] - center
        normal /= max(np.linalg.norm(normal), 1e-12)
        a = dict(alpha)
        if "bake" in a:
            a = {"bake": {**a["bake"], "seed": int(a["bake"].get("seed", 1)) * 1000 + k % 8}}
        cards.append({"points": p.tolist(), "width": float(width), "normal": normal.tolist(), "alpha": a})
    return cards
