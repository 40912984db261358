"""Render settings: one definition, read by the scene file, :func:`hairshade.render`,
the CLI, the docs and the tests.

A scene's ``render`` section (and the keywords of :func:`hairshade.render`)::

    "render": {
      "quality": "balanced",                          # fast | balanced | accurate
      "transparency": {"coverage": {"samples": 64}},  # or just "coverage"
      "shadows": {"opacity": {"map_size": 2048}},     # or just "traced"
      "multiple_scattering": {"dual": {"backscatter": "two_stream"}},
      "background": [0, 0, 0]
    }

``quality`` picks a preset: a bundle of methods chosen by measurement
(``docs/quality.md``: error against path-traced truth and frame time per
preset and head). Everything else refines it. A method with options is
written ``{"method": {options}}``, so that an option can only be written
under the method it belongs to; the method alone is its name. A group the
preset also sets keeps the preset's options when the method is the same, and
drops them when it differs. An option that does not apply (to its method,
to the scene's hair model, or to a scene without an environment) is an
error naming it, at load. The renderer checks each value's range (the
ranges are the renderer's; ``docs/options.md`` lists them).

The TypedDicts below *are* the definition: each key's type, its renderer
name and its documentation are read from them (``Annotated``), so adding an
option is one line here plus the code that uses it.

Older scene files spelt the settings flat (``"samples": 64``,
``"shadow_model": "traced"``, ``"dual_forward_density": 0.7``): those keys
are translated with a ``DeprecationWarning`` that names the new spelling,
and a section in the old spelling keeps the old defaults of what it leaves
out (quality 'fast', shadows 'exponential'), so it renders as it did.
The exact speed-ups (culling, reuse of shadow maps) never change an image;
they are not settings but switches of the benchmark
(:func:`hairshade.bench_render.render_switched`).
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import (Annotated, Any, Callable, Dict, Iterable, List, Literal, Mapping, Sequence, Tuple, TypedDict,
                    Union, get_args, get_origin, get_type_hints)

from ._errors import SceneError


# -- annotations -------------------------------------------------------------------


@dataclass(frozen=True)
class Native:
    """The renderer's name of an option (``hairshade._native.render_options``)."""

    name: str


@dataclass(frozen=True)
class Doc:
    text: str


@dataclass(frozen=True)
class Applies:
    """An option's condition beyond its method: ``when(ctx)`` true, else
    ``why`` (the error's reason)."""

    when: Callable[["Context"], bool]
    why: str


@dataclass(frozen=True)
class Context:
    """What decides whether an option applies: the hair model ('karis',
    'chiang', 'deon'), whether the scene has an environment light, and the
    methods chosen."""

    model: str
    environment: bool
    transparency: str
    shadows: str
    multiple_scattering: str
    shading: str = "pixel"

    @property
    def environment_as_lights(self) -> bool:
        # the renderer's env_light::as_lights
        return self.environment and (self.model != "karis" or self.multiple_scattering in ("dual", "volume"))


_CHIANG = Applies(lambda c: c.model == "chiang", "it applies to ChiangHair only")
_GRID = Applies(
    lambda c: c.shadows == "density" or c.multiple_scattering == "dual" or c.environment_as_lights,
    "no fiber density grid is built: it applies with shadows 'density', multiple_scattering 'dual' "
    "or an environment shaded as lights (ChiangHair, DEonHair, or dual scattering)")
_ENV = Applies(lambda c: c.environment_as_lights,
               "the environment is not shaded as lights here: it applies to a scene with an environment light "
               "and ChiangHair, DEonHair, or dual scattering")
_GUIDES = Applies(lambda c: c.shading in ("vertex", "split"),
                  "nothing is shaded at vertices: it applies with shading 'vertex' or 'split'")
_GUIDE_TERMS = Applies(lambda c: c.shading == "vertex",
                       "under shading 'split' a strand takes only the terms read at vertices from its guides: it "
                       "applies with shading 'vertex'")
_CULL = Applies(lambda c: c.model == "karis" and c.multiple_scattering not in ("dual", "volume"),
                "light culling applies to KarisHair without dual or volume scattering")


# -- the definition ------------------------------------------------------------------

Quality = Literal["fast", "balanced", "accurate"]
QUALITIES: Tuple[str, ...] = get_args(Quality)


