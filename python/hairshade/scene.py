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
  ``MAX_IMAGE_BYTES`` (1 GiB). Errors quote a
  file's content only when it is printable text.
"""

from __future__ import annotations

import copy
import json
import math
import os
import numbers
import stat
from dataclasses import dataclass, field
from typing import Any, NoReturn

import numpy as np
import numpy.typing as npt

from . import _native, options
from .chiang import ChiangHair
from .karis import KarisHair
from .lighting import sh_coefficients

VERSION = 1

#: Largest magnitude of a number in a scene (see the module docs).
MAX_MAGNITUDE = 1e18
#: Largest scene, strand or OBJ file read.
MAX_TEXT_BYTES = 256 << 20
#: Largest OBJ file read: parsed line by line at 0.074 s and 11 MB of peak
#: memory per MB of file (a 10 MB file of 200 000 triangles: 0.74 s, 107
#: MB), so 64 MiB takes about 5 s and 0.7 GB; a 250 MB file parsed for
#: minutes through gigabytes.
MAX_OBJ_BYTES = 64 << 20
#: Peak bytes of parsing an OBJ file per byte of it (measured 10.7, above).
OBJ_BYTES_PER_BYTE = 12
#: Largest image file read (card alpha textures).
MAX_IMAGE_BYTES = 1 << 30


from ._errors import SceneError  # noqa: E402  (defined apart so that options.py can raise it)


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
        if not isinstance(self.lights, list):
            c.fail("lights", "expected a list")
        for i, l in enumerate(self.lights):
            p = f"lights[{i}]"
            l = c.obj(l, p)
            c.known(l, p, {"type", "vector", "intensity", "shadows"})
            if l.get("type") not in ("directional", "point"):
                c.fail(f"{p}.type", f"expected 'directional' or 'point', got {l.get('type')!r:.80}")
            v = c.vec3(l.get("vector"), f"{p}.vector")
            if l["type"] == "directional":
                _unit(c, v, f"{p}.vector")
            c.vec3(l.get("intensity"), f"{p}.intensity", 0)
            c.boolean(l.get("shadows"), f"{p}.shadows")
        if not isinstance(self.spheres, list):
            c.fail("spheres", "expected a list")
        for i, sp in enumerate(self.spheres):
            p = f"spheres[{i}]"
            sp = c.obj(sp, p)
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

# -- files -----------------------------------------------------------------------


def show(line: str | bytes, limit: int = 80) -> str:
    """A line of a file for an error message: quoted and shortened when it
    is printable text, else only a note (file content that is not text is
    never echoed)."""
    if isinstance(line, bytes) or any(not (ch.isprintable() or ch == "\t") for ch in line):
        return "(content that is not text)"
    return repr(line if len(line) <= limit else line[:limit] + "...")


def read_bytes(path: str, limit: int, error: Any, nofollow: bool = False) -> bytes:
    """The content of the regular file ``path`` (at most ``limit`` bytes);
    ``error(message)`` builds the exception raised otherwise. Opened once,
    without blocking (a FIFO or a device would otherwise wait for a writer
    before the check that refuses it); with ``nofollow``, a path whose last
    part is a link is refused (a path resolved and checked before, which a
    link swapped in since would redirect)."""
    if "\x00" in path:
        raise error("the file name contains a NUL character")
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    if nofollow:
        flags |= getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
        with os.fdopen(fd, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                raise error("not a regular file")
            data = f.read(limit + 1)
    except FileNotFoundError:
        raise error("file not found") from None
    except IsADirectoryError:
        raise error("is a folder, not a file") from None
    except OSError as e:
        raise error(f"cannot read ({e.strerror or e})") from None
    if len(data) > limit:
        raise error(f"larger than the limit of {limit} bytes")
    return data


def read_text(path: str, limit: int, error: Any, nofollow: bool = False) -> str:
    """:func:`read_bytes` decoded as UTF-8 (an error names the offset of
    the first byte that is not)."""
    data = read_bytes(path, limit, error, nofollow)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(f"not UTF-8 text (byte {e.start})") from None

# -- validation helpers --------------------------------------------------------


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object as a dict, refusing a key given twice (json keeps the
    last silently)."""
    d: dict[str, Any] = {}
    for k, v in pairs:
        if k in d:
            raise SceneError(f"the key {k!r} appears twice in one object (which one was meant?)")
        d[k] = v
    return d


