"""Render settings (hairshade/options.py): one definition; a setting that
does not apply is an error at load naming it; keywords of hs.render equal
the scene file; old flat keys translate; the presets resolve per model."""

from __future__ import annotations

import copy
import re
import warnings
from typing import Any, get_args, get_type_hints

import numpy as np
import pytest

import hairshade as hs
from hairshade import _native, options
from hairshade.bench_render import render_switched


def _scene_dict(model: str = "chiang", environment: bool = False, **render: Any) -> dict[str, Any]:
    mat = {"karis": {"model": "karis"}, "chiang": {"model": "chiang"}, "deon": {"model": "deon", "h_samples": 4}}
    lights: list[dict[str, Any]] = [{"type": "directional", "direction": [0.3, 1, 1], "intensity": [2, 2, 2],
                                     "shadows": True}]
    if environment:
        lights.append({"type": "environment", "radiance": [0.2, 0.2, 0.2]})
    return {"hairshade_scene": 1,
            "camera": {"position": [0, 0.5, 1.6], "target": [0, 0.5, 0], "fov": 40, "resolution": [32, 24]},
            "lights": lights,
            "hair": {"generate": {"kind": "bundle", "strands": 40, "segments": 4, "seed": 3}, "material": mat[model]},
            "render": render}


def _value(f: options.Field) -> Any:
    """A valid value of an option's type (in the renderer's range)."""
    ranges = _native.render_option_ranges()
    t = f.type
    if t is bool:
        return True
    if t is int:
        return int(ranges[f.native][0])
    if t is float:
        return 0.5 if ranges[f.native][1] >= 1 else ranges[f.native][1]
    choices = [a for a in get_args(t) if isinstance(a, str)]
    if choices:
        return choices[0] if f.native != "lod" else 0.5
    return [0.1, 0.1, 0.1]  # background


GROUPED = [f for f in options.fields() if f.path.count(".") == 2]


# 01: every option of a method, written under each method it does not belong to, is refused at load, by name
@pytest.mark.parametrize("f", GROUPED, ids=lambda f: f.path)
def test_01_an_option_under_another_method_is_refused_at_load(f):
    group, method, key = f.path.split(".")
    others = [m for m, td in options.GROUPS[group][1].items() if key not in get_type_hints(td)]
    assert others or group == "shadows" and key != "density", f.path  # map options apply to every shadow model
    for m in others:
        model = "karis" if (group, m) == ("multiple_scattering", "karis") else "chiang"
        d = _scene_dict(model, **{group: {m: {key: _value(f)}}})
        with pytest.raises(hs.SceneError, match=rf"render\.{group}\.{m}\.{key}: does not apply to {group} '{m}'"):
            hs.Scene.from_dict(d)
    # and under its own method it loads
    hs.Scene.from_dict(_scene_dict("chiang", **{group: {method: {key: _value(f)}}}))


# 02: options whose condition is the model or the scene, refused where it does not hold
@pytest.mark.parametrize("model, environment, render, path", [
    ("karis", False, {"transparency": {"coverage": {"near_field": True}}}, "transparency.coverage.near_field"),
    ("chiang", False, {"multiple_scattering": "karis"}, "multiple_scattering"),
    ("deon", False, {"multiple_scattering": "dual"}, "multiple_scattering"),
    ("chiang", False, {"multiple_scattering": "none", "shadows": "opacity", "density_resolution": 64},
     "density_resolution"),
    ("chiang", False, {"environment_directions": 64}, "environment_directions"),
    ("karis", True, {"quality": "fast", "environment_directions": 64}, "environment_directions"),
    ("chiang", False, {"light_cull_threshold": 1e-3}, "light_cull_threshold"),
    ("karis", False, {"multiple_scattering": "dual", "light_cull_threshold": 1e-3}, "light_cull_threshold"),
])
def test_02_model_and_scene_conditions_are_checked_at_load(model, environment, render, path):
    with pytest.raises(hs.SceneError, match=rf"render\.{path}: "):
        hs.Scene.from_dict(_scene_dict(model, environment, **render))
    # where the condition holds, the same setting loads
    ok = {"transparency.coverage.near_field": ("chiang", False), "multiple_scattering": None,
          "density_resolution": ("chiang", False, {"multiple_scattering": "dual"}),
          "environment_directions": ("chiang", True), "light_cull_threshold": ("karis", False)}[path]
    if ok is not None:
        m, env, *extra = ok
        r = {**render, **(extra[0] if extra else {})}
        if path == "light_cull_threshold":
            r = {"quality": "fast", path: 1e-3}
        hs.Scene.from_dict(_scene_dict(m, env, **r))