class MlabOptions(TypedDict, total=False):
    layers: Annotated[int, Native("layers"), Doc("MLAB layers per pixel")]
    format: Annotated[Literal["f32", "r11g11b10", "rgb9e5"], Native("layer_format"), Doc(
        "how a layer is stored: f32 (20 bytes), or RE4's 64 bits: 16-bit depth and transmittance with "
        "R11G11B10 or RGB9E5 colour (docs/packed_layers.md)")]
    cull_transmittance: Annotated[float, Native("hair_cull_transmittance"), Doc(
        "a pixel's hair behind the depth where its transmittance falls below this is skipped "
        "(at most this times its radiance is lost; 0: off)")]


class SortedOptions(TypedDict, total=False):
    cull_transmittance: Annotated[float, Native("hair_cull_transmittance"), Doc(
        "as under mlab: hair behind this transmittance is skipped (0: off)")]


class CoverageOptions(TypedDict, total=False):
    samples: Annotated[int, Native("samples"), Doc("coverage samples per pixel")]
    near_field: Annotated[bool, Native("near_field"), _CHIANG, Doc(
        "ChiangHair's single scattering by the near field at each sample's offset across its fiber, "
        "as a path tracer's hit (off: the far field once per fragment)")]


class ExponentialShadows(TypedDict, total=False):
    map_size: Annotated[int, Native("shadow_map_size"), Doc("shadow-map texels per side")]
    pcf_radius: Annotated[int, Native("pcf_radius"), Doc("PCF kernel radius in texels (0: one tap)")]
    density: Annotated[float, Native("shadow_density"), Doc(
        "Karis 2016's optical density: exp(-density x depth behind the first hair)")]


class MapShadows(TypedDict, total=False):
    map_size: Annotated[int, Native("shadow_map_size"), Doc("shadow-map texels per side (the map holds "
                                                            "opaque geometry, and hair for 'opacity')")]
    pcf_radius: Annotated[int, Native("pcf_radius"), Doc("PCF kernel radius in texels (0: one tap)")]


class TracedShadows(MapShadows, total=False):
    own_strand: Annotated[Literal["shadows", "passes"], Native("traced_own_strand"), Doc(
        "shadows (the default): a shadow ray passes its own strand until it leaves the strand's tube, and "
        "is then blocked by its own strand where it enters it again, as by any other (a bend, a curl, a "
        "strand crossing the crown before it; the same wherever the strand is cut into segments); passes: a strand never "
        "shadows itself, as in Cycles, which skips every hit on the curve a ray leaves (for comparing with "
        "Cycles; docs/separated.md; the volume's multiple scattering keeps the default)")]
    vertices: Annotated[bool, Native("traced_vertices"), Doc(
        "a light's ray is traced from each strand vertex, and a fragment takes its segment's two vertices' "
        "answer where they agree, tracing its own ray only where they differ (a segment's shadow edges); "
        "a shadow that starts and ends between two vertices is missed (the demo head at 1280x720: 1.2x "
        "faster, relMSE 2.5e-4 against per-fragment rays; docs/speed.md). The near field's own probes "
        "across a fiber (ChiangHair with coverage samples) stay per fragment")]


class DualOptions(TypedDict, total=False):
    forward_density: Annotated[float, Native("dual_forward_density"), Doc("Zinke's d_f")]
    back_density: Annotated[float, Native("dual_back_density"), Doc("Zinke's d_b")]
    backscatter: Annotated[Literal["local", "two_stream"], Native("dual_backscatter"), Doc(
        "Zinke's local A_b, or the energy-conserving two-stream slab along each light's line")]
    sphere_bounce: Annotated[bool, Native("sphere_bounce"), Doc(
        "light the opaque spheres (a head) reflect back into the hair")]


class VolumeOptions(TypedDict, total=False):
    resolution: Annotated[int, Native("volume_resolution"), Doc(
        "cells along the longest side of the hair's bounds of the grid the light is tallied on (the "
        "fiber medium has twice as many voxels a side)")]
    photons: Annotated[int, Native("volume_photons"), Doc(
        "photons traced per light, the environment counted as one light")]
    bins: Annotated[int, Native("volume_bins"), Doc(
        "octahedral direction bins per side (bins² directions per voxel)")]
    transport: Annotated[Literal["medium", "strands"], Native("volume_transport"), Doc(
        "photons fly between the fibers they really meet, traced through the strands (the default: exact "
        "transport, docs/volume_transport.md), or through the oriented fiber medium (about 2x faster to "
        "solve; its bias depends on the light, docs/volume.md)")]
    directions: Annotated[Literal["mean", "centre"], Native("volume_directions"), Doc(
        "the direction each bin's light is read from: its own mean direction and spread, tallied with it "
        "(the default: sharper where the light in a bin runs one way), or the bin's centre (linear in the "
        "tallies, so a few photons' noisy mean direction adds no error: the balanced preset's; docs/volume.md)")]