class _Ctx:
    def __init__(self, source: str, base_dir: str = ".", allow_outside: bool = False):
        self.source = source
        self.base_dir = base_dir
        self.allow_outside = allow_outside

    def fail(self, path: str, msg: str) -> NoReturn:
        raise SceneError(f"{self.source}: {path}: {msg}")

    def file(self, name: Any, path: str) -> str:
        """The file a scene field names: relative to the scene's folder and
        inside it (after following links) unless outside files are allowed.
        Inside, the path returned is the resolved one, read with
        ``nofollow`` (``self.nofollow``): a link swapped in after the check
        is refused rather than followed outside."""
        if not isinstance(name, str) or not name:
            self.fail(path, f"expected a file name, got {name!r:.80}")
        full = os.path.join(self.base_dir, name)
        if not self.allow_outside:
            base = os.path.realpath(self.base_dir)
            real = os.path.realpath(full)
            if os.path.commonpath([base, real]) != base:
                self.fail(path, f"{name}: outside the scene's folder {base} "
                                "(load with allow_outside=True, or --allow-outside, to read it)")
            return real
        return full

    @property
    def nofollow(self) -> bool:
        return not self.allow_outside

    def integer(self, v: Any, path: str, lo: int, hi: int) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(path, f"expected an integer, got {v!r:.80}")
        if not lo <= v <= hi:
            self.fail(path, f"must be an integer in [{lo}, {hi}], got {v if abs(v) < 10**20 else '(a huge integer)'}")
        return v

    def obj(self, v: Any, path: str) -> dict[str, Any]:
        if not isinstance(v, dict):
            self.fail(path, f"expected an object, got {type(v).__name__}")
        return v

    def known(self, d: dict[str, Any], path: str, keys: set[str]) -> None:
        extra = set(d) - keys
        if extra:
            self.fail(f"{path}.{sorted(extra)[0]}" if path else sorted(extra)[0], f"unknown field (allowed: {', '.join(sorted(keys))})")

    def num(self, v: Any, path: str, lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False) -> float:
        # numbers.Real: int, float and numpy's scalars (np.int64, np.float32), not bool
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
            self.fail(path, f"expected a number, got {v!r:.80}")
        try:
            x = float(v)
        except OverflowError:
            self.fail(path, f"must be at most {MAX_MAGNITUDE:g} in magnitude, got an integer of {len(str(abs(v)))} digits")
        if not math.isfinite(x):
            self.fail(path, f"must be finite, got {v!r}")
        if abs(x) > MAX_MAGNITUDE:
            self.fail(path, f"must be at most {MAX_MAGNITUDE:g} in magnitude (the renderer computes in float32), got {x!r}")
        if x < lo or x > hi or (lo_open and x == lo):
            lo_s = "(" if lo_open else "["
            self.fail(path, f"must be in {lo_s}{lo}, {hi}], got {x}")
        return x

    def vec3(self, v: Any, path: str, lo: float = -math.inf, hi: float = math.inf) -> list[float]:
        if not isinstance(v, (list, tuple)) or len(v) != 3:
            self.fail(path, f"expected 3 numbers, got {v!r:.80}")
        return [self.num(x, f"{path}[{i}]", lo, hi) for i, x in enumerate(v)]

    def boolean(self, v: Any, path: str) -> bool:
        if not isinstance(v, bool):
            self.fail(path, f"expected true or false, got {v!r}")
        return v


