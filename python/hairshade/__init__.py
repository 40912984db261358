"""hairshade: hair fiber BSDFs and a CPU hair renderer, validated against Mitsuba 3.

>>> import hairshade as hs
>>> c = hs.ChiangHair(eumelanin=1.3, pheomelanin=0.2)
>>> c.eval([0.0, 0.2, 1.0], [0.3, -0.2, 0.9]).shape
(3,)
"""

from . import _env  # noqa: F401  (checks the environment first)
from . import lobes
from ._native import __version__, num_threads
from .chiang import ChiangHair
from .deon import DEonHair
from .karis import KarisHair
from .render import read_exr, rel_mse, render, side_by_side, write_exr, write_png
from .scene import Scene, SceneError

__all__ = [
    "ChiangHair", "DEonHair", "KarisHair", "Scene", "SceneError", "lobes", "render",
    "read_exr", "write_exr", "write_png", "rel_mse", "side_by_side", "__version__", "num_threads",
]
