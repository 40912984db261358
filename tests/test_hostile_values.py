"""Wrong values, wrong types and command-line misuse: each is refused
with an error that names the field, the parameter or the file and the
allowed range, or renders correctly (a near plane, a stray strand, a
strand longer than the view, pixels that overflow); the command line
refuses before it writes. Hostile files, huge inputs and slow work, run
under a memory cap: test_hostile.py."""

from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hairshade as hs
from helpers import PYTHON_DIR
from helpers import write_scene as scene


CAMERA = {"position": [0, 0, 3], "target": [0, 0, 0], "resolution": [32, 18]}
LIGHT = {"type": "directional", "direction": [1, 1, 1], "intensity": [3, 3, 3], "shadows": True}


# -- wrong results ------------------------------------------------------------


def _base(**extra) -> dict:
    return {"hairshade_scene": 1,
            "camera": {"position": [0, 0, 1], "target": [0, 0, 0], "fov": 40, "resolution": [48, 32]},
            "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [2, 2, 2], "shadows": False}],
            **extra}


def test_07_near_plane_follows_the_hair_not_the_ground():
    """A strand 1 from the camera with and without a ground sphere of
    radius 1e4 (which used to put the near plane at 2, past the strand):
    the same segments reach the image and the hair pixels are equal."""
    hair = {"strands": [{"points": [[-0.2, 0, 0], [0.2, 0, 0]], "radius": 0.01}]}
    alone = hs.render(hs.Scene.from_dict(_base(hair=hair)), quality="fast", return_stats=True, progress=False)
    ground = _base(hair=hair, meshes=[{"type": "sphere", "center": [0, -1.0e4 - 1, 0], "radius": 1.0e4}])
    with_ground = hs.render(hs.Scene.from_dict(ground), quality="fast", return_stats=True, progress=False)
    assert alone[1]["segments_visible"] == with_ground[1]["segments_visible"] == 1
    hair_px = alone[0].sum(axis=2) > 0
    assert hair_px.sum() > 10
    np.testing.assert_array_equal(with_ground[0][hair_px], alone[0][hair_px])


def test_08_triangles_crossing_the_near_plane_are_clipped():
    """A floor of half-size 2e4 reaching under the camera (height 1,
    looking along -z): its triangles cross the near plane. Clipped, the
    floor fills the lower half of the image with the Lambertian radiance
    albedo/pi * E * cos(theta) (the same at every point of a flat floor
    under a directional light; 1e-4 relative: float32 shading), and the
    upper half stays background."""
    s = 2.0e4
    floor = [[-s, -1, -s], [s, -1, -s], [s, -1, s], [-s, -1, s]]
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        Path(d, "floor.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in floor) + "f 1 4 3 2\n")
        sc = _base(meshes=[{"type": "obj", "file": "floor.obj", "albedo": [0.5, 0.5, 0.5]}])
        sc["camera"] = {"position": [0, 0, 0], "target": [0, 0, -1], "fov": 60, "resolution": [48, 32]}
        img = hs.render(hs.Scene.from_dict(sc, base_dir=d), progress=False)
    expected = 0.5 / np.pi * 2.0 * (1 / np.sqrt(2))  # direction (0, 1, 1): cos theta = 1/sqrt(2)
    np.testing.assert_allclose(img[-8:], expected, rtol=1e-4)
    assert np.all(img[:8] == 0)


def test_08b_vertex_shading_of_a_strand_clipped_at_the_near_plane():
    """One segment from behind the camera to 1.5 in front, shaded per
    vertex: the clipped end is shaded where it lies (not interpolated from
    the vertex behind the camera, seen from the wrong side), and where the
    segment leaves a guard band twice the view (the near-plane end lay 1.6e6
    pixels off, where float32 projection had lost 0.9 % of the strand's
    pixels' radiance). So the single segment renders as the same strand
    split in two at its midpoint (whose vertices all lie in front):
    per-pixel totals equal to float32 rounding, per-vertex within 1 %
    (measured: 0.27 %; before, 1.40 against 0.32)."""
    a, b = np.array([-1.5, -0.3, 0.5]), np.array([0.3, -0.3, -1.5])
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 0], "target": [0, 0, -1], "fov": 60, "resolution": [64, 48]},
         "lights": [{"type": "directional", "direction": [0, 1, 0.3], "intensity": [3, 3, 3], "shadows": False}]}
    total = {}
    for n in (1, 2):
        d["hair"] = {"strands": [{"points": [(a + (b - a) * k / n).tolist() for k in range(n + 1)],
                                  "radius": 0.004}]}
        for shading in ("pixel", "vertex"):
            d["render"] = {"shading": shading}
            total[shading, n] = float(hs.render(hs.Scene.from_dict(d), progress=False).sum())
    assert total["pixel", 1] > 0.1
    assert total["pixel", 1] == pytest.approx(total["pixel", 2], rel=1e-5), total
    assert total["vertex", 1] == pytest.approx(total["vertex", 2], rel=1e-2), total