def _strand_arrays(points: npt.ArrayLike, radii: npt.ArrayLike, offsets: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked flat strand arrays: (points (M, 3) f64, radii (M,) f64, offsets (S + 1,) int64)."""
    for name, a in (("points", points), ("radii", radii)):
        if np.iscomplexobj(a):
            raise SceneError(f"{name}: expected real numbers, got complex ones")
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise SceneError(f"points: expected shape (M, 3), got {p.shape}")
    r = np.asarray(radii, dtype=np.float64)
    if r.ndim == 0:
        r = np.full(len(p), float(r))
    if r.shape != (len(p),):
        raise SceneError(f"radii: expected a scalar or shape ({len(p)},), got {r.shape}")
    o = np.asarray(offsets)
    if o.ndim != 1 or o.dtype.kind not in "iu" or len(o) < 1:
        raise SceneError(f"offsets: expected a 1-d integer array of S + 1 entries, got {o.dtype} {o.shape}")
    o = o.astype(np.int64)
    if o[0] != 0 or o[-1] != len(p):
        raise SceneError(f"offsets: must start at 0 and end at len(points) = {len(p)}, got {o[0]} ... {o[-1]}")
    short = np.flatnonzero(np.diff(o) < 2)
    if len(short):
        raise SceneError(f"offsets: strand {short[0]} has {o[short[0] + 1] - o[short[0]]} points (at least 2, increasing offsets)")
    bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
    if len(bad):
        raise SceneError(f"points[{bad[0]}]: must be finite, got {p[bad[0]].tolist()}")
    bad = np.flatnonzero(~(np.isfinite(r) & (r >= 0)))
    if len(bad):
        raise SceneError(f"radii[{bad[0]}]: must be finite and >= 0, got {r[bad[0]]}")
    msg = _magnitude_error(p, r, "points", "radii")
    if msg:
        raise SceneError(msg)
    return p, r, o


def _strand_arrays_plausible(points: Any, radii: Any, offsets: Any) -> bool:
    """Whether the strand arrays of a loaded scene pass :func:`_strand_arrays`
    without a copy: float32 arrays of the right shapes whose largest
    magnitude is within MAX_MAGNITUDE (NaN fails the comparison), radii
    >= 0, offsets from 0 to len(points) by at least 2. A reduction per array
    (the demo head's 425 000 points: under 1 ms, against 10 ms for the full
    check on every render); False sends the arrays to the full check."""
    p, r, o = points, radii, offsets
    if not all(isinstance(a, np.ndarray) for a in (p, r, o)):
        return False
    if p.dtype != np.float32 or r.dtype != np.float32 or o.dtype.kind not in "iu":
        return False
    if p.ndim != 2 or p.shape[1] != 3 or r.shape != (len(p),) or o.ndim != 1 or len(o) < 1:
        return False
    if o[0] != 0 or o[-1] != len(p) or (len(o) > 1 and np.diff(o.astype(np.int64)).min() < 2):
        return False
    if len(p) == 0:
        return True
    # (max and min without a temporary; either is NaN where a value is)
    return bool(p.max() <= MAX_MAGNITUDE and -p.min() <= MAX_MAGNITUDE and r.min() >= 0 and r.max() <= MAX_MAGNITUDE)


def _magnitude_error(p: np.ndarray, r: np.ndarray, points: str, radii: str) -> str | None:
    """The scene format's bound on every number (``MAX_MAGNITUDE``: the
    renderer computes in float32) for strand points and radii from arrays
    and binary files, as for those of a scene file: the first value beyond
    it, named, or None."""
    bad = np.flatnonzero(~(np.abs(p) <= MAX_MAGNITUDE).all(axis=1))
    if len(bad):
        return (f"{points}[{bad[0]}]: must be at most {MAX_MAGNITUDE:g} in magnitude (the renderer computes "
                f"in float32), got {p[bad[0]].tolist()}")
    bad = np.flatnonzero(~(np.abs(r) <= MAX_MAGNITUDE))
    if len(bad):
        return (f"{radii}[{bad[0]}]: must be at most {MAX_MAGNITUDE:g} in magnitude (the renderer computes "
                f"in float32), got {r[bad[0]]:g}")
    return None


#: The smallest sine of the angle between the viewing direction and
#: camera.up, and the smallest distance between camera.target and
#: camera.position relative to their size: float32 rounds each coordinate
#: by up to 6e-8 of its magnitude, so the viewing direction (target -
#: position) is then known to about 1e-4 rad (0.1 pixel of a 640-pixel
#: image at 40 degrees), and the image's roll to 1e-4 rad.
MIN_VIEW_SEPARATION = 1e-3
#: The narrowest field of view in degrees (at 1e-30 the projected strand
#: widths overflow float32 and the image is black).
MIN_FOV = 1e-3


def _unit(c: "_Ctx", v: list[float], path: str) -> list[float]:
    """The unit vector along ``v``, normalized in float64 after scaling by
    its largest component (so [1e-40, 0, 0] is +x, not a vector float32
    rounds to zero)."""
    a = np.asarray(v, dtype=np.float64)
    m = float(np.max(np.abs(a)))
    if m == 0:
        c.fail(path, "must not be zero")
    a = a / m
    return (a / np.linalg.norm(a)).tolist()


def light_vector(light: dict[str, Any]) -> list[float]:
    """What the renderers take of a light of ``Scene.lights``: a point
    light's position, or a directional light's unit direction (towards the
    light), normalized in float64 after scaling by its largest component (a
    tiny vector such as [1e-40, 0, 0] would round to zero in float32)."""
    v = np.asarray(light["vector"], dtype=np.float64)
    if light["type"] != "directional":
        return v.tolist()
    v = v / np.max(np.abs(v))
    return (v / np.linalg.norm(v)).tolist()


def _check_view(c: "_Ctx", camera: dict[str, Any]) -> None:
    """A camera float32 can carry: target away from position, up away from
    the viewing direction, fov not below MIN_FOV (the numbers themselves
    already checked)."""
    pos, target, up = (np.asarray(camera[k], dtype=np.float64) for k in ("position", "target", "up"))
    fwd = target - pos
    size = max(float(np.max(np.abs(pos))), float(np.max(np.abs(target))))
    dist = float(np.linalg.norm(fwd))
    if dist == 0:
        c.fail("camera.target", "must differ from camera.position")
    if dist < MIN_VIEW_SEPARATION * size:
        c.fail("camera.target", f"must be at least {MIN_VIEW_SEPARATION:g} x {size:.6g} (the larger coordinate of "
                                f"position and target) from camera.position for float32 to resolve the viewing "
                                f"direction, got {dist:.3g}")
    if not np.any(up):
        c.fail("camera.up", "must not be zero")
    up_n = up / np.max(np.abs(up))
    if np.linalg.norm(np.cross(fwd / dist, up_n / np.linalg.norm(up_n))) < MIN_VIEW_SEPARATION:
        c.fail("camera.up", f"must not be parallel to the viewing direction (at least {MIN_VIEW_SEPARATION:g} rad "
                            "away from it)")
    if camera["fov"] < MIN_FOV:
        c.fail("camera.fov", f"must be in [{MIN_FOV:g}, 179] degrees, got {camera['fov']:.3g}")


def _parse(d: Any, base_dir: str, source: str,
           strands: list[tuple[np.ndarray, np.ndarray]] | None = None, allow_outside: bool = False) -> Scene:
    """The validated scene of the dict ``d``; ``strands``: (points, radii)
    of further strands, already checked (Scene.from_arrays); files it names
    must lie in ``base_dir`` unless ``allow_outside``."""
    c = _Ctx(source, base_dir, allow_outside)
    d = c.obj(d, "(top level)")
    c.known(d, "", {"hairshade_scene", "camera", "lights", "hair", "meshes", "render"})
    version = d.get("hairshade_scene")
    if type(version) is not int or version != VERSION:
        c.fail("hairshade_scene", f"expected version {VERSION}, got {version!r:.80}")

    cam = c.obj(d.get("camera"), "camera")
    c.known(cam, "camera", {"position", "target", "up", "fov", "resolution"})
    res = cam.get("resolution", [640, 360])
    if not isinstance(res, (list, tuple)) or len(res) != 2:
        c.fail("camera.resolution", f"expected [width, height], got {res!r}")
    width = c.integer(res[0], "camera.resolution[0]", 1, 16384)
    height = c.integer(res[1], "camera.resolution[1]", 1, 16384)
    camera = dict(
        position=c.vec3(cam.get("position"), "camera.position"),
        target=c.vec3(cam.get("target"), "camera.target"),
        up=c.vec3(cam.get("up", [0, 1, 0]), "camera.up"),
        fov=c.num(cam.get("fov", 40), "camera.fov", 0, 179, lo_open=True),
        width=width,
        height=height,
    )
    _check_view(c, camera)

    lights: list[dict[str, Any]] = []
    env = None
    raw_lights = d.get("lights", [])
    if not isinstance(raw_lights, list):
        c.fail("lights", "expected a list")
    for i, l in enumerate(raw_lights):
        p = f"lights[{i}]"
        l = c.obj(l, p)
        kind = l.get("type")
        if kind == "directional":
            c.known(l, p, {"type", "direction", "intensity", "shadows"})
            direction = c.vec3(l.get("direction"), f"{p}.direction")
            _unit(c, direction, f"{p}.direction")
            lights.append(dict(type=kind, vector=direction, intensity=c.vec3(l.get("intensity"), f"{p}.intensity", 0),
                               shadows=c.boolean(l.get("shadows", True), f"{p}.shadows")))
        elif kind == "point":
            c.known(l, p, {"type", "position", "intensity", "shadows"})
            lights.append(dict(type=kind, vector=c.vec3(l.get("position"), f"{p}.position"),
                               intensity=c.vec3(l.get("intensity"), f"{p}.intensity", 0),
                               shadows=c.boolean(l.get("shadows", False), f"{p}.shadows")))
        elif kind == "environment":
            c.known(l, p, {"type", "radiance", "sh"})
            if env is not None:
                c.fail(p, "only one environment light is allowed")
            if "sh" in l:
                sh = l["sh"]
                if not isinstance(sh, list) or len(sh) != 9:
                    c.fail(f"{p}.sh", "expected 9 RGB coefficients")
                env = np.array([c.vec3(x, f"{p}.sh[{k}]") for k, x in enumerate(sh)], dtype=np.float32)
            else:
                rad = c.vec3(l.get("radiance"), f"{p}.radiance", 0)
                env = sh_coefficients(rad).astype(np.float32)
        else:
            c.fail(f"{p}.type", f"expected 'directional', 'point' or 'environment', got {kind!r}")

    hair = c.obj(d.get("hair", {}), "hair")
    c.known(hair, "hair", {"strands", "file", "generate", "cards", "generate_cards", "material", "curve"})
    curve = _parse_curve(c, hair.get("curve", "polyline"))
    pts: list[np.ndarray] = []
    rads: list[np.ndarray] = []
    raw_strands = hair.get("strands", [])
    if not isinstance(raw_strands, list):
        c.fail("hair.strands", "expected a list")
    for i, s in enumerate(raw_strands):
        p = f"hair.strands[{i}]"
        s = c.obj(s, p)
        c.known(s, p, {"points", "radius", "radii"})
        if "radius" in s and "radii" in s:
            c.fail(p, "give radius or radii, not both")
        raw = s.get("points")
        if not isinstance(raw, list) or len(raw) < 2:
            c.fail(f"{p}.points", "expected a list of at least 2 points")
        v = np.array([c.vec3(x, f"{p}.points[{k}]") for k, x in enumerate(raw)], dtype=np.float64)
        if "radii" in s:
            rr = s["radii"]
            if not isinstance(rr, list) or len(rr) != len(v):
                c.fail(f"{p}.radii", f"expected {len(v)} radii (one per point)")
            r = np.array([c.num(x, f"{p}.radii[{k}]", 0) for k, x in enumerate(rr)])
        else:
            r = np.full(len(v), c.num(s.get("radius", 0.005), f"{p}.radius", 0))
        pts.append(v)
        rads.append(r)
    if "file" in hair:
        fpts, frads = _read_hair_file(c.file(hair["file"], "hair.file"), c, hair["file"])
        pts += fpts
        rads += frads
    if "generate" in hair:
        from .generate import generate

        spec = c.obj(hair["generate"], "hair.generate")
        try:
            gp, gr = generate(spec)
        except (TypeError, ValueError) as e:
            c.fail("hair.generate", str(e))
        pts += gp
        rads += gr
    for sp, sr in strands or []:
        pts.append(sp)
        rads.append(sr)
    points, radii, offsets = _flat_strands(pts, rads)

    cards = _parse_cards(hair, base_dir, c)

    mat = dict(c.obj(hair.get("material", {"model": "karis"}), "hair.material"))
    model = mat.get("model", "karis")
    if model not in options.MODELS:
        c.fail("hair.material.model", f"expected {options.choices_text(options.MODELS)}, got {model!r}")
    mat["model"] = model

    spheres = []
    obj_meshes = []
    raw_meshes = d.get("meshes", [])
    if not isinstance(raw_meshes, list):
        c.fail("meshes", "expected a list")
    for i, m in enumerate(raw_meshes):
        p = f"meshes[{i}]"
        m = c.obj(m, p)
        if m.get("type") == "obj":
            c.known(m, p, {"type", "file", "albedo"})
            path = c.file(m.get("file"), f"{p}.file")
            tris = _read_obj(path, c, f"{p}.file")
            obj_meshes.append(dict(file=path, albedo=c.vec3(m.get("albedo", [0.5, 0.5, 0.5]), f"{p}.albedo", 0, 1), triangles=tris))
            continue
        if m.get("type") != "sphere":
            c.fail(f"{p}.type", f"expected 'sphere' or 'obj', got {m.get('type')!r}")
        c.known(m, p, {"type", "center", "radius", "albedo"})
        spheres.append(dict(center=c.vec3(m.get("center"), f"{p}.center"),
                            radius=c.num(m.get("radius"), f"{p}.radius", 0, lo_open=True),
                            albedo=c.vec3(m.get("albedo", [0.5, 0.5, 0.5]), f"{p}.albedo", 0, 1)))

    r = c.obj(d.get("render", {}), "render")
    try:
        render = options.translate_flat(r, whole_section=True, model=mat["model"], environment=env is not None)
    except SceneError as e:
        raise SceneError(f"{c.source}: {e}") from None
    scene = Scene(camera, lights, env, points, radii, offsets, spheres, mat, render, source)
    scene.cards = cards
    scene.obj_meshes = obj_meshes
    scene.curve = curve
    try:
        scene.options()  # every setting checked at load: applies here, in range
    except SceneError as e:
        raise SceneError(f"{c.source}: {e}") from None
    return scene


def _parse_curve(c: _Ctx, v: Any) -> tuple[str, float]:
    """``hair.curve``: a curve's name, or {name: {"pixels": bound}}."""
    from .curves import CURVES, DEFAULT_PIXELS

    if isinstance(v, dict):
        if len(v) != 1:
            c.fail("hair.curve", f"expected one of {', '.join(CURVES)} or {{name: {{\"pixels\": bound}}}}")
        name, opts = next(iter(v.items()))
        opts = c.obj(opts, f"hair.curve.{name}")
        c.known(opts, f"hair.curve.{name}", {"pixels"})
        pixels = c.num(opts.get("pixels", DEFAULT_PIXELS), f"hair.curve.{name}.pixels", 0.25, 1024)
    else:
        name, pixels = v, DEFAULT_PIXELS
    if name not in CURVES:
        c.fail("hair.curve", f"expected one of {', '.join(CURVES)}, got {name!r:.80}")
    return str(name), float(pixels)


