"""Rendering with the software rasterizer, and images in and out."""

from __future__ import annotations

import os
from typing import Any, Literal, overload

import numpy as np
import numpy.typing as npt

from . import _native
from ._progress import Bar
from .scene import Scene

Image = npt.NDArray[np.float32]  # (H, W, 3) linear radiance


@overload
def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    transparency: str | None = None,
    layers: int | None = None,
    samples: int | None = None,
    shading: str | None = None,
    frustum_culling: bool | None = None,
    backface_culling: bool | None = None,
    opaque_culling: bool | None = None,
    skip_unused: bool | None = None,
    reuse_shadow_maps: bool | None = None,
    light_cull_threshold: float | None = None,
    multiple_scattering: str | None = None,
    lod: float | str | None = None,
    hair_cull_transmittance: float | None = None,
    progress: bool | None = None,
    return_stats: Literal[False] = False,
) -> Image: ...


@overload
def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    transparency: str | None = None,
    layers: int | None = None,
    samples: int | None = None,
    shading: str | None = None,
    frustum_culling: bool | None = None,
    backface_culling: bool | None = None,
    opaque_culling: bool | None = None,
    skip_unused: bool | None = None,
    reuse_shadow_maps: bool | None = None,
    light_cull_threshold: float | None = None,
    multiple_scattering: str | None = None,
    lod: float | str | None = None,
    hair_cull_transmittance: float | None = None,
    progress: bool | None = None,
    *,
    return_stats: Literal[True],
) -> tuple[Image, dict[str, Any]]: ...


@overload
def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    transparency: str | None = None,
    layers: int | None = None,
    samples: int | None = None,
    shading: str | None = None,
    frustum_culling: bool | None = None,
    backface_culling: bool | None = None,
    opaque_culling: bool | None = None,
    skip_unused: bool | None = None,
    reuse_shadow_maps: bool | None = None,
    light_cull_threshold: float | None = None,
    multiple_scattering: str | None = None,
    lod: float | str | None = None,
    hair_cull_transmittance: float | None = None,
    progress: bool | None = None,
    return_stats: bool = False,
) -> Image | tuple[Image, dict[str, Any]]: ...


