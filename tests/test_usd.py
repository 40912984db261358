"""USD grooms (hairshade.usd): Blender's export read back, cubic bases
evaluated against independent formulas, round trips, and bad files.

The Blender inputs in tests/data/blender were made by
scripts/blender_fixtures.py with bpy 5.0.1; groom_blender.npz holds what
Blender itself had (world-space control points from its matrix_world in
float64, radii, counts).
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest

import hairshade as hs

pxr = pytest.importorskip("pxr", reason="USD grooms need usd-core (pip install 'hairshade[usd]')")
from pxr import Usd, UsdGeom, Vt  # noqa: E402

from hairshade.usd import GroomError, read_usd, write_usd  # noqa: E402

BLENDER = Path(__file__).parent / "data" / "blender"


def blender_groom():
    return np.load(BLENDER / "groom_blender.npz")


def float32_ulp_of_extent(p):
    """One float32 unit in the last place of the largest coordinate: the
    precision a float32 file can hold the groom to."""
    return float(np.spacing(np.float32(np.abs(p).max())))


def make_curves(path, points, counts, widths=None, interp="vertex", ctype="cubic", basis="bspline",
                wrap="nonperiodic", **prim):
    """A one-prim USD file made with usd-core directly."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/g")
    bc = UsdGeom.BasisCurves.Define(stage, "/g/c")
    bc.CreateTypeAttr(ctype)
    bc.CreateBasisAttr(basis)
    bc.CreateWrapAttr(wrap)
    bc.CreateCurveVertexCountsAttr(Vt.IntArray([int(c) for c in counts]))
    bc.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    if widths is not None:
        bc.CreateWidthsAttr(Vt.FloatArray([float(w) for w in widths]))
        bc.SetWidthsInterpolation(interp)
    for k, v in prim.items():
        k(bc, v)
    stage.GetRootLayer().Save()
    return path


def catmull_rom(p0, p1, p2, p3, t):
    """The Catmull-Rom span from p1 to p2 (Catmull & Rom 1974, tension 1/2),
    written out term by term, independently of hairshade.usd's matrices."""
    t = np.asarray(t)[:, None]
    return 0.5 * (2 * p1 + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2 + (3 * p1 - p0 - 3 * p2 + p3) * t**3)


# -- Blender's export ------------------------------------------------------------


def test_01_blender_catmull_rom_groom_control_points_match_blender():
    """Blender writes its default hair curves as catmullRom, wrap pinned,
    under an Xform with translate, rotateXYZ and scale. The control points
    come back where Blender's matrix_world puts them, within one float32
    ulp of the groom's extent (the file stores the rotation in float32
    degrees; measured 0.57 ulp)."""
    z = blender_groom()
    g = read_usd(BLENDER / "groom_catmull_rom.usda", curves="control_points")
    assert np.array_equal(np.diff(g.offsets), z["counts"])
    assert np.abs(g.points - z["points"]).max() <= float32_ulp_of_extent(z["points"])
    np.testing.assert_allclose(g.radii, z["radii"], rtol=2 ** -23)
    np.testing.assert_array_equal(g.curve_primvars["clump"], z["clump"])
    assert g.prims == [("/root/Groom/GroomData", 0, 12)]
    assert g.up_axis == "Z"
    assert g.deviation == 0.0


def test_02_blender_poly_groom_is_read_as_it_is():
    z = blender_groom()
    g = read_usd(BLENDER / "groom_poly.usda")
    assert np.array_equal(np.diff(g.offsets), z["counts"])
    assert np.abs(g.points - z["points"]).max() <= float32_ulp_of_extent(z["points"])
    assert g.deviation == 0.0


