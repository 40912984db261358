"""The scene variants that are compared against Mitsuba in the tests and
their cached references (`scripts/make_references.py` regenerates them).

Each example scene is rendered with the *same* BSDF on both sides: the hair
material is ChiangHair (the rasterizer shades with its far field, which is
what Mitsuba's near-field `hair` averages to across a sub-pixel fiber),
lights are the scene's directional and point lights with shadows, and
environment lights are dropped (direct lighting only). Resolution is
reduced to keep the references small."""

from __future__ import annotations

import copy
import json
import os
from typing import Any

from .scene import Scene

EXAMPLES = os.path.join(os.path.dirname(__file__), "examples")
# The cached Mitsuba references live in the source tree (tests/data), not in
# the installed package.
REFERENCES = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data")
CASES = {
    "single_strand": dict(width=320, height=180, spp=1024),
    "backlit_bundle": dict(width=320, height=180, spp=1024),
    "strand_head": dict(width=160, height=90, spp=256),
}
# The ChiangHair used where a scene's own material is KarisHair: what
# mapping.chiang_params fits for the head's material (base color
# (0.45, 0.25, 0.12), roughness 0.45), rounded to 3 digits, except the
# azimuthal roughness, raised from the fitted 0.1 to 0.3: the rasterizer
# evaluates the Chiang far field per fragment, and 0.3 needs a third of the
# quadrature nodes (a 3x faster test for the same comparison).
HEAD_CHIANG = dict(sigma_a=[0.161, 0.279, 0.426], longitudinal_roughness=0.211, azimuthal_roughness=0.3, scale_tilt=1.766)


def comparison_scene(name: str, examples_dir: str | None = None) -> Scene:
    path = os.path.join(examples_dir or EXAMPLES, f"{name}.json")
    with open(path) as f:
        d: dict[str, Any] = json.load(f)
    d = copy.deepcopy(d)
    mat = d["hair"].get("material", {})
    if mat.get("model", "karis") != "chiang":
        d["hair"]["material"] = {"model": "chiang", **HEAD_CHIANG}
    d["lights"] = [l for l in d["lights"] if l["type"] != "environment"]
    # the references are direct light only: no multiple scattering
    d.setdefault("render", {})["multiple_scattering"] = "none"
    return Scene.from_dict(d, base_dir=os.path.dirname(os.path.abspath(path)), source=path)


def reference_path(name: str, data_dir: str) -> str:
    return os.path.join(data_dir, f"{name}_mitsuba_direct.exr")


# Scenes compared with KarisHair on both sides (the rasterizer's shading and
# Mitsuba's `hairshade_karis` plugin), direct light with shadows. MS is off:
# its Kajiya-Kay tint reads the rasterizer's shadow-map value, which Mitsuba's
# BSDF has no access to.
KARIS_CASES = {
    "single_strand": dict(width=320, height=180, spp=1024),
    "backlit_bundle": dict(width=320, height=180, spp=1024),
    # Mitsuba renders the baked cards as the fibers they were baked from.
    "card_head": dict(width=160, height=90, spp=128),
}
KARIS_MATERIAL = {"model": "karis", "base_color": [0.55, 0.4, 0.25], "roughness": 0.4, "components": ["R", "TT", "TRT"]}


def karis_scene(name: str, examples_dir: str | None = None) -> Scene:
    path = os.path.join(examples_dir or EXAMPLES, f"{name}.json")
    with open(path) as f:
        d: dict[str, Any] = json.load(f)
    d["hair"]["material"] = dict(KARIS_MATERIAL)
    d["lights"] = [l for l in d["lights"] if l["type"] != "environment"]
    return Scene.from_dict(d, base_dir=os.path.dirname(os.path.abspath(path)), source=path)


def karis_reference_path(name: str, data_dir: str) -> str:
    return os.path.join(data_dir, f"{name}_mitsuba_karis.exr")
