"""Whole hairshade scenes rendered by Mitsuba 3, the references the
rasterizer is compared with: :func:`scene_dict` (the Mitsuba scene
dictionary of a :class:`~hairshade.Scene`: strands as ``bsplinecurve``,
cards as masked OBJ meshes or as their fibers, spheres, OBJ meshes, lights,
a constant environment) and :func:`render` (the image, in passes)."""

from __future__ import annotations

import json
import os
import tempfile
import time
from typing import TYPE_CHECKING, Any

import drjit as dr
import mitsuba as mi
import numpy as np

from .._progress import Bar
from ..chiang import ChiangHair
from . import default_variant
from .bsdf import hair_dict
from .plugins import register_plugins

if TYPE_CHECKING:
    from ..scene import Scene


def scene_dict(scene: "Scene", strand_file: str, spp: int, integrator: str = "direct", max_depth: int = 64,
               width: int | None = None, height: int | None = None, hair_params: dict[str, Any] | None = None,
               hair_bsdf: str = "chiang", cards_as_fibers: bool = True, curve: str | None = None) -> dict[str, Any]:
    """The Mitsuba scene dictionary of a hairshade scene. Strands become a
    ``bsplinecurve`` (written to ``strand_file``; its frame has the tangent
    on local y as the ``hair`` BSDF requires, which ``linearcurve``'s does
    not) whose control points are the strand's vertices with both ends
    tripled, so that the curve reaches them (for the dense, smooth strands of
    hair scenes it stays within a fraction of a pixel of the polyline); the
    curve carries Mitsuba's ``hair``
    BSDF: the scene's ChiangHair material, or for a KarisHair material the
    ChiangHair fitted by :func:`hairshade.mapping.chiang_params` (or
    ``hair_params`` when given). Spheres get a diffuse BSDF."""
    from ..mapping import chiang_params
    from ..scene import light_vector, write_strand_file

    scene.check()
    cam = scene.camera
    w, h = width or cam["width"], height or cam["height"]
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "direct"} if integrator == "direct" else {"type": "path", "max_depth": int(max_depth)},
        "sensor": {
            "type": "perspective",
            "fov": float(cam["fov"]),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["target"], up=cam["up"]),
            "film": {"type": "hdrfilm", "width": int(w), "height": int(h), "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)},
        },
    }
    if integrator not in ("direct", "path"):
        raise ValueError(f"integrator: must be 'direct' or 'path', got {integrator!r}")
    if hair_params is None and hair_bsdf == "chiang" and (scene.strand_count > 0 or scene.cards is not None):
        hair_params = scene.hair.params if isinstance(scene.hair, ChiangHair) else chiang_params(scene.hair)
        hair_params = {k: v for k, v in hair_params.items() if k != "i0"}
    if scene.strand_count > 0:
        pts, rad, off = strand_controls(scene, curve)
        write_strand_file(strand_file, pts, rad, off)
        d["hair"] = {"type": "bsplinecurve", "filename": strand_file, "bsdf": _curve_bsdf(scene, hair_bsdf, hair_params)}
    if scene.cards is not None:
        if cards_as_fibers and scene.cards["fibers"] is not None:
            path = os.path.join(os.path.dirname(strand_file), "card_fibers.txt")
            cp, cr, co = _clamped_controls(*scene.cards["fibers"])
            write_strand_file(path, cp, cr, co)
            d["card_fibers"] = {"type": "bsplinecurve", "filename": path, "bsdf": _curve_bsdf(scene, hair_bsdf, hair_params)}
        else:
            d.update(_card_meshes(scene, os.path.dirname(strand_file), hair_bsdf, hair_params))
    for i, s in enumerate(scene.spheres):
        d[f"sphere_{i}"] = {
            "type": "sphere", "center": s["center"], "radius": s["radius"],
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": s["albedo"]}},
        }
    for i, m in enumerate(scene.obj_meshes):
        d[f"obj_{i}"] = {"type": "obj", "filename": m["file"], "face_normals": True,
                         "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["albedo"]}}}}
    for i, l in enumerate(scene.lights):
        if l["type"] == "directional":
            d[f"light_{i}"] = {"type": "directional", "direction": (-np.asarray(light_vector(l))).tolist(),
                               "irradiance": {"type": "rgb", "value": l["intensity"]}}
        else:
            d[f"light_{i}"] = {"type": "point", "position": l["vector"], "intensity": {"type": "rgb", "value": l["intensity"]}}
    if scene.environment_sh is not None:
        sh = np.asarray(scene.environment_sh)
        if np.any(sh[1:] != 0):
            raise ValueError("environment: the Mitsuba bridge supports constant environments only (SH bands > 0 given)")
        d["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": (sh[0] * 0.28209479177387814).tolist()}}
    return d


