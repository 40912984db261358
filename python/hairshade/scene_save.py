"""Writing a scene back: :meth:`hairshade.Scene.save`.

``.json`` writes the scene format (see :mod:`hairshade.scene`) with the
strands in a ``.hair`` file beside it (float32 points and radii, bit for
bit), OBJ meshes as ``.obj`` files (every triangle's corners, nine
significant digits: float32 exact) and card alpha images copied; loading
the saved scene gives the same arrays, settings and image. ``.usd``,
``.usda`` and ``.usdc`` write the strands alone as a linear
``BasisCurves`` groom (:func:`hairshade.usd.write_usd`).

Files beside the scene are named after it: ``head.json`` writes
``head.hair``, ``head.mesh0.obj``, ``head.alpha0.png``; existing files of
those names are replaced.
"""

from __future__ import annotations

import os
import re
import shutil
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .scene import Scene


def _plain(v: Any) -> Any:
    """A value with numpy arrays and scalars as lists and Python numbers."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


def scene_dict(scene: "Scene", stem: str, folder: str) -> dict[str, Any]:
    """The scene format's dict of ``scene``, writing its side files into
    ``folder`` under the name ``stem``."""
    from .hairfile import write_hair

    cam = scene.camera
    d: dict[str, Any] = {"hairshade_scene": 1}
    d["camera"] = {"position": list(cam["position"]), "target": list(cam["target"]), "up": list(cam["up"]),
                   "fov": cam["fov"], "resolution": [cam["width"], cam["height"]]}
    lights: list[dict[str, Any]] = []
    for l in scene.lights:
        if l["type"] == "directional":
            lights.append({"type": "directional", "direction": list(l["vector"]),
                           "intensity": list(l["intensity"]), "shadows": bool(l["shadows"])})
        else:
            lights.append({"type": "point", "position": list(l["vector"]),
                           "intensity": list(l["intensity"]), "shadows": bool(l["shadows"])})
    if scene.environment_sh is not None:
        lights.append({"type": "environment", "sh": np.asarray(scene.environment_sh, np.float64).tolist()})
    d["lights"] = lights
    hair: dict[str, Any] = {"material": _plain(scene.material)}
    if scene.curve != ("polyline", 4.0):
        hair["curve"] = {scene.curve[0]: {"pixels": scene.curve[1]}}
    if scene.strand_count:
        name = f"{stem}.hair"
        write_hair(os.path.join(folder, name), scene.points, scene.radii, scene.offsets)
        hair["file"] = name
    if scene.cards is not None:
        cards = []
        copied: dict[str, str] = {}
        for spec, image in scene.cards["specs"]:
            spec = _plain(spec)
            if image is not None:
                if image not in copied:
                    ext = os.path.splitext(image)[1]
                    copied[image] = f"{stem}.alpha{len(copied)}{ext}"
                    shutil.copyfile(image, os.path.join(folder, copied[image]))
                spec = dict(spec, alpha={"image": copied[image]})
            cards.append(spec)
        hair["cards"] = cards
    d["hair"] = hair
    meshes: list[dict[str, Any]] = [{"type": "sphere", "center": list(s["center"]), "radius": s["radius"],
                                     "albedo": list(s["albedo"])} for s in scene.spheres]
    for i, m in enumerate(scene.obj_meshes):
        name = f"{stem}.mesh{i}.obj"
        tris = np.asarray(m["triangles"], np.float32).reshape(-1, 3)
        with open(os.path.join(folder, name), "w") as f:
            f.write("".join("v %.9g %.9g %.9g\n" % tuple(v) for v in tris.astype(np.float64)))
            f.write("".join(f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}\n" for k in range(len(tris) // 3)))
        meshes.append({"type": "obj", "file": name, "albedo": list(m["albedo"])})
    if meshes:
        d["meshes"] = meshes
    d["render"] = _plain(scene.render)
    return _plain(d)


def save(scene: "Scene", path: str | os.PathLike) -> None:
    import json

    from .usd import is_usd, write_usd

    path = os.fspath(path)
    low = path.lower()
    if is_usd(low) and not low.endswith(".usdz"):
        write_usd(path, scene.points, scene.radii, scene.offsets)
        return
    if not low.endswith(".json"):
        raise ValueError(f"path: expected a .json, .usd, .usda or .usdc file name, got {path!r:.200}")
    folder = os.path.dirname(os.path.abspath(path))
    stem = os.path.splitext(os.path.basename(path))[0]
    d = scene_dict(scene, stem, folder)
    text = json.dumps(d, indent=2)
    # lists of numbers on one line
    text = re.sub(r"\[\s+([-+0-9.eE,\s]*?)\s+\]", lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]",
                  text)
    with open(path, "w") as f:
        f.write(text + "\n")