def test_09_karis_shadow_range_and_to_chiang_eta():
    """KarisHair's `shadow` outside [0, 1] (200 made a channel 0 and MS
    NaN) is refused; `mapping.to_chiang` keeps DEonHair's eta."""
    from hairshade import mapping

    k = hs.KarisHair()
    with pytest.raises(ValueError, match=r"shadow: must be in \[0.0, 1.0\], got 200"):
        k.eval_lobes([0, 0.2, 1.0], [0.3, -0.2, 0.9], [0, 1, 0], shadow=200)
    ms = k.eval_lobes([0, 0.2, 1.0], [0.3, -0.2, 0.9], [0, 1, 0], shadow=1.0)["MS"]
    assert np.all(np.isfinite(ms))
    assert mapping.chiang_params(hs.DEonHair(eta=3.0), fit=False)["eta"] == 3.0
    assert mapping.chiang_params(hs.KarisHair(), fit=False)["eta"] == 1.55


def test_21_a_stray_strand_far_away_leaves_the_hair_in_view():
    """One strand 1e5 away behind the hair (z = -1e5) took the near plane
    (1e-4 of the hair's far side) past the rest of the hair: 1736
    fragments fell to 0 and the image went black. The far side is the
    hair's 99th percentile distance: every fragment of the head stays."""
    from hairshade.generate import generate

    pts, _ = generate({"kind": "head", "strands": 200, "segments": 8, "seed": 1})
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 2.3], "target": [0, 0, 0], "fov": 40, "resolution": [64, 36]},
         "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [1, 1, 1]}],
         "hair": {"strands": [{"points": np.asarray(p).tolist(), "radius": 0.002} for p in pts]}, "render": {}}
    _, alone = hs.render(hs.Scene.from_dict(d), return_stats=True)
    d["hair"]["strands"].append({"points": [[0, 0, -1e5], [0, 0.1, -1e5]], "radius": 0.002})
    _, stray = hs.render(hs.Scene.from_dict(d), return_stats=True)
    assert alone["fragments"] > 1000
    assert stray["fragments"] >= alone["fragments"]


def test_22_overflowing_pixels_are_reported():
    """A background of 3e38 under coverage transparency overflows float32
    in 2303 of 2304 pixels; they become 0, are counted in the stats, and a
    RuntimeWarning says so (before, only the stats did, and the command
    line said nothing)."""
    from hairshade.generate import generate

    pts, _ = generate({"kind": "head", "strands": 100, "segments": 6, "seed": 1})
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 2.3], "target": [0, 0, 0], "fov": 40, "resolution": [48, 48]},
         "lights": [{"type": "directional", "direction": [0, 1, 1], "intensity": [1, 1, 1]}],
         "hair": {"strands": [{"points": np.asarray(p).tolist(), "radius": 0.002} for p in pts]},
         "render": {"background": [3e38] * 3, "transparency": "coverage"}}
    with pytest.warns(RuntimeWarning, match=r"2303 of 2304 pixels overflowed"):
        img, st = hs.render(hs.Scene.from_dict(d), return_stats=True)
    assert st["non_finite_pixels"] == 2303 and np.all(np.isfinite(img))


