"""USD grooms: ``UsdGeomBasisCurves`` read into strands, and strands written
back as linear ``BasisCurves`` (extra ``usd``: ``pip install 'hairshade[usd]'``,
which installs ``usd-core``).

Blender, Houdini and Maya hand grooms to renderers as ``BasisCurves``:
``points``, ``curveVertexCounts``, ``widths`` (the diameter) and a cubic
``basis`` (``bspline``, ``catmullRom``, ``bezier``) or ``type = "linear"``.
The renderer draws polylines, so :func:`read_usd` evaluates each cubic
curve and subdivides every span until the polyline lies within
``tolerance`` fiber radii of the curve; the largest distance it measured is
:attr:`Groom.deviation` (``curves="control_points"`` takes the control
points as the polyline instead, unchanged).

What is read, per the UsdGeomBasisCurves schema:

============  ==========================================================
``type``      ``linear`` or ``cubic`` (fallback ``cubic``)
``basis``     ``bspline``, ``catmullRom`` or ``bezier`` (fallback
              ``bezier``); unused for linear curves
``wrap``      ``nonperiodic`` (fallback), ``pinned`` (the ends are met
              through the phantom points P[-1] = 2 P[0] - P[1] and
              P[n] = 2 P[n-1] - P[n-2]) or ``periodic`` (closed)
``widths``    ``primvars:widths`` if authored, else ``widths``; the
              radius is half. ``constant``, ``uniform`` (one per curve),
              ``varying`` (one per span end) or ``vertex`` (one per
              control point, evaluated with the curve's basis)
transforms    every prim's local-to-world transform; widths scale by the
              cube root of its determinant
primvars      ``uniform`` and ``constant`` numeric primvars, one value per
              strand in :attr:`Groom.curve_primvars` (the renderer shades
              every strand with the scene's one material)
============  ==========================================================

Every ``BasisCurves`` prim under ``prim`` (default: the whole stage) is
read, in the stage's order, except invisible ones and those whose purpose
is ``guide`` or ``proxy``. Coordinates are the file's world space,
untouched: a Z-up file (Blender's) stays Z-up (:attr:`Groom.up_axis`).

Bad input gets a :class:`GroomError` (a ``ValueError``) naming the file,
the prim and the problem: no points, no widths (unless ``default_radius``
is given), vertex counts below the basis' minimum or summing to other than
the point count, widths of the wrong count or negative, non-finite
values, zero-length curves. The declared counts are checked against the
memory available before the points are fetched.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _extras, _memory
from .curves import BSPLINE, CATMULL_ROM

#: Most polyline segments one cubic span is cut into.
MAX_SUBDIVISIONS = 64

# Cubic basis matrices: a span is C(t) = [t^3, t^2, t, 1] B G over its 4
# control points G.
BASES = {
    "bspline": BSPLINE,
    "catmullRom": CATMULL_ROM,
    "bezier": np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 3, 0, 0], [1, 0, 0, 0]], np.float64),
}
VSTEP = {"bspline": 1, "catmullRom": 1, "bezier": 3}


class GroomError(ValueError):
    """A USD groom that cannot be read; the message names the file and prim."""


@dataclass
class Groom:
    """Strands read from a USD stage, as the renderer takes them."""

    points: np.ndarray  # (M, 3) float32
    radii: np.ndarray  # (M,) float32
    offsets: np.ndarray  # (S + 1,) uint32
    #: (prim path, first strand, strand count) of every prim read.
    prims: list[tuple[str, int, int]] = field(default_factory=list)
    #: Per-strand values of the prims' uniform and constant primvars (NaN
    #: for strands of prims that lack one).
    curve_primvars: dict[str, np.ndarray] = field(default_factory=dict)
    #: Largest distance between a cubic curve and its polyline, in fiber
    #: radii (0 for linear curves and for ``curves="control_points"``).
    deviation: float = 0.0
    #: The same in scene units.
    deviation_abs: float = 0.0
    #: The stage's up axis ("Y" or "Z").
    up_axis: str = "Y"

    @property
    def strand_count(self) -> int:
        return len(self.offsets) - 1


def _pxr() -> tuple[Any, Any, Any, Any]:
    _extras.require("pxr", "reading and writing USD grooms")
    from pxr import Sdf, Usd, UsdGeom, Vt

    return Sdf, Usd, UsdGeom, Vt


def read_usd(path: str | os.PathLike, prim: str | None = None, curves: str = "evaluate",
             tolerance: float = 0.1, default_radius: float | None = None, time: float | None = None) -> Groom:
    """The strands of the ``BasisCurves`` prims of a USD file (``.usd``,
    ``.usda``, ``.usdc``, ``.usdz``), see the module docs.

    ``prim``: read only under this prim path. ``curves``: ``"evaluate"``
    (cubic curves subdivided to within ``tolerance`` fiber radii, 0.001 to
    10) or ``"control_points"`` (the control points as the polyline).
    ``default_radius``: the radius of prims without widths (otherwise an
    error). ``time``: the time code to read (default: the default time)."""
    Sdf, Usd, UsdGeom, Vt = _pxr()
    path = os.fspath(path)
    if curves not in ("evaluate", "control_points"):
        raise ValueError(f"curves: expected 'evaluate' or 'control_points', got {curves!r:.80}")
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not 1e-3 <= tolerance <= 10:
        raise ValueError(f"tolerance: expected a number of fiber radii in [0.001, 10], got {tolerance!r:.80}")
    if default_radius is not None and (isinstance(default_radius, bool) or not isinstance(default_radius, (int, float))
                                       or not 0 <= default_radius <= 1e18):
        raise ValueError(f"default_radius: expected a finite number >= 0 or None, got {default_radius!r:.80}")
    if not os.path.isfile(path):
        raise GroomError(f"{path}: no such file" if not os.path.exists(path) else f"{path}: not a regular file")
    try:
        stage = Usd.Stage.Open(path)
    except Exception as e:  # pxr raises Tf.ErrorException
        raise GroomError(f"{path}: cannot open as USD: {_first_line(e)}") from None
    if stage is None:
        raise GroomError(f"{path}: cannot open as USD")
    tc = Usd.TimeCode.Default() if time is None else Usd.TimeCode(float(time))
    if prim is not None:
        root = stage.GetPrimAtPath(prim) if Sdf.Path.IsValidPathString(prim) else None
        if not root:
            raise GroomError(f"{path}: no prim {prim!r:.200}")
        prims = [p for p in Usd.PrimRange(root)]
    else:
        prims = list(stage.Traverse())
    cache = UsdGeom.XformCache(tc)  # USD matrices act on row vectors: transposed below
    found = [p for p in prims if p.IsA(UsdGeom.BasisCurves)]
    if not found:
        other = sorted({str(p.GetTypeName()) for p in prims if p.IsA(UsdGeom.Curves)})
        hint = f" (it has {', '.join(other)}, which are not read)" if other else ""
        raise GroomError(f"{path}: no BasisCurves prim{' under ' + prim if prim else ''}{hint}")
    parts: list[tuple[str, _Curves, dict[str, np.ndarray]]] = []
    for p in found:
        img = UsdGeom.Imageable(p)
        if img.ComputeVisibility(tc) == UsdGeom.Tokens.invisible \
                or img.ComputePurpose() in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy):
            continue
        where = f"{path}: {p.GetPath()}"
        c = _Curves.of(p, UsdGeom, tc, where, default_radius)
        c.transform(np.array(cache.GetLocalToWorldTransform(p), dtype=np.float64).T, where)
        parts.append((str(p.GetPath()), c, _curve_primvars(p, UsdGeom, tc, len(c.counts))))
    if not parts:
        raise GroomError(f"{path}: every BasisCurves prim is invisible, a guide or a proxy")
    return groom_of(parts, path, curves, tolerance, str(UsdGeom.GetStageUpAxis(stage)))


def groom_of(parts: list[tuple[str, "_Curves", dict[str, np.ndarray]]], path: str, curves: str, tolerance: float,
             up_axis: str) -> Groom:
    """The :class:`Groom` of curve sets (name, curves, per-curve values),
    cubic ones evaluated (``curves="evaluate"``) or taken as polylines."""
    pts: list[np.ndarray] = []
    rads: list[np.ndarray] = []
    counts_all: list[np.ndarray] = []
    read: list[tuple[str, int, int]] = []
    dev = dev_abs = 0.0
    strands = 0
    for name, c, _ in parts:
        if curves == "evaluate" and c.type == "cubic":
            ep, ew, ec, d, da = _evaluate(c, tolerance, f"{path}: {name}")
            dev, dev_abs = max(dev, d), max(dev_abs, da)
        else:
            ep, ew, ec = _as_polylines(c)
        pts.append(ep)
        rads.append(ew / 2)
        counts_all.append(ec)
        read.append((name, strands, len(ec)))
        strands += len(ec)
    if dev > tolerance * 1.5:
        warnings.warn(f"{path}: cubic spans cut into {MAX_SUBDIVISIONS} segments still leave the polyline up to "
                      f"{dev:.3g} fiber radii from the curve (tolerance {tolerance:g})", stacklevel=3)
    points = np.concatenate(pts)
    offsets = np.zeros(strands + 1, np.uint64)
    offsets[1:] = np.cumsum(np.concatenate(counts_all))
    if offsets[-1] >= 2**32:
        raise GroomError(f"{path}: {offsets[-1]} points after subdivision, more than the 2^32 the renderer indexes")
    primvars = [pv for _, _, pv in parts]
    per_strand = {}
    for k in sorted({k for pv in primvars for k in pv}):
        cols = [pv.get(k) for pv in primvars]
        shape = next(v.shape[1:] for v in cols if v is not None)
        if any(v is not None and v.shape[1:] != shape for v in cols):
            continue  # one name, different shapes in different prims: not merged
        per_strand[k] = np.concatenate([v if v is not None else np.full((n,) + shape, np.nan)
                                        for v, (_, _, n) in zip(cols, read)])
    return Groom(points.astype(np.float32), np.concatenate(rads).astype(np.float32), offsets.astype(np.uint32),
                 read, per_strand, dev, dev_abs, up_axis)


def _first_line(e: Exception) -> str:
    s = str(e).strip().splitlines()
    return (s[0] if s else type(e).__name__)[:300]


@dataclass
class _Curves:
    """One prim's curves as read: control points (float64, world space
    after the transform), widths expanded to one per control point (or per
    span end for ``varying``), and the prim's type, basis and wrap."""

    points: np.ndarray
    counts: np.ndarray
    widths: np.ndarray
    width_kind: str  # "vertex" or "varying" (constant and uniform expanded to vertex)
    type: str
    basis: str
    wrap: str
    #: varying widths per curve, spread evenly over its spans
    varying: np.ndarray | None = None

    def transform(self, m: np.ndarray, where: str) -> None:
        """Applies the 4 x 4 matrix ``m`` (column vectors: p' = M p) to the
        points; the widths scale by the cube root of its determinant."""
        if np.array_equal(m, np.eye(4)):
            return
        if not np.all(np.isfinite(m)):
            raise GroomError(f"{where}: its transform is not finite")
        self.points = self.points @ m[:3, :3].T + m[:3, 3]
        self.widths = self.widths * abs(np.linalg.det(m[:3, :3])) ** (1 / 3)
        if not np.all(np.isfinite(self.points)):
            raise GroomError(f"{where}: its transformed points overflow")

    @staticmethod
    def of(p: Any, UsdGeom: Any, tc: Any, where: str, default_radius: float | None) -> "_Curves":
        bc = UsdGeom.BasisCurves(p)
        ctype = str(bc.GetTypeAttr().Get() or "cubic")
        basis = str(bc.GetBasisAttr().Get() or "bezier")
        wrap = str(bc.GetWrapAttr().Get() or "nonperiodic")
        if ctype not in ("linear", "cubic"):
            raise GroomError(f"{where}: type {ctype!r}: expected 'linear' or 'cubic'")
        if ctype == "cubic" and basis not in BASES:
            raise GroomError(f"{where}: basis {basis!r}: expected 'bspline', 'catmullRom' or 'bezier'")
        if wrap not in ("nonperiodic", "pinned", "periodic"):
            raise GroomError(f"{where}: wrap {wrap!r}: expected 'nonperiodic', 'pinned' or 'periodic'")
        raw_counts = bc.GetCurveVertexCountsAttr().Get(tc)
        if raw_counts is None or len(raw_counts) == 0:
            raise GroomError(f"{where}: no curveVertexCounts")
        counts = np.asarray(raw_counts, dtype=np.int64)
        least = _min_count(ctype, basis, wrap)
        bad = np.flatnonzero(counts < least)
        if bad.size:
            i = int(bad[0])
            raise GroomError(f"{where}: curve {i} has {counts[i]} vertices; a {ctype} {'' if ctype == 'linear' else basis + ' '}"
                             f"{wrap} curve needs at least {least}")
        if ctype == "cubic":
            step = VSTEP[basis]
            rem = (counts % step) if wrap == "periodic" else ((counts - 4) % step if wrap == "nonperiodic" else counts * 0)
            bad = np.flatnonzero(rem)
            if bad.size:
                i = int(bad[0])
                raise GroomError(f"{where}: curve {i} has {counts[i]} vertices, which a {basis} {wrap} curve cannot "
                                 f"have (its spans take {step} more each)")
        total = int(counts.sum())
        # points and widths in float64 while converting, and the subdivided result
        _memory.check(total * 8 * 4 * (3 if ctype == "cubic" else 1) + total * 16 * 4, where,
                      "is the curveVertexCounts array right?")
        attr = bc.GetPointsAttr()
        if not attr.HasValue():
            raise GroomError(f"{where}: no points")
        points = np.asarray(attr.Get(tc), dtype=np.float64).reshape(-1, 3)
        if len(points) != total:
            raise GroomError(f"{where}: curveVertexCounts sum to {total} vertices, but it has {len(points)} points")
        _finite(points, counts, where, "point")
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        ext = np.maximum.reduceat(points, starts) - np.minimum.reduceat(points, starts)
        zero = np.flatnonzero(~np.any(ext > 0, axis=1))
        if zero.size:  # no length and no tangent: nothing to draw or shade
            raise GroomError(f"{where}: curve {int(zero[0])} has zero length (all its points coincide)")
        widths, kind, varying = _widths(p, bc, UsdGeom, tc, counts, ctype, basis, wrap, where, default_radius)
        return _Curves(points, counts, widths, kind, ctype, basis, wrap, varying)