class NoOptions(TypedDict, total=False):
    """A method without options."""


class _Mlab(TypedDict):
    mlab: MlabOptions


class _Sorted(TypedDict):
    sorted: SortedOptions


class _Coverage(TypedDict):
    coverage: CoverageOptions


class _Exponential(TypedDict):
    exponential: ExponentialShadows


class _Opacity(TypedDict):
    opacity: MapShadows


class _Density(TypedDict):
    density: MapShadows


class _Traced(TypedDict):
    traced: TracedShadows


class _NoMS(TypedDict):
    none: NoOptions


class _KarisMS(TypedDict):
    karis: NoOptions


class _Dual(TypedDict):
    dual: DualOptions


class _Volume(TypedDict):
    volume: VolumeOptions


Transparency = Union[Literal["mlab", "sorted", "coverage"], _Mlab, _Sorted, _Coverage]
Shadows = Union[Literal["exponential", "opacity", "density", "traced"], _Exponential, _Opacity, _Density, _Traced]
MultipleScattering = Union[Literal["none", "karis", "dual", "volume"], _NoMS, _KarisMS, _Dual, _Volume]


class RenderSettings(TypedDict, total=False):
    """A scene's ``render`` section; also the keywords of :func:`hairshade.render`."""

    quality: Annotated[Quality, Doc("the preset everything else refines (default 'balanced')")]
    transparency: Annotated[Transparency, Doc(
        "mlab: Multi-Layer Alpha Blending of anti-aliased footprints; sorted: every fragment in depth "
        "order; coverage: hair as opaque sub-pixel geometry, the nearest fiber per sample")]
    shadows: Annotated[Shadows, Doc(
        "exponential: Karis 2016's falloff behind the first hair; opacity: a deep opacity map; density: "
        "exp(-n) for the fibers counted in a density grid; traced: rays through the strands (exact)")]
    multiple_scattering: Annotated[MultipleScattering, Doc(
        "none; karis: KarisHair's own term; dual: dual scattering through the fiber density grid "
        "(ChiangHair, KarisHair); volume: light traced through the hair as an oriented fiber medium, "
        "solved once per lighting and reused for every view (ChiangHair, KarisHair)")]
    shading: Annotated[Literal["pixel", "split", "vertex"], Native("shading"), Doc(
        "pixel: strands shaded per fragment; split: per fragment only each light's unscattered light (its "
        "shadow, the near field), the environment and multiple scattering per vertex and interpolated; "
        "vertex: everything per vertex")]
    lod: Annotated[Union[float, Literal["auto"]], Native("lod"), Doc(
        "the fraction of the strands drawn, each wider by its inverse, or 'auto': from their width and depth on "
        "screen, thinning only hair whose strands are under 2 px wide and keeping the drawn strands 4 deep "
        "(frame against error: docs/lod_tradeoff.md)")]
    guides: Annotated[Union[float, Sequence[int]], Native("guides"), _GUIDES, Doc(
        "guide-strand lighting: the fraction of the strands shaded at their vertices (the guides), or the guide "
        "strands' indices; every other strand takes its vertices' values from its 3 nearest guides at the same "
        "fraction of their length (1: every strand shaded; docs/guides.md)")]
    guide_choice: Annotated[Literal["every", "clusters"], Native("guide_choice"), _GUIDES, Doc(
        "which strands guide: every k-th, or the strand nearest each centre of k-means clusters of the strands")]
    guide_terms: Annotated[Literal["scattered", "all"], Native("guide_terms"), _GUIDE_TERMS, Doc(
        "under shading 'vertex', what a strand takes from its guides: scattered: the environment and multiple "
        "scattering, each vertex shading its lights' unscattered light with its own shadow; all: everything "
        "(RE4; darker where the guides lie deeper in a shadowed head)")]
    density_resolution: Annotated[int, Native("density_resolution"), _GRID, Doc(
        "voxels along the longest side of the hair's bounds in the fiber density grid")]
    environment_directions: Annotated[int, Native("environment_directions"), _ENV, Doc(
        "directions of the environment's spherical quadrature, each dimmed by the fibers on its way")]
    light_cull_threshold: Annotated[float, Native("light_cull_threshold"), _CULL, Doc(
        "radiance below which a light's bounded contribution is skipped (0: off)")]
    background: Annotated[Sequence[float], Native("background"), Doc(
        "RGB radiance behind everything when the scene has no environment light")]