@pytest.mark.parametrize("half_length", [1e6, 1e18])
def test_27_a_strand_far_longer_than_the_view_draws_its_visible_part(half_length):
    """A strand from x = -L to L behind the hair: at L = 1e18 it took the
    near plane (a percentile of vertex distances) and every other strand
    vanished; from L = 1e6 its pixel coordinates lost the line in float32
    and it drew nothing. The near plane now comes from the segments'
    nearest points, segments are clipped in float64 to a guard band twice
    the view, and shadow maps, density grids and the traced grid leave
    vertices beyond 16 times the 90th-percentile distance out of their box.
    The long strand draws the same pixels as one 200 units long; beside a
    head of 200 strands, the head's pixels it does not cross are those of
    the head alone (to float32 rounding)."""
    from hairshade.generate import generate

    cam = {"position": [0, 0.5, 2.5], "target": [0, 0.5, 0]}
    line = lambda x: np.array([[-x, 0.5, -0.5], [x, 0.5, -0.5]])  # noqa: E731
    shown = lambda img: img.sum(-1) > 0  # noqa: E731
    short = hs.render(hs.Scene.from_arrays(line(100.0), 0.01, [0, 2], camera=cam), 64, 36)
    long = hs.render(hs.Scene.from_arrays(line(half_length), 0.01, [0, 2], camera=cam), 64, 36)
    assert shown(short).sum() > 60 and np.array_equal(shown(long), shown(short))
    pts, _ = generate({"kind": "head", "strands": 200, "segments": 8, "seed": 1})
    head = np.vstack(pts) + [0, 0.5, 0]
    offsets = np.arange(0, len(head) + 1, 9)
    alone = hs.render(hs.Scene.from_arrays(head, 0.002, offsets, camera=cam), 64, 36)
    both = hs.render(hs.Scene.from_arrays(np.vstack([head, line(half_length)]), 0.002,
                                          np.append(offsets, len(head) + 2), camera=cam), 64, 36)
    mask = shown(alone) & ~shown(long)
    assert mask.sum() > 200 and np.allclose(both[mask], alone[mask], rtol=1e-5, atol=0)


# -- validation ---------------------------------------------------------------


@pytest.mark.parametrize("change, field, words", [
    (lambda d: d.update(hairshade_scene=True), "hairshade_scene", "expected version 1"),
    (lambda d: d["camera"].update(resolution=[48.5, 32]), "camera.resolution[0]", "expected an integer"),
    (lambda d: d.update(render={"transparency": {"mlab": {"layers": 4.5}}}), "render.transparency.mlab.layers",
     "integer"),
    (lambda d: d.update(hair={"material": {"model": "karis", "roughness": "0.5"}}), "hair.material", "roughness"),
    (lambda d: d.update(hair={"material": {"model": "deon", "h_samples": 2.5}}), "hair.material", "h_samples"),
    (lambda d: d.update(hair={"cards": [{"points": [[0, 0, 0], [0, 1, 0]], "width": 0.1,
                                         "alpha": {"bake": {}, "color": 1}}]}), "hair.cards[0].alpha", "color"),
    (lambda d: d.update(hair={"cards": [{"points": [[0, 0, 0], [0, 1, 0]], "width": 0.1,
                                         "alpha": {"bake": {}, "image": "a.png"}}]}), "hair.cards[0].alpha",
     "not both"),
    (lambda d: d.update(hair={"strands": [{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.01, "radii": [0, 0]}]}),
     "hair.strands[0]", "not both"),
    (lambda d: d.update(hair={"generate": {"kind": "head", "strands": 10.5}}), "hair.generate", "strands"),
    (lambda d: d.update(hair={"strands": [{"points": [[0, 0, 0], [0, "1", 0]]}]}), "hair.strands[0].points[1][1]",
     "expected a number"),
])
def test_10_strict_scene_validation(change, field, words):
    """Booleans, strings and fractions where numbers or integers belong,
    unknown keys and mutually exclusive keys: a SceneError naming the field."""
    d = _base()
    change(d)
    with pytest.raises(hs.SceneError) as e:
        hs.Scene.from_dict(d, source="t.json")
    msg = str(e.value)
    assert msg.startswith(f"t.json: {field}") and words in msg, msg
    assert msg.count("hair.generate") <= 1, msg


