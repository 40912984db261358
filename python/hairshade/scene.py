"""The scene format (JSON, versioned) and its validated in-memory form.

A scene file::

    {
      "hairshade_scene": 1,
      "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0],
                 "fov": 40, "resolution": [640, 360]},
      "lights": [
        {"type": "directional", "direction": [1, 1, 1], "intensity": [3, 3, 3], "shadows": true},
        {"type": "point", "position": [0, 2, 2], "intensity": [10, 10, 10], "shadows": false},
        {"type": "environment", "radiance": [0.2, 0.2, 0.25]}
      ],
      "hair": {
        "strands": [{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.01}],
        "file": "strands.txt",
        "generate": {"kind": "head", "strands": 3000, "segments": 16, ...},
        "material": {"model": "karis", "base_color": [0.3, 0.15, 0.08], "roughness": 0.5}
      },
      "meshes": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "albedo": [0.5, 0.4, 0.3]},
                 {"type": "obj", "file": "floor.obj", "albedo": [0.6, 0.6, 0.6]}],
      "render": {"quality": "balanced", "transparency": {"mlab": {"layers": 4}},
                 "shadows": {"exponential": {"map_size": 1024, "density": 20}}, "background": [0, 0, 0]}
    }

- ``direction`` of a directional light points *towards* the light;
  ``intensity`` is the irradiance it gives a surface facing it. Point lights
  have intensity in W/sr. An environment is ``radiance`` (constant) or
  ``sh`` (9 RGB real SH coefficients).
- Hair comes from any combination of inline ``strands`` (``radius`` or a
  per-vertex ``radii`` list), a ``file`` (relative to the scene file; by
  extension: ``.hair``, Cem Yuksel's binary format, see
  :mod:`hairshade.hairfile`; ``.usd``, ``.usda``, ``.usdc``, ``.usdz``: a
  USD groom's ``BasisCurves``, cubic curves subdivided to within a tenth of
  the fiber radius, see :mod:`hairshade.usd` (extra ``usd``); anything else
  is text: one ``x y z r`` vertex per line, a blank line between strands,
  ``#`` comments) and ``generate`` (procedural: ``head``, ``bundle``, see
  :mod:`hairshade.generate`). Radius 0 is allowed and draws nothing.
  ``hair.curve`` draws the strands as ``"polyline"`` (default),
  ``"bspline"`` or ``"catmull_rom"``, optionally ``{"bspline": {"pixels":
  4}}`` (:mod:`hairshade.curves`).
- ``Scene.save`` writes a scene back (:mod:`hairshade.scene_save`).
- Hair cards: ``cards`` (ribbons with an alpha texture, see
  :mod:`hairshade.cards`) and ``generate_cards`` (cards around a procedural
  head). Card and mesh triangles are clipped at the camera's near plane.
- ``material.model`` is ``karis`` (KarisHair keyword arguments),
  ``chiang`` (ChiangHair keyword arguments; shaded with its far field) or
  ``deon`` (DEonHair keyword arguments; slow unless ``h_samples`` is set).
- ``render``: the render settings, defined in :mod:`hairshade.options`
  (reference: ``docs/options.md``). ``quality`` (``fast``, ``balanced``
  (default), ``accurate``) picks a preset measured against path tracing
  (``docs/quality.md``); ``transparency`` (``mlab``, ``sorted``,
  ``coverage``), ``shadows`` (``exponential``, ``opacity``, ``density``,
  ``traced``) and ``multiple_scattering`` (``none``, ``karis``, ``dual``,
  ``volume``)
  are a method's name or ``{method: {options}}``, so that an option is
  written under the method it belongs to; ``shading``, ``lod``,
  ``density_resolution``, ``environment_directions``,
  ``light_cull_threshold`` and ``background`` stand alone. A setting that
  does not apply (to its method, to the hair model, or to a scene without
  an environment) is an error at load naming it; the renderer checks the
  ranges. The older flat keys (``layers``, ``samples``,
  ``shadow_model``, ``dual_forward_density``, ...) are translated with a
  ``DeprecationWarning`` that names the new spelling.
- An environment light shades KarisHair by its environment variant, and
  ChiangHair and DEonHair by a spherical quadrature of
  ``render.environment_directions`` directions (8 to 1024, default 32), each
  dimmed by the fibers on its way.
- Every field is checked on load; an error names the file, the field's path
  (``hair.strands[3].points[5]``) and what is wrong. Types are strict: a
  number is a JSON number (not a string, not a boolean), an integer field
  (``resolution``, ``hairshade_scene``) takes integers only, and unknown
  keys are errors. Non-finite numbers, and numbers above ``MAX_MAGNITUDE``
  (1e18) in magnitude, are errors: the renderer computes in float32
  (largest 3.4e38) and squares lengths, so larger inputs would overflow to
  inf and end in a hang or a black image.
- Referenced files (``hair.file``, ``meshes[i].file``, a card's
  ``alpha.image``) are resolved relative to the scene file's folder and
  must lie inside it (after following links), unless the scene is loaded
  with ``allow_outside=True`` (``hairshade render --allow-outside``).
  Only regular files are read: text files up to ``MAX_TEXT_BYTES``
  (256 MiB; OBJ files up to ``MAX_OBJ_BYTES``, 64 MiB), images up to
  ``hairshade.cards.MAX_IMAGE_BYTES`` (1 GiB). Errors quote a
  file's content only when it is printable text.

Loading is in :mod:`hairshade._scene_parse`, the checks it shares with
:meth:`Scene.check` in :mod:`hairshade._scene_check`, and the files a scene
names are read by :mod:`hairshade._scene_files`.
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _native, options
from .chiang import ChiangHair
from .karis import KarisHair

VERSION = 1

from ._errors import SceneError  # noqa: E402  (defined apart so that options.py can raise it)
from ._scene_check import (  # noqa: E402,F401  (MAX_MAGNITUDE, MIN_FOV, MIN_VIEW_SEPARATION, light_vector: public)
    MAX_MAGNITUDE, MIN_FOV, MIN_VIEW_SEPARATION, _Ctx, _check_view, _parse_curve, _strand_arrays,
    _strand_arrays_plausible, _unique_keys, _unit, light_vector)
from ._scene_files import (  # noqa: E402,F401  (the limits, read_bytes, read_text, write_strand_file: public)
    MAX_OBJ_BYTES, MAX_TEXT_BYTES, OBJ_BYTES_PER_BYTE, read_bytes, read_text, write_strand_file)


@dataclass
class Scene:
    """A validated scene, ready to render."""

    camera: dict[str, Any]
    lights: list[dict[str, Any]]
    environment_sh: np.ndarray | None
    points: np.ndarray  # (M, 3) float32
    radii: np.ndarray  # (M,) float32
    offsets: np.ndarray  # (S + 1,) uint32
    spheres: list[dict[str, Any]]
    material: dict[str, Any]
    render: dict[str, Any]
    source: str = "<dict>"
    hair: Any = field(init=False)  # KarisHair | ChiangHair | DEonHair
    cards: dict[str, Any] | None = field(default=None, init=False)
    obj_meshes: list[dict[str, Any]] = field(default_factory=list, init=False)
    #: The strands' curve and its subdivision bound in pixels
    #: (:mod:`hairshade.curves`): ("polyline" | "bspline" | "catmull_rom", pixels).
    curve: tuple[str, float] = field(default=("polyline", 4.0), init=False)

    def __post_init__(self) -> None:
        self._build_hair()

    def _build_hair(self) -> None:
        m = dict(self.material)
        model = m.pop("model", None)
        from .deon import DEonHair

        if model not in options.MODELS:
            raise SceneError(f"{self.source}: hair.material.model: expected {options.choices_text(options.MODELS)}, got {model!r:.80}")
        try:
            self.hair = {"karis": KarisHair, "chiang": ChiangHair, "deon": DEonHair}[model](**m)
        except (TypeError, ValueError) as e:
            raise SceneError(f"{self.source}: hair.material: {e}") from None
        self._material_built = copy.deepcopy(self.material)

    def check(self) -> None:
        """Checks the scene's fields as a scene file's are checked, for a
        scene edited after loading (``render`` calls it): the camera, lights,
        spheres, environment and strand arrays, with the same limits and
        messages naming the field; a changed ``material`` builds the hair
        model again (``hair`` follows it). Raises :class:`SceneError`."""
        c = _Ctx(f"{self.source} (as edited)")
        cam = c.obj(self.camera, "camera")
        c.known(cam, "camera", {"position", "target", "up", "fov", "width", "height"})
        camera = dict(
            position=c.vec3(cam.get("position"), "camera.position"),
            target=c.vec3(cam.get("target"), "camera.target"),
            up=c.vec3(cam.get("up"), "camera.up"),
            fov=c.num(cam.get("fov"), "camera.fov", 0, 179, lo_open=True),
            width=c.integer(cam.get("width"), "camera.width", 1, 16384),
            height=c.integer(cam.get("height"), "camera.height", 1, 16384),
        )
        _check_view(c, camera)
        for p, l in c.objects(self.lights, "lights"):
            c.known(l, p, {"type", "vector", "intensity", "shadows"})
            if l.get("type") not in ("directional", "point"):
                c.fail(f"{p}.type", f"expected 'directional' or 'point', got {l.get('type')!r:.80}")
            v = c.vec3(l.get("vector"), f"{p}.vector")
            if l["type"] == "directional":
                _unit(c, v, f"{p}.vector")
            c.vec3(l.get("intensity"), f"{p}.intensity", 0)
            c.boolean(l.get("shadows"), f"{p}.shadows")
        for p, sp in c.objects(self.spheres, "spheres"):
            c.known(sp, p, {"center", "radius", "albedo"})
            c.vec3(sp.get("center"), f"{p}.center")
            c.num(sp.get("radius"), f"{p}.radius", 0, lo_open=True)
            c.vec3(sp.get("albedo"), f"{p}.albedo", 0, 1)
        if self.environment_sh is not None:
            sh = np.asarray(self.environment_sh)
            if sh.shape != (9, 3) or not np.all(np.abs(sh) <= MAX_MAGNITUDE):
                c.fail("environment_sh", f"expected 9 x 3 finite numbers of magnitude at most {MAX_MAGNITUDE:g}, "
                                         f"got shape {sh.shape}")
        if not _strand_arrays_plausible(self.points, self.radii, self.offsets):
            # the full check, for the message naming the first bad entry
            try:
                _strand_arrays(self.points, self.radii, self.offsets)
            except SceneError as e:
                raise SceneError(f"{c.source}: {e}") from None
        if not (isinstance(self.curve, tuple) and len(self.curve) == 2):
            c.fail("curve", f"expected (name, pixels), got {self.curve!r:.80}")
        name, px = self.curve
        self.curve = _parse_curve(c, {name: {"pixels": px}})
        if self.material != self._material_built:
            self._build_hair()

    @property
    def strand_count(self) -> int:
        return len(self.offsets) - 1

    @property
    def model(self) -> str:
        """The hair model's name in the scene format: 'karis', 'chiang' or 'deon'."""
        return str(self.material["model"])

    def options(self, **overrides: Any) -> dict[str, Any]:
        """The renderer's options for this scene's ``render`` settings with
        ``overrides`` set (as :func:`hairshade.render`'s keywords), every
        value checked: a :class:`SceneError` names a setting that does not
        apply or is out of range (see :mod:`hairshade.options`)."""
        settings = options.settings_of(overrides, self.render)
        flat = options.resolve(settings, self.model, self.environment_sh is not None)
        try:
            return _native.render_options(flat)
        except ValueError as e:
            key, _, msg = str(e).partition(": ")
            raise SceneError(f"render.{options.path_of(key, settings)}: {msg}") from None

    def save(self, path: str | os.PathLike) -> None:
        """Writes the scene: ``.json`` in the scene format, with the strands
        in a ``.hair`` file beside it (and OBJ meshes and card images), so
        that :meth:`load` gives back the same arrays, settings and image;
        ``.usd``/``.usda``/``.usdc``: the strands as a USD groom (extra
        ``usd``). See :mod:`hairshade.scene_save`."""
        from .scene_save import save

        self.check()
        save(self, path)

    @classmethod
    def load(cls, path: str | os.PathLike, allow_outside: bool = False) -> "Scene":
        """The scene in the JSON file ``path``. Files it references must lie
        in its folder unless ``allow_outside`` (see the module docs)."""
        path = os.fspath(path)
        text = read_text(path, MAX_TEXT_BYTES, lambda msg: SceneError(f"{path}: {msg}"))
        try:
            data = json.loads(text, object_pairs_hook=_unique_keys)
        except json.JSONDecodeError as e:
            raise SceneError(f"{path}: not valid JSON ({e})") from None
        except RecursionError:
            raise SceneError(f"{path}: not valid JSON (nested too deeply)") from None
        except SceneError as e:  # a duplicate key
            raise SceneError(f"{path}: {e}") from None
        except ValueError as e:  # an integer beyond Python's digit limit
            raise SceneError(f"{path}: not valid JSON ({e})") from None
        return cls.from_dict(data, base_dir=os.path.dirname(os.path.abspath(path)), source=path,
                             allow_outside=allow_outside)

    @classmethod
    def from_dict(cls, d: dict[str, Any], base_dir: str | None = None, source: str = "<dict>",
                  allow_outside: bool = False) -> "Scene":
        """The scene a dict describes; relative file names are resolved in
        ``base_dir`` (default: the current folder) and must stay inside it
        unless ``allow_outside``."""
        if not isinstance(allow_outside, bool):
            raise TypeError(f"allow_outside: expected True or False, got {allow_outside!r}")
        try:
            return _parse(d, base_dir or os.getcwd(), source, allow_outside=allow_outside)
        except RecursionError:
            raise SceneError(f"{source}: nested too deeply") from None


    @classmethod
    def from_arrays(
        cls,
        points: npt.ArrayLike,
        radii: npt.ArrayLike,
        offsets: npt.ArrayLike,
        material: dict[str, Any] | None = None,
        camera: dict[str, Any] | None = None,
        lights: list[dict[str, Any]] | None = None,
        **fields: Any,
    ) -> "Scene":
        """A scene of the strands in flat arrays: ``points`` (M, 3),
        ``radii`` (M,) or a scalar, ``offsets`` (S + 1,) (strand s is
        points[offsets[s]:offsets[s+1]], offsets[0] = 0, offsets[-1] = M,
        at least 2 points per strand), as the renderer and ``Scene.points``,
        ``radii`` and ``offsets`` hold them.

        ``material``, ``camera``, ``lights`` and any other top-level field of
        the scene format (``meshes``, ``render``, and ``hair`` entries such
        as ``generate`` inside ``fields["hair"]``) are as in a scene file and
        checked the same way. Defaults: KarisHair; a camera looking at the
        strands' bounding box along -z from 2.5 times its size; one
        shadowed directional light."""
        p, r, o = _strand_arrays(points, radii, offsets)
        d: dict[str, Any] = {"hairshade_scene": VERSION, **fields}
        d["hair"] = dict(d.get("hair", {}), material=material or {"model": "karis"})
        if camera is None and len(p):
            lo, hi = p.min(axis=0).astype(float), p.max(axis=0).astype(float)
            c, size = (lo + hi) / 2, max(float(np.max(hi - lo)), 1e-6)
            camera = {"position": [c[0], c[1], c[2] + 2.5 * size], "target": c.tolist()}
        d["camera"] = camera if camera is not None else {"position": [0, 0, 3], "target": [0, 0, 0]}
        d["lights"] = lights if lights is not None else [
            {"type": "directional", "direction": [0.5, 0.7, 0.6], "intensity": [3, 3, 3], "shadows": True}]
        strands = [(p[o[s]:o[s + 1]], r[o[s]:o[s + 1]]) for s in range(len(o) - 1)]
        return _parse(d, os.getcwd(), "<arrays>", strands)


from ._scene_parse import _parse  # noqa: E402  (it builds a Scene)
