"""Checks of a scene's fields, shared by loading (:mod:`hairshade._scene_parse`)
and by :meth:`hairshade.Scene.check`: a context that names the file and
the field in every error, the strand arrays' checks, the camera's and
the curve's."""

from __future__ import annotations

import math
import numbers
import os
from typing import Any, Iterator, NoReturn

import numpy as np
import numpy.typing as npt

from ._errors import SceneError

#: Largest magnitude of a number in a scene (see :mod:`hairshade.scene`).
MAX_MAGNITUDE = 1e18



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

    def objects(self, v: Any, path: str) -> Iterator[tuple[str, dict[str, Any]]]:
        """(``path[i]``, the object) for each entry of the list ``v``."""
        if not isinstance(v, list):
            self.fail(path, "expected a list")
        for i, x in enumerate(v):
            yield f"{path}[{i}]", self.obj(x, f"{path}[{i}]")

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