def test_11_api_type_errors_name_the_parameter():
    """Strings where numbers belong name the parameter (not Python's bare
    "could not convert string to float"); boolean arrays are not directions;
    HAIRSHADE_SIMD=bogus is refused at import with the allowed values."""
    with pytest.raises(TypeError, match="roughness: expected a number, got 'abc'"):
        hs.KarisHair(roughness="abc")
    with pytest.raises(TypeError, match="eta: expected a number"):
        hs.DEonHair(eta="1.5")
    with pytest.raises(TypeError, match="sigma_a: expected a number or 3 numbers"):
        hs.ChiangHair(sigma_a="0.5")
    with pytest.raises(TypeError, match="separable_r: expected True or False"):
        hs.KarisHair(separable_r=1)
    with pytest.raises(ValueError, match="wi: expected real numbers, got booleans"):
        hs.ChiangHair().eval(np.array([True, False, True]), [0, 0, 1.0])
    out = subprocess.run([sys.executable, "-c", "import hairshade"], capture_output=True, text=True, timeout=60,
                         env=dict(os.environ, PYTHONPATH=PYTHON_DIR, HAIRSHADE_SIMD="bogus"))
    assert out.returncode != 0 and "HAIRSHADE_SIMD" in out.stderr and "'avx2'" in out.stderr, out.stderr


@pytest.mark.parametrize("value", ["0", "-1", "abc", "100000", "2.5", ""])
def test_11b_thread_count_out_of_range_is_refused_at_import(value):
    """RAYON_NUM_THREADS was ignored when 0, negative or not a number, and
    100000 panicked when the pool started: each is refused at import with
    the range."""
    out = subprocess.run([sys.executable, "-c", "import hairshade"], capture_output=True, text=True, timeout=60,
                         env=dict(os.environ, PYTHONPATH=PYTHON_DIR, RAYON_NUM_THREADS=value))
    assert out.returncode != 0 and "RAYON_NUM_THREADS" in out.stderr and "[1, 1024]" in out.stderr, out.stderr
    assert "PanicException" not in out.stderr


def test_14b_numpy_numbers_and_exact_bounds_in_messages(tmp_path):
    """numpy's scalars are numbers (`layers=np.int64(8)` was refused as
    "expected a number"; np.bool_ still is), a value past the 1e18 bound is
    printed as it was given (1.0000001e18 read "got 1e+18"), and
    read_exr's max_pixels below 1 is refused by name (-1 raised a bare
    OverflowError)."""
    d = json.loads((Path(hs.__file__).parent / "examples" / "single_strand.json").read_text())
    s = hs.Scene.from_dict(d)
    want = hs.render(s, width=32, height=18, transparency={"mlab": {"layers": 8}}, progress=False)
    got = hs.render(s, width=32, height=18, transparency={"mlab": {"layers": np.int64(8)}}, progress=False)
    np.testing.assert_array_equal(got, want)
    # the value as numpy prints it: np.True_ (numpy 2), True (numpy 1.x)
    with pytest.raises(hs.SceneError, match=f"layers: expected a number, got {re.escape(repr(np.bool_(True)))}$"):
        hs.render(s, width=32, height=18, transparency={"mlab": {"layers": np.bool_(True)}}, progress=False)
    e = json.loads(json.dumps(d))
    e["camera"]["fov"] = np.float32(40.0)
    assert hs.Scene.from_dict(e).camera["fov"] == 40.0
    e["camera"]["position"][0] = 1.0000001e18
    with pytest.raises(hs.SceneError, match=r"camera.position\[0\]: must be at most 1e\+18 .* got 1.0000001e\+18"):
        hs.Scene.from_dict(e)
    path = tmp_path / "one.exr"
    hs.write_exr(str(path), np.ones((2, 2, 3), np.float32))
    for bad in (-1, 0, 2.5, True):
        with pytest.raises(ValueError, match="max_pixels: expected a whole number >= 1 or None"):
            hs.read_exr(path, max_pixels=bad)
    assert hs.read_exr(path, max_pixels=np.int64(4)).shape == (2, 2, 3)


def test_16b_eval_env_refuses_coefficients_float32_cannot_carry():
    """KarisHair.eval_env in float32 with SH 3e38 returned inf (the
    coefficient, 3.5x the radiance, overflowed float32): refused naming
    `sh`; 1e30 and below stay finite, and float64 takes the same input."""
    k = hs.KarisHair()
    v, t = np.array([[0, 0, 1.0]], np.float32), np.array([[1, 0, 0.0]], np.float32)
    with pytest.raises(ValueError, match="sh: in float32 the coefficients must be at most 1e\\+30"):
        k.eval_env(v, t, [3e38] * 3)
    assert np.isfinite(k.eval_env(v, t, np.full((9, 3), 1e30))).all()
    assert np.isfinite(k.eval_env(v.astype(np.float64), t.astype(np.float64), [3e38] * 3)).all()