def _min_count(ctype: str, basis: str, wrap: str) -> int:
    if ctype == "linear":
        return 3 if wrap == "periodic" else 2
    if wrap == "pinned":
        return 2
    return VSTEP[basis] if wrap == "periodic" else 4


def _spans(n: np.ndarray, ctype: str, basis: str, wrap: str) -> np.ndarray:
    """Spans (segments) per curve of n vertices."""
    if ctype == "linear":
        return n if wrap == "periodic" else n - 1
    if wrap == "periodic":
        return n // VSTEP[basis]
    if wrap == "pinned" and basis != "bezier":
        return n - 1
    return (n - 4) // VSTEP[basis] + 1


def _finite(a: np.ndarray, counts: np.ndarray, where: str, what: str) -> None:
    bad = np.flatnonzero(~np.all(np.isfinite(a.reshape(len(a), -1)), axis=1))
    if bad.size:
        k = int(bad[0])
        curve = int(np.searchsorted(np.cumsum(counts), k, side="right"))
        raise GroomError(f"{where}: {what} {k} (curve {curve}) is not finite: {a[k].tolist()}")


def _widths(p: Any, bc: Any, UsdGeom: Any, tc: Any, counts: np.ndarray, ctype: str, basis: str, wrap: str,
            where: str, default_radius: float | None) -> tuple[np.ndarray, str, np.ndarray | None]:
    """Widths as one value per vertex, or ``varying``: values spread evenly
    over each curve's spans, with their count per curve."""
    pv = UsdGeom.PrimvarsAPI(p).GetPrimvar("widths")
    if pv and pv.HasAuthoredValue():
        raw, interp = pv.ComputeFlattened(tc), str(pv.GetInterpolation())
    else:
        raw, interp = bc.GetWidthsAttr().Get(tc), str(bc.GetWidthsInterpolation())
    total = int(counts.sum())
    if raw is None or len(raw) == 0:
        if default_radius is None:
            raise GroomError(f"{where}: no widths (pass default_radius= to read it with one radius)")
        return np.full(total, 2.0 * default_radius), "vertex", None
    w = np.asarray(raw, dtype=np.float64).reshape(-1)
    # varying: one value per span end (the schema's table). For pinned
    # cubics the schema's own code counts max((n - 4) / vstep, 0) + 2 per
    # curve instead of n; either is taken, spread evenly over the spans.
    varying = _spans(counts, ctype, basis, wrap) + (0 if wrap == "periodic" else 1)
    sizes = {"constant": 1, "uniform": len(counts), "vertex": total, "varying": int(varying.sum())}
    if interp not in sizes:
        raise GroomError(f"{where}: widths interpolation {interp!r}: expected constant, uniform, varying or vertex")
    if interp == "varying" and len(w) != sizes["varying"] and ctype == "cubic" and wrap == "pinned":
        code = np.maximum((counts - 4) // VSTEP[basis], 0) + 2
        if len(w) == int(code.sum()):
            varying = code
            sizes["varying"] = len(w)
    if len(w) != sizes[interp]:
        raise GroomError(f"{where}: {len(w)} widths for {interp} interpolation; expected {sizes[interp]}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        k = int(np.flatnonzero(~(np.isfinite(w) & (w >= 0)))[0])
        raise GroomError(f"{where}: width {k} is {float(w[k])!r}; expected a finite number >= 0")
    if interp == "constant":
        return np.full(total, w[0]), "vertex", None
    if interp == "uniform":
        return np.repeat(w, counts), "vertex", None
    return w, interp, (varying if interp == "varying" else None)


def _varying_at(c: _Curves, curve: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Varying widths at curve parameters ``u`` in [0, 1] (piecewise
    linear between values spread evenly over the curve)."""
    assert c.varying is not None
    starts = np.concatenate([[0], np.cumsum(c.varying)[:-1]])
    m = c.varying[curve]
    x = u * (m - 1)
    i = np.minimum(np.floor(x).astype(np.int64), np.maximum(m - 2, 0))
    f = np.where(m > 1, x - i, 0.0)
    a = c.widths[starts[curve] + i]
    b = c.widths[starts[curve] + np.minimum(i + 1, m - 1)]
    return a + (b - a) * f


def _curve_primvars(p: Any, UsdGeom: Any, tc: Any, curves: int) -> dict[str, np.ndarray]:
    out = {}
    for pv in UsdGeom.PrimvarsAPI(p).GetPrimvarsWithValues():
        name = str(pv.GetPrimvarName())
        interp = str(pv.GetInterpolation())
        if name == "widths" or interp not in ("uniform", "constant"):
            continue
        try:
            v = np.asarray(pv.ComputeFlattened(tc))
        except Exception:
            continue
        if v.dtype.kind not in "fiub" or v.size == 0:
            continue
        v = v.astype(np.float64)
        if interp == "constant":
            v = np.broadcast_to(v.reshape((1,) + v.shape[1:]) if v.ndim > 1 else v[:1], (curves,) + v.shape[1:]).copy()
        if len(v) != curves:
            continue
        out[name] = v
    return out


def _as_polylines(c: _Curves) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Control points taken as the polyline (periodic curves closed)."""
    w = c.widths
    if c.width_kind == "varying":  # spread over the vertices
        curve = np.repeat(np.arange(len(c.counts)), c.counts)
        k = np.arange(len(curve)) - np.repeat(np.cumsum(c.counts) - c.counts, c.counts)
        w = _varying_at(c, curve, k / np.maximum(c.counts[curve] - 1, 1))
    if c.wrap != "periodic":
        return c.points, w, c.counts
    starts = np.concatenate([[0], np.cumsum(c.counts)[:-1]])
    idx = np.concatenate([np.append(np.arange(s, s + n), s) for s, n in zip(starts, c.counts)])
    return c.points[idx], w[idx], c.counts + 1


def _span_controls(c: _Curves) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For every span: its 4 control point indices into the (padded)
    points, its curve and its index within the curve; and the padded
    control points (pinned curves get their phantom points)."""
    pts, counts = c.points, c.counts
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    if c.wrap == "pinned" and c.basis != "bezier":
        parts = []
        for s, n in zip(starts, counts):
            q = pts[s:s + n]
            parts.append(np.concatenate([[2 * q[0] - q[1]], q, [2 * q[-1] - q[-2]]]))
        pts = np.concatenate(parts)
        counts = counts + 2
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        wrap = "nonperiodic"
    else:
        wrap = c.wrap
    spans = _spans(counts, "cubic", c.basis, wrap)
    curve = np.repeat(np.arange(len(counts)), spans)
    j = np.arange(int(spans.sum())) - np.repeat(np.cumsum(spans) - spans, spans)
    first = j * VSTEP[c.basis]
    k = first[:, None] + np.arange(4)[None, :]
    if wrap == "periodic":
        k = k % counts[curve][:, None]
    return starts[curve][:, None] + k, curve, j, pts


def _evaluate(c: _Curves, tolerance: float, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """Cubic curves as polylines: every span cut into equal parameter steps
    until its chord error bound |C''| h^2 / 8 is within ``tolerance`` radii;
    then the distance to the curve measured at three points inside every
    step. Returns points, widths, per-strand counts, deviation in radii and
    in scene units."""
    idx, curve, j, pts = _span_controls(c)
    B = BASES[c.basis]
    G = pts[idx]  # (spans, 4, 3)
    BG = np.einsum("ij,sjk->sik", B, G)  # power-basis coefficients [a, b, c, d]
    # widths at the span's control points (vertex widths, evaluated with the
    # basis); varying widths are linear along the curve (zero here, added below)
    nspan = np.bincount(curve, minlength=len(c.counts))
    if c.width_kind == "vertex":
        wpad = c.widths
        if c.wrap == "pinned" and c.basis != "bezier":
            starts = np.concatenate([[0], np.cumsum(c.counts)[:-1]])
            wpad = np.concatenate([np.concatenate([[2 * w[0] - w[1]], w, [2 * w[-1] - w[-2]]])
                                   for w in (c.widths[s:s + n] for s, n in zip(starts, c.counts))])
        Wc = np.einsum("ij,sj->si", B, wpad[idx])
    else:
        u0 = j / nspan[curve]
        u1 = (j + 1) / nspan[curve]
        w0, w1 = _varying_at(c, curve, u0), _varying_at(c, curve, u1)
        Wc = np.stack([np.zeros_like(w0), np.zeros_like(w0), w1 - w0, w0], axis=1)
    # per-span tolerance in scene units: `tolerance` times its smaller end radius
    # (at least 1e-7 of the span's size, for curves of zero width)
    r_span = np.minimum(Wc[:, 3], Wc.sum(axis=1)) / 2
    size = np.linalg.norm(G.max(axis=1) - G.min(axis=1), axis=1)
    tol = np.maximum(tolerance * np.maximum(r_span, 0), 1e-7 * size + 1e-30)
    d2 = np.maximum(np.linalg.norm(2 * BG[:, 1], axis=1), np.linalg.norm(6 * BG[:, 0] + 2 * BG[:, 1], axis=1))
    n = np.clip(np.ceil(np.sqrt(d2 / (8 * tol))), 1, MAX_SUBDIVISIONS).astype(np.int64)
    # parameters: every span's steps, the last span of each curve closing at t = 1
    last = np.r_[curve[1:] != curve[:-1], True]
    per = n + last
    _memory.check(int(per.sum()) * 8 * 16, where, "lower the tolerance or read curves='control_points'")
    s_of = np.repeat(np.arange(len(n)), per)
    k = np.arange(int(per.sum())) - np.repeat(np.cumsum(per) - per, per)
    t = k / n[s_of]

    def at(tt: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        T = np.stack([tt**3, tt**2, tt, np.ones_like(tt)], axis=1)
        return np.einsum("si,sik->sk", T, BG[s]), np.einsum("si,si->s", T, Wc[s])

    P, W = at(t, s_of)
    W = np.maximum(W, 0)
    # measured deviation: three points inside every step against its chord
    step_s = np.repeat(np.arange(len(n)), n)
    kk = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    h = 1 / n[step_s]
    a, _ = at(kk * h, step_s)
    b, _ = at((kk + 1) * h, step_s)
    worst = np.zeros(len(kk))
    rmin = np.full(len(kk), np.inf)
    for f in (0.25, 0.5, 0.75):
        q, wq = at((kk + f) * h, step_s)
        ab = b - a
        L2 = np.einsum("ij,ij->i", ab, ab)
        u = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.where(L2 > 0, L2, 1), 0, 1)
        worst = np.maximum(worst, np.linalg.norm(q - (a + u[:, None] * ab), axis=1))
        rmin = np.minimum(rmin, np.maximum(wq, 0) / 2)
    dev_abs = float(worst.max()) if len(worst) else 0.0
    rel = worst / np.where(rmin > 0, rmin, np.inf)
    dev = float(rel.max()) if len(rel) else 0.0
    counts = np.bincount(curve[s_of], minlength=len(c.counts))
    return P, W, counts, dev, dev_abs


def write_usd(path: str | os.PathLike, points: Any, radii: Any, offsets: Any, prim: str = "/hair",
              curve_primvars: dict[str, Any] | None = None, up_axis: str = "Y") -> None:
    """Writes strands (the renderer's flat arrays, as :class:`Groom` and
    ``Scene`` hold them) as one linear ``BasisCurves`` prim at ``prim``:
    the points as float32, widths (twice the radii) per vertex, and
    ``curve_primvars`` (name -> one value per strand) as uniform primvars.
    Reading the file back with :func:`read_usd` gives the same arrays, bit
    for bit. The format follows the extension (``.usda`` text, ``.usd`` or
    ``.usdc`` binary)."""
    Sdf, Usd, UsdGeom, Vt = _pxr()
    from .scene import _strand_arrays

    path = os.fspath(path)
    p, r, o = _strand_arrays(points, radii, offsets)
    if not Sdf.Path.IsValidPathString(prim) or not Sdf.Path(prim).IsAbsolutePath() or prim == "/":
        raise ValueError(f"prim: expected an absolute prim path such as '/hair', got {prim!r:.80}")
    if up_axis not in ("Y", "Z"):
        raise ValueError(f"up_axis: expected 'Y' or 'Z', got {up_axis!r:.80}")
    if not path.lower().endswith((".usd", ".usda", ".usdc")):
        raise ValueError(f"path: expected a .usd, .usda or .usdc file name, got {path!r:.200}")
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if up_axis == "Y" else UsdGeom.Tokens.z)
    for anc in reversed(Sdf.Path(prim).GetParentPath().GetPrefixes()):
        UsdGeom.Xform.Define(stage, anc)
    bc = UsdGeom.BasisCurves.Define(stage, prim)
    bc.CreateTypeAttr(UsdGeom.Tokens.linear)
    bc.CreateWrapAttr(UsdGeom.Tokens.nonperiodic)
    bc.CreateCurveVertexCountsAttr(Vt.IntArray.FromNumpy(np.diff(o.astype(np.int64)).astype(np.int32)))
    bc.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(p)))
    bc.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.ascontiguousarray(2 * r)))
    bc.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    if len(p):
        lo = p.min(axis=0) - r.max()
        hi = p.max(axis=0) + r.max()
        bc.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([lo, hi]).astype(np.float32)))
    api = UsdGeom.PrimvarsAPI(bc.GetPrim())
    for name, values in (curve_primvars or {}).items():
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 1 or len(v) != len(o) - 1:
            raise ValueError(f"curve_primvars[{name!r}]: expected one number per strand ({len(o) - 1}), "
                             f"got shape {v.shape}")
        if not Sdf.Path.IsValidIdentifier(name):
            raise ValueError(f"curve_primvars: {name!r} is not a valid primvar name")
        pv = api.CreatePrimvar(name, Sdf.ValueTypeNames.DoubleArray, UsdGeom.Tokens.uniform)
        pv.Set(Vt.DoubleArray.FromNumpy(v))
    stage.SetDefaultPrim(stage.GetPrimAtPath(Sdf.Path(prim).GetPrefixes()[0]))
    if not stage.GetRootLayer().Export(path):
        raise OSError(f"{path}: cannot write")


def is_usd(name: str) -> bool:
    """Whether a file name is a USD file by its extension."""
    return name.lower().endswith((".usd", ".usda", ".usdc", ".usdz"))


__all__ = ["Groom", "GroomError", "read_usd", "write_usd", "is_usd", "MAX_SUBDIVISIONS"]