def test_03_catmull_rom_is_evaluated_through_its_control_points():
    """Evaluated, every control point is on the polyline (pinned
    Catmull-Rom interpolates them), every other point lies on the
    term-by-term Catmull-Rom formula with the phantom end points
    2 P0 - P1 (float32 rounding: 1e-6 of the extent), and the measured
    deviation is within the tolerance."""
    z = blender_groom()
    cp = read_usd(BLENDER / "groom_catmull_rom.usda", curves="control_points")
    g = read_usd(BLENDER / "groom_catmull_rom.usda")
    assert g.strand_count == 12 and len(g.points) > 3 * len(cp.points)
    assert 0 < g.deviation <= 0.1
    ext = np.abs(z["points"]).max()
    for s in range(12):
        P = cp.points[cp.offsets[s]:cp.offsets[s + 1]].astype(np.float64)
        Q = g.points[g.offsets[s]:g.offsets[s + 1]].astype(np.float64)
        # each control point appears in order
        d = np.linalg.norm(Q[None, :, :] - P[:, None, :], axis=2)
        hit = d.argmin(axis=1)
        assert np.all(d.min(axis=1) < 1e-6 * ext) and np.all(np.diff(hit) > 0) and hit[0] == 0 and hit[-1] == len(Q) - 1
        padded = np.concatenate([[2 * P[0] - P[1]], P, [2 * P[-1] - P[-2]]])
        for k in range(len(P) - 1):
            between = Q[hit[k]:hit[k + 1] + 1]
            t = np.linspace(0, 1, len(between))  # equal parameter steps within a span
            want = catmull_rom(padded[k], padded[k + 1], padded[k + 2], padded[k + 3], t)
            assert np.abs(between - want).max() < 1e-6 * ext


def test_04_tolerance_bounds_the_measured_deviation():
    loose = read_usd(BLENDER / "groom_catmull_rom.usda", tolerance=1.0)
    tight = read_usd(BLENDER / "groom_catmull_rom.usda", tolerance=0.01)
    assert tight.deviation <= 0.01 < loose.deviation <= 1.0
    assert len(tight.points) > len(loose.points)


def test_05_pinned_bspline_meets_its_end_points_and_nonperiodic_does_not(tmp_path):
    """B(0) = (P[-1] + 4 P0 + P1) / 6 = P0 for the phantom P[-1] = 2 P0 - P1:
    an exact identity; a nonperiodic B-spline starts at (P0 + 4 P1 + P2) / 6."""
    P = np.array([[0, 0, 0], [1, 0.5, 0], [2, -0.5, 0.2], [3, 0, 0.4], [4, 1, 0]], np.float32)
    pinned = read_usd(make_curves(tmp_path / "p.usda", P, [5], [0.02] * 5, wrap="pinned"))
    np.testing.assert_allclose(pinned.points[0], P[0], atol=1e-6)
    np.testing.assert_allclose(pinned.points[-1], P[-1], atol=1e-6)
    free = read_usd(make_curves(tmp_path / "n.usda", P, [5], [0.02] * 5))
    np.testing.assert_allclose(free.points[0], (P[0] + 4 * P[1] + P[2]) / 6, atol=1e-6)
    np.testing.assert_allclose(free.points[-1], (P[2] + 4 * P[3] + P[4]) / 6, atol=1e-6)


def test_06_bezier_quarter_circle_is_within_its_known_error(tmp_path):
    """The cubic Bezier with handles at k = 4/3 (sqrt 2 - 1) of the radius
    stays within 2.8e-4 of the unit circle (its known radial error,
    +2.7e-4): every evaluated point checks that, independently."""
    k = 4 / 3 * (np.sqrt(2) - 1)
    P = np.array([[1, 0, 0], [1, k, 0], [k, 1, 0], [0, 1, 0]], np.float32)
    g = read_usd(make_curves(tmp_path / "b.usda", P, [4], [0.02] * 4, basis="bezier"), tolerance=0.01)
    r = np.linalg.norm(g.points[:, :2].astype(np.float64), axis=1)
    assert len(g.points) > 8 and np.abs(r - 1).max() < 2.8e-4


