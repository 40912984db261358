"""Test inputs made by Blender itself: a hair-curves groom exported to USD
and Alembic, and one render saved as a multilayer and as a plain EXR.

Run with a Python that has ``bpy`` (``pip install 'hairshade[blender]'``,
Python 3.11):

    python scripts/blender_fixtures.py [--out tests/data/blender]

Writes, all from one Blender session:

- ``groom_catmull_rom.usda``: 12 curly strands of 9 to 16 points
  (Blender's default curve type, Catmull-Rom: USD ``catmullRom`` with
  ``wrap = "pinned"``), radii tapering root to tip, a per-curve float
  attribute ``clump``, on an object moved, rotated and scaled;
  ``groom_poly.usda``: the same strands as poly curves (USD ``linear``);
- ``groom.abc``: the Catmull-Rom groom through Blender's Alembic exporter;
- ``groom_blender.npz``: what Blender holds: every control point in world
  space (``matrix_world`` applied in float64), radii in world units
  (scaled by the cube root of the matrix's determinant), the per-curve
  vertex counts and ``clump``;
- ``render_multilayer.exr`` (Combined, Depth and Normal passes of one
  Cycles render, 32 x 18, Blender's ``ViewLayer.Combined.R`` naming) and
  ``render_rgb.exr`` (the same render result as a plain float RGB file).
"""

from __future__ import annotations

import argparse
import os

import numpy as np


def groom_points(seed: int = 7) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    """Curly strands (helices about a drooping axis) in object space."""
    rng = np.random.default_rng(seed)
    pts, rads, clump = [], [], []
    for s in range(12):
        n = int(rng.integers(9, 17))
        t = np.linspace(0, 1, n)
        root = np.array([0.3 * np.cos(s), 0.3 * np.sin(s), 0.0])
        phase = rng.uniform(0, 2 * np.pi)
        p = np.stack([root[0] + 0.05 * np.cos(phase + 9 * t) + 0.2 * t,
                      root[1] + 0.05 * np.sin(phase + 9 * t),
                      root[2] - 0.9 * t], axis=1)
        pts.append(p.astype(np.float32))
        rads.append(np.linspace(0.006, 0.002, n).astype(np.float32))
        clump.append(s / 11)
    return pts, rads, np.array(clump, np.float32)


def main() -> None:
    import bpy

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "tests", "data", "blender"))
    args = ap.parse_args()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    pts, rads, clump = groom_points()
    cu = bpy.data.hair_curves.new("GroomData")
    cu.add_curves([len(p) for p in pts])
    cu.attributes["position"].data.foreach_set("vector", np.concatenate(pts).ravel())
    r = cu.attributes.get("radius") or cu.attributes.new("radius", "FLOAT", "POINT")
    r.data.foreach_set("value", np.concatenate(rads))
    cu.attributes.new("clump", "FLOAT", "CURVE").data.foreach_set("value", clump)
    ob = bpy.data.objects.new("Groom", cu)
    bpy.context.scene.collection.objects.link(ob)
    ob.location = (0.1, -0.2, 1.5)
    ob.rotation_euler = (0.3, -0.2, 0.5)
    ob.scale = (1.2, 1.2, 1.2)
    bpy.context.view_layer.update()

    m = np.array(ob.matrix_world, dtype=np.float64)
    local = np.concatenate(pts).astype(np.float64)
    world = local @ m[:3, :3].T + m[:3, 3]
    scale = abs(np.linalg.det(m[:3, :3])) ** (1 / 3)
    np.savez(os.path.join(out, "groom_blender.npz"), points=world, radii=np.concatenate(rads) * scale,
             counts=np.array([len(p) for p in pts]), clump=clump, matrix=m, version=bpy.app.version_string)

    bpy.ops.wm.usd_export(filepath=os.path.join(out, "groom_catmull_rom.usda"), selected_objects_only=False)
    bpy.ops.wm.alembic_export(filepath=os.path.join(out, "groom.abc"), selected=False)
    cu.set_types(type="POLY")
    bpy.ops.wm.usd_export(filepath=os.path.join(out, "groom_poly.usda"), selected_objects_only=False)
    cu.set_types(type="CATMULL_ROM")

    # one small Cycles render, saved two ways
    sc = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    sc.collection.objects.link(cam)
    cam.location = (0.0, -3.0, 1.2)
    cam.rotation_euler = (np.pi / 2, 0, 0)
    sc.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sc.collection.objects.link(sun)
    sun.rotation_euler = (0.6, 0.2, 0.3)
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = 4
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 32, 18, 100
    vl = sc.view_layers[0]
    vl.use_pass_z = True
    vl.use_pass_normal = True
    if hasattr(sc.render.image_settings, "media_type"):  # Blender 5
        sc.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    sc.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    sc.render.image_settings.color_depth = "32"
    sc.render.filepath = os.path.join(out, "render_multilayer.exr")
    bpy.ops.render.render(write_still=True)
    if hasattr(sc.render.image_settings, "media_type"):
        sc.render.image_settings.media_type = "IMAGE"
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_mode = "RGB"
    sc.render.image_settings.color_depth = "32"
    bpy.data.images["Render Result"].save_render(os.path.join(out, "render_rgb.exr"), scene=sc)
    print("wrote", sorted(os.listdir(out)))


if __name__ == "__main__":
    main()
