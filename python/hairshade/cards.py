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

import os
from typing import Any

import numpy as np

BAKE_SIZE = (64, 256)  # (u, v) texels


def bake_fibers(fibers: int = 24, fiber_width: float = 0.04, seed: int = 1) -> np.ndarray:
    """The strands a baked card stands for: rows (u0, amplitude, frequency,
    phase, end) of fibers ``u(v) = u0 + amplitude sin(2 pi frequency v + phase)``
    for v in [0, end]."""
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
    fw = float(bake.get("fiber_width", 0.04))
    fibers = bake_fibers(int(bake.get("fibers", 24)), fw, int(bake.get("seed", 1)))
    pts, rads = [], []
    for u0, amp, freq, phase, end in fibers:
        v = np.linspace(0.0, end, samples)
        u = u0 + amp * np.sin(2 * np.pi * freq * v + phase)
        spine = np.stack([np.interp(v, v_knots, p[:, k]) for k in range(3)], -1)
        side = np.stack([np.interp(v, v_knots, b[:, k]) for k in range(3)], -1)
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        pts.append(spine + (u - 0.5)[:, None] * width * side)
        rads.append(np.full(samples, 0.25 * fw * width))
    return pts, rads


def load_alpha(spec: dict[str, Any], base_dir: str) -> np.ndarray:
    from . import _native

    if "image" in spec:
        path = os.path.join(base_dir, spec["image"])
        if not os.path.exists(path):
            raise ValueError(f"image: {path}: file not found")
        if path.lower().endswith(".exr"):
            w, h, d = _native.read_exr(path)
            return d.reshape(h, w, 3).mean(axis=2).astype(np.float32)
        w, h, d = _native.read_png(path)
        rgba = d.reshape(h, w, 4)
        if np.all(rgba[..., 3] == 1):
            return (rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)).astype(np.float32)
        return rgba[..., 3].astype(np.float32)
    if "bake" in spec:
        b = spec["bake"]
        if not isinstance(b, dict):
            raise ValueError("bake: expected an object")
        unknown = set(b) - {"fibers", "fiber_width", "seed"}
        if unknown:
            raise ValueError(f"bake.{sorted(unknown)[0]}: unknown field")
        return bake_alpha(int(b.get("fibers", 24)), float(b.get("fiber_width", 0.04)), int(b.get("seed", 1)))
    raise ValueError("expected {'image': path} or {'bake': {...}}")


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