def test_07_widths_interpolations(tmp_path):
    P = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0], [1, 0, 0], [1, 1, 0], [1, 2, 0], [1, 3, 0]], np.float32)
    lin = dict(ctype="linear")
    const = read_usd(make_curves(tmp_path / "c.usda", P, [4, 4], [0.5], "constant", **lin))
    np.testing.assert_array_equal(const.radii, 0.25)
    uni = read_usd(make_curves(tmp_path / "u.usda", P, [4, 4], [0.2, 0.4], "uniform", **lin))
    np.testing.assert_array_equal(uni.radii, np.float32([0.1] * 4 + [0.2] * 4))
    vert = read_usd(make_curves(tmp_path / "v.usda", P, [4, 4], np.arange(8) / 10, "vertex", **lin))
    np.testing.assert_allclose(vert.radii, np.arange(8) / 20, rtol=1e-6)
    # varying on linear curves: one per vertex as well (segments + 1)
    var = read_usd(make_curves(tmp_path / "va.usda", P, [4, 4], np.arange(8) / 10, "varying", **lin))
    np.testing.assert_allclose(var.radii, np.arange(8) / 20, rtol=1e-6)
    # varying on a nonperiodic cubic B-spline of 5 points: 2 spans, 3 values, linear along the curve
    Q = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0], [0, 4, 0]], np.float32)
    cub = read_usd(make_curves(tmp_path / "vc.usda", Q, [5], [0.2, 0.4, 0.6], "varying"))
    # a straight B-spline with equal steps is linear in y: y from 1 to 3, width from 0.2 to 0.6
    np.testing.assert_allclose(cub.radii, 0.1 + (cub.points[:, 1] - 1) * 0.1, atol=1e-6)


def test_08_transforms_nest_and_scale_widths(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "x.usda"))
    a = UsdGeom.Xform.Define(stage, "/a")
    a.AddTranslateOp().Set((1, 2, 3))
    b = UsdGeom.Xform.Define(stage, "/a/b")
    b.AddScaleOp().Set((2, 2, 2))
    bc = UsdGeom.BasisCurves.Define(stage, "/a/b/c")
    bc.CreateTypeAttr("linear")
    bc.CreateCurveVertexCountsAttr([2])
    bc.CreatePointsAttr([(0, 0, 0), (0, 1, 0)])
    bc.CreateWidthsAttr([0.1, 0.1])
    stage.GetRootLayer().Save()
    g = read_usd(tmp_path / "x.usda")
    np.testing.assert_allclose(g.points, [[1, 2, 3], [1, 4, 3]], atol=1e-6)
    np.testing.assert_allclose(g.radii, [0.1, 0.1], rtol=1e-6)  # half of 0.1, times 2


def test_09_hidden_guides_and_prim_selection(tmp_path):
    P = np.array([[0, 0, 0], [0, 1, 0]], np.float32)
    stage = Usd.Stage.CreateNew(str(tmp_path / "m.usda"))
    for name, vis, purpose in (("a", "inherited", "default"), ("b", "invisible", "default"), ("c", "inherited", "guide"),
                               ("d", "inherited", "render")):
        bc = UsdGeom.BasisCurves.Define(stage, f"/g/{name}")
        bc.CreateTypeAttr("linear")
        bc.CreateCurveVertexCountsAttr([2])
        bc.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(P + [ord(name), 0, 0]))
        bc.CreateWidthsAttr([0.01, 0.01])
        bc.CreateVisibilityAttr(vis)
        bc.CreatePurposeAttr(purpose)
    stage.GetRootLayer().Save()
    g = read_usd(tmp_path / "m.usda")
    assert [p for p, _, _ in g.prims] == ["/g/a", "/g/d"]
    assert [p for p, _, _ in read_usd(tmp_path / "m.usda", prim="/g/d").prims] == ["/g/d"]
    with pytest.raises(GroomError, match="no prim '/nope'"):
        read_usd(tmp_path / "m.usda", prim="/nope")


# -- round trips and scenes ------------------------------------------------------


def test_10_write_read_round_trip_is_bit_identical(tmp_path):
    rng = np.random.default_rng(3)
    counts = rng.integers(2, 12, 50)
    pts = rng.normal(size=(counts.sum(), 3)).astype(np.float32) * np.float32(0.37)
    rad = rng.uniform(0, 0.01, counts.sum()).astype(np.float32)
    off = np.concatenate([[0], np.cumsum(counts)]).astype(np.uint32)
    clump = rng.random(50)
    for ext in ("usda", "usdc"):
        write_usd(tmp_path / f"r.{ext}", pts, rad, off, curve_primvars={"clump": clump})
        g = read_usd(tmp_path / f"r.{ext}")
        assert np.array_equal(g.points, pts) and np.array_equal(g.radii, rad) and np.array_equal(g.offsets, off)
        np.testing.assert_array_equal(g.curve_primvars["clump"], clump)