def _read_obj(path: str, c: _Ctx, field_path: str) -> np.ndarray:
    """Triangles (T, 3, 3) of an OBJ file's `v` and `f` lines (polygons fan-
    triangulated; texture/normal indices and everything else ignored)."""
    from . import _memory

    text = read_text(path, MAX_OBJ_BYTES, lambda msg: SceneError(f"{c.source}: {field_path}: {path}: {msg}"),
                     c.nofollow)
    _memory.check(len(text) * OBJ_BYTES_PER_BYTE, f"{c.source}: {field_path}: {path}",
                  "simplify the mesh")
    lines = text.splitlines()
    del text
    verts: list[list[float]] = []
    tris: list[list[int]] = []
    for n, line in enumerate(lines, 1):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        if parts[0] == "v":
            try:
                v = [float(x) for x in parts[1:4]]
            except ValueError:
                v = []
            if len(v) != 3 or not all(math.isfinite(x) and abs(x) <= MAX_MAGNITUDE for x in v):
                c.fail(field_path, f"{path}:{n}: expected 'v x y z' with finite numbers, got {show(line)}")
            verts.append(v)
        elif parts[0] == "f":
            try:
                idx = [int(x.split("/")[0]) for x in parts[1:]]
            except ValueError:
                c.fail(field_path, f"{path}:{n}: bad face {show(line)}")
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            if len(idx) < 3 or any(i < 0 or i >= len(verts) for i in idx):
                c.fail(field_path, f"{path}:{n}: face indices out of range in {show(line)}")
            tris += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    if not tris:
        c.fail(field_path, f"{path}: no faces")
    return np.asarray(verts, dtype=np.float32)[np.asarray(tris)]


