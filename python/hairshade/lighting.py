"""Environment light as band-2 real spherical harmonics (9 RGB
coefficients, order Y00, Y1-1, Y10, Y11, Y2-2, Y2-1, Y20, Y21, Y22), the form
KarisHair's environment lighting and the renderer take."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._native import SH_Y00

Y00: float = float(SH_Y00)
"""The constant basis function 1/(2 sqrt(pi)): a constant radiance L has the
single coefficient L / Y00."""


def sh_coefficients(sh: npt.ArrayLike) -> np.ndarray:
    """(9, 3) float64 SH coefficients from (3,) constant radiance, or (4, 3)
    / (9, 3) coefficients (bands 0-1 / 0-2; missing bands are 0). Raises
    ValueError for other shapes or non-finite values."""
    c = np.asarray(sh, dtype=np.float64)
    if c.shape == (3,):
        c = np.vstack([c / Y00, np.zeros((8, 3))])
    elif c.shape == (4, 3):
        c = np.vstack([c, np.zeros((5, 3))])
    elif c.shape != (9, 3):
        raise ValueError(f"sh: expected (3,), (4, 3) or (9, 3), got {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError("sh: coefficients must be finite")
    return c