def test_11_a_scene_loads_a_usd_groom_and_saves_it_back(tmp_path):
    """hair.file names Blender's groom; the scene renders; Scene.save to
    .usda and loading that gives the same strands, bit for bit, and the
    same image."""
    import shutil

    shutil.copy(BLENDER / "groom_catmull_rom.usda", tmp_path / "groom.usda")
    spec = {"hairshade_scene": 1, "camera": {"position": [0.2, -4, 1], "target": [0.2, 0, 1], "up": [0, 0, 1],
                                             "resolution": [48, 32]},
            "lights": [{"type": "directional", "direction": [0.3, -1, 0.5], "intensity": [3, 3, 3]}],
            "hair": {"file": "groom.usda", "material": {"model": "chiang"}}}
    sc = hs.Scene.from_dict(spec, base_dir=str(tmp_path))
    g = read_usd(tmp_path / "groom.usda")
    assert np.array_equal(sc.points, g.points) and np.array_equal(sc.radii, g.radii)
    img = hs.render(sc)
    assert img.max() > 0 and np.all(np.isfinite(img))
    sc.save(tmp_path / "again.usda")
    back = hs.Scene.from_dict(dict(spec, hair={"file": "again.usda", "material": {"model": "chiang"}}),
                              base_dir=str(tmp_path))
    assert np.array_equal(back.points, sc.points) and np.array_equal(back.radii, sc.radii)
    assert np.array_equal(back.offsets, sc.offsets)
    np.testing.assert_array_equal(hs.render(back), img)


# -- bad files -------------------------------------------------------------------


BAD = [
    # (name, points, counts, widths, extra, error)
    ("missing_widths", [[0, 0, 0], [0, 1, 0]], [2], None, dict(ctype="linear"), "no widths"),
    ("zero_length", [[0, 0, 0]] * 4, [4], [0.01] * 4, {}, "curve 0 has zero length"),
    ("zero_length_linear", [[0, 1, 0], [0, 1, 0]], [2], [0.01] * 2, dict(ctype="linear"), "curve 0 has zero length"),
    ("nan_point", [[0, 0, 0], [0, np.nan, 0], [0, 2, 0], [0, 3, 0]], [4], [0.01] * 4, {}, r"point 1 \(curve 0\) is not finite"),
    ("count_mismatch", [[0, 0, 0], [0, 1, 0], [0, 2, 0]], [2, 2], [0.01] * 4, dict(ctype="linear"),
     "curveVertexCounts sum to 4 vertices, but it has 3 points"),
    ("too_few_vertices", [[0, 0, 0], [0, 1, 0], [0, 2, 0]], [3], [0.01] * 3, {},
     "curve 0 has 3 vertices; a cubic bspline nonperiodic curve needs at least 4"),
    ("bezier_count", [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0], [0, 4, 0]], [5], [0.01] * 5, dict(basis="bezier"),
     "curve 0 has 5 vertices, which a bezier nonperiodic curve cannot have"),
    ("widths_count", [[0, 0, 0], [0, 1, 0]], [2], [0.01] * 3, dict(ctype="linear"), "3 widths for vertex interpolation; expected 2"),
    ("negative_width", [[0, 0, 0], [0, 1, 0]], [2], [0.01, -1], dict(ctype="linear"), "width 1 is -1.0"),
    ("nan_width", [[0, 0, 0], [0, 1, 0]], [2], [0.01, np.nan], dict(ctype="linear"), "width 1 is nan"),
]


@pytest.mark.parametrize("name,points,counts,widths,extra,error", BAD, ids=[b[0] for b in BAD])
def test_12_bad_curves_name_the_prim_and_the_problem(tmp_path, name, points, counts, widths, extra, error):
    path = make_curves(tmp_path / f"{name}.usda", np.array(points, np.float32), counts, widths, **extra)
    with pytest.raises(GroomError, match=f"{name}.usda: /g/c: {error}"):
        read_usd(path)


def test_13_missing_widths_read_with_a_default_radius(tmp_path):
    path = make_curves(tmp_path / "w.usda", np.array([[0, 0, 0], [0, 1, 0]], np.float32), [2], ctype="linear")
    np.testing.assert_array_equal(read_usd(path, default_radius=0.003).radii, np.float32(0.003))


