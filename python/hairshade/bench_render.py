"""Rendering run time against error (``hairshade bench --render``).

Every number of one report is measured in one run (the machines are shared
and noisy; compare ratios, not absolute times). Rows (CSV columns
``section, scene, variant, width, height, threads, spp, ms, rel_mse``):

- ``frame``: the rasterizer's ms/frame (best of ``repeats``) for each example
  scene at 640x360, 1280x720 and 1920x1080, shadow maps built every frame
  (``cold``) and reused from the previous frame (``warm``, a camera move);
  for the strand head also per-vertex shading with reused maps (``vertex``).
- ``error``: the rasterizer at the resolution of the scene's cached Mitsuba
  reference (tests/data; same BSDF on both sides: ChiangHair's far field
  against Mitsuba's ``hair``, or KarisHair against the ``hairshade_karis``
  plugin; direct light with shadows), its time and relMSE there.
- ``mitsuba``: Mitsuba rendering the same scene variant at 1, 4, 16, 64, 256
  spp (seed 1, the reference used seed 0), time and relMSE against the
  reference. The time is the render alone, best of ``repeats`` as for the
  rasterizer: JIT compilation (a warm-up render with the same settings
  first) and scene loading are not counted. The reference's own noise
  sets a floor (tests/test_render.py).
- ``equal_error``: Mitsuba's time at the rasterizer's error (log-log
  interpolation between the two spp that bracket it) over the rasterizer's
  time; ``variant`` says ``interpolated``, ``<=`` (1 spp already reaches it:
  the ratio is an upper bound) or ``>=`` (256 spp do not: a lower bound).
- ``error``, ``mitsuba``, ``equal_error`` on the dense heads of the
  dense-hair comparison (tests/data/dense, 10k strands, 320x180): the
  rasterizer by default and in its most accurate configuration (64 coverage
  samples, dual scattering, traced shadows), against the converged
  path-traced truth (max_depth 64); Mitsuba with that same integrator
  (``path``, max_depth 64) at 1 to 64 spp.
- ``models``: a dense ChiangHair head (the dense-hair reference scene
  ``auburn_key``, 10k strands, 320x180) shaded with ChiangHair's tabulated
  far field and with KarisHair, per pixel and per vertex, alternating.
- ``lod``: the strand head (shadowed light and environment) at 1280x720 at
  strand fractions 1, 1/2, 1/4, 1/8 and ``auto``, per vertex and per
  pixel, shadow maps reused (``warm``) and built (``cold``), with its
  relMSE against the full-strand render of the same settings.
- ``strands``: the strand head with 1k to 100k strands (16 segments), 1280x720.
- ``threads``: the strand head at 1280x720 on one thread and on all.
- ``skip``: each skip on and off on the scene where it acts, with the
  image difference (0 = bit-identical).

The run goes through the steps of ``STEPS`` in order; ``steps`` picks some
of them (``hairshade bench --render-steps dense``), and :func:`merge` puts
their rows in place of the same step's rows of an earlier run's CSV.
"""

from __future__ import annotations

import copy
import json
import math
import os
import tempfile
import time
from typing import Any, Callable, Sequence

import numpy as np

from . import _native
from ._progress import progress
from .references import CASES, EXAMPLES, REFERENCES, KARIS_CASES, comparison_scene, karis_reference_path, karis_scene, reference_path
from .render import read_exr, rel_mse, render
from .scene import Scene

RESOLUTIONS = ((640, 360), (1280, 720), (1920, 1080))
SPP = (1, 4, 16, 64, 256)
STRANDS = (1000, 3000, 10000, 30000, 100000)
KEYS = ["section", "scene", "variant", "width", "height", "threads", "spp", "ms", "rel_mse"]
STEPS = ("frame", "models", "lod", "error", "dense", "strands", "threads", "skip")


def _example(name: str) -> dict[str, Any]:
    with open(os.path.join(EXAMPLES, f"{name}.json")) as f:
        return json.load(f)


def _scene(d: dict[str, Any], allow_outside: bool = False) -> Scene:
    return Scene.from_dict(d, base_dir=os.path.abspath(EXAMPLES), allow_outside=allow_outside)


