"""Bridge to Mitsuba 3: the same hair materials evaluated by Mitsuba's own
``hair`` plugin, on numpy arrays, for validation and benchmarks.

Mitsuba is optional at install time (``pip install hairshade[mitsuba]``);
importing this module without it raises ImportError with that hint.

Variants: ``llvm_ad_rgb`` evaluates whole batches in one JIT kernel and is
the fast path; its JIT needs LLVM >= 16 (Debian 12's default LLVM 14/15
aborts the process on ``fmaximum``), so it is used only when
``DRJIT_LIBLLVM_PATH`` is set or a known libLLVM >= 16 is present, in which
case ``DRJIT_LIBLLVM_PATH`` is set before drjit loads. ``scalar_rgb`` works
everywhere and loops in Python (about 20 µs per pair). Both are single
precision.
"""

from __future__ import annotations

import glob
import os
from typing import Any

import numpy as np

from .chiang import ChiangHair

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .scene import Scene

# Newest first; libLLVM 16+ is what drjit's LLVM backend needs.
_LLVM_GLOBS = [
    "/usr/lib/llvm-{v}/lib/libLLVM.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM-{v}.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.{v}*",
    "/usr/lib/aarch64-linux-gnu/libLLVM-{v}.so",
]


def find_libllvm() -> str | None:
    """Path of a libLLVM that drjit's LLVM backend can use (version 16 to 21)."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    for v in range(21, 15, -1):
        for pattern in _LLVM_GLOBS:
            hits = sorted(glob.glob(pattern.format(v=v)))
            if hits:
                return hits[0]
    return None


_LLVM = find_libllvm()
if _LLVM and "DRJIT_LIBLLVM_PATH" not in os.environ:
    os.environ["DRJIT_LIBLLVM_PATH"] = _LLVM

try:
    import drjit as dr
    import mitsuba as mi
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError(
        "hairshade.mitsuba needs Mitsuba 3: pip install 'hairshade[mitsuba]'"
    ) from e


def default_variant() -> str:
    """``llvm_ad_rgb`` when a usable LLVM is present, else ``scalar_rgb``."""
    return "llvm_ad_rgb" if _LLVM and "llvm_ad_rgb" in mi.variants() else "scalar_rgb"


def hair_dict(model: ChiangHair) -> dict[str, Any]:
    """Mitsuba scene-dictionary entry of Mitsuba's ``hair`` BSDF with the
    parameters of ``model`` (``ext_ior`` 1 so that eta is int_ior)."""
    p = model.params
    d: dict[str, Any] = {
        "type": "hair",
        "int_ior": p["eta"],
        "ext_ior": 1.0,
        "longitudinal_roughness": p["longitudinal_roughness"],
        "azimuthal_roughness": p["azimuthal_roughness"],
        "scale_tilt": p["scale_tilt"],
    }
    if p["sigma_a"] is not None:
        d["sigma_a"] = {"type": "rgb", "value": list(p["sigma_a"])}
    else:
        if p["eumelanin"] is not None:
            d["eumelanin"] = p["eumelanin"]
        if p["pheomelanin"] is not None:
            d["pheomelanin"] = p["pheomelanin"]
    return d


def _unit_rows(a: object, name: str) -> np.ndarray:
    x = np.atleast_2d(np.asarray(a, dtype=np.float64))
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (N, 3) or (3,), got {np.shape(a)}")
    return x / np.linalg.norm(x, axis=1, keepdims=True)


class MitsubaHair:
    """Mitsuba's ``hair`` BSDF for the parameters of a :class:`ChiangHair`,
    evaluated on numpy arrays in Mitsuba's local frame (the same frame as
    hairshade). Results are float64 arrays of Mitsuba's float32 values."""

    def __init__(self, model: ChiangHair, variant: str | None = None) -> None:
        self.variant = variant or default_variant()
        if self.variant not in mi.variants():
            raise ValueError(f"variant: {self.variant!r} is not one of {mi.variants()}")
        self.params = hair_dict(model)
        mi.set_variant(self.variant)
        self._bsdf = mi.load_dict(self.params)

    def _activate(self) -> None:
        mi.set_variant(self.variant)

    @property
    def _vectorized(self) -> bool:
        return not self.variant.startswith("scalar")

    def _pairs(self, wi: object, wo: object) -> tuple[np.ndarray, np.ndarray, int]:
        """Activates the variant; unit (N,3) arrays of both directions, N."""
        self._activate()
        a, b = np.broadcast_arrays(_unit_rows(wi, "wi"), _unit_rows(wo, "wo"))
        return a, b, a.shape[0]

    @staticmethod
    def _wide_si(a: np.ndarray) -> Any:
        si = dr.zeros(mi.SurfaceInteraction3f, a.shape[0])
        si.wi = mi.Vector3f(a[:, 0], a[:, 1], a[:, 2])
        return si

    def eval_pdf(self, wi: object, wo: object) -> tuple[np.ndarray, np.ndarray]:
        """(value (N,3), pdf (N,)) from Mitsuba's ``eval_pdf``."""
        a, b, n = self._pairs(wi, wo)
        ctx = mi.BSDFContext()
        if self._vectorized:
            v, p = self._bsdf.eval_pdf(ctx, self._wide_si(a), mi.Vector3f(b[:, 0], b[:, 1], b[:, 2]))
            return np.array(v, dtype=np.float64).T.reshape(n, 3), np.array(p, dtype=np.float64).reshape(n)
        si = mi.SurfaceInteraction3f()
        val = np.empty((n, 3))
        pdf = np.empty(n)
        for i in range(n):
            si.wi = mi.Vector3f(a[i])
            v, p = self._bsdf.eval_pdf(ctx, si, mi.Vector3f(b[i]))
            val[i] = np.array(v)
            pdf[i] = float(p)
        return val, pdf

    def eval(self, wi: object, wo: object) -> np.ndarray:
        """Mitsuba's ``eval`` (N,3)."""
        a, b, n = self._pairs(wi, wo)
        if self._vectorized:
            v = self._bsdf.eval(mi.BSDFContext(), self._wide_si(a), mi.Vector3f(b[:, 0], b[:, 1], b[:, 2]))
            return np.array(v, dtype=np.float64).T.reshape(n, 3)
        return self.eval_pdf(a, b)[0]

    def sample(self, wi: object, u1: object, u2: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mitsuba's ``sample``: (wo (N,3), weight (N,3), pdf (N,))."""
        self._activate()
        u1 = np.asarray(u1, dtype=np.float64).reshape(-1)
        u2 = np.asarray(u2, dtype=np.float64).reshape(-1, 2)
        n = u1.shape[0]
        a = np.broadcast_to(_unit_rows(wi, "wi"), (n, 3))
        ctx = mi.BSDFContext()
        if self._vectorized:
            bs, w = self._bsdf.sample(ctx, self._wide_si(a), mi.Float(u1), mi.Point2f(u2[:, 0], u2[:, 1]))
            wo = np.array(bs.wo, dtype=np.float64).T.reshape(n, 3)
            return wo, np.array(w, dtype=np.float64).T.reshape(n, 3), np.array(bs.pdf, dtype=np.float64).reshape(n)
        si = mi.SurfaceInteraction3f()
        wo = np.empty((n, 3))
        weight = np.empty((n, 3))
        pdf = np.empty(n)
        for i in range(n):
            si.wi = mi.Vector3f(a[i])
            bs, w = self._bsdf.sample(ctx, si, float(u1[i]), mi.Point2f(u2[i]))
            wo[i] = np.array(bs.wo)
            weight[i] = np.array(w)
            pdf[i] = float(bs.pdf)
        return wo, weight, pdf


# -- hairshade's models as Mitsuba BSDFs -------------------------------------------

_REGISTERED = False


def register_plugins() -> None:
    """Registers ``hairshade_karis`` and ``hairshade_deon``: KarisHair and
    DEonHair as Mitsuba BSDFs, so Mitsuba can render the exact shading the
    rasterizer uses. They take a ``params`` string (JSON of the model's
    keyword arguments), read the fiber tangent as local y (as Mitsuba's
    ``hair`` does: use them on ``bsplinecurve``), evaluate
    ``S(L = wo, V = wi, T)`` through hairshade on numpy arrays, and sample
    directions uniformly on the sphere. They need a JIT variant
    (``llvm_ad_rgb``) rendered in wavefront mode; :func:`render` sets that up.
    Both models are far-field: the value does not depend on where the ray
    hits the fiber."""
    global _REGISTERED
    if _REGISTERED:
        return
    import json

    from .deon import DEonHair
    from .karis import KarisHair

    def make(model_cls: type) -> Any:
        class HairshadeBSDF(mi.BSDF):
            def __init__(self, props: Any) -> None:
                mi.BSDF.__init__(self, props)
                kwargs = json.loads(props.get("params", "{}"))
                self.model = model_cls(**kwargs)
                flags = (mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.GlossyTransmission
                         | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
                self.m_components = [flags]
                self.m_flags = flags

            def _eval(self, si: Any, wo: Any) -> Any:
                v = np.array(si.wi, dtype=np.float64).T.reshape(-1, 3)
                l = np.array(wo, dtype=np.float64).T.reshape(-1, 3)
                n = max(len(v), len(l))
                f = self.model.eval(np.broadcast_to(l, (n, 3)), np.broadcast_to(v, (n, 3)), np.array([0.0, 1.0, 0.0]))
                return mi.Color3f(f[:, 0], f[:, 1], f[:, 2])

            def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any, active: Any = True) -> Any:
                bs = mi.BSDFSample3f()
                bs.wo = mi.warp.square_to_uniform_sphere(sample2)
                bs.pdf = mi.warp.square_to_uniform_sphere_pdf(bs.wo)
                bs.eta = 1.0
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
                bs.sampled_component = mi.UInt32(0)
                return bs, self._eval(si, bs.wo) / bs.pdf

            def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
                return self._eval(si, wo)

            def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
                return mi.warp.square_to_uniform_sphere_pdf(wo)

            def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
                return self._eval(si, wo), mi.warp.square_to_uniform_sphere_pdf(wo)

            def to_string(self) -> str:
                return f"{model_cls.__name__}BSDF[{self.model!r}]"

        return HairshadeBSDF

    for name, cls in (("hairshade_karis", KarisHair), ("hairshade_deon", DEonHair)):
        plugin = make(cls)
        mi.register_bsdf(name, lambda props, plugin=plugin: plugin(props))
    _REGISTERED = True


# -- whole scenes ----------------------------------------------------------------


def scene_dict(scene: "Scene", strand_file: str, spp: int, integrator: str = "direct", max_depth: int = 64,
               width: int | None = None, height: int | None = None, hair_params: dict[str, Any] | None = None,
               hair_bsdf: str = "chiang", cards_as_fibers: bool = True) -> dict[str, Any]:
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
    from .chiang import ChiangHair
    from .mapping import chiang_params
    from .scene import write_strand_file

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
        pts, rad, off = _clamped_controls(scene.points, scene.radii, scene.offsets)
        write_strand_file(strand_file, pts, rad, off)
        d["hair"] = {"type": "bsplinecurve", "filename": strand_file, "bsdf": _curve_bsdf(scene, hair_bsdf, hair_params)}
    if scene.cards is not None:
        if cards_as_fibers and scene.cards["fibers"] is not None:
            fpts, frads = scene.cards["fibers"]
            off = np.concatenate([[0], np.cumsum([len(x) for x in fpts])])
            path = os.path.join(os.path.dirname(strand_file), "card_fibers.txt")
            cp, cr, co = _clamped_controls(np.concatenate(fpts), np.concatenate(frads), off)
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
            v = np.asarray(l["vector"], dtype=np.float64)
            d[f"light_{i}"] = {"type": "directional", "direction": (-v / np.linalg.norm(v)).tolist(),
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
    from .chiang import ChiangHair
    from .karis import KarisHair

    if hair_bsdf == "chiang":
        return hair_dict(ChiangHair(**hair_params))
    if hair_bsdf == "karis":
        import json

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
    import json

    from .chiang import ChiangHair

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


def _clamped_controls(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray):
    """Each strand's vertices with the first and last repeated twice more."""
    pts, rad, off = [], [], [0]
    for s in range(len(offsets) - 1):
        i0, i1 = int(offsets[s]), int(offsets[s + 1])
        idx = [i0, i0] + list(range(i0, i1)) + [i1 - 1, i1 - 1]
        pts.append(points[idx])
        rad.append(radii[idx])
        off.append(off[-1] + len(idx))
    return np.concatenate(pts), np.concatenate(rad), np.array(off)


def render(scene: "Scene", spp: int = 64, integrator: str = "direct", max_depth: int = 64, width: int | None = None,
           height: int | None = None, variant: str | None = None, passes: int | None = None, seed: int = 0,
           progress: bool | None = None, hair_params: dict[str, Any] | None = None, hair_bsdf: str = "chiang",
           timing: dict[str, float] | None = None) -> np.ndarray:
    """Reference render of ``scene`` by Mitsuba 3 -> (H, W, 3) float32.

    ``hair_bsdf``: "chiang" (Mitsuba's ``hair`` with the scene's ChiangHair,
    or the one fitted to its KarisHair) or "karis" (the scene's KarisHair
    itself through the ``hairshade_karis`` plugin; needs ``llvm_ad_rgb``).
    The samples are split into ``passes`` renders with different seeds
    (default: 8, or spp if fewer) so that a progress bar can be shown;
    Ctrl-C stops between passes. ``timing``, when given, receives
    ``load_s`` (building and loading the scene) and ``render_s`` (rendering
    and reading back the image), summed over the passes."""
    import sys
    import tempfile
    import time

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
                              timing if timing is not None else {})
    finally:
        if flags is not None:
            dr.set_flag(dr.JitFlag.VCallRecord, flags[0])
            dr.set_flag(dr.JitFlag.LoopRecord, flags[1])


def _render_passes(scene: "Scene", spp: int, integrator: str, max_depth: int, width: int | None, height: int | None,
                   passes: int | None, seed: int, progress: bool | None, hair_params: dict[str, Any] | None,
                   hair_bsdf: str, timing: dict[str, float]) -> np.ndarray:
    import sys
    import tempfile
    import time

    passes = max(1, min(passes or 8, spp))
    show = sys.stderr.isatty() if progress is None else progress
    with tempfile.TemporaryDirectory() as tmp:
        per = [spp // passes + (1 if k < spp % passes else 0) for k in range(passes)]
        acc = None
        start = time.perf_counter()
        timing.update(load_s=0.0, render_s=0.0)
        for k, n in enumerate(per):
            t0 = time.perf_counter()
            d = scene_dict(scene, f"{tmp}/strands.txt", n, integrator, max_depth, width, height, hair_params, hair_bsdf)
            mscene = mi.load_dict(d)
            t1 = time.perf_counter()
            img = np.array(mi.render(mscene, spp=n, seed=seed * 1000 + k), dtype=np.float64) * n
            timing["load_s"] += t1 - t0
            timing["render_s"] += time.perf_counter() - t1
            acc = img if acc is None else acc + img
            if show:
                sys.stderr.write(f"\rmitsuba [{'#' * int(30 * (k + 1) / passes):30s}] pass {k + 1}/{passes} {time.perf_counter() - start:5.1f}s")
                sys.stderr.flush()
        if show:
            sys.stderr.write("\n")
    return (acc / spp).astype(np.float32)[..., :3]