#: Each choice group: its renderer name, and per method the TypedDict of its options.
GROUPS: Dict[str, Tuple[str, Dict[str, type]]] = {
    "transparency": ("transparency", {"mlab": MlabOptions, "sorted": SortedOptions, "coverage": CoverageOptions}),
    "shadows": ("shadow_model", {"exponential": ExponentialShadows, "opacity": MapShadows,
                                 "density": MapShadows, "traced": TracedShadows}),
    "multiple_scattering": ("multiple_scattering", {"none": NoOptions, "karis": NoOptions, "dual": DualOptions,
                                                   "volume": VolumeOptions}),
}

#: Methods that need a model: (model allowed?, why).
_METHOD_MODELS: Dict[Tuple[str, str], Tuple[Callable[[str], bool], str]] = {
    ("multiple_scattering", "karis"): (lambda m: m == "karis",
                                       "'karis' is KarisHair's own term; ChiangHair takes 'dual' or 'none'"),
    ("multiple_scattering", "dual"): (lambda m: m != "deon", "'dual' is not available for DEonHair (use 'none')"),
    ("multiple_scattering", "volume"): (lambda m: m != "deon",
                                        "'volume' is not available for DEonHair (use 'none')"),
}


@dataclass(frozen=True)
class Field:
    """One option: where it is written, its renderer name, type, docs and condition."""

    path: str          # e.g. "transparency.coverage.samples" or "lod"
    native: str
    type: Any
    doc: str
    applies: Applies | None


@functools.cache
def _hints(td: type) -> Mapping[str, Any]:
    """The annotations of the TypedDict ``td``, read once (reading them took
    3 ms of every render)."""
    return get_type_hints(td, include_extras=True)


@functools.cache
def _fields_of(td: type, prefix: str) -> Tuple[Field, ...]:
    out = []
    for key, hint in _hints(td).items():
        if get_origin(hint) is not Annotated:
            continue
        base, *meta = get_args(hint)
        native = next((m.name for m in meta if isinstance(m, Native)), None)
        if native is None:
            continue
        doc = next((m.text for m in meta if isinstance(m, Doc)), "")
        applies = next((m for m in meta if isinstance(m, Applies)), None)
        out.append(Field(f"{prefix}{key}", native, base, doc, applies))
    return tuple(out)


def fields() -> List[Field]:
    """Every option, read from the TypedDicts (the docs and tests use this)."""
    out = list(_fields_of(RenderSettings, ""))
    for group, (_, methods) in GROUPS.items():
        for method, td in methods.items():
            out += _fields_of(td, f"{group}.{method}.")
    return out


def _group_doc(group: str) -> str:
    hint = _hints(RenderSettings)[group]
    return next(m.text for m in get_args(hint)[1:] if isinstance(m, Doc))


# -- presets -------------------------------------------------------------------------

#: The hair models (a scene's ``hair.material.model``), in the order a per-model preset lists them.
MODELS: Tuple[str, ...] = ("karis", "chiang", "deon")


def choices_text(names: Iterable[str]) -> str:
    """Allowed values as error messages and the settings reference list
    them: "'a'", "'a' or 'b'", "'a', 'b' or 'c'" ("" for none)."""
    quoted = [f"'{n}'" for n in names]
    return " or ".join(quoted) if len(quoted) < 3 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