#: Peak bytes of loading a baked card's fiber vertex (24 per fiber):
#: 83.8 measured for 2000 cards x 256 fibers, 82.7 for 200 x 2048 (peak
#: RSS of Scene.from_dict over the vertices), rounded up.
BYTES_PER_BAKED_VERTEX = 96


def _baked_fibers(card: Any) -> int:
    """The baked fibers a card (or a ``generate_cards`` spec) asks for per
    card; 0 for anything the checks that follow will refuse."""
    alpha = card.get("alpha", {"bake": {}}) if isinstance(card, dict) else None
    bake = alpha.get("bake") if isinstance(alpha, dict) else None
    n = bake.get("fibers", 24) if isinstance(bake, dict) else 0
    return n if isinstance(n, int) and not isinstance(n, bool) and 0 < n <= 4096 else 0


def _check_baked_memory(where: str, cards: int, fibers: int) -> None:
    """MemoryError naming ``where`` before ``fibers`` baked fibers of
    ``cards`` cards are built, when they would need more memory than is
    available (200 000 cards of 4096 fibers grew for minutes towards
    1.5 TB)."""
    from .cards import card_fiber_strands
    from . import _memory

    samples = card_fiber_strands.__defaults__[-1]
    _memory.check(fibers * samples * BYTES_PER_BAKED_VERTEX, f"{where}: {cards} cards, {fibers} baked fibers",
                  "lower cards or bake.fibers")


