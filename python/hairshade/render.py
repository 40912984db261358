"""Rendering with the software rasterizer, and images in and out."""

from __future__ import annotations

import numbers
import os
import warnings
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np
import numpy.typing as npt

from . import _native
from ._errors import SceneError
from ._progress import Bar
from .scene import Scene, light_vector

Image = npt.NDArray[np.float32]  # (H, W, 3) linear radiance


if TYPE_CHECKING:
    from typing_extensions import Unpack

    from .options import RenderSettings


@overload
def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    *,
    progress: bool | None = None,
    return_stats: Literal[False] = False,
    **settings: Unpack[RenderSettings],
) -> Image: ...


@overload
def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    *,
    progress: bool | None = None,
    return_stats: Literal[True],
    **settings: Unpack[RenderSettings],
) -> tuple[Image, dict[str, Any]]: ...


def render(
    scene: Scene,
    width: int | None = None,
    height: int | None = None,
    *,
    progress: bool | None = None,
    return_stats: bool = False,
    **settings: Any,
) -> Image | tuple[Image, dict[str, Any]]:
    """Renders ``scene`` -> (H, W, 3) float32 linear radiance.

    ``width``/``height`` override the scene's resolution (if only one is
    given the other follows the scene's aspect ratio). Every other keyword
    is a render setting (:class:`hairshade.options.RenderSettings`) and
    equals writing it in the scene's ``render`` section: ``quality``
    ("fast", "balanced" (default), "accurate"), ``transparency``,
    ``shadows``, ``multiple_scattering`` (a method's name, or
    ``{method: {options}}``), ``shading``, ``lod``, ``guides``, ``guide_choice``,
    ``density_resolution``, ``environment_directions``,
    ``light_cull_threshold``, ``background``. For example
    ``render(scene, quality="accurate")`` or
    ``render(scene, transparency={"coverage": {"samples": 64}})``.
    See :mod:`hairshade.options` and ``docs/options.md``.

    A setting that does not apply (to its method, the scene's model or
    lights) or is out of range raises :class:`hairshade.SceneError` naming
    it. The older flat keywords (``samples=``, ``multiple_scattering=
    "auto"``, ...) are translated with a ``DeprecationWarning``.

    ``progress``: a progress bar (tqdm's when installed; default: where it
    can be seen, a terminal or a notebook) over the tiles, and over the
    solve of multiple scattering through the volume when there is one (100
    steps). Ctrl-C stops the render (KeyboardInterrupt). Non-finite pixels (an overflow) are set to 0,
    counted in the stats as ``non_finite_pixels``, and reported by a ``RuntimeWarning``.

    ``return_stats=True`` returns ``(image, stats)``. ``stats`` holds the
    renderer's resolved options (``transparency``, ``samples``,
    ``shading``, ...) and what the frame did: counts (``segments``,
    ``segments_visible``, ``fragments``, ``vertices_shaded``,
    ``strands_drawn``, the ``culled_*`` counts, ``non_finite_pixels``), the
    level of detail (``lod_fraction``; under ``lod: "auto"``, ``lod_overlap``:
    how many strands deep the hair lay on screen, from which it was chosen),
    what it reused from the frame before (``shadow_maps_reused``,
    ``lighting_reused``, ``volume_reused``), ``memory_estimate`` (bytes),
    and wall times in milliseconds: ``shadow_ms``, ``setup_ms`` (which
    includes ``vertex_ms``, the per-vertex shading done before the tiles;
    shaded on demand, vertices are shaded in ``tiles_ms``), ``tiles_ms``, ``volume_ms``, ``guides_ms`` and
    ``total_ms`` (the renderer's whole frame; the call's own wall time adds
    the scene's conversion in and the image's out). ``tiles_busy_ms`` is
    the tiles' own times summed: over ``tiles_ms`` times the threads, how
    busy the threads were in the tile pass."""
    return _render(scene, width, height, progress, return_stats, scene.options(**settings))


def _render(scene: Scene, width: int | None, height: int | None, progress: bool | None, return_stats: bool,
            options: dict[str, Any]) -> Any:
    """:func:`render` with the renderer's options resolved (the benchmark's
    speed-up switches are added to these)."""
    scene.check()
    _check_guides(options.get("guides"), len(scene.offsets) - 1)
    cam = dict(scene.camera)
    if width is not None or height is not None:
        for name, v in (("width", width), ("height", height)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 16384):
                raise ValueError(f"{name}: expected an integer in [1, 16384], got {v!r:.80}")
        w0, h0 = cam["width"], cam["height"]
        w = int(width) if width is not None else max(1, round(int(height) * w0 / h0))
        h = int(height) if height is not None else max(1, round(int(width) * h0 / w0))
        cam["width"], cam["height"] = w, h
    with Bar(0, "render", unit="step", enabled=progress) as bar:
        flat, stats = _native.render(_native_scene(scene, cam), options, bar.update_to if progress is not False else None)
    img = flat.reshape(cam["height"], cam["width"], 3)
    stats = dict(stats)
    if stats.get("non_finite_pixels", 0) > 0:
        warnings.warn(f"render: {stats['non_finite_pixels']} of {img.shape[0] * img.shape[1]} pixels overflowed to a "
                      "non-finite value and were set to 0 (a radiance, background or light too large for float32)",
                      RuntimeWarning, stacklevel=3)
    return (img, stats) if return_stats else img