#: The presets, chosen by measurement (docs/quality.md, `scripts/quality_table.py`).
#: Per model where the model decides: DEonHair takes no multiple
#: scattering, KarisHair's own term stands in where the cost of the others is
#: not wanted. ChiangHair takes the volume (docs/volume.md: its mean per
#: channel within 6% of path tracing on eight of nine heads, where dual
#: scattering leaves it 0.87-0.95); KarisHair keeps dual scattering (the
#: volume with its lobes: the demo and card heads within 7%, but with more
#: error per pixel than dual's).
PRESETS: Dict[str, Dict[str, Any]] = {
    # interactive: MLAB, deep opacity maps, the model's own multiple scattering, strands
    # shaded per vertex (docs/speed.md: 2x faster at 1280x720, relMSE 3e-4 from per pixel),
    # fewer, wider strands where they are under 2 px wide and lie deep (`lod: "auto"`,
    # docs/lod_tradeoff.md: the demo head at 1280x720 0.36x the frame of every strand drawn
    # at 1.43x its relMSE against the truth; medians over the dense heads 0.86x at 1.07x
    # (320x180) and 0.75x at 1.36x (1280x720), over the held-out heads 0.60x at 1.37x and
    # 0.68x at 1.38x, at most 4.22x: the error it adds lies at the sparse fringe of tips,
    # against a bright environment most). A pixel's hair
    # behind 2% transmittance is skipped, not behind 0.1% (at 1280x720 the demo head's frame
    # 1.14x faster, the dense heads' 1.03-1.12x; relMSE at most 2e-5 against 0.1%, a
    # channel's mean at most 0.33% darker: docs/speed.md). ChiangHair takes dual scattering
    # (its six dense heads' means 0.72-1.01 of the truth's, not 0.41-0.96 without multiple
    # scattering; relMSE lower on five of them, 1.45x higher on the backlit blond, whose
    # opacity-mapped shadows are too light once multiple scattering is added; frames 1.41x
    # longer, median, at most 1.6x), and the environment is read along 8 directions, not 32
    # (the blond head under an environment: the frame as without multiple scattering, relMSE
    # 1.4e-2 against 9.1e-3 at 32 and 7.5e-2 without; docs/fast_multiple_scattering.md)
    "fast": {
        "transparency": {"mlab": {"layers": 4, "cull_transmittance": 0.02}},
        "shadows": {"opacity": {}},
        "multiple_scattering": {"karis": "karis", "chiang": "dual", "deon": "none"},
        "shading": "vertex",
        "environment_directions": 8,
        "lod": "auto",
    },
    # the best error per second: 16 coverage samples (32 for ChiangHair, below), traced shadows (decided at the strand
    # vertices where a segment's two ends agree: the demo head 1.2x faster at 1280x720, relMSE
    # 2.5e-4 against per-fragment rays; ChiangHair's near field keeps its own probes), multiple
    # scattering through the volume (ChiangHair) or dual scattering (KarisHair), its slowly
    # varying terms read at the strands' vertices (split shading: docs/speed.md), computed at a
    # tenth of the strands (docs/guides.md, guides_held_out.md: 1.1-1.7x faster at 320x180,
    # the error against the truth within 4.4% of itself on the dense and held-out heads, the
    # mean within 0.6%)
    # ChiangHair takes 64 coverage samples: each sample also samples its fiber's offset h for the
    # near field, whose noise then dominates (relMSE against the truth at 16 -> 32 samples:
    # ginger_two 5.2e-3 -> 3.1e-3, wavy_ginger_back 5.4e-3 -> 2.5e-3, wavy_black_env 7.1e-3 ->
    # 4.1e-3; the frame about 1.2x longer; 32 -> 64 on the backlit blond, 5.5e-3 -> 4.8e-3, the
    # frame 1.25x longer); the volume is solved with 2^17 photons a light on 8 x 8 direction bins
    # read at the bins' centres (at 2^16 photons on 6 x 6 bins read at their mean directions, the
    # backlit blond's relMSE was 7.4e-3: a few photons' mean direction is noisy, and the fiber's
    # response turns that noise into error; docs/volume.md)
    "balanced": {
        "transparency": {"karis": {"coverage": {"samples": 16}}, "chiang": {"coverage": {"samples": 64}},
                         "deon": {"coverage": {"samples": 16}}},
        "shadows": {"traced": {"vertices": True}},
        "multiple_scattering": {"karis": "dual",
                                "chiang": {"volume": {"photons": 1 << 17, "bins": 8, "directions": "centre"}},
                                "deon": "none"},
        "shading": "split",
        "guides": 0.1,
    },
    # the closest: 64 coverage samples (128 for ChiangHair, whose near field samples its fiber's
    # offset h at each), the volume solved with 2^21 photons a light on 96 cells a side
    # (docs/volume.md: at 48 cells and 2^20 photons, with 64 samples, the wavy rim-lit blond
    # head's red was 0.946 of the truth's and the backlit blond's relMSE 3.77e-3; a coarse
    # cell averages the light over fibers deeper than those seen, its multiple scattering rose
    # with the cells to 0.957, and the sampling noise of 64 samples was 1.2e-3 of that relMSE
    # (2.80e-3 at 128); the solve about 2x longer, once per lighting, the frame about 1.3x)
    "accurate": {
        "transparency": {"karis": {"coverage": {"samples": 64}}, "chiang": {"coverage": {"samples": 128}},
                         "deon": {"coverage": {"samples": 64}}},
        "shadows": {"traced": {}},
        "multiple_scattering": {"karis": "dual", "chiang": {"volume": {"photons": 1 << 21, "resolution": 96}},
                                "deon": "none"},
        "shading": "split",
    },
}

