"""Strands as smooth curves: the uniform cubic B-spline of a strand's
vertices or the Catmull-Rom spline through them, cut into segments no
longer on screen than a bound in pixels (RE4's strand renderer cuts its
Catmull-Rom strands where a projected segment's Manhattan length passes 8
pixels).

A scene's ``hair.curve`` chooses (:mod:`hairshade.scene`):

- ``"polyline"`` (default): the vertices joined by straight segments;
- ``"bspline"``: the uniform cubic B-spline with the vertices as control
  points and both ends tripled, so that it starts and ends at the strand's
  ends; it does not pass through the other vertices. This is what the
  Mitsuba references trace (``bsplinecurve``);
- ``"catmull_rom"``: the Catmull-Rom spline through every vertex (tension
  1/2), its ends met through the phantom points P[-1] = 2 P[0] - P[1] and
  P[n] = 2 P[n-1] - P[n-2] (USD's ``pinned`` wrap), as Blender draws hair.

or ``{"bspline": {"pixels": 4}}`` with the bound (default
:data:`DEFAULT_PIXELS`). The rasterizer renders the subdivided polyline,
so the shadow maps, the density grid and the traced shadows see the same
curve, shaded with its segments' tangents; :func:`subdivide` cuts each span
into k equal parameter steps, k the span's control polygon's projected
Manhattan length over the bound (an upper bound of the curve's, since a
cubic span lies in its control points' hull), between 1 and
:data:`MAX_STEPS`. Radii follow the same curve. The Mitsuba and Cycles
bridges draw the same curve (:func:`curve_points`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

CURVES = ("polyline", "bspline", "catmull_rom")
#: Default bound on a subdivided segment's projected Manhattan length, pixels.
DEFAULT_PIXELS = 4.0
#: Most segments one span is cut into.
MAX_STEPS = 64

BSPLINE = np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 0, 3, 0], [1, 4, 1, 0]], np.float64) / 6
CATMULL_ROM = np.array([[-1, 3, -3, 1], [2, -5, 4, -1], [-1, 0, 1, 0], [0, 2, 0, 0]], np.float64) / 2


def _controls(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray, curve: str
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Control points and radii of every strand's spans: (P (N, 3), R (N,),
    span's first control index (S,), span's strand (S,))."""
    o = np.asarray(offsets, np.int64)
    n = np.diff(o)
    p = np.asarray(points, np.float64)
    r = np.asarray(radii, np.float64)
    if curve == "bspline":
        rep = np.ones(len(p), np.int64)
        np.add.at(rep, o[:-1], 2)
        np.add.at(rep, o[1:] - 1, 2)
        idx = np.repeat(np.arange(len(p)), rep)
        P, R = p[idx], r[idx]
        count = n + 4
        spans = n + 1
    else:  # catmull_rom, pinned: a phantom point before and after each strand
        first, last = o[:-1], o[1:] - 1
        pre_p, post_p = 2 * p[first] - p[first + 1], 2 * p[last] - p[last - 1]
        pre_r, post_r = 2 * r[first] - r[first + 1], 2 * r[last] - r[last - 1]
        count = n + 2
        P = np.empty((int(count.sum()), 3))
        R = np.empty(int(count.sum()))
        starts = np.concatenate([[0], np.cumsum(count)[:-1]])
        body = np.ones(len(R), bool)
        body[starts] = False
        body[starts + count - 1] = False
        P[body], R[body] = p, r
        P[starts], R[starts] = pre_p, pre_r
        P[starts + count - 1], R[starts + count - 1] = post_p, post_r
        spans = n - 1
    starts = np.concatenate([[0], np.cumsum(count)[:-1]])
    strand = np.repeat(np.arange(len(n)), spans)
    first = np.repeat(starts, spans) + (np.arange(int(spans.sum())) - np.repeat(np.cumsum(spans) - spans, spans))
    return P, R, first, strand


