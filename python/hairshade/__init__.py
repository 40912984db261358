"""hairshade: hair fiber BSDFs and a CPU hair renderer, validated against Mitsuba 3.

>>> import hairshade as hs
>>> c = hs.ChiangHair(eumelanin=1.3, pheomelanin=0.2)
>>> c.eval([0.0, 0.2, 1.0], [0.3, -0.2, 0.9]).shape
(3,)
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from . import _env  # noqa: F401  (checks the environment first)
from . import lobes
from ._native import __version__, num_threads
from .chiang import ChiangHair
from .deon import DEonHair
from .karis import KarisHair
from .render import Preview, exr_layers, read_exr, rel_mse, render, show, side_by_side, tonemap, write_exr, write_png
from .scene import Scene, SceneError

if TYPE_CHECKING:
    from . import mapping

EXAMPLES_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "examples")


def examples() -> list[str]:
    """Paths of the example scene files shipped with the package (sorted),
    each loadable with :meth:`Scene.load`."""
    return sorted(os.path.join(EXAMPLES_DIR, f) for f in os.listdir(EXAMPLES_DIR) if f.endswith(".json"))


def __getattr__(name: str) -> Any:
    # hairshade.mapping needs scipy: imported on first use, not by `import hairshade`
    # (without scipy it raises MissingExtra naming hairshade[mapping]).
    if name == "mapping":
        import importlib

        return importlib.import_module(".mapping", __name__)
    raise AttributeError(f"module 'hairshade' has no attribute {name!r}")


__all__ = [
    "ChiangHair", "DEonHair", "KarisHair", "Scene", "SceneError", "lobes", "mapping", "render",
    "read_exr", "exr_layers", "write_exr", "write_png", "tonemap", "show", "Preview", "rel_mse", "side_by_side", "examples",
    "__version__", "num_threads",
]