#: The settings besides the groups a preset may set.
PRESET_SETTINGS: Tuple[str, ...] = ("shading", "lod", "guides", "environment_directions")
DEFAULT_QUALITY = "balanced"

# -- old flat keys -------------------------------------------------------------------

#: Flat keys of older scene files -> (group, key within the method) or the group itself.
_FLAT: Dict[str, Tuple[str, str | None]] = {
    "layers": ("transparency", "layers"),
    "samples": ("transparency", "samples"),
    "near_field": ("transparency", "near_field"),
    "hair_cull_transmittance": ("transparency", "cull_transmittance"),
    "shadow_model": ("shadows", None),
    "shadow_map_size": ("shadows", "map_size"),
    "pcf_radius": ("shadows", "pcf_radius"),
    "shadow_density": ("shadows", "density"),
    "dual_forward_density": ("multiple_scattering", "forward_density"),
    "dual_back_density": ("multiple_scattering", "back_density"),
    "dual_backscatter": ("multiple_scattering", "backscatter"),
    "sphere_bounce": ("multiple_scattering", "sphere_bounce"),
}
#: The exact speed-ups: not settings (they never change an image).
SPEEDUPS: Tuple[str, ...] = ("frustum_culling", "backface_culling", "opaque_culling", "vertices_on_demand",
                             "nearest_first", "skip_unused", "reuse_shadow_maps")


def _fail(path: str, msg: str) -> SceneError:
    return SceneError(f"render.{path}: {msg}")


def _method_of(value: Any, group: str) -> Tuple[str, Dict[str, Any]]:
    """(method, its options) of a group's value: a name or {name: {options}}."""
    methods = GROUPS[group][1]
    names = choices_text(methods)
    if isinstance(value, str):
        if value not in methods:
            raise _fail(group, f"expected {names}, got {value!r:.80}")
        return value, {}
    if isinstance(value, Mapping):
        if len(value) != 1:
            raise _fail(group, f"expected one method ({names}) with its options, got {len(value)} keys")
        (method, opts), = value.items()
        if method not in methods:
            raise _fail(group, f"expected {names}, got {method!r:.80}")
        if opts is None:
            opts = {}
        if not isinstance(opts, Mapping):
            raise _fail(f"{group}.{method}", f"expected an object of options, got {type(opts).__name__}")
        return method, dict(opts)
    raise _fail(group, f"expected {names}, or {{method: {{options}}}}, got {type(value).__name__}")