# 03: unknown keys and methods, and out-of-range values, name the setting
@pytest.mark.parametrize("render, words", [
    ({"qualty": "fast"}, "render.qualty: unknown render setting"),
    ({"quality": "best"}, "render.quality: expected 'fast', 'balanced' or 'accurate'"),
    ({"transparency": "opaque"}, "render.transparency: expected 'mlab', 'sorted' or 'coverage', got 'opaque'"),
    ({"transparency": {"coverage": {"sample": 4}}}, "render.transparency.coverage.sample: unknown option"),
    ({"transparency": {"mlab": {}, "sorted": {}}}, "render.transparency: expected one method"),
    ({"shadows": "deep"}, "render.shadows: expected"),
    ({"transparency": {"coverage": {"samples": 257}}}, r"render.transparency.coverage.samples: must be in \[1, 256\]"),
    ({"multiple_scattering": {"dual": {"forward_density": 2}}},
     r"render.multiple_scattering.dual.forward_density: must be in \[0, 1\]"),
    ({"frustum_culling": False}, "render.frustum_culling: is an exact speed-up"),
])
def test_03_unknown_and_out_of_range_settings_name_the_key(render, words):
    with pytest.raises(hs.SceneError, match=words):
        hs.Scene.from_dict(_scene_dict(**render))


SETTINGS = [
    {"quality": "fast"},
    {"quality": "accurate", "transparency": {"coverage": {"samples": 4}}},
    {"transparency": {"mlab": {"layers": 2, "cull_transmittance": 0.01}}, "shadows": {"opacity": {"map_size": 256}}},
    {"shadows": {"exponential": {"density": 30, "pcf_radius": 0}}, "multiple_scattering": "none", "shading": "vertex"},
    {"multiple_scattering": {"dual": {"backscatter": "two_stream", "forward_density": 1.0}}, "shadows": "density",
     "density_resolution": 32, "lod": 0.5},
    {"quality": "balanced", "background": [0.1, 0.2, 0.3]},
]


# 04: a keyword of hs.render is the same setting written in the scene file: images bit-identical
@pytest.mark.parametrize("settings", SETTINGS, ids=lambda s: ",".join(s))
def test_04_keywords_equal_the_scene_file(settings):
    base = hs.Scene.from_dict(_scene_dict(transparency={"mlab": {"layers": 4}}))
    by_keyword = hs.render(base, progress=False, **settings)
    d = _scene_dict(transparency={"mlab": {"layers": 4}})
    d["render"].update(copy.deepcopy(settings))
    in_file = hs.render(hs.Scene.from_dict(d), progress=False)
    np.testing.assert_array_equal(by_keyword, in_file)
    assert by_keyword.max() > 0


# 05: a preset fills what the scene leaves out; a group the scene sets keeps the preset's options
# only for the same method
def test_05_presets_resolve_per_model_and_merge_by_method():
    chiang = hs.Scene.from_dict(_scene_dict("chiang"))
    karis = hs.Scene.from_dict(_scene_dict("karis"))
    deon = hs.Scene.from_dict(_scene_dict("deon"))
    assert chiang.options()["multiple_scattering"] == "volume"  # balanced, the default
    assert karis.options()["multiple_scattering"] == "dual"
    assert chiang.options(quality="fast")["multiple_scattering"] == "dual"
    assert karis.options(quality="fast")["multiple_scattering"] == "karis"
    assert deon.options(quality="accurate")["multiple_scattering"] == "none"
    acc = chiang.options(quality="accurate")
    assert (acc["transparency"], acc["samples"], acc["shadow_model"]) == ("coverage", 128, "traced")
    assert karis.options(quality="accurate")["samples"] == 64
    # same method: the preset's samples stay unless given; another method: its own defaults
    assert chiang.options(quality="accurate", transparency="coverage")["samples"] == 128
    assert chiang.options(quality="accurate", transparency={"coverage": {"samples": 8}})["samples"] == 8
    assert chiang.options(quality="accurate", transparency="mlab")["transparency"] == "mlab"
    for q in options.QUALITIES:
        for s in (chiang, karis, deon):
            s.options(quality=q)  # every preset loads for every model