def test_17_messages_show_keys_and_names_as_visible_text(tmp_path):
    """A zero-width space, an ANSI escape or a right-to-left override in a
    key, and a newline in an output name, reach the terminal escaped
    (\\u200b, \\x1b, \\u202e, \\n): SceneError escapes its whole text, the
    CLI its file names. A NUL in a file name is refused by name; a key given
    twice in one JSON object is an error naming it (json kept the last)."""
    strand = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    for key, shown in (("qua\u200blity", "qua\\u200blity"), ("\x1b[31mred", "\\x1b[31mred"),
                       ("a\u202eb", "a\\u202eb")):
        with pytest.raises(hs.SceneError) as e:
            hs.Scene.from_dict({"hairshade_scene": 1, "camera": CAMERA, "hair": strand, "render": {key: 1}})
        assert shown in str(e.value) and str(e.value).isprintable(), str(e.value)
    with pytest.raises(hs.SceneError, match=r"s\\x00\.json: the file name contains a NUL character"):
        hs.Scene.load(str(tmp_path / "s\x00.json"))
    dup = tmp_path / "dup.json"
    dup.write_text('{"hairshade_scene": 1, "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40, '
                   '"fov": 50}, "hair": {}}')
    with pytest.raises(hs.SceneError, match="the key 'fov' appears twice"):
        hs.Scene.load(str(dup))
    p = scene(tmp_path, strand)
    out = subprocess.run([sys.executable, "-m", "hairshade", "render", str(p), "-o", str(tmp_path / "a\nfake: line.exr")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "a\\nfake: line.exr" in out.stdout and "\nfake" not in out.stdout, out.stdout


def test_19_numbers_in_messages_are_short_and_complex_points_refused():
    """A value far out of range is printed in exponent form (1e39 was
    printed with 40 digits, f64::MAX with 309); complex points are refused
    (they lost their imaginary part silently)."""
    strand = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    with pytest.raises(hs.SceneError, match=r"render\.shadows\.exponential\.density: must be finite \(as a float32\), "
                                            r"got 1e39$"):
        hs.Scene.from_dict({"hairshade_scene": 1, "camera": CAMERA, "hair": strand, "lights": [LIGHT],
                            "render": {"shadows": {"exponential": {"density": 1e39}}}})
    with pytest.raises(ValueError, match=r"roughness: must be in \[0, 1\], got 1\.7976931348623157e308"):
        hs.KarisHair(roughness=1.7976931348623157e308)
    with pytest.raises(hs.SceneError, match="points: expected real numbers, got complex ones"):
        hs.Scene.from_arrays(np.array([[0, 0, 0], [0, 1, 0]], complex), 0.01, [0, 2])


def _line_scene(**camera) -> dict:
    """One vertical strand seen from +z, as a scene dict."""
    cam = {"position": [0, 0.5, 2.5], "target": [0, 0.5, 0], "fov": 40, "resolution": [32, 18], **camera}
    return {"hairshade_scene": 1, "camera": cam,
            "lights": [{"type": "directional", "direction": [0.5, 0.7, 0.6], "intensity": [3, 3, 3]}],
            "hair": {"strands": [{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.01}]}}


@pytest.mark.parametrize("camera, field, words", [
    # float32 cannot tell a target 1e-12 away from the position (the image was black)
    (dict(target=[0, 0.5, 2.5 - 1e-12]), "camera.target", "at least 0.001 x 2.5"),
    # the projected strand widths overflowed float32 (black)
    (dict(fov=1e-30), "camera.fov", "[0.001, 179]"),
    # 1e-6 rad from the viewing direction: the roll was float32's rounding
    (dict(up=[0, 1e-6, -1]), "camera.up", "parallel to the viewing direction"),
])
def test_23_cameras_float32_cannot_carry_are_refused(camera, field, words):
    """Degenerate cameras are refused by name, from a file and from a
    Scene edited after loading alike; each worked case next to a refused
    one (the bounds' derivation: ``scene.MIN_VIEW_SEPARATION``)."""
    with pytest.raises(hs.SceneError, match=rf"{field}: .*{re.escape(words)}"):
        hs.Scene.from_dict(_line_scene(**camera))
    sc = hs.Scene.from_dict(_line_scene())
    key, value = next(iter(camera.items()))
    sc.camera[key] = value
    with pytest.raises(hs.SceneError, match=rf"\(as edited\): {field}: .*{re.escape(words)}"):
        hs.render(sc)
    # the narrowest allowed fov still sees the strand: it fills the image
    img = hs.render(hs.Scene.from_dict(_line_scene(fov=1e-3)))
    assert np.all(img.sum(-1) > 0)


def test_24_a_tiny_light_direction_is_a_direction():
    """[1e-40, 0, 0] rounded to zero in float32 and lit the hair from +z;
    it is normalized in float64 first: the same image as [1, 0, 0]."""
    d = _line_scene()
    d["lights"][0]["direction"] = [1e-40, 0, 0]
    tiny = hs.render(hs.Scene.from_dict(d))
    d["lights"][0]["direction"] = [1, 0, 0]
    unit = hs.render(hs.Scene.from_dict(d))
    d["lights"][0]["direction"] = [0, 0, 1]
    plus_z = hs.render(hs.Scene.from_dict(d))
    assert np.array_equal(tiny, unit)
    assert not np.allclose(unit, plus_z)


def test_25_a_scene_edited_after_loading_is_checked_again():
    """Scene fields changed after loading go through the scene file's
    checks before rendering (they reached the renderer unchecked: a zero
    light rendered, an unknown key was ignored); a changed material builds
    the hair model again."""
    cases = {
        "lights[0].vector: must not be zero": lambda s: s.lights[0].update(vector=[0, 0, 0]),
        "lights[0].directionx: unknown field": lambda s: s.lights[0].update(directionx=[0, 0, 1]),
        "camera.width: must be an integer in [1, 16384]": lambda s: s.camera.update(width=0),
        "spheres[0].radius: must be in (0": lambda s: s.spheres.append(dict(center=[0, 0, 0], radius=-1,
                                                                            albedo=[1, 1, 1])),
        "points[1]: must be finite": lambda s: setattr(s, "points", np.array([[0, 0, 0], [0, np.inf, 0]])),
        "hair.material: ": lambda s: s.material.update(roughness=7.0),
    }
    for words, edit in cases.items():
        sc = hs.Scene.from_dict(_line_scene())
        edit(sc)
        with pytest.raises(hs.SceneError, match=re.escape(words)):
            hs.render(sc)
    sc = hs.Scene.from_dict(_line_scene())
    karis = hs.render(sc)
    sc.material = {"model": "chiang", "eumelanin": 0.2}
    chiang = hs.render(sc)
    assert type(sc.hair).__name__ == "ChiangHair" and not np.allclose(karis, chiang)


# -- command line -------------------------------------------------------------


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hairshade", *args], capture_output=True, text=True, timeout=120,
                          cwd=cwd, env=dict(os.environ, PYTHONPATH=PYTHON_DIR))


def test_12_cli_outputs_and_compare_guards(tmp_path):
    """`render -o out.png --png` writes one PNG (not EXR bytes); an unknown
    extension and `--exposure nan` are refused; `compare` of NaN images
    exits non-zero naming the file; `compare` against a black reference
    reports FLIP as undefined instead of dying inside flip-evaluator."""
    scene(tmp_path, {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.05}]},
          lights=[{"type": "directional", "direction": [0, 0, 1], "intensity": [1, 1, 1]}])
    r = _cli("render", "s.json", "-o", "out.png", "--png", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "out.exr").exists() and r.stdout.count("out.png") == 1
    r = _cli("render", "s.json", "-o", "out.xyz", cwd=tmp_path)
    assert r.returncode == 2 and "out.xyz" in r.stderr and ".exr or .png" in r.stderr
    r = _cli("render", "s.json", "--exposure", "nan", cwd=tmp_path)
    assert r.returncode == 2 and "--exposure" in r.stderr
    nan = np.zeros((4, 4, 3), np.float32)
    nan[1, 1] = np.nan
    hs.write_exr(tmp_path / "nan.exr", nan)
    hs.write_exr(tmp_path / "black.exr", np.zeros((4, 4, 3), np.float32))
    hs.write_exr(tmp_path / "grey.exr", np.full((4, 4, 3), 0.5, np.float32))
    r = _cli("compare", "nan.exr", "nan.exr", cwd=tmp_path)
    assert r.returncode == 2 and "nan.exr: 1 pixel(s) not finite" in r.stderr
    r = _cli("compare", "grey.exr", "black.exr", cwd=tmp_path)
    assert r.returncode == 0 and "mean FLIP nan" in r.stdout and "black" in r.stderr, (r.stdout, r.stderr)
    # A uniform reference of 1e-10: FLIP's own exposure range comes out
    # reversed by rounding and it ends the process; contained in a child.
    hs.write_exr(tmp_path / "dim.exr", np.full((4, 4, 3), 1e-10, np.float32))
    r = _cli("compare", "grey.exr", "dim.exr", cwd=tmp_path)
    assert r.returncode == 0 and "FLIP failed" in r.stderr, (r.stdout, r.stderr)


