"""Scene.save: a scene written and loaded back is the same scene, bit for
bit, and renders the same image."""

from __future__ import annotations

import json

import numpy as np
import pytest

import hairshade as hs


def rich_scene(tmp_path):
    """Strands from a generator and inline, an OBJ mesh, a sphere, cards
    with a baked and an image alpha, three kinds of light, render settings."""
    (tmp_path / "floor.obj").write_text("v -1 -0.6 -1\nv 1 -0.6 -1\nv 1 -0.6 1\nv -1 -0.6 1\nf 1 2 3 4\n")
    alpha = np.tile(np.linspace(0, 1, 8, dtype=np.float32)[None, :, None], (4, 1, 3))
    hs.write_exr(tmp_path / "alpha.exr", alpha)
    spec = {
        "hairshade_scene": 1,
        "camera": {"position": [0.3, 0.2, 3.1], "target": [0, 0.1, 0], "up": [0, 1, 0.1], "fov": 35.5,
                   "resolution": [48, 30]},
        "lights": [{"type": "directional", "direction": [0.3, 0.8, 0.5], "intensity": [2.5, 2.4, 2.2]},
                   {"type": "point", "position": [0.5, 1.5, 1.0], "intensity": [1.3, 1.2, 1.1], "shadows": True},
                   {"type": "environment", "radiance": [0.21, 0.2, 0.25]}],
        "hair": {"generate": {"kind": "head", "strands": 200, "segments": 8},
                 "strands": [{"points": [[0, 0.6, 0], [0.1, 0.9, 0.05], [0.15, 1.1, 0.1]], "radii": [0.01, 0.008, 0.004]}],
                 "cards": [{"points": [[-0.4, 0.5, 0.3], [-0.45, 0.1, 0.4]], "width": 0.1, "alpha": {"image": "alpha.exr"}},
                           {"points": [[0.4, 0.5, 0.3], [0.45, 0.1, 0.4]], "width": 0.1,
                            "alpha": {"bake": {"fibers": 6}}}],
                 "material": {"model": "chiang", "eumelanin": 0.7, "pheomelanin": 0.3, "longitudinal_roughness": 0.25}},
        "meshes": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.45, "albedo": [0.5, 0.4, 0.3]},
                   {"type": "obj", "file": "floor.obj", "albedo": [0.6, 0.6, 0.6]}],
        "render": {"quality": "fast", "background": [0.01, 0.02, 0.03]},
    }
    return hs.Scene.from_dict(spec, base_dir=str(tmp_path))


def test_01_json_round_trip_is_the_same_scene(tmp_path):
    sc = rich_scene(tmp_path)
    out = tmp_path / "saved"
    out.mkdir()
    sc.save(out / "head.json")
    assert sorted(p.name for p in out.iterdir()) == ["head.alpha0.exr", "head.hair", "head.json", "head.mesh0.obj"]
    back = hs.Scene.load(out / "head.json")
    for k in ("points", "radii", "offsets", "environment_sh"):
        assert np.array_equal(getattr(back, k), getattr(sc, k)), k
    assert (back.camera, back.lights, back.material, back.render, back.spheres) == \
           (sc.camera, sc.lights, sc.material, sc.render, sc.spheres)
    for k in ("corners", "uvs", "tangents", "texture"):
        assert np.array_equal(back.cards[k], sc.cards[k]), k
    assert all(np.array_equal(a, b) for a, b in zip(back.cards["textures"], sc.cards["textures"]))
    assert np.array_equal(back.obj_meshes[0]["triangles"], sc.obj_meshes[0]["triangles"])
    np.testing.assert_array_equal(hs.render(back), hs.render(sc))
    # and saving the loaded scene again writes the same file
    back.save(out / "again.json")
    again = json.loads((out / "again.json").read_text())
    first = json.loads((out / "head.json").read_text())
    assert again["hair"]["file"] == "again.hair" and first["hair"]["file"] == "head.hair"
    again["hair"]["file"] = first["hair"]["file"]
    again["hair"]["cards"][0]["alpha"] = first["hair"]["cards"][0]["alpha"]
    again["meshes"][1]["file"] = first["meshes"][1]["file"]
    assert again == first


def test_02_edited_scenes_are_checked_before_saving(tmp_path):
    sc = rich_scene(tmp_path)
    sc.camera["fov"] = 500
    with pytest.raises(hs.SceneError, match="camera.fov"):
        sc.save(tmp_path / "x.json")


def test_03_save_names_the_formats_it_writes(tmp_path):
    sc = rich_scene(tmp_path)
    with pytest.raises(ValueError, match=r"path: expected a .json, .usd, .usda or .usdc file name"):
        sc.save(tmp_path / "x.txt")
