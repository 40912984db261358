"""Bridge to Mitsuba 3: the same hair materials evaluated by Mitsuba's own
``hair`` plugin, on numpy arrays, for validation and benchmarks, and whole
hairshade scenes rendered by Mitsuba as references.

Mitsuba is optional at install time (``pip install hairshade[mitsuba]``);
importing this package without it raises ImportError with that hint.

Variants: ``llvm_ad_rgb`` evaluates whole batches in one JIT kernel and is
the fast path; its JIT needs LLVM >= 16 (Debian 12's default LLVM 14/15
aborts the process on ``fmaximum``), so it is used only when
``DRJIT_LIBLLVM_PATH`` is set or a known libLLVM >= 16 is present, in which
case ``DRJIT_LIBLLVM_PATH`` is set before drjit loads. ``scalar_rgb`` works
everywhere and loops in Python (about 20 µs per pair). Both are single
precision.

This module holds what must happen before drjit is imported (finding
libLLVM), the import itself and :func:`default_variant`; the rest lives in

- :mod:`.bsdf`: Mitsuba's ``hair`` BSDF on numpy arrays (:class:`MitsubaHair`,
  :func:`hair_dict`);
- :mod:`.plugins`: hairshade's models registered as Mitsuba BSDFs
  (:func:`register_plugins`);
- :mod:`.scene`: whole scenes (:func:`scene_dict`, :func:`render`);

and every public name is available from here.
"""

from __future__ import annotations

import glob
import os

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
    import drjit as dr  # noqa: F401  (imported here, after DRJIT_LIBLLVM_PATH is set)
    import mitsuba as mi
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError(
        "hairshade.mitsuba needs Mitsuba 3: pip install 'hairshade[mitsuba]'"
    ) from e


def default_variant() -> str:
    """``llvm_ad_rgb`` when a usable LLVM is present, else ``scalar_rgb``."""
    return "llvm_ad_rgb" if _LLVM and "llvm_ad_rgb" in mi.variants() else "scalar_rgb"


# The submodules import drjit and mitsuba themselves: only after the lines
# above have run (importing any of them runs this file first).
from .bsdf import MitsubaHair, hair_dict  # noqa: E402
from .plugins import register_plugins  # noqa: E402
from .scene import LoadedScene, render, scene_dict  # noqa: E402

__all__ = [
    "LoadedScene",
    "MitsubaHair",
    "default_variant",
    "find_libllvm",
    "hair_dict",
    "register_plugins",
    "render",
    "scene_dict",
]