# 06: old flat keys are translated, with a warning naming the new spelling, to the same image
def test_06_old_flat_keys_translate_with_a_warning():
    old = _scene_dict(transparency="coverage", samples=4, shadow_model="opacity", shadow_map_size=256,
                      multiple_scattering="dual", dual_backscatter="two_stream")
    with pytest.warns(DeprecationWarning, match=r"render.samples is deprecated: write render.transparency.coverage"
                                                r".samples"):
        a = hs.Scene.from_dict(old)
    # a section in the old spelling renders as it did: quality 'fast' for what it leaves out, shaded per pixel,
    # every strand drawn
    new = _scene_dict(quality="fast", transparency={"coverage": {"samples": 4}},
                      shadows={"opacity": {"map_size": 256}},
                      multiple_scattering={"dual": {"backscatter": "two_stream"}}, shading="pixel", lod=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        b = hs.Scene.from_dict(new)
    assert a.render == b.render
    np.testing.assert_array_equal(hs.render(a, progress=False), hs.render(b, progress=False))
    # what an old section leaves out keeps the old defaults (MLAB, exponential shadows, the model's own
    # multiple scattering), so it renders bit-identically to them
    with pytest.warns(DeprecationWarning, match="read as it rendered before"):
        c = hs.Scene.from_dict(_scene_dict("karis", layers=4))
    assert c.render == {"quality": "fast", "transparency": {"mlab": {"layers": 4}}, "shadows": "exponential",
                        "shading": "pixel", "lod": 1.0}
    assert c.options()["multiple_scattering"] == "karis" and c.options()["shadow_model"] == "exponential"
    assert c.options()["shading"] == "pixel"
    # ChiangHair: no multiple scattering, and under an environment its 32 directions (fast now sets dual
    # scattering and 8); the same image as those settings written out
    for environment in (False, True):
        with pytest.warns(DeprecationWarning, match="read as it rendered before"):
            ch = hs.Scene.from_dict(_scene_dict("chiang", environment, layers=4))
        o = ch.options()
        assert o["multiple_scattering"] == "none"
        assert ("environment_directions" in ch.render) == environment
        if environment:
            assert o["environment_directions"] == 32
        spelt = hs.Scene.from_dict(_scene_dict("chiang", environment, quality="fast", transparency={"mlab": {"layers": 4}},
                                               shadows="exponential", shading="pixel", multiple_scattering="none", lod=1.0,
                                               **({"environment_directions": 32} if environment else {})))
        np.testing.assert_array_equal(hs.render(ch, progress=False), hs.render(spelt, progress=False))
    # KarisHair under an environment with the volume: the environment is shaded as lights, at 32 directions
    with pytest.warns(DeprecationWarning, match="read as it rendered before"):
        kv = hs.Scene.from_dict(_scene_dict("karis", True, layers=4, multiple_scattering="volume"))
    assert kv.options()["environment_directions"] == 32
    # the old 'auto' keyword: the preset decides, with a warning
    with pytest.warns(DeprecationWarning, match="multiple_scattering 'auto' is deprecated"):
        assert b.options(multiple_scattering="auto") == b.options()
    # inapplicable old keys are no longer ignored
    with pytest.raises(hs.SceneError, match="render.transparency.mlab.samples: does not apply"):
        with pytest.warns(DeprecationWarning):
            hs.Scene.from_dict(_scene_dict(transparency="mlab", samples=4))
    with pytest.raises(hs.SceneError, match="render.transparency.coverage.layers: does not apply"):
        with pytest.warns(DeprecationWarning):
            hs.Scene.from_dict(_scene_dict(transparency="coverage", layers=4))


# 07: the definition and the renderer agree: every option's renderer name exists and every
# renderer option but the speed-ups is reachable from the definition
def test_07_the_definition_covers_the_renderers_options():
    native = set(_native.render_options({}))
    defined = {f.native for f in options.fields()} | {g for g, _ in options.GROUPS.values()}
    assert defined <= native, defined - native
    assert native - defined == set(options.SPEEDUPS), native - defined
    ranges = _native.render_option_ranges()
    for f in options.fields():
        if f.type in (int, float):
            assert f.native in ranges, f.path
    md = options.markdown()
    for f in options.fields():
        assert f"`{f.path}`" in md


# 08: the speed-ups switched off change no pixel, and are refused by name where unknown
def test_08_speedups_are_benchmark_switches():
    s = hs.Scene.from_dict(_scene_dict("karis", quality="fast"))
    np.testing.assert_array_equal(hs.render(s, progress=False),
                                  render_switched(s, off=options.SPEEDUPS))
    with pytest.raises(ValueError, match="off: expected names among"):
        render_switched(s, off=("culling",))
    with pytest.raises(hs.SceneError, match="render.frustum_culling: is an exact speed-up"):
        hs.render(s, frustum_culling=False)


# 09: the command line sets the same settings (--quality, a method, --set PATH=VALUE)
def test_09_cli_settings(tmp_path):
    import json
    import subprocess
    import sys

    path = tmp_path / "s.json"
    path.write_text(json.dumps(_scene_dict(transparency={"mlab": {"layers": 4}})))
    out = tmp_path / "a.exr"
    r = subprocess.run([sys.executable, "-m", "hairshade", "render", str(path), "-o", str(out), "--quality",
                        "accurate", "--transparency", "coverage", "--set", "transparency.coverage.samples=4",
                        "--set", "multiple_scattering.dual.backscatter=two_stream"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    want = hs.render(hs.Scene.load(path), quality="accurate", transparency={"coverage": {"samples": 4}},
                     multiple_scattering={"dual": {"backscatter": "two_stream"}}, progress=False)
    np.testing.assert_array_equal(hs.read_exr(out), want)
    r = subprocess.run([sys.executable, "-m", "hairshade", "render", str(path), "-o", str(tmp_path / "b.exr"),
                        "--set", "transparency.mlab.samples=4"], capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and "render.transparency.mlab.samples: does not apply" in r.stderr, r.stderr


def test_10_an_unknown_hair_model_is_refused_naming_every_model():
    """A scene file's unknown model, and a loaded scene's material changed to one, are refused with
    the same list of models, spelt from `options.MODELS` (so a new model is listed where it is defined)."""
    d = _scene_dict()
    d["hair"]["material"] = {"model": "marschner"}
    listed = " or ".join([", ".join(repr(m) for m in options.MODELS[:-1]), repr(options.MODELS[-1])])
    with pytest.raises(hs.SceneError, match=f"hair.material.model: expected {listed}, got 'marschner'"):
        hs.Scene.from_dict(d)
    sc = hs.Scene.from_dict(_scene_dict())
    sc.material = {"model": "marschner"}
    with pytest.raises(hs.SceneError, match=f"hair.material.model: expected {listed}, got 'marschner'"):
        sc.check()


def test_11_allowed_values_are_listed_one_way():
    """Error messages and the settings reference list allowed values alike: two joined by "or",
    three or more by commas and a final "or"."""
    assert options.choices_text(["pixel"]) == "'pixel'"
    assert options.choices_text(["medium", "strands"]) == "'medium' or 'strands'"
    assert options.choices_text(["pixel", "split", "vertex"]) == "'pixel', 'split' or 'vertex'"
    assert options.choices_text([]) == ""
    reference = options.markdown()
    assert "| `shading` | 'pixel', 'split' or 'vertex' |" in reference
    assert not re.search(r"'[\w.]+' or '[\w.]+' or '", reference)