def test_14_a_billion_declared_points_are_refused_before_allocating(tmp_path):
    """curveVertexCounts declaring 10^9 vertices over 4 points: the memory
    check on the declared counts fires before the points are fetched."""
    path = make_curves(tmp_path / "big.usda", np.zeros((4, 3), np.float32), [10**9], [0.01] * 4)
    with pytest.raises((MemoryError, GroomError), match="big.usda: /g/c"):
        read_usd(path)


def test_15_files_that_are_not_grooms(tmp_path):
    with pytest.raises(GroomError, match="no such file"):
        read_usd(tmp_path / "missing.usda")
    (tmp_path / "junk.usda").write_text("#usda 1.0\nthis is not usd {")
    with pytest.raises(GroomError, match="cannot open as USD"):
        read_usd(tmp_path / "junk.usda")
    stage = Usd.Stage.CreateNew(str(tmp_path / "empty.usda"))
    UsdGeom.NurbsCurves.Define(stage, "/n")
    stage.GetRootLayer().Save()
    with pytest.raises(GroomError, match="no BasisCurves prim .it has NurbsCurves"):
        read_usd(tmp_path / "empty.usda")
    with pytest.raises(ValueError, match="curves: expected"):
        read_usd(tmp_path / "empty.usda", curves="bspline")
    with pytest.raises(ValueError, match="tolerance: expected"):
        read_usd(tmp_path / "empty.usda", tolerance=0)


def test_16_a_scene_names_the_bad_usd_file(tmp_path):
    make_curves(tmp_path / "g.usda", np.array([[0, 0, 0], [0, 1, 0]], np.float32), [2], ctype="linear")
    spec = {"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},
            "hair": {"file": "g.usda"}}
    with pytest.raises(hs.SceneError, match="hair.file: .*g.usda: /g/c: no widths"):
        hs.Scene.from_dict(spec, base_dir=str(tmp_path))


def test_17_alembic_through_blender():
    """Blender's Alembic export of the same groom, read through bpy: the
    control points within 3 float32 ulps of the extent (Alembic stores
    Y-up: Blender converts on the way out and back; measured 2.1 ulps),
    radii within one ulp, and evaluated like the USD file's curves."""
    pytest.importorskip("bpy", reason="Alembic grooms are read through Blender (pip install 'hairshade[blender]')")
    from hairshade.blender import read_alembic

    z = blender_groom()
    g = read_alembic(BLENDER / "groom.abc", curves="control_points")
    assert np.array_equal(np.diff(g.offsets), z["counts"])
    assert np.abs(g.points - z["points"]).max() <= 3 * float32_ulp_of_extent(z["points"])
    np.testing.assert_allclose(g.radii, z["radii"], rtol=2 ** -22)
    ev = read_alembic(BLENDER / "groom.abc")
    usd = read_usd(BLENDER / "groom_catmull_rom.usda")
    assert np.array_equal(ev.offsets, usd.offsets)
    assert np.abs(ev.points - usd.points).max() <= 4 * float32_ulp_of_extent(z["points"])


def test_18_subdivision_cap_warns(tmp_path):
    """A Bezier span with handles far out cannot be followed in
    MAX_SUBDIVISIONS steps to a tiny tolerance: a warning says how far the
    polyline stays from the curve."""
    P = np.array([[0, 0, 0], [50, 40, 0], [-50, 40, 0], [0, 1, 0]], np.float32)
    path = make_curves(tmp_path / "wild.usda", P, [4], [1e-4] * 4, basis="bezier")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        g = read_usd(path, tolerance=0.001)
    assert g.deviation > 0.0015 and any("fiber radii from the curve" in str(x.message) for x in w)
    assert os.path.exists(path)


def test_19_bad_alembic_files(tmp_path):
    """Through Blender: a file that is not Alembic, and a missing one, get
    a GroomError naming the file."""
    pytest.importorskip("bpy", reason="Alembic grooms are read through Blender (pip install 'hairshade[blender]')")
    from hairshade.blender import read_alembic

    junk = tmp_path / "junk.abc"
    junk.write_bytes(b"not an alembic archive" * 10)
    with pytest.raises(GroomError, match="junk.abc: (Blender cannot import it|no hair curves)"):
        read_alembic(junk)
    with pytest.raises(GroomError, match="no such file"):
        read_alembic(tmp_path / "missing.abc")
