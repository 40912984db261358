"""Procedural strands for example and test scenes (deterministic per seed).

- ``head``: strands rooted on the upper part of a sphere (the scalp), leaving
  along the normal and bending down under gravity:
  ``{"kind": "head", "strands": 3000, "segments": 16, "center": [0,0,0],
  "scalp_radius": 0.5, "length": 0.5, "radius": 0.0015, "seed": 1}``
- ``bundle``: roughly parallel strands from ``start`` along ``direction``
  with a lateral spread and a gentle wave:
  ``{"kind": "bundle", "strands": 50, "segments": 16, "start": [0,-0.5,0],
  "direction": [0,1,0], "length": 1.0, "spread": 0.05, "radius": 0.003, "seed": 1}``
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _memory

#: Peak bytes per generated vertex, the strands and their temporaries
#: included: 161 (head) and 83 (bundle) measured with tracemalloc for
#: 20000 strands x 16 segments (154 and 72 at 5000 x 64), through the
#: float32 copy a scene makes (``scripts/generate_memory.py``); rounded up
#: by 10 %.
BYTES_PER_VERTEX = 176


def _get(d: dict[str, Any], key: str, default: Any, lo: float | None = None, hi: float | None = None) -> Any:
    v = d.get(key, default)
    if isinstance(default, int) and not isinstance(default, bool):
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"{key}: expected an integer, got {v!r:.80}")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise ValueError(f"{key}: must be in [{lo}, {hi}], got {v if abs(v) < 10**20 else '(a huge integer)'}")
    if isinstance(default, float):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"{key}: expected a finite number, got {v!r:.80}")
        try:
            v = float(v)
        except OverflowError:
            raise ValueError(f"{key}: must be in [{lo}, {hi}], got an integer of {len(str(abs(v)))} digits") from None
        if not np.isfinite(v):
            raise ValueError(f"{key}: expected a finite number, got {v!r}")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise ValueError(f"{key}: must be in [{lo}, {hi}], got {v}")
    if isinstance(default, list):
        ok = isinstance(v, (list, tuple)) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and abs(x) <= 1e18 for x in v)
        a = np.asarray(v, dtype=np.float64) if ok else np.zeros(0)
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise ValueError(f"{key}: expected 3 finite numbers, got {v!r}")
        return a
    return v


def generate(spec: dict[str, Any]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    kind = spec.get("kind")
    allowed = {"kind", "strands", "segments", "seed", "radius", "length"}
    if kind == "head":
        allowed |= {"center", "scalp_radius"}
    elif kind == "bundle":
        allowed |= {"start", "direction", "spread"}
    else:
        raise ValueError(f"kind: expected 'head' or 'bundle', got {kind!r}")
    extra = set(spec) - allowed
    if extra:
        raise ValueError(f"{sorted(extra)[0]}: unknown field (allowed: {', '.join(sorted(allowed))})")
    n = int(_get(spec, "strands", 1000, 1, 2_000_000))
    k = int(_get(spec, "segments", 16, 1, 256))
    _memory.check(n * (k + 1) * BYTES_PER_VERTEX, f"{n} strands of {k} segments",
                  "lower strands or segments")
    radius = float(_get(spec, "radius", 0.002, 0, 1e3))
    length = float(_get(spec, "length", 0.5, 0, 1e6))
    rng = np.random.default_rng(int(_get(spec, "seed", 1, 0, 2**31)))
    t = np.linspace(0.0, 1.0, k + 1)
    if kind == "head":
        c = _get(spec, "center", [0.0, 0.0, 0.0])
        rs = float(_get(spec, "scalp_radius", 0.5, 0, 1e6))
        # Roots: uniform on the cap y > -0.2 rs, tilted backwards a little.
        y = rng.uniform(-0.2, 1.0, n)
        phi = rng.uniform(0, 2 * np.pi, n)
        rxy = np.sqrt(1 - y * y)
        normal = np.stack([rxy * np.cos(phi), y, rxy * np.sin(phi)], -1)
        roots = c + rs * normal
        lens = length * rng.uniform(0.8, 1.2, n)
        # Out along the normal, then down under gravity, hugging the scalp.
        out = normal[:, None, :] * (0.25 * lens[:, None, None] * np.sin(0.5 * np.pi * t)[None, :, None])
        down = np.array([0.0, -1.0, 0.0]) * (lens[:, None, None] * (t**1.5)[None, :, None])
        pts = roots[:, None, :] + out + down
        # Keep strands outside the scalp.
        rel = pts - c
        d = np.linalg.norm(rel, axis=-1, keepdims=True)
        pts = np.where(d < rs * 1.01, c + rel / np.maximum(d, 1e-12) * rs * 1.01, pts)
    else:
        start = _get(spec, "start", [0.0, -0.5, 0.0])
        direction = _get(spec, "direction", [0.0, 1.0, 0.0])
        nd = np.linalg.norm(direction)
        if nd == 0:
            raise ValueError("direction: must not be zero")
        direction = direction / nd
        spread = float(_get(spec, "spread", 0.05, 0, 1e6))
        a = np.cross(direction, [1.0, 0.0, 0.0] if abs(direction[0]) < 0.9 else [0.0, 0.0, 1.0])
        a /= np.linalg.norm(a)
        b = np.cross(direction, a)
        off = rng.normal(0, spread, (n, 2))
        phase = rng.uniform(0, 2 * np.pi, n)
        wave = 0.2 * spread * np.sin(2 * np.pi * t[None, :] * 1.5 + phase[:, None])
        pts = (
            start
            + direction * (length * t)[None, :, None]
            + a * (off[:, 0:1] + wave)[:, :, None]
            + b * off[:, 1:2, None]
        )
    # Radius tapers to 40% at the tip.
    r = radius * (1.0 - 0.6 * t)
    return [p for p in pts], [r.copy() for _ in range(n)]