def test_12b_nonsense_refused_before_work(tmp_path):
    """write_exr / write_png of an image without pixels wrote a file the
    readers refuse, and `bench --repeats 0` exited 0 with zeros: both are
    refused naming what is wrong."""
    for w in (hs.write_exr, hs.write_png):
        with pytest.raises(ValueError, match="image: expected at least one pixel, got 5x0"):
            w(str(tmp_path / "x.img"), np.zeros((5, 0, 3)))
    assert not (tmp_path / "x.img").exists()
    for arg in (["--repeats", "0"], ["--n", "-3"]):
        out = subprocess.run([sys.executable, "-m", "hairshade", "bench", *arg], capture_output=True, text=True,
                             timeout=60, env=dict(os.environ, PYTHONPATH=PYTHON_DIR))
        assert out.returncode == 2 and arg[0] in out.stderr and "expected a whole number >= 1" in out.stderr, out.stderr


def test_15b_demo_sizes_refused_by_name_and_every_option_documented():
    """`demo --width 3` failed with "got 0" (its warm-up renders at a
    quarter of the size, now at least 1 pixel); sizes and spp below 1 are
    refused naming the option, before any work, and every option of
    `demo` has help text."""
    env = dict(os.environ, PYTHONPATH=PYTHON_DIR)
    for arg in ("--width", "--height", "--spp"):
        out = subprocess.run([sys.executable, "-m", "hairshade", "demo", arg, "0"], capture_output=True, text=True,
                             timeout=60, env=env)
        assert out.returncode == 2 and f"argument {arg}: expected a whole number >= 1, got 0" in out.stderr, out.stderr
    out = subprocess.run([sys.executable, "-m", "hairshade", "demo", "--help"], capture_output=True, text=True,
                         timeout=60, env=env)
    options = [line.split()[0] for line in out.stdout.splitlines() if line.strip().startswith("--")]
    assert set(options) == {"--scene", "--out", "--width", "--height", "--spp", "--mitsuba-equal", "--exposure"}, options
    for line in out.stdout.splitlines():
        if line.strip().startswith("--"):
            assert len(line.split()) > 2, f"no help: {line}"


