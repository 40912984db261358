"""A scene file's dict, checked field by field, into a :class:`hairshade.Scene`
(the format: :mod:`hairshade.scene`)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import numpy as np

from . import options
from ._errors import SceneError
from ._scene_check import _Ctx, _check_view, _parse_curve, _unit
from ._scene_files import _flat_strands, _read_hair_file, _read_obj
from .lighting import sh_coefficients

if TYPE_CHECKING:
    from .scene import Scene
def _parse(d: Any, base_dir: str, source: str,
           strands: list[tuple[np.ndarray, np.ndarray]] | None = None, allow_outside: bool = False) -> Scene:
    """The validated scene of the dict ``d``; ``strands``: (points, radii)
    of further strands, already checked (Scene.from_arrays); files it names
    must lie in ``base_dir`` unless ``allow_outside``."""
    from .scene import VERSION, Scene

    c = _Ctx(source, base_dir, allow_outside)
    d = c.obj(d, "(top level)")
    c.known(d, "", {"hairshade_scene", "camera", "lights", "hair", "meshes", "render"})
    version = d.get("hairshade_scene")
    if type(version) is not int or version != VERSION:
        c.fail("hairshade_scene", f"expected version {VERSION}, got {version!r:.80}")

    cam = c.obj(d.get("camera"), "camera")
    c.known(cam, "camera", {"position", "target", "up", "fov", "resolution"})
    res = cam.get("resolution", [640, 360])
    if not isinstance(res, (list, tuple)) or len(res) != 2:
        c.fail("camera.resolution", f"expected [width, height], got {res!r}")
    width = c.integer(res[0], "camera.resolution[0]", 1, 16384)
    height = c.integer(res[1], "camera.resolution[1]", 1, 16384)
    camera = dict(
        position=c.vec3(cam.get("position"), "camera.position"),
        target=c.vec3(cam.get("target"), "camera.target"),
        up=c.vec3(cam.get("up", [0, 1, 0]), "camera.up"),
        fov=c.num(cam.get("fov", 40), "camera.fov", 0, 179, lo_open=True),
        width=width,
        height=height,
    )
    _check_view(c, camera)

    lights: list[dict[str, Any]] = []
    env = None
    for p, l in c.objects(d.get("lights", []), "lights"):
        kind = l.get("type")
        if kind == "directional":
            c.known(l, p, {"type", "direction", "intensity", "shadows"})
            direction = c.vec3(l.get("direction"), f"{p}.direction")
            _unit(c, direction, f"{p}.direction")
            lights.append(dict(type=kind, vector=direction, intensity=c.vec3(l.get("intensity"), f"{p}.intensity", 0),
                               shadows=c.boolean(l.get("shadows", True), f"{p}.shadows")))
        elif kind == "point":
            c.known(l, p, {"type", "position", "intensity", "shadows"})
            lights.append(dict(type=kind, vector=c.vec3(l.get("position"), f"{p}.position"),
                               intensity=c.vec3(l.get("intensity"), f"{p}.intensity", 0),
                               shadows=c.boolean(l.get("shadows", False), f"{p}.shadows")))
        elif kind == "environment":
            c.known(l, p, {"type", "radiance", "sh"})
            if env is not None:
                c.fail(p, "only one environment light is allowed")
            if "sh" in l:
                sh = l["sh"]
                if not isinstance(sh, list) or len(sh) != 9:
                    c.fail(f"{p}.sh", "expected 9 RGB coefficients")
                env = np.array([c.vec3(x, f"{p}.sh[{k}]") for k, x in enumerate(sh)], dtype=np.float32)
            else:
                rad = c.vec3(l.get("radiance"), f"{p}.radiance", 0)
                env = sh_coefficients(rad).astype(np.float32)
        else:
            c.fail(f"{p}.type", f"expected 'directional', 'point' or 'environment', got {kind!r}")

    hair = c.obj(d.get("hair", {}), "hair")
    c.known(hair, "hair", {"strands", "file", "generate", "cards", "generate_cards", "material", "curve"})
    curve = _parse_curve(c, hair.get("curve", "polyline"))
    pts: list[np.ndarray] = []
    rads: list[np.ndarray] = []
    for p, s in c.objects(hair.get("strands", []), "hair.strands"):
        c.known(s, p, {"points", "radius", "radii"})
        if "radius" in s and "radii" in s:
            c.fail(p, "give radius or radii, not both")
        raw = s.get("points")
        if not isinstance(raw, list) or len(raw) < 2:
            c.fail(f"{p}.points", "expected a list of at least 2 points")
        v = np.array([c.vec3(x, f"{p}.points[{k}]") for k, x in enumerate(raw)], dtype=np.float64)
        if "radii" in s:
            rr = s["radii"]
            if not isinstance(rr, list) or len(rr) != len(v):
                c.fail(f"{p}.radii", f"expected {len(v)} radii (one per point)")
            r = np.array([c.num(x, f"{p}.radii[{k}]", 0) for k, x in enumerate(rr)])
        else:
            r = np.full(len(v), c.num(s.get("radius", 0.005), f"{p}.radius", 0))
        pts.append(v)
        rads.append(r)
    if "file" in hair:
        fpts, frads = _read_hair_file(c.file(hair["file"], "hair.file"), c, hair["file"])
        pts += fpts
        rads += frads
    if "generate" in hair:
        from .generate import generate

        spec = c.obj(hair["generate"], "hair.generate")
        try:
            gp, gr = generate(spec)
        except (TypeError, ValueError) as e:
            c.fail("hair.generate", str(e))
        pts += gp
        rads += gr
    for sp, sr in strands or []:
        pts.append(sp)
        rads.append(sr)
    points, radii, offsets = _flat_strands(pts, rads)

    cards = _parse_cards(hair, base_dir, c)

    mat = dict(c.obj(hair.get("material", {"model": "karis"}), "hair.material"))
    model = mat.get("model", "karis")
    if model not in options.MODELS:
        c.fail("hair.material.model", f"expected {options.choices_text(options.MODELS)}, got {model!r}")
    mat["model"] = model

    spheres = []
    obj_meshes = []
    for p, m in c.objects(d.get("meshes", []), "meshes"):
        if m.get("type") == "obj":
            c.known(m, p, {"type", "file", "albedo"})
            path = c.file(m.get("file"), f"{p}.file")
            tris = _read_obj(path, c, f"{p}.file")
            obj_meshes.append(dict(file=path, albedo=c.vec3(m.get("albedo", [0.5, 0.5, 0.5]), f"{p}.albedo", 0, 1), triangles=tris))
            continue
        if m.get("type") != "sphere":
            c.fail(f"{p}.type", f"expected 'sphere' or 'obj', got {m.get('type')!r}")
        c.known(m, p, {"type", "center", "radius", "albedo"})
        spheres.append(dict(center=c.vec3(m.get("center"), f"{p}.center"),
                            radius=c.num(m.get("radius"), f"{p}.radius", 0, lo_open=True),
                            albedo=c.vec3(m.get("albedo", [0.5, 0.5, 0.5]), f"{p}.albedo", 0, 1)))

    r = c.obj(d.get("render", {}), "render")
    try:
        render = options.translate_flat(r, whole_section=True, model=mat["model"], environment=env is not None)
    except SceneError as e:
        raise SceneError(f"{c.source}: {e}") from None
    scene = Scene(camera, lights, env, points, radii, offsets, spheres, mat, render, source)
    scene.cards = cards
    scene.obj_meshes = obj_meshes
    scene.curve = curve
    try:
        scene.options()  # every setting checked at load: applies here, in range
    except SceneError as e:
        raise SceneError(f"{c.source}: {e}") from None
    return scene


#: Peak bytes of loading a baked card's fiber vertex (24 per fiber):
#: 83.8 measured for 2000 cards x 256 fibers, 82.7 for 200 x 2048 (peak
#: RSS of Scene.from_dict over the vertices), rounded up.
BYTES_PER_BAKED_VERTEX = 96


def _baked_fibers(card: Any) -> int:
    """The baked fibers a card (or a ``generate_cards`` spec) asks for per
    card; 0 for anything the checks that follow will refuse."""
    alpha = card.get("alpha", {"bake": {}}) if isinstance(card, dict) else None
    bake = alpha.get("bake") if isinstance(alpha, dict) else None
    n = bake.get("fibers", 24) if isinstance(bake, dict) else 0
    return n if isinstance(n, int) and not isinstance(n, bool) and 0 < n <= 4096 else 0


def _check_baked_memory(where: str, cards: int, fibers: int) -> None:
    """MemoryError naming ``where`` before ``fibers`` baked fibers of
    ``cards`` cards are built, when they would need more memory than is
    available (200 000 cards of 4096 fibers grew for minutes towards
    1.5 TB)."""
    from .cards import card_fiber_strands
    from . import _memory

    samples = card_fiber_strands.__defaults__[-1]
    _memory.check(fibers * samples * BYTES_PER_BAKED_VERTEX, f"{where}: {cards} cards, {fibers} baked fibers",
                  "lower cards or bake.fibers")


def _parse_cards(hair: dict[str, Any], base_dir: str, c: _Ctx) -> dict[str, Any] | None:
    """Cards as flat arrays for the renderer, or None."""
    from .cards import card_fiber_strands, card_quads, head_cards, load_alpha

    raw = hair.get("cards", [])
    if not isinstance(raw, list):
        c.fail("hair.cards", "expected a list")
    entries = [(f"hair.cards[{i}]", x) for i, x in enumerate(raw)]
    if "generate_cards" in hair:
        spec = c.obj(hair["generate_cards"], "hair.generate_cards")
        count = spec.get("cards", 400)
        if isinstance(count, int) and not isinstance(count, bool) and count > 0:
            _check_baked_memory("hair.generate_cards", count, count * _baked_fibers(spec))
        try:
            gen = head_cards(spec)
        except (TypeError, ValueError) as e:
            c.fail("hair.generate_cards", str(e))
        entries += [(f"hair.generate_cards (card {i})", x) for i, x in enumerate(gen)]
    if not entries:
        return None
    _check_baked_memory("hair.cards", len(entries), sum(_baked_fibers(x) for _, x in entries))
    corners, uvs, tangents, tex_index = [], [], [], []
    fiber_pts: list[np.ndarray] = []
    fiber_rads: list[np.ndarray] = []
    all_baked = True
    textures: list[np.ndarray] = []
    tex_keys: dict[str, int] = {}
    specs: list[tuple[dict[str, Any], str | None]] = []
    for path, card in entries:
        card = c.obj(card, path)
        c.known(card, path, {"points", "width", "normal", "alpha"})
        raw_pts = card.get("points")
        if not isinstance(raw_pts, list) or len(raw_pts) < 2:
            c.fail(f"{path}.points", "expected a list of at least 2 points")
        pts = np.array([c.vec3(x, f"{path}.points[{k}]") for k, x in enumerate(raw_pts)])
        width = c.num(card.get("width"), f"{path}.width", 0, lo_open=True)
        normal = np.array(c.vec3(card.get("normal", [0, 0, 1]), f"{path}.normal"))
        if np.linalg.norm(normal) == 0:
            c.fail(f"{path}.normal", "must not be zero")
        alpha_spec = c.obj(card.get("alpha", {"bake": {}}), f"{path}.alpha")
        key = json.dumps(alpha_spec, sort_keys=True)
        if key not in tex_keys:
            try:
                textures.append(load_alpha(alpha_spec, base_dir, lambda name: c.file(name, f"{path}.alpha.image")))
            except SceneError:
                raise
            except (TypeError, ValueError, OSError) as e:
                c.fail(f"{path}.alpha", str(e))
            tex_keys[key] = len(textures) - 1
        try:
            q, uv, t = card_quads(pts, width, normal / np.linalg.norm(normal))
        except ValueError as e:
            c.fail(path, str(e))
        corners.append(q)
        uvs.append(uv)
        tangents.append(t)
        specs.append((card, c.file(alpha_spec["image"], f"{path}.alpha.image") if "image" in alpha_spec else None))
        if "bake" in alpha_spec:  # checked by load_alpha above
            fp, fr = card_fiber_strands(pts, width, normal / np.linalg.norm(normal), alpha_spec["bake"])
            fiber_pts += fp
            fiber_rads += fr
        else:
            all_baked = False
        tex_index.append(np.full(len(t), tex_keys[key], dtype=np.uint32))
    return dict(
        corners=np.concatenate(corners).astype(np.float32),
        uvs=np.concatenate(uvs).astype(np.float32),
        tangents=np.concatenate(tangents).astype(np.float32),
        texture=np.concatenate(tex_index),
        textures=textures,
        # The fibers baked cards stand for, flat as the strands (points,
        # radii, offsets; None unless every card is baked).
        fibers=_flat_strands(fiber_pts, fiber_rads) if all_baked else None,
        # every card as given (generated ones expanded), and the path of its
        # alpha image (None when baked): what Scene.save writes back
        specs=specs,
    )