def _curve_bsdf(scene: "Scene", hair_bsdf: str, hair_params: dict[str, Any] | None) -> dict[str, Any]:
    from ..karis import KarisHair

    if hair_bsdf == "chiang":
        return hair_dict(ChiangHair(**hair_params))
    if hair_bsdf == "karis":
        if not isinstance(scene.hair, KarisHair):
            raise ValueError("hair_bsdf: 'karis' needs a scene whose material is KarisHair")
        register_plugins()
        return {"type": "hairshade_karis", "params": json.dumps(scene.hair.params)}
    raise ValueError(f"hair_bsdf: must be 'chiang' or 'karis', got {hair_bsdf!r}")


def _card_meshes(scene: "Scene", folder: str, hair_bsdf: str, hair_params: dict[str, Any] | None) -> dict[str, Any]:
    """Cards as OBJ meshes (one per alpha texture) under a ``mask`` BSDF whose
    opacity is the card's alpha. u runs across the card, v along it, so the
    mesh's shading frame has the fiber on local y (t = n x dp/du), as the
    hair BSDFs expect. With ``hair_bsdf="karis"`` the card carries the same
    KarisHair as the rasterizer; with "chiang", Mitsuba's near-field ``hair``
    (evaluated at the offset h of a flat card, not the far field the
    rasterizer uses)."""
    c = scene.cards
    out: dict[str, Any] = {}
    for k, tex in enumerate(c["textures"]):
        quads = np.nonzero(c["texture"] == k)[0]
        if len(quads) == 0:
            continue
        path = os.path.join(folder, f"cards_{k}.obj")
        with open(path, "w") as f:
            for q in quads:
                for v in c["corners"][q]:
                    f.write(f"v {v[0]:.7g} {v[1]:.7g} {v[2]:.7g}\n")
            for q in quads:
                for uv in c["uvs"][q]:
                    f.write(f"vt {uv[0]:.7g} {1 - uv[1]:.7g}\n")  # OBJ: v up
            for j in range(len(quads)):
                i = 4 * j + 1
                f.write(f"f {i}/{i} {i + 1}/{i + 1} {i + 2}/{i + 2}\nf {i}/{i} {i + 2}/{i + 2} {i + 3}/{i + 3}\n")
        if hair_bsdf == "karis":
            register_plugins()
            inner = {"type": "hairshade_karis", "params": json.dumps(scene.hair.params)}
        else:
            inner = hair_dict(ChiangHair(**hair_params))
        out[f"cards_{k}"] = {
            "type": "obj", "filename": path, "face_normals": True,
            "bsdf": {"type": "mask", "bsdf": inner,
                     "opacity": {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(tex[:, :, None], dtype=np.float32)),
                                 "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp"}},
        }
    return out


class LoadedScene:
    """A hairshade scene loaded into Mitsuba once (``path``, ``max_depth``),
    rendered as often as asked: :meth:`render` times ``mi.render`` and the
    read-back of the image together, each call with the next seed from
    ``first_seed`` on (the way to measure Mitsuba at its best: no reload,
    no bridge in the timed part). ``load_s`` is the build and load time.
    ``curve`` (default "bspline", the B-spline of the strands' vertices, as
    the references were made) draws every scene's strands that way: for a
    polyline scene Mitsuba renders it 30% faster than the exact polyline
    (every vertex tripled), and on smooth grooms within a fraction of a
    pixel of it; None draws the scene's own curve."""

    def __init__(self, scene: "Scene", variant: str | None = None, max_depth: int = 64, first_seed: int = 1,
                 curve: str | None = "bspline"):
        self.variant = variant or default_variant()
        mi.set_variant(self.variant)
        t = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            self.scene = mi.load_dict(scene_dict(scene, os.path.join(tmp, "strands.txt"), 1, "path", max_depth,
                                                 curve=curve))
        self.load_s = time.perf_counter() - t
        self.seed = first_seed - 1

    def render(self, spp: int) -> tuple[np.ndarray, float]:
        """(H, W, 3) float32 image at ``spp``, and the seconds it took."""
        self.seed += 1
        t = time.perf_counter()
        img = np.array(mi.render(self.scene, spp=spp, seed=self.seed), dtype=np.float32)[..., :3]
        return img, time.perf_counter() - t