def _sphere_obj(path: str, center: list[float], radius: float, rings: int = 100, sectors: int = 100) -> None:
    """A closed UV sphere (shared vertices, faces wound outwards) as an OBJ
    file: 2·rings·sectors − 2·sectors triangles."""
    c = np.asarray(center, float)
    lines = [f"v {c[0]:.7g} {c[1] + radius:.7g} {c[2]:.7g}"]
    for i in range(1, rings):
        th = math.pi * i / rings
        for j in range(sectors):
            ph = 2 * math.pi * j / sectors
            p = c + radius * np.array([math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)])
            lines.append("v " + " ".join(f"{x:.7g}" for x in p))
    lines.append(f"v {c[0]:.7g} {c[1] - radius:.7g} {c[2]:.7g}")
    ring = lambda i, j: 2 + (i - 1) * sectors + j % sectors  # noqa: E731 (1-based OBJ index)
    bottom = 2 + (rings - 1) * sectors
    for j in range(sectors):
        lines.append(f"f 1 {ring(1, j + 1)} {ring(1, j)}")
        for i in range(1, rings - 1):
            lines.append(f"f {ring(i, j)} {ring(i, j + 1)} {ring(i + 1, j + 1)} {ring(i + 1, j)}")
        lines.append(f"f {bottom} {ring(rings - 1, j)} {ring(rings - 1, j + 1)}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def _best_ms(fn: Callable[[], Any], repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best * 1e3


def _row(section: str, scene: str, variant: str = "", width: int = 0, height: int = 0, threads: str = "all",
         spp: int = 0, ms: float = math.nan, rel: float = math.nan) -> dict[str, Any]:
    return dict(section=section, scene=scene, variant=variant, width=width, height=height, threads=threads, spp=spp,
                ms=ms, rel_mse=rel)


def equal_error_ratio(raster_ms: float, raster_err: float, mitsuba: list[tuple[float, float]]) -> tuple[float, str]:
    """(Mitsuba time at the rasterizer's error / rasterizer time, kind) from
    Mitsuba's (ms, rel_mse) points in increasing spp."""
    if not mitsuba:
        return math.nan, "n/a"
    if mitsuba[0][1] <= raster_err:
        return mitsuba[0][0] / raster_ms, "<="
    for (t0, e0), (t1, e1) in zip(mitsuba, mitsuba[1:]):
        if e1 <= raster_err < e0:
            f = (math.log(raster_err) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))) / raster_ms, "interpolated"
    return mitsuba[-1][0] / raster_ms, ">="


def valid_steps(steps: tuple[str, ...]) -> bool:
    """Whether ``steps`` are some names of ``STEPS`` (at least one)."""
    return bool(steps) and all(s in STEPS for s in steps)