def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    transparency: str | None = None,
    layers: int | None = None,
    samples: int | None = None,
    shading: str | None = None,
    frustum_culling: bool | None = None,
    backface_culling: bool | None = None,
    opaque_culling: bool | None = None,
    skip_unused: bool | None = None,
    reuse_shadow_maps: bool | None = None,
    light_cull_threshold: float | None = None,
    multiple_scattering: str | None = None,
    lod: float | str | None = None,
    hair_cull_transmittance: float | None = None,
    progress: bool | None = None,
    return_stats: bool = False,
) -> Image | tuple[Image, dict[str, Any]]:
    """Renders ``scene`` -> (H, W, 3) float32 linear radiance.

    ``width``/``height`` override the scene's resolution (if only one is
    given the other follows the scene's aspect ratio). Every other keyword
    overrides the scene's render option of the same name (None: the
    scene's value, whose default is given here):

    - ``transparency`` ("mlab", default; "sorted"; or "coverage": hair as
      opaque sub-pixel geometry, the nearest fiber per coverage sample, so
      disjoint thin strands add up to their true area and only visible
      fragments are shaded), ``layers`` (MLAB layers, 1 to 64, default 4),
      ``samples`` (coverage samples per pixel, 1 to 64, default 16),
      ``shading`` ("pixel", default, or "vertex");
    - ``frustum_culling`` (default on) drops strand segments that reach no
      pixel before shading them (per-vertex shading then shades only the
      vertices of the remaining segments; exact: the image is identical);
    - ``backface_culling`` (on) skips the back faces of OBJ meshes that are
      closed, consistently oriented outwards, seen from outside and wholly
      in front of the camera (their back faces are always hidden; other
      meshes are drawn two-sided);
    - ``opaque_culling`` (on) skips hair behind a tile's farthest opaque
      surface (exact; off only to measure it);
    - ``skip_unused`` (on) compiles out model terms that cannot contribute
      (KarisHair's MS block at Scatter 0; exact) and builds no shadow map
      for a light that light culling skips at every hair point (KarisHair;
      exact: the map is never read);
    - ``reuse_shadow_maps`` (on) takes the shadow maps of an earlier render
      in this process when the geometry, the light and the shadow settings
      are the same (a camera move; exact, the maps are deterministic; at
      most 4 maps, 32 MiB at the default size, are kept);
    - ``light_cull_threshold`` (1e-4): with KarisHair, a light whose
      irradiance times the model's upper bound is below this radiance at a
      shading point is skipped there (on opaque surfaces: irradiance/pi); a
      pixel changes by at most threshold x lights (0 turns it off; the
      stats report the number skipped and the largest skipped bound);
    - ``multiple_scattering`` ("auto", default: KarisHair's own term for
      KarisHair, none for the other models; "none"; "karis", KarisHair only;
      "dual", ChiangHair and KarisHair: dual scattering through the fiber
      density grid, see the scene format's ``render.multiple_scattering``);
    - ``lod`` (1, all strands): the fraction of the strands drawn, in
      (0, 1], each drawn ``1/lod`` times as wide so that the hair's area
      and opacity are kept (a fixed pseudo-random subset, nested as the
      fraction grows), or "auto": strands thinner than 2 pixels on screen
      are drawn as fewer, wider ones (at least 1/8 of them); the stats
      report ``lod_fraction`` and ``strands_drawn``;
    - ``hair_cull_transmittance`` (1e-3; 0 turns it off): with MLAB and
      sorted transparency, a tile's strands are drawn front to back and,
      per pixel, the hair behind the depth where the transmittance of the
      hair drawn so far falls below this value is skipped, as is the
      opaque surface behind it: what is left out is at most this value
      times its radiance (stats: ``culled_behind_hair``). Drawn front to
      back, MLAB merges its farthest layers in depth order, which makes it
      closer to the exact sorted composite than in scene order.

    Ranges are checked by the renderer; a ``ValueError`` names the option.
    ``progress``: a progress bar (tqdm's when installed; default: where it
    can be seen, a terminal or a notebook). Ctrl-C stops the render
    (KeyboardInterrupt)."""
    cam = dict(scene.camera)
    if width is not None or height is not None:
        for name, v in (("width", width), ("height", height)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 16384):
                raise ValueError(f"{name}: expected an integer in [1, 16384], got {v!r:.80}")
        w0, h0 = cam["width"], cam["height"]
        w = int(width) if width is not None else max(1, round(int(height) * w0 / h0))
        h = int(height) if height is not None else max(1, round(int(width) * h0 / w0))
        cam["width"], cam["height"] = w, h
    options = dict(scene.render)
    overrides = dict(
        transparency=transparency, layers=layers, samples=samples, shading=shading, frustum_culling=frustum_culling,
        backface_culling=backface_culling, opaque_culling=opaque_culling, skip_unused=skip_unused,
        reuse_shadow_maps=reuse_shadow_maps, light_cull_threshold=light_cull_threshold,
        multiple_scattering=multiple_scattering, lod=lod, hair_cull_transmittance=hair_cull_transmittance,
    )
    options.update({k: v for k, v in overrides.items() if v is not None})
    with Bar(0, "render", unit="tile", enabled=progress) as bar:
        flat, stats = _native.render(_native_scene(scene, cam), options, bar.update_to if progress is not False else None)
    img = flat.reshape(cam["height"], cam["width"], 3)
    return (img, dict(stats)) if return_stats else img