def strand_controls(scene: "Scene", curve: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``bsplinecurve`` control points that draw the scene's curve
    (:mod:`hairshade.curves`): for "bspline" the vertices with both ends
    tripled; for "polyline" every vertex tripled (a uniform cubic B-spline
    through three equal control points and the next three is the straight
    segment between them: the polyline exactly, its tangent along each
    segment); for "catmull_rom" the spline sampled at 16 steps a span,
    drawn as that polyline (within 1/500 of a span's turning of the curve).
    ``curve`` overrides the scene's."""
    from ..curves import CURVES, curve_points

    curve = curve or scene.curve[0]
    if curve not in CURVES:
        raise ValueError(f"curve: expected one of {', '.join(CURVES)}, got {curve!r:.80}")
    if curve == "bspline":
        return _clamped_controls(scene.points, scene.radii, scene.offsets)
    p, r, o = curve_points(scene.points, scene.radii, scene.offsets, curve, 16) if curve == "catmull_rom" else \
        (scene.points, scene.radii, scene.offsets)
    idx = np.repeat(np.arange(len(p)), 3)
    return p[idx], r[idx], np.asarray(o, np.int64) * 3


def _clamped_controls(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray):
    """Each strand's vertices with the first and last repeated twice more."""
    offsets = np.asarray(offsets, dtype=np.int64)
    rep = np.ones(len(points), dtype=np.int64)
    np.add.at(rep, offsets[:-1], 2)
    np.add.at(rep, offsets[1:] - 1, 2)
    idx = np.repeat(np.arange(len(points)), rep)
    return points[idx], radii[idx], np.concatenate([[0], np.cumsum(np.diff(offsets) + 4)])


def render(scene: "Scene", spp: int = 64, integrator: str = "direct", max_depth: int = 64, width: int | None = None,
           height: int | None = None, variant: str | None = None, passes: int | None = None, seed: int = 0,
           progress: bool | None = None, hair_params: dict[str, Any] | None = None, hair_bsdf: str = "chiang",
           timing: dict[str, float] | None = None, curve: str | None = None) -> np.ndarray:
    """Reference render of ``scene`` by Mitsuba 3 -> (H, W, 3) float32.

    ``hair_bsdf``: "chiang" (Mitsuba's ``hair`` with the scene's ChiangHair,
    or the one fitted to its KarisHair) or "karis" (the scene's KarisHair
    itself through the ``hairshade_karis`` plugin; needs ``llvm_ad_rgb``).
    The samples are split into ``passes`` renders with different seeds
    (default: 8, or spp if fewer) so that a progress bar can be shown;
    Ctrl-C stops between passes. ``timing``, when given, receives
    ``load_s`` (building and loading the scene) and ``render_s`` (rendering
    and reading back the image, summed over the passes). The scene is
    built and loaded once; each pass renders it with its own seed.
    ``curve``: how the strands are drawn (:func:`strand_controls`; default:
    the scene's own ``hair.curve``)."""
    if spp < 1:
        raise ValueError(f"spp: must be >= 1, got {spp}")
    v = variant or default_variant()
    if hair_bsdf == "karis" and v.startswith("scalar"):
        raise ValueError("hair_bsdf: 'karis' needs a JIT variant (llvm_ad_rgb); install libllvm19")
    mi.set_variant(v)
    flags = None
    if hair_bsdf == "karis":
        # Python BSDFs are evaluated on concrete arrays: wavefront mode
        # (restored afterwards).
        flags = (dr.flag(dr.JitFlag.VCallRecord), dr.flag(dr.JitFlag.LoopRecord))
        dr.set_flag(dr.JitFlag.VCallRecord, False)
        dr.set_flag(dr.JitFlag.LoopRecord, False)
    try:
        return _render_passes(scene, spp, integrator, max_depth, width, height, passes, seed, progress, hair_params, hair_bsdf,
                              timing if timing is not None else {}, curve)
    finally:
        if flags is not None:
            dr.set_flag(dr.JitFlag.VCallRecord, flags[0])
            dr.set_flag(dr.JitFlag.LoopRecord, flags[1])


def _render_passes(scene: "Scene", spp: int, integrator: str, max_depth: int, width: int | None, height: int | None,
                   passes: int | None, seed: int, progress: bool | None, hair_params: dict[str, Any] | None,
                   hair_bsdf: str, timing: dict[str, float], curve: str | None = None) -> np.ndarray:
    passes = max(1, min(passes or 8, spp))
    with tempfile.TemporaryDirectory() as tmp, Bar(passes, "mitsuba", unit="pass", enabled=progress) as bar:
        per = [spp // passes + (1 if k < spp % passes else 0) for k in range(passes)]
        acc = None
        t0 = time.perf_counter()
        d = scene_dict(scene, f"{tmp}/strands.txt", per[0], integrator, max_depth, width, height, hair_params, hair_bsdf,
                       curve=curve)
        mscene = mi.load_dict(d)
        timing.update(load_s=time.perf_counter() - t0, render_s=0.0)
        for k, n in enumerate(per):
            t1 = time.perf_counter()
            img = np.array(mi.render(mscene, spp=n, seed=seed * 1000 + k), dtype=np.float64) * n
            timing["render_s"] += time.perf_counter() - t1
            acc = img if acc is None else acc + img
            bar.update_to(k + 1)
    return (acc / spp).astype(np.float32)[..., :3]