def _parse_cards(hair: dict[str, Any], base_dir: str, c: _Ctx) -> dict[str, Any] | None:
    """Cards as flat arrays for the renderer, or None."""
    from .cards import card_fiber_strands, card_quads, head_cards, load_alpha

    raw = hair.get("cards", [])
    if not isinstance(raw, list):
        c.fail("hair.cards", "expected a list")
    entries = [(f"hair.cards[{i}]", x) for i, x in enumerate(raw)]
    if "generate_cards" in hair:
        spec = c.obj(hair["generate_cards"], "hair.generate_cards")
        count = spec.get("cards", 400)
        if isinstance(count, int) and not isinstance(count, bool) and count > 0:
            _check_baked_memory("hair.generate_cards", count, count * _baked_fibers(spec))
        try:
            gen = head_cards(spec)
        except (TypeError, ValueError) as e:
            c.fail("hair.generate_cards", str(e))
        entries += [(f"hair.generate_cards (card {i})", x) for i, x in enumerate(gen)]
    if not entries:
        return None
    _check_baked_memory("hair.cards", len(entries), sum(_baked_fibers(x) for _, x in entries))
    corners, uvs, tangents, tex_index = [], [], [], []
    fiber_pts: list[np.ndarray] = []
    fiber_rads: list[np.ndarray] = []
    all_baked = True
    textures: list[np.ndarray] = []
    tex_keys: dict[str, int] = {}
    specs: list[tuple[dict[str, Any], str | None]] = []
    for path, card in entries:
        card = c.obj(card, path)
        c.known(card, path, {"points", "width", "normal", "alpha"})
        raw_pts = card.get("points")
        if not isinstance(raw_pts, list) or len(raw_pts) < 2:
            c.fail(f"{path}.points", "expected a list of at least 2 points")
        pts = np.array([c.vec3(x, f"{path}.points[{k}]") for k, x in enumerate(raw_pts)])
        width = c.num(card.get("width"), f"{path}.width", 0, lo_open=True)
        normal = np.array(c.vec3(card.get("normal", [0, 0, 1]), f"{path}.normal"))
        if np.linalg.norm(normal) == 0:
            c.fail(f"{path}.normal", "must not be zero")
        alpha_spec = c.obj(card.get("alpha", {"bake": {}}), f"{path}.alpha")
        key = json.dumps(alpha_spec, sort_keys=True)
        if key not in tex_keys:
            try:
                textures.append(load_alpha(alpha_spec, base_dir, lambda name: c.file(name, f"{path}.alpha.image")))
            except SceneError:
                raise
            except (TypeError, ValueError, OSError) as e:
                c.fail(f"{path}.alpha", str(e))
            tex_keys[key] = len(textures) - 1
        try:
            q, uv, t = card_quads(pts, width, normal / np.linalg.norm(normal))
        except ValueError as e:
            c.fail(path, str(e))
        corners.append(q)
        uvs.append(uv)
        tangents.append(t)
        specs.append((card, c.file(alpha_spec["image"], f"{path}.alpha.image") if "image" in alpha_spec else None))
        if "bake" in alpha_spec:  # checked by load_alpha above
            fp, fr = card_fiber_strands(pts, width, normal / np.linalg.norm(normal), alpha_spec["bake"])
            fiber_pts += fp
            fiber_rads += fr
        else:
            all_baked = False
        tex_index.append(np.full(len(t), tex_keys[key], dtype=np.uint32))
    return dict(
        corners=np.concatenate(corners).astype(np.float32),
        uvs=np.concatenate(uvs).astype(np.float32),
        tangents=np.concatenate(tangents).astype(np.float32),
        texture=np.concatenate(tex_index),
        textures=textures,
        # The fibers baked cards stand for, flat as the strands (points,
        # radii, offsets; None unless every card is baked).
        fibers=_flat_strands(fiber_pts, fiber_rads) if all_baked else None,
        # every card as given (generated ones expanded), and the path of its
        # alpha image (None when baked): what Scene.save writes back
        specs=specs,
    )


