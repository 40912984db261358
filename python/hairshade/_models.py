"""Shared plumbing of the model wrappers: pickling (every model), components,
colors and per-pair inputs (KarisHair, DEonHair)."""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np
import numpy.typing as npt

from . import _arrays

COMPONENTS = ("R", "TT", "TRT", "MS")


class Picklable:
    """Pickling for a model whose ``_params`` are its constructor's keyword
    arguments: the parameters are pickled and the native model is rebuilt
    from them on load (so the copy evaluates bit-identically)."""

    _params: dict[str, Any]

    def __getstate__(self) -> dict[str, Any]:
        return dict(self._params)

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(**state)  # type: ignore[misc]


def components(value: str | Iterable[str], allowed: tuple[str, ...]) -> list[str]:
    names = [value] if isinstance(value, str) else list(value)
    for n in names:
        if n not in allowed:
            raise ValueError(f"components: unknown component {n!r}; allowed: {', '.join(allowed)}")
    return names


def scalar(value: object, name: str) -> float:
    """A real-number parameter as float: ints, floats and numpy scalars
    (not bools, not strings); the error names the parameter."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a number, got {value!r:.80}")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name}: too large for a float, got an integer of {len(str(abs(int(value))))} digits") from None


def flag(value: object, name: str) -> bool:
    """A boolean parameter (True/False only)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, got {value!r:.80}")
    return bool(value)


def rgb(value: npt.ArrayLike, name: str) -> list[float]:
    raw = np.asarray(value) if not isinstance(value, str) else None
    if raw is None or raw.dtype.kind not in "fiu":
        raise TypeError(f"{name}: expected a number or 3 numbers, got {value!r:.80}")
    a = raw.astype(np.float64)
    if a.ndim == 0:
        a = np.repeat(a, 3)
    if a.shape != (3,):
        raise ValueError(f"{name}: expected 3 values (RGB), got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
        raise ValueError(f"{name}: each component must be finite and in [0, 1], got {a.tolist()}")
    return [float(x) for x in a]


def triples(L: npt.ArrayLike, V: npt.ArrayLike, T: npt.ArrayLike) -> tuple[list[np.ndarray], type, int, bool]:
    """Validated (flat L, V, T), dtype, N, single for a world-space evaluation."""
    arrs = [_arrays.directions(x, n) for x, n in ((L, "L"), (V, "V"), (T, "T"))]
    counts = [1 if a.ndim == 1 else a.shape[0] for a in arrs]
    n = max(counts)
    for a, c, name in zip(arrs, counts, "LVT"):
        if c not in (1, n):
            raise ValueError(f"L, V, T: shapes {[x.shape for x in arrs]} do not broadcast ({name})")
    dtype = _arrays.common_dtype(arrs)
    single = all(a.ndim == 1 for a in arrs)
    return [_arrays.flat(a, dtype) for a in arrs], dtype, n, single


def per_pair(value: npt.ArrayLike, name: str, n: int, dtype: type, rgb_values: bool,
             bounds: tuple[float, float] | None = None) -> tuple[np.ndarray, bool]:
    """A per-pair input: scalar or (N,) (rgb_values False); scalar, (3,) or
    (N, 3) (rgb_values True), its finite values within ``bounds`` when
    given (non-finite ones give a 0 result, like degenerate directions).
    Returns (flat array, is_single)."""
    a = np.asarray(value)
    if a.dtype.kind not in "fiub":
        raise ValueError(f"{name}: expected real numbers, got dtype {a.dtype}")
    if rgb_values:
        if a.ndim == 0:
            a = np.repeat(a.reshape(1), 3)
        ok = a.shape == (3,) or a.shape == (n, 3)
        want = f"a scalar, (3,) or ({n}, 3)"
    else:
        if a.ndim == 0:
            a = a.reshape(1)
        ok = a.shape == (1,) or a.shape == (n,)
        want = f"a scalar or ({n},)"
    if not ok:
        raise ValueError(f"{name}: expected {want}, got shape {np.shape(value)}")
    if bounds is not None:
        lo, hi = bounds
        with np.errstate(invalid="ignore"):
            bad = np.isfinite(a) & ((a < lo) | (a > hi))
        if np.any(bad):
            k = int(np.flatnonzero(bad.reshape(-1))[0])
            raise ValueError(f"{name}: must be in [{lo}, {hi}], got {a.reshape(-1)[k]} (value {k})")
    single = a.shape in ((1,), (3,))
    return _arrays.flat(a, dtype), single