def translate_flat(settings: Mapping[str, Any], where: str = "render", whole_section: bool = False,
                   model: str | None = None, environment: bool = False) -> Dict[str, Any]:
    """``settings`` with the flat keys of older files turned into the grouped
    form, read as they were read before (a ``DeprecationWarning`` names each
    new spelling): an option's method is the one the settings name, else
    the old default (transparency 'mlab', or 'coverage' for ``samples`` and
    ``near_field``; shadows 'exponential'; dual scattering for ``dual_*``
    and ``sphere_bounce``). With ``whole_section`` (a scene file's
    ``render``), a section in the old spelling also keeps the old defaults
    of what it leaves out: quality 'fast' (MLAB, the model's own multiple
    scattering: none for ChiangHair, whose ``model`` the caller gives),
    shadows 'exponential', shading 'pixel', every strand drawn (``lod`` 1) and, where the scene has an
    ``environment`` shaded as lights, the renderer's 32 environment
    directions, so that it renders as it did.
    The speed-up switches are refused."""
    if not isinstance(settings, Mapping):
        raise SceneError(f"{where}: expected an object of render settings, got {type(settings).__name__}")
    for k in settings:
        if k in SPEEDUPS:
            raise _fail(k, "is an exact speed-up (it never changes the image), not a render setting: "
                           "switch it off for a benchmark with hairshade.bench_render.render_switched(scene, "
                           f"off=({k!r},))")
    out = {k: v for k, v in settings.items() if k not in _FLAT}
    old = any(k in _FLAT for k in settings) or out.get("multiple_scattering") == "auto"
    legacy = whole_section and old and "quality" not in out
    if legacy:
        warnings.warn(f"{where}: the flat spelling of render settings is deprecated; this section is read as it "
                      "rendered before (quality 'fast', shadows 'exponential' unless it names them): write the "
                      "settings grouped (docs/options.md) to render with the quality presets",
                      DeprecationWarning, stacklevel=3)
        out["quality"] = "fast"
        if "shadows" not in out and "shadow_model" not in settings:
            out["shadows"] = "exponential"
        # the old defaults of what 'fast' now sets besides
        out.setdefault("shading", "pixel")
        out.setdefault("lod", 1.0)
    if out.get("multiple_scattering") == "auto":
        warnings.warn("render.multiple_scattering 'auto' is deprecated: leave it out (the quality preset "
                      "decides)", DeprecationWarning, stacklevel=3)
        del out["multiple_scattering"]
    for group in GROUPS:
        keys = {k: settings[k] for k, (g, _) in _FLAT.items() if g == group and k in settings}
        if not keys:
            continue
        if "shadow_model" in keys:
            # the flat key names the method; options of render.shadows that
            # the method also takes are kept (map_size, pcf_radius)
            method, opts = _method_of(keys.pop("shadow_model"), "shadows")
            if "shadows" in out:
                _, given = _method_of(out["shadows"], "shadows")
                takes = _hints(GROUPS["shadows"][1][method])
                opts = {k: v for k, v in given.items() if k in takes}
            warnings.warn(f"render.shadow_model is deprecated: write render.shadows ({method!r})",
                          DeprecationWarning, stacklevel=3)
        elif group in out:
            method, opts = _method_of(out[group], group)
        else:
            method, opts = _OLD_DEFAULT[group](keys), {}
        for k, v in keys.items():
            new = _FLAT[k][1]
            opts[new] = v
            warnings.warn(f"render.{k} is deprecated: write render.{group}.{method}.{new} "
                          f'({{"{group}": {{"{method}": {{"{new}": ...}}}}}})', DeprecationWarning, stacklevel=3)
        out[group] = {method: opts} if opts else method
    if legacy:
        # what 'fast' sets now that it did not: dual scattering for ChiangHair, and 8 environment directions
        if model == "chiang":
            out.setdefault("multiple_scattering", "none")
        m = model or "karis"
        ms = _method_of(out.get("multiple_scattering", PRESETS["fast"]["multiple_scattering"][m]),
                        "multiple_scattering")[0]
        if Context(m, environment, "", "", ms).environment_as_lights:
            from . import _native
            out.setdefault("environment_directions", _native.render_options({})["environment_directions"])
    return out


_OLD_DEFAULT: Dict[str, Callable[[Mapping[str, Any]], str]] = {
    "transparency": lambda keys: "coverage" if {"samples", "near_field"} & set(keys) else "mlab",
    "shadows": lambda keys: "exponential",
    "multiple_scattering": lambda keys: "dual",
}


# -- resolution ----------------------------------------------------------------------


def resolve(settings: Mapping[str, Any], model: str, environment: bool) -> Dict[str, Any]:
    """The renderer's flat options for ``settings`` (a ``render`` section,
    old flat keys translated first) with the scene's hair ``model`` ('karis',
    'chiang', 'deon') and whether it has an ``environment`` light. Raises
    :class:`SceneError` naming a key that is unknown or does not apply; value
    ranges are checked by the renderer."""
    s = translate_flat(settings)
    known = set(_hints(RenderSettings))
    for k in s:
        if k not in known:
            raise _fail(str(k), f"unknown render setting (allowed: {', '.join(sorted(known))})")
    quality = s.get("quality", DEFAULT_QUALITY)
    if quality not in QUALITIES:
        raise _fail("quality", f"expected {choices_text(QUALITIES)}, got {quality!r:.80}")
    preset = PRESETS[quality]
    chosen: Dict[str, Tuple[str, Dict[str, Any], Dict[str, Any]]] = {}  # group -> (method, preset's, user's)
    for group in GROUPS:
        p = preset[group]
        if isinstance(p, Mapping) and model in p:
            p = p[model]
        pm, popts = _method_of(p, group)
        if group in s:
            um, uopts = _method_of(s[group], group)
            chosen[group] = (um, popts if um == pm else {}, uopts)
        else:
            chosen[group] = (pm, popts, {})
    ctx = Context(model, environment, chosen["transparency"][0], chosen["shadows"][0],
                  chosen["multiple_scattering"][0], s.get("shading", preset.get("shading", "pixel")))
    native: Dict[str, Any] = {}
    for group, (method, popts, uopts) in chosen.items():
        allowed, why = _METHOD_MODELS.get((group, method), (lambda m: True, ""))
        if not allowed(model):
            raise _fail(group, why)
        native[GROUPS[group][0]] = method
        by_key = {f.path.rsplit(".", 1)[-1]: f for f in _fields_of(GROUPS[group][1][method], "")}
        for key, value in {**popts, **uopts}.items():
            path = f"{group}.{method}.{key}"
            f = by_key.get(key)
            if f is None:
                owners = [m for m, td in GROUPS[group][1].items() if key in _hints(td)]
                if owners:
                    src = "" if group in s else f" (the method of quality {quality!r})"
                    raise _fail(path, f"does not apply to {group} {method!r}{src}: it belongs to "
                                      f"{' and '.join(map(repr, owners))}")
                raise _fail(path, f"unknown option of {group} {method!r} "
                                  f"(allowed: {', '.join(sorted(by_key)) or 'none'})")
            if key in uopts and f.applies is not None and not f.applies.when(ctx):
                raise _fail(path, f.applies.why)
            native[f.native] = value
    for f in _fields_of(RenderSettings, ""):
        if f.path in s:
            if f.applies is not None and not f.applies.when(ctx):
                raise _fail(f.path, f.applies.why)
            native[f.native] = s[f.path]
        elif f.path in preset:
            native[f.native] = preset[f.path]
    return native


