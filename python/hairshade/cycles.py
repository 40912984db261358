"""Whole hairshade scenes rendered by Blender's Cycles, a second path-traced
reference beside Mitsuba (extra ``blender``: ``bpy``, Blender as a Python
module; Python 3.11).

:func:`render` builds the scene in Blender in this process (it resets
Blender's session) and path traces it on the CPU:

- strands: a hair-curves object of round ("3D") curves carrying the
  Principled Hair BSDF, Chiang model, from the scene's :class:`ChiangHair`
  (Absorption Coefficient parametrization: the same σa, Roughness β_m,
  Radial Roughness β_n, IOR η, Coat ``coat``). Cycles interpolates
  Catmull-Rom through the points it is given; it is given the scene's
  curve (:mod:`hairshade.curves`, as the Mitsuba bridge draws it) at
  ``curve_samples`` points a span;
- the tilt: Cycles' ``Offset`` leans R towards the root as ChiangHair's
  ``scale_tilt`` does (and Mitsuba's the other way; ``docs/tilt.md``
  measures all of them), so Offset is ``scale_tilt``;
- spheres: UV spheres of ``SPHERE_SEGMENTS`` segments, smooth shaded
  (their facets stay within 2e-5 of the radius), with a diffuse BSDF;
  OBJ meshes with a diffuse BSDF, flat shaded;
- directional lights: sun lights of angle 0 and strength the irradiance;
  point lights: Blender point lights of radius 0 with power 4π I (Blender's
  watts, calibrated in ``tests/test_cycles.py`` against the analytic
  diffuse sphere); a constant environment: the world colour;
- the film: a box pixel filter of one pixel, no denoising, no clamping, no
  glossy filter, no adaptive sampling, ``max_bounces`` for every kind of
  bounce, the Standard view transform; the image is read back linear.

KarisHair scenes, cards and non-constant environments are refused (Cycles
has no UE hair model; the Mitsuba bridge renders those).
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _extras

if TYPE_CHECKING:
    from .scene import Scene

#: Segments around a sphere's mesh (half as many from pole to pole).
SPHERE_SEGMENTS = 512


def bspline_polyline(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray,
                     samples: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each strand's uniform cubic B-spline (its vertices as control points,
    both ends tripled, as the Mitsuba bridge's ``bsplinecurve``) evaluated
    at ``samples`` points a span, and at its end: (points, radii, offsets)."""
    from .curves import curve_points

    return curve_points(points, radii, offsets, "bspline", samples)