def render_runtime_vs_error(fast: bool = False, repeats: int = 3, data_dir: str | None = None,
                            progress_bar: bool = True, steps: tuple[str, ...] | None = None) -> list[dict[str, Any]]:
    """All rows (see the module doc), or those of ``steps`` (names of
    ``STEPS``). ``fast``: small resolutions and spp, fewer strands (for the
    notebook and the tests)."""
    if steps is not None and not valid_steps(steps):
        raise ValueError(f"steps: expected names among {', '.join(STEPS)}, got {list(steps)!r}")
    data = data_dir or REFERENCES
    rows: list[dict[str, Any]] = []
    resolutions = ((160, 90), (320, 180)) if fast else RESOLUTIONS
    spps = (1, 4) if fast else SPP
    strands = (300, 1000, 3000) if fast else STRANDS
    head_strands = 3000 if fast else None
    todo = [s for s in STEPS if steps is None or s in steps]
    bar = progress(todo, desc="render bench", enabled=progress_bar)

    def head(n: int | None = None) -> dict[str, Any]:
        d = _example("strand_head")
        if n is not None:
            d["hair"]["generate"]["strands"] = n
        return d

    for step in bar:
        first = len(rows)
        if step == "frame":
            for name in ("single_strand", "backlit_bundle", "strand_head", "card_head"):
                d = head(head_strands) if name == "strand_head" else _example(name)
                s = _scene(d)
                for w, h in resolutions:
                    cold = _best_ms(lambda: render_switched(s, w, h, off=("reuse_shadow_maps",)), repeats)
                    warm = _best_ms(lambda: render(s, w, h, progress=False), repeats)
                    rows.append(_row("frame", name, "cold", w, h, ms=cold))
                    rows.append(_row("frame", name, "warm", w, h, ms=warm))
                    if name == "strand_head":
                        # per-vertex shading (on the vector kernel), maps reused
                        vtx = _best_ms(lambda: render(s, w, h, shading="vertex", progress=False), repeats)
                        rows.append(_row("frame", name, "vertex", w, h, ms=vtx))
        elif step == "models":
            rows += _models(fast, repeats)
        elif step == "lod":
            rows += _lod(fast, repeats, head())
        elif step == "error":
            cases = [(n, c, comparison_scene(n), reference_path(n, data), "chiang") for n, c in CASES.items()]
            cases += [(n, c, karis_scene(n), karis_reference_path(n, data), "karis") for n, c in KARIS_CASES.items()
                      if n == "card_head"]
            for name, c, s, ref_path, bsdf in cases:
                if not os.path.exists(ref_path):
                    continue
                ref = read_exr(ref_path)
                w, h = (c["width"], c["height"]) if not fast else (c["width"] // 2, c["height"] // 2)
                if fast:
                    ref = ref.reshape(h, 2, w, 2, 3).mean(axis=(1, 3))
                img = render(s, w, h, progress=False)
                t = _best_ms(lambda: render_switched(s, w, h, off=("reuse_shadow_maps",)), repeats)
                e = rel_mse(img, ref)
                rows.append(_row("error", name, f"rasterizer ({bsdf})", w, h, ms=t, rel=e))
                pts = []
                try:
                    from . import mitsuba as hm

                    for spp in spps:
                        if bsdf == "karis" and spp > 64:
                            continue  # the Python BSDF plugin is slow: 64 spp is enough to bracket
                        # warm-up with these very settings: JIT compilation of the
                        # kernels (drjit may compile anew per spp and seed) is not counted
                        # Mitsuba at its best: the B-spline of the vertices, as
                        # the references (hairshade.mitsuba.LoadedScene)
                        hm.render(s, spp=spp, integrator="direct", width=w, height=h, seed=1, passes=1,
                                  progress=False, hair_bsdf=bsdf, curve="bspline")
                        # best of the repeats, as for the rasterizer (one render
                        # of a JIT-compiled kernel can catch the host's noise)
                        tm = math.inf
                        for _ in range(repeats):
                            timing: dict[str, float] = {}
                            m = hm.render(s, spp=spp, integrator="direct", width=w, height=h, seed=1, passes=1,
                                          progress=False, hair_bsdf=bsdf, timing=timing, curve="bspline")
                            tm = min(tm, timing["render_s"] * 1e3)  # scene loading not counted
                        em = rel_mse(m, ref)
                        pts.append((tm, em))
                        rows.append(_row("mitsuba", name, f"mitsuba ({bsdf})", w, h, "mitsuba", spp, tm, em))
                except (ImportError, ValueError):
                    pass  # no Mitsuba, or no JIT variant for the KarisHair plugin
                ratio, kind = equal_error_ratio(t, e, pts)
                rows.append(_row("equal_error", name, kind, w, h, ms=ratio, rel=e))
        elif step == "dense":
            rows += _dense(fast, repeats, data)
        elif step == "strands":
            for n in strands:
                s = _scene(head(n))
                w, h = (320, 180) if fast else (1280, 720)
                t = _best_ms(lambda: render_switched(s, w, h, off=("reuse_shadow_maps",)), repeats)
                rows.append(_row("strands", "strand_head", f"{n} strands", w, h, ms=t))
        elif step == "threads":
            s = _scene(head(head_strands))
            w, h = (320, 180) if fast else (1280, 720)
            for threads in ("1", "all"):
                _native.set_single_threaded(threads == "1")
                try:
                    t = _best_ms(lambda: render_switched(s, w, h, off=("reuse_shadow_maps",)), repeats)
                finally:
                    _native.set_single_threaded(False)
                rows.append(_row("threads", "strand_head", "", w, h, threads, ms=t))
        elif step == "skip":
            rows += _skips(fast, repeats, head(head_strands))
        for r in rows[first:]:
            r["step"] = step
    return rows


def step_of(row: dict[str, Any]) -> str:
    """The step of ``STEPS`` a row comes from (rows read back from a CSV do
    not carry it: the dense heads' rows are ``dense``'s, the sections
    ``error``, ``mitsuba`` and ``equal_error`` otherwise ``error``'s)."""
    if "step" in row:
        return row["step"]
    if row["section"] in ("error", "mitsuba", "equal_error"):
        return "dense" if row["scene"] in DENSE_SCENES else "error"
    return row["section"]


def merge(old: list[dict[str, Any]], new: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """An earlier run's rows with those of the steps ``new`` ran replaced by
    ``new``'s, in the order of ``STEPS``."""
    ran = {step_of(r) for r in new}
    rows = [r for r in old if step_of(r) not in ran] + new
    return sorted(rows, key=lambda r: STEPS.index(step_of(r)))  # stable: each step keeps its order


def _models(fast: bool, repeats: int) -> list[dict[str, Any]]:
    """The same dense head shaded by ChiangHair and by KarisHair."""
    path = os.path.join(REFERENCES, "dense", "auburn_key.json")
    if not os.path.exists(path):
        return []  # the dense references live in a source checkout's tests/data
    with open(path) as f:
        d = json.load(f)
    if fast:
        d["hair"]["generate"]["strands"] = 2000
    w, h = (160, 90) if fast else tuple(d["camera"]["resolution"])
    karis = copy.deepcopy(d)
    karis["hair"]["material"] = {"model": "karis"}
    scenes = {"ChiangHair": Scene.from_dict(d), "KarisHair": Scene.from_dict(karis)}
    out = []
    for shading in ("pixel", "vertex"):
        best = {k: math.inf for k in scenes}
        for name, s in scenes.items():  # warm-up: tables, shadow maps
            render(s, w, h, shading=shading, progress=False)
        for _ in range(max(repeats, 3)):
            for name, s in scenes.items():
                best[name] = min(best[name], _best_ms(lambda: render(s, w, h, shading=shading, progress=False), 1))
        for name in scenes:
            out.append(_row("models", "auburn_key", f"{name} {shading}", w, h, ms=best[name]))
    return out


DENSE_SCENES = ("auburn_key", "blond_back", "black_top", "brown_side", "blond_env", "ginger_two")
DENSE_SPP = (1, 4, 16, 64)
# The rasterizer's configurations on the dense heads: its defaults (MLAB, 8
# f32 layers), the same layers packed into 64 bits (docs/packed_layers.md),
# the strands drawn as the references' B-spline (docs/curves.md; "hair_curve"
# goes to the scene's hair.curve), guide-strand lighting, and the most accurate one of
# docs/dense_hair.md.
DENSE_CONFIGS: dict[str, dict[str, Any]] = {
    "default": {},
    "mlab 8 rgb9e5": dict(transparency={"mlab": {"layers": 8, "format": "rgb9e5"}}),
    "mlab 8 r11g11b10": dict(transparency={"mlab": {"layers": 8, "format": "r11g11b10"}}),
    "bspline 8 px": dict(hair_curve={"bspline": {"pixels": 8}}),
    # a tenth of the strands lit, the rest taking their guides' lighting
    # (docs/guides.md): everything, as RE4's prototype, or only the scattered terms
    "guides 1/10 all": dict(guides=0.1, guide_terms="all"),
    "guides 1/10 scattered": dict(guides=0.1),
    "coverage 64+dual+traced": dict(
        transparency="coverage", samples=64, multiple_scattering="dual", shadow_model="traced"
    ),
}


def _dense(fast: bool, repeats: int, data: str) -> list[dict[str, Any]]:
    """The dense ChiangHair heads against their converged path-traced truth
    (tests/data/dense: max_depth 64): the rasterizer per configuration, and
    Mitsuba's `path` (max_depth 64, the truth's own integrator) from 1 to 64
    spp, each best of ``repeats`` after a warm-up with the same settings."""
    out: list[dict[str, Any]] = []
    names = ("black_top",) if fast else DENSE_SCENES
    for name in names:
        path = os.path.join(data, "dense", f"{name}.json")
        if not os.path.exists(path):
            continue
        with open(path) as f:
            d = json.load(f)
        ref = read_exr(os.path.join(data, "dense", f"{name}.exr"))[..., :3]
        w, h = d["camera"]["resolution"]
        if fast:
            w, h = w // 2, h // 2
            ref = ref.reshape(h, 2, w, 2, 3).mean(axis=(1, 3))
        for label, opts in DENSE_CONFIGS.items():
            dd = copy.deepcopy(d)
            opts = dict(opts)
            if "hair_curve" in opts:
                dd["hair"]["curve"] = opts.pop("hair_curve")
            dd["render"].update(opts)
            s = Scene.from_dict(dd)
            img = render(s, w, h, progress=False)
            t = _best_ms(lambda: render_switched(s, w, h, off=("reuse_shadow_maps",)), repeats)
            out.append(_row("error", name, f"rasterizer (chiang, {label})", w, h, ms=t, rel=rel_mse(img, ref)))
        pts = []
        try:
            from . import mitsuba as hm

            s = Scene.from_dict(d)
            for spp in DENSE_SPP[:2] if fast else DENSE_SPP:
                kw = dict(spp=spp, integrator="path", max_depth=64, width=w, height=h, seed=1, passes=1, progress=False,
                          curve="bspline")  # Mitsuba at its best, as the references
                hm.render(s, **kw)  # warm-up: JIT compilation with these settings
                tm = math.inf
                for _ in range(repeats):
                    timing: dict[str, float] = {}
                    m = hm.render(s, timing=timing, **kw)
                    tm = min(tm, timing["render_s"] * 1e3)
                pts.append((tm, rel_mse(m, ref)))
                out.append(_row("mitsuba", name, "mitsuba path (chiang)", w, h, "mitsuba", spp, tm, pts[-1][1]))
        except (ImportError, ValueError):
            pass
        for r in [r for r in out if r["section"] == "error" and r["scene"] == name]:
            ratio, kind = equal_error_ratio(r["ms"], r["rel_mse"], pts)
            label = r["variant"][len("rasterizer (chiang, "):-1]
            out.append(_row("equal_error", name, f"{kind} ({label})", w, h, ms=ratio, rel=r["rel_mse"]))
    return out


LOD_FRACTIONS: tuple[float | str, ...] = (1.0, 0.5, 0.25, 0.125, "auto")


def _lod(fast: bool, repeats: int, head: dict[str, Any]) -> list[dict[str, Any]]:
    """Time and error against the full-strand render per strand fraction."""
    w, h = (320, 180) if fast else (1280, 720)
    if fast:
        head["hair"]["generate"]["strands"] = 3000
    s = _scene(head)
    out = []
    for shading in ("vertex", "pixel"):
        full = render(s, w, h, shading=shading, progress=False)
        for lod in LOD_FRACTIONS:
            img, st = render(s, w, h, shading=shading, lod=lod, progress=False, return_stats=True)
            warm = _best_ms(lambda: render(s, w, h, shading=shading, lod=lod, progress=False), repeats)
            cold = _best_ms(lambda: render_switched(s, w, h, shading=shading, lod=lod, off=("reuse_shadow_maps",),
                                           progress=False), repeats)
            label = f"{shading} lod={lod} ({st['lod_fraction']:.3f}, {st['strands_drawn']} strands)"
            e = rel_mse(img, full)
            out.append(_row("lod", "strand_head", f"{label} warm", w, h, ms=warm, rel=e))
            out.append(_row("lod", "strand_head", f"{label} cold", w, h, ms=cold, rel=e))
    return out


def _skips(fast: bool, repeats: int, head: dict[str, Any]) -> list[dict[str, Any]]:
    """Each skip on and off: (ms on, ms off, max |difference|)."""
    w, h = (320, 180) if fast else (1280, 720)
    out = []
    s = _scene(head)
    lit = copy.deepcopy(head)
    # A scene where light culling acts: the head's lights plus four dim
    # point lights far away (fill lights whose bound falls below 1e-4).
    for k in range(4):
        a = 2 * math.pi * k / 4
        lit["lights"].append({"type": "point", "position": [30 * math.cos(a), 5.0, 30 * math.sin(a)],
                              "intensity": [0.01, 0.01, 0.01], "shadows": False})
    s_lit = _scene(lit)
    shadowed = copy.deepcopy(lit)
    for light in shadowed["lights"][-4:]:
        light["shadows"] = True
    s_shadowed = _scene(shadowed)
    # The head as a closed 20k-triangle OBJ mesh instead of the analytic sphere.
    meshed = copy.deepcopy(head)
    sphere = meshed.pop("meshes")[0]
    with tempfile.TemporaryDirectory(prefix="hairshade_bench_") as mesh_dir:
        _sphere_obj(os.path.join(mesh_dir, "head.obj"), sphere["center"], sphere["radius"])
        meshed["meshes"] = [{"type": "obj", "file": os.path.join(mesh_dir, "head.obj"), "albedo": sphere["albedo"]}]
        # the triangles are read here, from the benchmark's own temporary folder
        s_meshed = _scene(meshed, allow_outside=True)
    close = copy.deepcopy(head)
    close["camera"]["fov"] = 10.0  # a close-up: most of the hair off screen
    s_close = _scene(close)
    scattered = copy.deepcopy(head)
    scattered["hair"]["material"]["scatter"] = 0.0
    s_scatter0 = _scene(scattered)
    # (label, scene, settings, speed-ups off when on, off when off)
    cases: list[tuple[str, Any, dict[str, Any], tuple[str, ...], tuple[str, ...]]] = [
        ("skip_unused (MS block at Scatter 0)", s_scatter0, {}, (), ("skip_unused",)),
        ("frustum_culling (close-up, per-vertex shading)", s_close, dict(shading="vertex"), (), ("frustum_culling",)),
        ("frustum_culling (close-up, per-pixel shading)", s_close, {}, (), ("frustum_culling",)),
        ("backface_culling (head as a closed 20k-triangle mesh)", s_meshed, {}, (), ("backface_culling",)),
        ("opaque_culling (hair behind the head)", s, {}, (), ("opaque_culling",)),
        ("vertices_on_demand (per-vertex shading, hair behind hair)", s, {}, (), ("vertices_on_demand",)),
        ("nearest_first (coverage 16, traced shadows, dual)", s,
         dict(transparency={"coverage": {"samples": 16}}, shadows="traced", multiple_scattering="dual",
              shading="split"), (), ("nearest_first",)),
        ("reuse_shadow_maps (camera moved)", s, {}, (), ("reuse_shadow_maps",)),
        ("light culling (4 dim far point lights)", s_lit, dict(light_cull_threshold=1e-4), (), ()),
        # approximate, bounded: hair behind nearly opaque hair (cutoff 1e-3)
        ("hair culling (behind opaque hair, cutoff 1e-3)", s, dict(transparency={"mlab": {"cull_transmittance": 1e-3}}),
         (), ()),
        # the head's material has Scatter > 0: skip_unused acts on the maps alone
        ("no map for lights culled everywhere (4 shadowed dim lights)", s_shadowed, {}, (), ("skip_unused",)),
    ]
    cases_off = {
        "light culling (4 dim far point lights)": dict(light_cull_threshold=0.0),
        "hair culling (behind opaque hair, cutoff 1e-3)": dict(transparency={"mlab": {"cull_transmittance": 0.0}}),
    }
    for label, scene, settings, on_off, off_off in cases:
        if "reuse_shadow_maps" not in off_off:
            on_off, off_off = on_off + ("reuse_shadow_maps",), off_off + ("reuse_shadow_maps",)
        # KarisHair with its own multiple-scattering term: the path the skips act on
        on_settings = {"quality": "fast", **settings}
        off_settings = {**on_settings, **cases_off.get(label, {})}
        frame_on = lambda: render_switched(scene, w, h, off=on_off, **on_settings)  # noqa: E731
        frame_off = lambda: render_switched(scene, w, h, off=off_off, **off_settings)  # noqa: E731
        a, b = frame_on(), frame_off()
        diff = float(np.abs(a - b).max())
        # on and off alternate, so both see the same machine load
        t_on = t_off = math.inf
        for _ in range(repeats):
            t_on = min(t_on, _best_ms(frame_on, 1))
            t_off = min(t_off, _best_ms(frame_off, 1))
        out.append(_row("skip", "strand_head", f"{label} on", w, h, ms=t_on, rel=diff))
        out.append(_row("skip", "strand_head", f"{label} off", w, h, ms=t_off, rel=diff))
    return out


def summary(rows: list[dict[str, Any]]) -> str:
    """The report as text (what ``hairshade bench --render`` prints)."""
    out = ["Rasterizer ms/frame (best of the repeats; cold: shadow maps built, warm: reused, vertex: per-vertex shading)"]
    for r in rows:
        if r["section"] == "frame":
            out.append(f"  {r['scene']:15s} {r['width']:5d}x{r['height']:<5d} {r['variant']:6s} {r['ms']:9.1f} ms")
    out.append("Error against the converged Mitsuba reference (same BSDF), at its resolution")
    for r in rows:
        if r["section"] in ("error", "mitsuba"):
            spp = f"{r['spp']:4d} spp" if r["section"] == "mitsuba" else "        "
            out.append(f"  {r['scene']:15s} {r['variant']:22s} {spp} {r['ms']:10.1f} ms  relMSE {r['rel_mse']:.3e}")
        if r["section"] == "equal_error":
            out.append(f"  {r['scene']:15s} Mitsuba time at equal error / rasterizer time: {r['variant']} {r['ms']:.3g}x")
    out.append("Same dense head, ChiangHair (tabulated far field) and KarisHair")
    m = {r["variant"]: r for r in rows if r["section"] == "models"}
    for shading in ("pixel", "vertex"):
        c, k = m.get(f"ChiangHair {shading}"), m.get(f"KarisHair {shading}")
        if c and k:
            out.append(f"  {shading:6s} ChiangHair {c['ms']:8.1f} ms  KarisHair {k['ms']:8.1f} ms  ratio {c['ms'] / k['ms']:.2f}")
    out.append("Strand level of detail (time, relMSE against the full-strand render)")
    for r in rows:
        if r["section"] == "lod":
            out.append(f"  {r['variant']:52s} {r['width']}x{r['height']} {r['ms']:8.1f} ms  relMSE {r['rel_mse']:.2e}")
    out.append("Scaling")
    for r in rows:
        if r["section"] == "strands":
            out.append(f"  {r['variant']:15s} {r['width']}x{r['height']} {r['ms']:9.1f} ms")
        if r["section"] == "threads":
            out.append(f"  threads {r['threads']:6s} {r['width']}x{r['height']} {r['ms']:9.1f} ms")
    out.append("Skips (on / off, image max |difference|)")
    sk = [r for r in rows if r["section"] == "skip"]
    for on, off in zip(sk[::2], sk[1::2]):
        name = on["variant"][:-3]
        out.append(f"  {name:42s} {on['ms']:8.1f} / {off['ms']:8.1f} ms  x{off['ms'] / on['ms']:.2f}  diff {on['rel_mse']:.2e}")
    return "\n".join(out)


def write_csv(rows: list[dict[str, Any]], path: str) -> None:
    with open(path, "w") as f:
        f.write(",".join(KEYS) + "\n")
        for r in rows:
            f.write(",".join(f'"{r[k]}"' if k == "variant" else (f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]))
                             for k in KEYS) + "\n")