def _flat_strands(pts: list[np.ndarray], rads: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Strands given as lists of per-strand points and radii, as flat
    float32 points (M, 3), radii (M,) and uint32 offsets (S + 1,)."""
    offsets = np.zeros(len(pts) + 1, dtype=np.uint32)
    offsets[1:] = np.cumsum([len(p) for p in pts]) if pts else []
    points = np.concatenate(pts).astype(np.float32) if pts else np.zeros((0, 3), np.float32)
    radii = np.concatenate(rads).astype(np.float32) if rads else np.zeros(0, np.float32)
    return points, radii, offsets


def _read_hair_file(path: str, c: _Ctx, name: str) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """A hair file's strands as lists of (points, radii): ``.hair``
    (binary, :mod:`hairshade.hairfile`) or the text format, by the extension
    of the ``name`` the scene gave (``path`` may be its resolved target)."""
    from .usd import is_usd

    if is_usd(name):
        return _read_usd_file(path, c)
    if not name.lower().endswith(".hair"):
        return _read_strand_file(path, c)
    from .hairfile import parse_hair

    # A regular file within the size limit, as every file a scene names.
    data = read_bytes(path, MAX_TEXT_BYTES, lambda msg: SceneError(f"{c.source}: hair.file: {path}: {msg}"),
                      c.nofollow)
    try:
        p, r, o = parse_hair(data, path)
    except ValueError as e:
        c.fail("hair.file", str(e))
    msg = _magnitude_error(p, r, f"{path}: point", f"{path}: radius")
    if msg:
        c.fail("hair.file", msg)
    return np.split(p.astype(np.float64), o[1:-1]), np.split(r.astype(np.float64), o[1:-1])


def _read_usd_file(path: str, c: _Ctx) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """A USD groom's strands (:func:`hairshade.usd.read_usd`, cubic curves
    subdivided to within a tenth of the fiber radius)."""
    from .usd import GroomError, read_usd

    try:
        g = read_usd(path)
    except GroomError as e:
        c.fail("hair.file", str(e))
    msg = _magnitude_error(g.points, g.radii, f"{path}: point", f"{path}: radius")
    if msg:
        c.fail("hair.file", msg)
    o = g.offsets.astype(np.int64)
    return np.split(g.points.astype(np.float64), o[1:-1]), np.split(g.radii.astype(np.float64), o[1:-1])


def _read_strand_file(path: str, c: _Ctx) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """`x y z r` per line, blank lines between strands, `#` comments."""
    lines = read_text(path, MAX_TEXT_BYTES, lambda msg: SceneError(f"{c.source}: hair.file: {path}: {msg}"),
                      c.nofollow).splitlines()
    pts: list[np.ndarray] = []
    rads: list[np.ndarray] = []
    cur: list[list[float]] = []

    def flush(line_no: int) -> None:
        if cur:
            if len(cur) < 2:
                c.fail("hair.file", f"{path}:{line_no}: a strand needs at least 2 vertices")
            a = np.array(cur, dtype=np.float64)
            pts.append(a[:, :3])
            rads.append(a[:, 3])
            cur.clear()

    for n, line in enumerate(lines, 1):
        s = line.split("#", 1)[0].strip()
        if not s:
            flush(n)
            continue
        parts = s.split()
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            c.fail("hair.file", f"{path}:{n}: expected 4 numbers 'x y z r', got {show(line)}")
        if len(vals) != 4 or not all(math.isfinite(v) and abs(v) <= MAX_MAGNITUDE for v in vals) or vals[3] < 0:
            c.fail("hair.file", f"{path}:{n}: expected 4 finite numbers 'x y z r' (at most {MAX_MAGNITUDE:g} "
                                f"in magnitude) with r >= 0, got {show(line)}")
        cur.append(vals)
    flush(len(lines))
    return pts, rads


def write_strand_file(path: str, points: np.ndarray, radii: np.ndarray, offsets: np.ndarray) -> None:
    """Writes strands in the `x y z r` text format (also Mitsuba's curve
    format): one vertex per line, a blank line after each strand."""
    rows = np.column_stack([np.asarray(points, dtype=np.float64).reshape(-1, 3),
                            np.asarray(radii, dtype=np.float64).reshape(-1)]).tolist()
    lines = ["%.7g %.7g %.7g %.7g" % tuple(r) for r in rows]
    for e in np.asarray(offsets[1:], dtype=np.int64) - 1:
        if e >= 0:
            lines[e] += "\n"
    with open(path, "w") as f:
        f.write("\n".join(lines))
        if lines:
            f.write("\n")