def _check_guides(guides: Any, strands: int) -> None:
    """Guide strands given by index must be strands of the scene."""
    if guides is None or isinstance(guides, (str, bytes, int, float, np.number)):
        return
    idx = np.asarray(guides)
    if idx.ndim == 1 and idx.size and np.issubdtype(idx.dtype, np.integer) and idx.max() >= strands:
        raise SceneError(f"render.guides: strand index {int(idx.max())} is out of range (the scene has "
                         f"{strands} strands)")


def _strands(scene: Scene, cam: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The strands the renderer draws: the scene's arrays, or its curves cut
    for this camera (:mod:`hairshade.curves`), kept for the next frame of
    the same camera and strands."""
    from .curves import subdivide

    curve, pixels = scene.curve
    if curve == "polyline":
        return scene.points, scene.radii, scene.offsets
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    for a in (scene.points, scene.radii, scene.offsets):
        h.update(np.ascontiguousarray(a).view(np.uint8).reshape(-1))
    key = (curve, pixels, repr(sorted(cam.items())), h.digest())
    cached = getattr(scene, "_curve_cache", None)
    if cached is not None and cached[0] == key:
        return cached[1]
    arrays = subdivide(scene.points, scene.radii, scene.offsets, curve, cam, pixels)
    scene._curve_cache = (key, arrays)  # type: ignore[attr-defined]
    return arrays


def _native_scene(scene: Scene, cam: dict[str, Any]) -> dict[str, Any]:
    """The scene as the flat arrays the renderer takes."""
    f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32).reshape(-1)  # noqa: E731
    cards = scene.cards
    meshes = scene.obj_meshes
    points, radii, offsets = _strands(scene, cam)
    return dict(
        camera=(cam["position"], cam["target"], cam["up"], cam["fov"], cam["width"], cam["height"]),
        lights=[(l["type"], light_vector(l), l["intensity"], l["shadows"]) for l in scene.lights],
        environment=None if scene.environment_sh is None else [float(x) for x in scene.environment_sh.reshape(-1)],
        points=f32(points),
        radii=f32(radii),
        offsets=np.ascontiguousarray(offsets, dtype=np.uint32),
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


def read_exr(path: str | os.PathLike[str], max_pixels: int | None = None, layer: str | None = None) -> Image:
    """Reads an OpenEXR file's RGB channels -> (H, W, 3) float32 (A ignored).

    A plain RGB(A) file needs no ``layer``. In a multilayer file (Blender's
    ``ViewLayer.Combined.R``, ..., or several parts), ``layer`` names the
    channels' common prefix, joined to the part's name with ``.``
    (``"ViewLayer.Combined"``); without it, the file's only layer, its
    unnamed RGB layer, its only RGB layer or its only RGB layer named
    ``Combined`` (Blender's beauty pass) is read, and otherwise the
    ``ValueError`` lists the file's layers (:func:`exr_layers` lists them
    too). A single-channel layer (``"ViewLayer.Depth"``, a file of ``Y``
    only) is read as grey: its value in R, G and B.

    A file declaring more than ``max_pixels`` (default 2^28) pixels, or
    more than its size can hold, is refused (ValueError) before its pixels
    are allocated; MemoryError when they cannot be. ``max_pixels``: a
    whole number >= 1, or None. Deep and subsampled channels are refused."""
    if max_pixels is not None and (isinstance(max_pixels, (bool, np.bool_))
                                   or not isinstance(max_pixels, numbers.Integral) or max_pixels < 1):
        raise ValueError(f"max_pixels: expected a whole number >= 1 or None, got {max_pixels!r:.80}")
    if layer is not None and not isinstance(layer, str):
        raise TypeError(f"layer: expected a layer name (str) or None, got {layer!r:.80}")
    w, h, data = _native.read_exr(os.fspath(path), None if max_pixels is None else int(max_pixels), layer)
    return data.reshape(h, w, 3)


def exr_layers(path: str | os.PathLike[str]) -> dict[str, tuple[str, ...]]:
    """The layers of an OpenEXR file (from its headers): layer name ->
    channel names, in the file's order, as :func:`read_exr`'s ``layer``
    takes them (``""`` for a plain file's channels)."""
    return {name: tuple(channels) for name, channels, _, _ in _native.exr_layers(os.fspath(path))}


def _rgb(image: npt.ArrayLike) -> np.ndarray:
    a = np.ascontiguousarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image: expected shape (H, W, 3), got {a.shape}")
    return a


def _stops(image: np.ndarray, exposure: float | str) -> float:
    """``exposure`` in stops; "auto" maps the 99.5th percentile of the
    image's finite values to 1 (0 for an image without a positive one)."""
    if isinstance(exposure, str):
        if exposure != "auto":
            raise ValueError(f"exposure: expected a number of stops in [-100, 100] or 'auto', got {exposure!r:.80}")
        v = image[np.isfinite(image)]
        p = float(np.percentile(v, 99.5)) if v.size else 0.0
        return float(np.clip(-np.log2(p), -100, 100)) if p > 0 else 0.0
    if isinstance(exposure, (bool, np.bool_)) or not isinstance(exposure, (int, float, np.integer, np.floating)) \
            or not np.isfinite(exposure) or abs(exposure) > 100:
        raise ValueError(f"exposure: expected a finite number of stops in [-100, 100] or 'auto', got {exposure!r:.80}")
    return float(exposure)


def write_png(path: str | os.PathLike[str], image: npt.ArrayLike, exposure: float | str = 0.0) -> None:
    """8-bit sRGB preview of a linear image scaled by 2**exposure, clamped
    to [0, 1] (the bytes of :func:`tonemap`). ``exposure``: stops in
    [-100, 100], or "auto" (the 99.5th percentile becomes white)."""
    a = _rgb(image)
    _native.write_png(os.fspath(path), (a.shape[1], a.shape[0], a.reshape(-1)), _stops(a, exposure))


def tonemap(image: npt.ArrayLike, exposure: float | str = 0.0) -> npt.NDArray[np.uint8]:
    """A linear image as 8-bit sRGB -> (H, W, 3) uint8: scaled by
    2**exposure, clamped to [0, 1], sRGB-encoded (linear 0.18 becomes 118).
    Non-finite values become 0. ``exposure``: stops in [-100, 100], or
    "auto" (the 99.5th percentile of the finite values becomes white)."""
    a = _rgb(image)
    b = _native.srgb8((a.shape[1], a.shape[0], a.reshape(-1)), _stops(a, exposure), False)
    return np.frombuffer(b, dtype=np.uint8).reshape(a.shape)


def srgb_to_linear(v: npt.ArrayLike) -> np.ndarray:
    """Display values in [0, 1] (sRGB-encoded, as a PNG holds them) to
    linear ones: the inverse of the encoding :func:`tonemap` applies."""
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


class Preview:
    """A linear image that a notebook shows as an sRGB PNG
    (``_repr_png_``); :func:`show` makes one."""

    def __init__(self, image: npt.ArrayLike, exposure: float | str = 0.0):
        self.image = _rgb(image)
        self.exposure = _stops(self.image, exposure)

    def _repr_png_(self) -> bytes:
        a = self.image
        return _native.srgb8((a.shape[1], a.shape[0], a.reshape(-1)), self.exposure, True)

    def __repr__(self) -> str:
        h, w, _ = self.image.shape
        return f"Preview({w}x{h}, exposure={self.exposure:+.2f} stops)"


def show(image: npt.ArrayLike, exposure: float | str = 0.0) -> Preview:
    """The image displayed in a notebook (Jupyter shows the returned
    :class:`Preview` as a PNG, encoded as :func:`write_png` writes it)."""
    return Preview(image, exposure)


def rel_mse(image: npt.ArrayLike, reference: npt.ArrayLike, eps: float = 1e-2) -> float:
    """Relative MSE: mean of (image - reference)^2 / (reference^2 + eps)."""
    image, reference = np.asarray(image), np.asarray(reference)
    if image.shape != reference.shape:
        raise ValueError(f"image, reference: shapes {image.shape} and {reference.shape} differ")
    return float(np.mean((image - reference) ** 2 / (reference**2 + eps)))


def side_by_side(image: npt.ArrayLike, reference: npt.ArrayLike) -> Image:
    """[image | reference | absolute difference scaled to the reference's 99th percentile]."""
    image, reference = np.asarray(image, dtype=np.float32), np.asarray(reference, dtype=np.float32)
    if image.shape != reference.shape:
        raise ValueError(f"image, reference: shapes {image.shape} and {reference.shape} differ")
    diff = np.abs(image - reference).mean(axis=2, keepdims=True)
    scale = max(float(np.quantile(reference, 0.99)), 1e-12)
    err = np.clip(diff / scale, 0, 1)
    heat = np.concatenate([err, 1 - np.abs(2 * err - 1), 1 - err], axis=2) * scale * (err > 0)
    return np.concatenate([image, reference, heat.astype(np.float32)], axis=1)