def read_csv(path: str) -> list[dict[str, Any]]:
    import csv

    with open(path) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("width", "height", "spp"):
            r[k] = int(r[k])
        for k in ("ms", "rel_mse"):
            r[k] = float(r[k])
    return rows


def plot(rows: list[dict[str, Any]], path: str, dpi: int = 130) -> None:
    """Left: time against error per scene (a colour each: Mitsuba's spp
    sweep as a line, the rasterizer's configurations as markers, a shape
    each). Middle: ms/frame against strand count. Right: the level of
    detail's time against error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(18, 5.5))
    scenes = sorted({r["scene"] for r in rows if r["section"] in ("error", "mitsuba")})
    configs: list[str] = []
    for r in rows:
        if r["section"] == "error" and r["variant"] not in configs:
            configs.append(r["variant"])
    markers = "*sDv^<>ph8"
    handles = []
    for k, name in enumerate(scenes):
        color = f"C{k % 10}"
        m = [r for r in rows if r["section"] == "mitsuba" and r["scene"] == name]
        if m:
            ax.plot([r["ms"] for r in m], [r["rel_mse"] for r in m], "o-", color=color, ms=3)
            for r in m:
                ax.annotate(f"{r['spp']}", (r["ms"], r["rel_mse"]), fontsize=6, xytext=(2, 2), textcoords="offset points")
        for r in rows:
            if r["section"] == "error" and r["scene"] == name:
                mk = markers[configs.index(r["variant"]) % len(markers)]
                ax.plot(r["ms"], r["rel_mse"], mk, color=color, ms=8 if mk == "*" else 5)
        handles.append(Line2D([], [], color=color, marker="o", ms=3, label=name))
    for j, c in enumerate(configs):
        mk = markers[j % len(markers)]
        handles.append(Line2D([], [], color="0.3", marker=mk, ls="", ms=8 if mk == "*" else 5, label=c))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ms per frame (reference resolution)")
    ax.set_ylabel("relMSE vs converged Mitsuba (same BSDF)")
    ax.set_title("scene: colour (line: Mitsuba's spp); rasterizer configuration: marker", fontsize=8)
    ax.legend(handles=handles, fontsize=6, loc="upper left", bbox_to_anchor=(0.0, -0.14), ncol=3, frameon=False)
    s = [r for r in rows if r["section"] == "strands"]
    if s:
        bx.plot([int(r["variant"].split()[0]) for r in s], [r["ms"] for r in s], "o-")
        bx.set_xscale("log")
        bx.set_yscale("log")
        bx.set_xlabel(f"strands (16 segments), {s[0]['width']}x{s[0]['height']}")
        bx.set_ylabel("ms per frame")
    lod = [r for r in rows if r["section"] == "lod" and r["variant"].endswith(" warm")]
    for k, shading in enumerate(("vertex", "pixel")):
        pts = [r for r in lod if r["variant"].startswith(shading) and "lod=auto" not in r["variant"]]
        auto = [r for r in lod if r["variant"].startswith(shading) and "lod=auto" in r["variant"]]
        if pts:
            floor = min((r["rel_mse"] for r in pts if r["rel_mse"] > 0), default=1e-6) / 10
            cx.plot([r["ms"] for r in pts], [max(r["rel_mse"], floor) for r in pts], "o-", color=f"C{k}",
                    label=f"per {shading}, fractions 1 (error 0, drawn at {floor:.0e}) to 1/8")
        for r in auto:
            cx.plot(r["ms"], max(r["rel_mse"], 1e-9), "*", color=f"C{k}", ms=12, label=f"per {shading}, auto")
    if lod:
        cx.set_xscale("log")
        cx.set_yscale("log")
        cx.set_xlabel(f"ms per frame, strand head {lod[0]['width']}x{lod[0]['height']} (maps reused)")
        cx.set_ylabel("relMSE vs the full-strand render")
        cx.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def render_switched(scene: Any, width: int | None = None, height: int | None = None, *,
                    off: Sequence[str] = (), progress: bool | None = False, return_stats: bool = False,
                    **settings: Any) -> Any:
    """:func:`hairshade.render` with some of the exact speed-ups switched off
    (``off``: names among :data:`hairshade.options.SPEEDUPS`), to measure
    what each saves and to test that it never changes the image. They are
    not render settings: on, the image is the same."""
    from . import options as _options
    from .render import _render

    if isinstance(off, str) or not all(isinstance(k, str) and k in _options.SPEEDUPS for k in off):
        raise ValueError(f"off: expected names among {', '.join(_options.SPEEDUPS)}, got {off!r:.120}")
    opts = scene.options(**settings)
    opts.update({k: False for k in off})
    return _render(scene, width, height, progress, return_stats, opts)
