"""Grooms through Blender (extra ``blender``: ``pip install 'hairshade[blender]'``,
which installs ``bpy``, Blender as a Python module; about 800 MB, Python 3.11).

:func:`read_alembic` reads the hair curves of an Alembic (``.abc``) file,
as UE5 grooms are exchanged, with Blender's own importer: PyPI has no
Alembic bindings. It runs Blender in this process and resets its session
(``read_factory_settings``), so do not call it from a Blender session
whose data you want to keep.

The curves come back as :func:`hairshade.usd.read_usd` gives them:
Catmull-Rom curves (Blender's default, and what its Alembic exporter
writes) are evaluated through their control points with the end
condition of USD's ``pinned`` wrap and subdivided to within ``tolerance``
fiber radii (Blender itself repeats the end points instead, which bends
the first and last spans slightly less); poly curves are read as they
are; ``curves="control_points"`` takes every curve's points as its
polyline. Object transforms are applied, and radii scale by the cube
root of the transform's determinant.
"""

from __future__ import annotations

import os

import numpy as np

from . import _extras
from .usd import Groom, GroomError, _Curves, groom_of

# Blender's curve_type attribute values
CATMULL_ROM, POLY, BEZIER, NURBS = 0, 1, 2, 3


def read_alembic(path: str | os.PathLike, curves: str = "evaluate", tolerance: float = 0.1) -> Groom:
    """The hair curves of the Alembic file ``path``, through Blender's
    importer (see the module docs). Raises :class:`GroomError` when the
    file cannot be imported or holds no curves, or when a curve is not
    Catmull-Rom or poly."""
    bpy = _extras.require("bpy", "reading Alembic grooms")
    path = os.path.abspath(os.fspath(path))
    if curves not in ("evaluate", "control_points"):
        raise ValueError(f"curves: expected 'evaluate' or 'control_points', got {curves!r:.80}")
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not 1e-3 <= tolerance <= 10:
        raise ValueError(f"tolerance: expected a number of fiber radii in [0.001, 10], got {tolerance!r:.80}")
    if not os.path.isfile(path):
        raise GroomError(f"{path}: no such file" if not os.path.exists(path) else f"{path}: not a regular file")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        result = bpy.ops.wm.alembic_import(filepath=path, as_background_job=False)
    except RuntimeError as e:
        raise GroomError(f"{path}: Blender cannot import it: {str(e).strip()[:300]}") from None
    if "FINISHED" not in result:
        raise GroomError(f"{path}: Blender cannot import it")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    parts = []
    for ob in bpy.context.scene.objects:
        if ob.type != "CURVES":
            continue
        data = ob.evaluated_get(depsgraph).data
        where = f"{path}: {ob.name}"
        n_pts, n_curves = len(data.points), len(data.curves)
        if n_curves == 0:
            continue
        pos = np.zeros(3 * n_pts, np.float32)
        data.attributes["position"].data.foreach_get("vector", pos)
        rad = np.full(n_pts, 0.005, np.float32)
        if "radius" in data.attributes:
            data.attributes["radius"].data.foreach_get("value", rad)
        counts = np.zeros(n_curves, np.int64)
        for i, cv in enumerate(data.curves):
            counts[i] = cv.points_length
        kinds = np.zeros(n_curves, np.int8)
        if "curve_type" in data.attributes:
            data.attributes["curve_type"].data.foreach_get("value", kinds)
        bad = np.flatnonzero((kinds != CATMULL_ROM) & (kinds != POLY))
        if bad.size:
            raise GroomError(f"{where}: curve {int(bad[0])} is {['Catmull-Rom', 'poly', 'Bezier', 'NURBS'][kinds[bad[0]]]}"
                             "; only Catmull-Rom and poly curves are read")
        m = np.array(ob.matrix_world, dtype=np.float64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        p64 = pos.reshape(-1, 3).astype(np.float64)
        if not np.all(np.isfinite(p64)):
            raise GroomError(f"{where}: a point is not finite")
        for kind, ctype, basis, wrap in ((CATMULL_ROM, "cubic", "catmullRom", "pinned"),
                                         (POLY, "linear", "catmullRom", "nonperiodic")):
            sel = np.flatnonzero(kinds == kind)
            if not sel.size:
                continue
            idx = np.concatenate([np.arange(starts[i], starts[i] + counts[i]) for i in sel])
            c = _Curves(p64[idx], counts[sel], 2 * rad[idx].astype(np.float64), "vertex", ctype, basis, wrap)
            if np.any(c.counts < 2):
                raise GroomError(f"{where}: a curve has fewer than 2 points")
            c.transform(m, where)
            parts.append((f"{ob.name} ({'Catmull-Rom' if kind == CATMULL_ROM else 'poly'})", c, {}))
    if not parts:
        raise GroomError(f"{path}: no hair curves")
    return groom_of(parts, path, curves, tolerance, "Z")