def _project(camera: dict[str, Any], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates of points (..., 3), and whether each is in front of
    the camera."""
    pos = np.asarray(camera["position"], np.float64)
    f = np.asarray(camera["target"], np.float64) - pos
    f /= np.linalg.norm(f)
    right = np.cross(f, np.asarray(camera["up"], np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    d = q - pos
    z = d @ f
    focal = 0.5 * camera["height"] / np.tan(0.5 * np.radians(camera["fov"]))
    zs = np.where(z > 1e-9, z, 1e-9)
    return np.stack([(d @ right) / zs * focal, (d @ up) / zs * focal], axis=-1), z > 1e-9


def steps(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray, curve: str, camera: dict[str, Any] | None,
          pixels: float, fixed: int = 8) -> np.ndarray:
    """Segments per span: from the projected control polygon (``camera``
    given), or ``fixed`` (no camera)."""
    P, _, first, _ = _controls(points, radii, offsets, curve)
    if camera is None:
        return np.full(len(first), fixed, np.int64)
    xy, front = _project(camera, P)
    k = first[:, None] + np.arange(4)[None, :]
    legs = np.abs(np.diff(xy[k], axis=1)).sum(axis=(1, 2))  # Manhattan length of the 3 legs
    visible = front[k].all(axis=1)
    n = np.ceil(legs / pixels)
    n = np.where(visible, n, 1)  # spans behind the camera are not drawn
    return np.clip(n, 1, MAX_STEPS).astype(np.int64)


def curve_points(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray, curve: str,
                 n_steps: np.ndarray | int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every strand's curve sampled at ``n_steps`` equal parameter steps a
    span (an array, one per span, or one number), and at its end: float32
    (points, radii, offsets). ``curve="polyline"`` returns the arrays."""
    if curve == "polyline":
        return (np.asarray(points, np.float32), np.asarray(radii, np.float32),
                np.asarray(offsets, np.uint32))
    if curve not in CURVES:
        raise ValueError(f"curve: expected one of {', '.join(CURVES)}, got {curve!r:.80}")
    B = BSPLINE if curve == "bspline" else CATMULL_ROM
    P, R, first, strand = _controls(points, radii, offsets, curve)
    ns = np.broadcast_to(np.asarray(n_steps, np.int64), first.shape)
    n_strands = len(offsets) - 1
    last = np.r_[strand[1:] != strand[:-1], True] if len(strand) else np.zeros(0, bool)
    per = ns + last  # the last span of a strand also gives its end point
    total = int(per.sum())
    if total >= 2**32:
        raise ValueError(f"curve: {total} points after subdivision, more than the 2^32 the renderer indexes")
    from . import _memory

    # the float64 output and one group's products (4 x 8 bytes of control
    # weights a point, 32 of points and radii), then the float32 copies
    _memory.check(total * 96, f"curve: cutting the strands into {total} points", "raise hair.curve's pixels")
    start = np.cumsum(per) - per  # each span's first output point
    out_p = np.empty((int(per.sum()), 3))
    out_r = np.empty(int(per.sum()))
    # spans grouped by their step count: one (steps x 4) @ (4 x spans) product a group
    for n in np.unique(ns):
        sel = np.flatnonzero(ns == n)
        t = np.arange(n + 1) / n
        T = np.stack([t**3, t**2, t, np.ones_like(t)], axis=1) @ B  # (n + 1, 4) weights
        K = first[sel][:, None] + np.arange(4)[None, :]
        gp = np.einsum("tj,sjk->stk", T, P[K])  # (spans, n + 1, 3)
        gr = np.einsum("tj,sj->st", T, R[K])
        rows = start[sel][:, None] + np.arange(n)[None, :]
        out_p[rows] = gp[:, :n]
        out_r[rows] = gr[:, :n]
        ends = last[sel]
        out_p[start[sel][ends] + n] = gp[ends, n]
        out_r[start[sel][ends] + n] = gr[ends, n]
    out_r = np.maximum(out_r, 0.0)
    counts = np.bincount(strand, weights=per, minlength=n_strands).astype(np.int64)
    off = np.concatenate([[0], np.cumsum(counts)])
    return out_p.astype(np.float32), out_r.astype(np.float32), off.astype(np.uint32)


def subdivide(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray, curve: str,
              camera: dict[str, Any] | None, pixels: float = DEFAULT_PIXELS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The strands as the polyline the renderer draws for ``camera``: each
    span cut until its projected control polygon is at most ``pixels`` long
    (Manhattan) a segment."""
    if curve == "polyline":
        return curve_points(points, radii, offsets, curve, 1)
    return curve_points(points, radii, offsets, curve, steps(points, radii, offsets, curve, camera, pixels))