def settings_of(overrides: Mapping[str, Any], base: Mapping[str, Any]) -> Dict[str, Any]:
    """``base`` (a scene's render section) with ``overrides`` (keywords of
    :func:`hairshade.render`) set, as writing them in the scene file would:
    a keyword replaces the key of the same name (old flat keywords are
    translated first, against the base's methods)."""
    base = translate_flat(base)
    over = translate_flat({**{g: base[g] for g in GROUPS if g in base}, **overrides})
    return {**base, **over}


def markdown() -> str:
    """The settings as a Markdown reference (docs/options.md), with the
    renderer's ranges and the presets."""
    from . import _native

    ranges = _native.render_option_ranges()
    defaults = _native.render_options({})
    lines = ["# Render settings", "",
             "Generated by `scripts/quality_table.py --options` from `hairshade/options.py`; "
             "ranges are the renderer's (`hairshade._native.render_option_ranges`).", "",
             "| setting | range | description |", "| --- | --- | --- |"]

    def rng(native: str, typ: Any) -> str:
        if native in ranges:
            lo, hi = ranges[native]
            return f"{lo:g} to {hi:g}"
        if typ is bool:
            return "true/false"
        return choices_text(a for a in get_args(typ) if isinstance(a, str))

    lines.append(f"| `quality` | {' / '.join(QUALITIES)} | {_group_doc('quality')} |")
    for group, (_, methods) in GROUPS.items():
        lines.append(f"| `{group}` | {' / '.join(methods)} | {_group_doc(group)} |")
        for method, td in methods.items():
            for f in _fields_of(td, f"{group}.{method}."):
                note = f" ({f.applies.why.split(':')[0]})" if f.applies else ""
                lines.append(f"| `{f.path}` | {rng(f.native, f.type)} | {f.doc}{note} |")
    for f in _fields_of(RenderSettings, ""):
        note = f" Only where it applies: {f.applies.why}." if f.applies else ""
        lines.append(f"| `{f.path}` | {rng(f.native, f.type)} | {f.doc}.{note} |")
    lines += ["", "## Presets", "", "A setting with three values is per model: KarisHair / ChiangHair / DEonHair.", "",
              "| quality | transparency | shadows | multiple scattering | shading | lod | guides | "
              "environment directions |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]

    def per_model(v: Any) -> str:
        if isinstance(v, Mapping) and set(v) == set(MODELS):
            return " / ".join(per_model(v[m]) for m in MODELS)
        return v if isinstance(v, str) else f"`{v}`"

    for q, p in PRESETS.items():
        lines.append(f"| `{q}` | {per_model(p['transparency'])} | {per_model(p['shadows'])} | "
                     f"{per_model(p['multiple_scattering'])} | {p.get('shading', 'pixel')} | "
                     f"{p.get('lod', 1.0)} | {p.get('guides', 1.0)} | "
                     f"{p.get('environment_directions', defaults['environment_directions'])} |")
    return "\n".join(lines) + "\n"


def path_of(native: str, settings: Mapping[str, Any]) -> str:
    """Where ``settings`` write the renderer's option ``native`` (for its
    error messages): its path under the method the settings chose."""
    candidates = [f for f in fields() if f.native == native]
    for f in candidates:
        parts = f.path.split(".")
        if len(parts) == 3 and parts[0] in settings:
            try:
                if _method_of(settings[parts[0]], parts[0])[0] == parts[1]:
                    return f.path
            except SceneError:
                pass
    return candidates[0].path if candidates else native