def _native_scene(scene: Scene, cam: dict[str, Any]) -> dict[str, Any]:
    """The scene as the flat arrays the renderer takes."""
    f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32).reshape(-1)  # noqa: E731
    cards = scene.cards
    meshes = scene.obj_meshes
    return dict(
        camera=(cam["position"], cam["target"], cam["up"], cam["fov"], cam["width"], cam["height"]),
        lights=[(l["type"], l["vector"], l["intensity"], l["shadows"]) for l in scene.lights],
        environment=None if scene.environment_sh is None else [float(x) for x in scene.environment_sh.reshape(-1)],
        points=f32(scene.points),
        radii=f32(scene.radii),
        offsets=np.ascontiguousarray(scene.offsets, dtype=np.uint32),
        spheres=[(s["center"], s["radius"], s["albedo"]) for s in scene.spheres],
        hair=scene.hair._native,
        cards=None if cards is None else dict(
            corners=f32(cards["corners"]), uvs=f32(cards["uvs"]), tangents=f32(cards["tangents"]),
            texture=np.ascontiguousarray(cards["texture"], dtype=np.uint32),
            textures=[(t.shape[1], t.shape[0], f32(t)) for t in cards["textures"]],
            fibers=None if cards["fibers"] is None else (
                f32(cards["fibers"][0]), f32(cards["fibers"][1]), cards["fibers"][2]),
        ),
        triangles=None if not meshes else (
            f32(np.concatenate([m["triangles"].reshape(-1) for m in meshes])),  # positions
            f32(np.concatenate([np.tile(np.asarray(m["albedo"], np.float32), len(m["triangles"])) for m in meshes])),
            np.concatenate([np.full(len(m["triangles"]), i, np.uint32) for i, m in enumerate(meshes)]),  # mesh index
        ),
    )


def write_exr(path: str | os.PathLike[str], image: npt.ArrayLike) -> None:
    """Writes an (H, W, 3) image as a float32 RGB OpenEXR file."""
    a = np.ascontiguousarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image: expected shape (H, W, 3), got {a.shape}")
    _native.write_exr(os.fspath(path), (a.shape[1], a.shape[0], a.reshape(-1)))


def read_exr(path: str | os.PathLike[str], max_pixels: int | None = None) -> Image:
    """Reads the RGB channels of an OpenEXR file -> (H, W, 3) float32.
    A file declaring more than ``max_pixels`` (default 2^28) pixels, or
    more than its size can hold, is refused (ValueError) before its pixels
    are allocated; MemoryError when they cannot be."""
    w, h, data = _native.read_exr(os.fspath(path), max_pixels)
    return data.reshape(h, w, 3)


def write_png(path: str | os.PathLike[str], image: npt.ArrayLike, exposure: float = 0.0) -> None:
    """8-bit sRGB preview of a linear image scaled by 2**exposure, clamped."""
    a = np.ascontiguousarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image: expected shape (H, W, 3), got {a.shape}")
    if isinstance(exposure, bool) or not isinstance(exposure, (int, float, np.integer, np.floating)) \
            or not np.isfinite(exposure) or abs(exposure) > 100:
        raise ValueError(f"exposure: expected a finite number of stops in [-100, 100], got {exposure!r}")
    _native.write_png(os.fspath(path), (a.shape[1], a.shape[0], a.reshape(-1)), float(exposure))


def rel_mse(image: npt.ArrayLike, reference: npt.ArrayLike, eps: float = 1e-2) -> float:
    """Relative MSE: mean of (image - reference)^2 / (reference^2 + eps)."""
    image, reference = np.asarray(image), np.asarray(reference)
    if image.shape != reference.shape:
        raise ValueError(f"image, reference: shapes {image.shape} and {reference.shape} differ")
    return float(np.mean((image - reference) ** 2 / (reference**2 + eps)))


def side_by_side(image: npt.ArrayLike, reference: npt.ArrayLike) -> Image:
    """[image | reference | |difference| scaled to the reference's 99th percentile]."""
    image, reference = np.asarray(image, dtype=np.float32), np.asarray(reference, dtype=np.float32)
    if image.shape != reference.shape:
        raise ValueError(f"image, reference: shapes {image.shape} and {reference.shape} differ")
    diff = np.abs(image - reference).mean(axis=2, keepdims=True)
    scale = max(float(np.quantile(reference, 0.99)), 1e-12)
    err = np.clip(diff / scale, 0, 1)
    heat = np.concatenate([err, 1 - np.abs(2 * err - 1), 1 - err], axis=2) * scale * (err > 0)
    return np.concatenate([image, reference, heat.astype(np.float32)], axis=1)