def _strand_polyline(scene: "Scene", samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points through which Cycles' Catmull-Rom interpolation draws the
    scene's curve: the B-spline or Catmull-Rom spline at ``samples`` points a
    span, or for a polyline each segment cut into ``samples`` equal pieces
    (collinear points: straight between the vertices, rounded only at them)."""
    from .curves import curve_points

    curve = scene.curve[0]
    if curve != "polyline":
        return curve_points(scene.points, scene.radii, scene.offsets, curve, samples)
    p, r = np.asarray(scene.points, np.float64), np.asarray(scene.radii, np.float64)
    o = np.asarray(scene.offsets, np.int64)
    seg = np.ones(len(p), bool)
    seg[o[1:] - 1] = False
    a = np.flatnonzero(seg)
    t = np.arange(samples) / samples
    q = (p[a][:, None] + (p[a + 1] - p[a])[:, None] * t[None, :, None]).reshape(-1, 3)
    w = (r[a][:, None] + (r[a + 1] - r[a])[:, None] * t[None, :]).reshape(-1)
    n = np.diff(o)
    counts = (n - 1) * samples + 1
    out_p = np.empty((int(counts.sum()), 3))
    out_r = np.empty(int(counts.sum()))
    off = np.concatenate([[0], np.cumsum(counts)])
    body = np.ones(len(out_r), bool)
    body[off[1:] - 1] = False
    out_p[body], out_r[body] = q, w
    out_p[~body], out_r[~body] = p[o[1:] - 1], r[o[1:] - 1]
    return out_p, out_r, off


def _look_at(position: Any, target: Any, up: Any) -> np.ndarray:
    """Blender's camera matrix: local -Z along the view, +Y up."""
    p, t, u = (np.asarray(x, np.float64) for x in (position, target, up))
    f = t - p
    f /= np.linalg.norm(f)
    x = np.cross(f, u)
    x /= np.linalg.norm(x)
    y = np.cross(x, f)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, -f, p
    return m


def _hair_material(bpy: Any, model: Any, offset_sign: float) -> Any:
    p = model.params
    mat = bpy.data.materials.new("Hair")
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    h = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
    h.model = "CHIANG"
    h.parametrization = "ABSORPTION"
    values = {
        "Absorption Coefficient": [float(x) for x in np.asarray(model.sigma_a)],
        "Roughness": float(p["longitudinal_roughness"]),
        "Radial Roughness": float(p["azimuthal_roughness"]),
        "Coat": float(p.get("coat", 0.0)),
        "IOR": float(p["eta"]),
        "Offset": math.radians(offset_sign * float(p["scale_tilt"])),
        "Random Color": 0.0,
        "Random Roughness": 0.0,
    }
    for sock in h.inputs:  # by name: some names are not keys in every Blender version
        if sock.name in values:
            sock.default_value = values.pop(sock.name)
    if values:
        raise RuntimeError(f"Blender's Principled Hair BSDF has no input {sorted(values)[0]!r}")
    nt.links.new(h.outputs[0], out.inputs["Surface"])
    return mat


def _diffuse_material(bpy: Any, name: str, albedo: Any) -> Any:
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        mat.node_tree.nodes.remove(bsdf)
    d = mat.node_tree.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = [*map(float, albedo), 1.0]
    d.inputs["Roughness"].default_value = 0.0
    mat.node_tree.links.new(d.outputs[0], mat.node_tree.nodes["Material Output"].inputs["Surface"])
    return mat


def build(scene: "Scene", spp: int = 64, max_bounces: int = 64, seed: int = 0, threads: int | None = None,
          curve_samples: int = 4, width: int | None = None, height: int | None = None,
          offset_sign: float = 1.0) -> Any:
    """Builds ``scene`` in a fresh Blender session and returns Blender's
    scene (see the module docs). ``offset_sign``: Cycles' Offset is
    ``offset_sign`` × the material's ``scale_tilt`` (1: the same tilt as
    the rasterizer's)."""
    bpy = _extras.require("bpy", "rendering with Cycles")
    import bmesh
    from mathutils import Matrix

    from .chiang import ChiangHair

    scene.check()
    if scene.strand_count and not isinstance(scene.hair, ChiangHair):
        raise ValueError(f"the Cycles bridge renders ChiangHair strands; this scene's material is {scene.model!r} "
                         "(hairshade.mitsuba renders KarisHair)")
    if scene.cards is not None:
        raise ValueError("the Cycles bridge does not render hair cards (hairshade.mitsuba does)")
    if scene.environment_sh is not None and np.any(np.asarray(scene.environment_sh)[1:] != 0):
        raise ValueError("environment: the Cycles bridge supports constant environments only (SH bands > 0 given)")
    if not 1 <= curve_samples <= 64:
        raise ValueError(f"curve_samples: expected 1 to 64, got {curve_samples!r}")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    cam = scene.camera
    w, h = int(width or cam["width"]), int(height or cam["height"])

    c = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    sc.collection.objects.link(c)
    c.matrix_world = Matrix(_look_at(cam["position"], cam["target"], cam["up"]).tolist())
    c.data.sensor_fit = "VERTICAL"
    c.data.angle_y = math.radians(float(cam["fov"]))
    c.data.clip_start = 1e-4
    c.data.clip_end = 1e6
    sc.camera = c

    if scene.strand_count:
        p, r, o = _strand_polyline(scene, curve_samples)
        cu = bpy.data.hair_curves.new("Strands")
        cu.add_curves(np.diff(o).tolist())
        cu.attributes["position"].data.foreach_set("vector", p.astype(np.float32).ravel())
        rad = cu.attributes.get("radius") or cu.attributes.new("radius", "FLOAT", "POINT")
        rad.data.foreach_set("value", r.astype(np.float32))
        ob = bpy.data.objects.new("Strands", cu)
        sc.collection.objects.link(ob)
        cu.materials.append(_hair_material(bpy, scene.hair, offset_sign))
    for i, s in enumerate(scene.spheres):
        me = bpy.data.meshes.new(f"Sphere{i}")
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=SPHERE_SEGMENTS, v_segments=SPHERE_SEGMENTS // 2,
                                  radius=float(s["radius"]))
        bm.to_mesh(me)
        bm.free()
        me.shade_smooth()
        ob = bpy.data.objects.new(f"Sphere{i}", me)
        ob.location = [float(x) for x in s["center"]]
        sc.collection.objects.link(ob)
        me.materials.append(_diffuse_material(bpy, f"Sphere{i}", s["albedo"]))
    for i, m in enumerate(scene.obj_meshes):
        tris = np.asarray(m["triangles"], np.float64).reshape(-1, 3)
        me = bpy.data.meshes.new(f"Mesh{i}")
        me.from_pydata(tris.tolist(), [], [(3 * k, 3 * k + 1, 3 * k + 2) for k in range(len(tris) // 3)])
        ob = bpy.data.objects.new(f"Mesh{i}", me)
        sc.collection.objects.link(ob)
        me.materials.append(_diffuse_material(bpy, f"Mesh{i}", m["albedo"]))
    from .scene import light_vector

    for i, l in enumerate(scene.lights):
        inten = np.asarray(l["intensity"], np.float64)
        top = float(inten.max())
        color = (inten / top).tolist() if top > 0 else [1.0, 1.0, 1.0]
        if l["type"] == "directional":
            ld = bpy.data.lights.new(f"Sun{i}", "SUN")
            ld.energy = top
            ld.angle = 0.0
            ob = bpy.data.objects.new(f"Sun{i}", ld)
            d = np.asarray(light_vector(l), np.float64)  # towards the light: the sun's -Z points away from it
            ob.matrix_world = Matrix(_look_at([0, 0, 0], -d, _any_perpendicular(d)).tolist())
        else:
            ld = bpy.data.lights.new(f"Point{i}", "POINT")
            ld.energy = 4 * math.pi * top
            ld.shadow_soft_size = 0.0
            ob = bpy.data.objects.new(f"Point{i}", ld)
            ob.location = [float(x) for x in l["vector"]]
        ld.color = color
        ld.use_shadow = bool(l["shadows"]) if hasattr(ld, "use_shadow") else True
        sc.collection.objects.link(ob)
    world = bpy.data.worlds.new("World")
    sc.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    env = np.zeros(3) if scene.environment_sh is None else np.asarray(scene.environment_sh)[0] * 0.28209479177387814
    bg.inputs["Color"].default_value = [*map(float, env), 1.0]
    bg.inputs["Strength"].default_value = 1.0

    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = int(spp)
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = int(seed)
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces",
              "transparent_max_bounces"):
        setattr(cy, k, int(max_bounces))
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    sc.cycles_curves.shape = "THICK"
    sc.cycles_curves.subdivisions = 4
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = w, h, 100
    sc.render.film_transparent = False
    if threads is not None:
        sc.render.threads_mode = "FIXED"
        sc.render.threads = int(threads)
    return sc


def _any_perpendicular(d: np.ndarray) -> list[float]:
    a = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return np.cross(d, a).tolist()


def render(scene: "Scene", spp: int = 64, max_bounces: int = 64, seed: int = 0, threads: int | None = None,
           curve_samples: int = 4, width: int | None = None, height: int | None = None,
           timing: dict[str, float] | None = None, offset_sign: float = 1.0) -> np.ndarray:
    """Cycles' render of ``scene`` -> (H, W, 3) float32, linear (see the
    module docs). ``max_bounces`` 0 gives direct light only (Mitsuba's
    ``max_depth`` 2). ``timing``, when given, receives ``build_s`` and
    ``render_s``."""
    if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
        raise ValueError(f"spp: expected a whole number >= 1, got {spp!r:.80}")
    if isinstance(max_bounces, bool) or not isinstance(max_bounces, int) or not 0 <= max_bounces <= 1024:
        raise ValueError(f"max_bounces: expected a whole number in [0, 1024], got {max_bounces!r:.80}")
    t0 = time.perf_counter()
    sc = build(scene, spp, max_bounces, seed, threads, curve_samples, width, height, offset_sign)
    t1 = time.perf_counter()
    img = render_built(sc)
    if timing is not None:
        timing["build_s"] = t1 - t0
        timing["render_s"] = time.perf_counter() - t1
    return img


def render_built(sc: Any) -> np.ndarray:
    """Renders the Blender scene :func:`build` made (perhaps edited since)
    -> (H, W, 3) float32, linear, through a float RGB EXR."""
    bpy = _extras.require("bpy", "rendering with Cycles")
    from .render import read_exr

    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cycles.exr")
        if hasattr(sc.render.image_settings, "media_type"):
            sc.render.image_settings.media_type = "IMAGE"
        sc.render.image_settings.file_format = "OPEN_EXR"
        sc.render.image_settings.color_mode = "RGB"
        sc.render.image_settings.color_depth = "32"
        sc.render.filepath = out
        bpy.ops.render.render(write_still=True)
        return read_exr(out)