def test_18_command_line_refuses_before_writing(tmp_path):
    """`compare --png x.txt` is refused (it wrote a PNG named x.txt), and
    `--exposure 1000` before the EXR is written (it was refused after, or
    not at all with -o NAME.exr); an existing output is replaced with a
    note; a render that does not fit in memory is one line, no traceback."""
    strand = {"strands": [{"points": [[0, -0.5, 0], [0, 0.5, 0]], "radius": 0.01}]}
    p = scene(tmp_path, strand)
    run = lambda *a, **k: subprocess.run([sys.executable, "-m", "hairshade", *a], capture_output=True,  # noqa: E731
                                         text=True, timeout=120, cwd=tmp_path, **k)
    assert run("render", str(p), "-o", "a.exr").returncode == 0
    r = run("compare", "a.exr", "a.exr", "--no-flip", "--png", "x.txt")
    assert r.returncode == 2 and "--png: x.txt" in r.stderr and not (tmp_path / "x.txt").exists(), r.stderr
    r = run("render", str(p), "-o", "b.exr", "--exposure", "1000")
    assert r.returncode == 2 and "--exposure" in r.stderr and "[-100, 100]" in r.stderr
    assert not (tmp_path / "b.exr").exists()
    r = run("render", str(p), "-o", "a.exr")
    assert r.returncode == 0 and "note: replacing a.exr" in r.stderr
    cap = lambda: resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))  # noqa: E731
    r = run("render", str(p), "--width", "16384", "--height", "16384", "-o", "big.exr", preexec_fn=cap)
    assert r.returncode == 2 and r.stderr.startswith("error: out of memory: render: needs about"), r.stderr
    assert "Traceback" not in r.stderr
