"""Optional dependencies: which extra installs each, and one clear error when
one is missing.

The core package needs numpy only. Every feature that needs more imports it
through :func:`require`, which raises :class:`MissingExtra` (an
``ImportError``) naming the ``pip install`` line; the command line checks
its command's extras with :func:`check` before doing any work.
"""

from __future__ import annotations

import importlib
from types import ModuleType

# import name -> (distribution, extra of hairshade that installs it)
EXTRAS: dict[str, tuple[str, str]] = {
    "mitsuba": ("mitsuba", "mitsuba"),
    "drjit": ("drjit", "mitsuba"),
    "scipy": ("scipy", "mapping"),
    "matplotlib": ("matplotlib", "plot"),
    "flip_evaluator": ("flip-evaluator", "flip"),
    "tqdm": ("tqdm", "progress"),
    "pxr": ("usd-core", "usd"),
    "bpy": ("bpy", "blender"),
}


class MissingExtra(ImportError):
    """An optional dependency is not installed; the message says what to install."""


def missing(modules: list[str]) -> list[str]:
    """The modules of ``modules`` that cannot be found (without importing them)."""
    import importlib.util

    return [m for m in modules if importlib.util.find_spec(m) is None]


def message(modules: list[str], what: str, extras: list[str] | None = None) -> str:
    dists = ", ".join(dict.fromkeys(EXTRAS[m][0] for m in modules))
    names = ",".join(extras or dict.fromkeys(EXTRAS[m][1] for m in modules))
    return f"{what} needs {dists}: pip install 'hairshade[{names}]'"


def check(modules: list[str], what: str, extras: list[str] | None = None) -> None:
    """Raises MissingExtra naming the missing modules and the extras that
    install them (``extras``, or each module's own), else nothing."""
    gone = missing(modules)
    if gone:
        raise MissingExtra(message(gone, what, extras))


def require(module: str, what: str) -> ModuleType:
    """``import module``, or MissingExtra saying which extra installs it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        if e.name is not None and e.name.split(".")[0] != module.split(".")[0]:
            raise  # a broken install of something else: keep the original error
        raise MissingExtra(message([module.split(".")[0]], what)) from e
