"""Array conversion shared by every model wrapper.

Rules (the public contract):

- directions are array-likes of shape (N, 3) or (3,); a (3,) input broadcasts
  against the other arguments;
- float32 inputs (all of them) give float32 outputs computed in f32; anything
  else is converted to float64 and computed in f64;
- contiguous inputs of the chosen dtype are passed to Rust without a copy;
- if every input was a single vector, the leading axis of the result is
  dropped (shape (3,) or ()).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import numpy.typing as npt


def _as_array(x: npt.ArrayLike, name: str) -> np.ndarray:
    try:
        a = np.asarray(x)
    except Exception as e:  # ragged nested lists and the like
        raise ValueError(f"{name}: cannot be converted to an array ({e})") from None
    if a.dtype.kind not in "fiub":
        raise ValueError(f"{name}: expected real numbers, got dtype {a.dtype}")
    return a


def common_dtype(arrays: Sequence[np.ndarray]) -> type:
    """float32 if every array is float32, else float64."""
    return np.float32 if all(a.dtype == np.float32 for a in arrays) else np.float64


def directions(x: npt.ArrayLike, name: str) -> np.ndarray:
    """Validates a (N, 3) or (3,) direction array (dtype left as given;
    booleans are not directions)."""
    a = _as_array(x, name)
    if a.dtype.kind == "b":
        raise ValueError(f"{name}: expected real numbers, got booleans")
    if a.ndim == 1 and a.shape[0] == 3:
        return a
    if a.ndim == 2 and a.shape[1] == 3 and a.shape[0] > 0:
        return a
    raise ValueError(f"{name}: expected shape (N, 3) with N >= 1 or (3,), got {a.shape}")


def pair_count(wi: np.ndarray, wo: np.ndarray) -> int:
    ni = 1 if wi.ndim == 1 else wi.shape[0]
    no = 1 if wo.ndim == 1 else wo.shape[0]
    if ni != no and 1 not in (ni, no):
        raise ValueError(f"wi, wo: shapes {wi.shape} and {wo.shape} do not broadcast")
    return max(ni, no)


def flat(a: np.ndarray, dtype: type) -> np.ndarray:
    """C-contiguous 1-D view of `a` in `dtype` (a copy only when needed)."""
    return np.ascontiguousarray(a, dtype=dtype).reshape(-1)


def prepare_pairs(wi: npt.ArrayLike, wo: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, type, int, bool]:
    """(flat wi, flat wo, dtype, N, single) for a pair-wise evaluation."""
    a = directions(wi, "wi")
    b = directions(wo, "wo")
    n = pair_count(a, b)
    dtype = common_dtype([a, b])
    single = a.ndim == 1 and b.ndim == 1
    return flat(a, dtype), flat(b, dtype), dtype, n, single


def uniforms(x: npt.ArrayLike, name: str, n: int | None, width: int) -> np.ndarray:
    """Validates random numbers of shape (N,) (width 1) or (N, width)."""
    a = _as_array(x, name)
    shape = (n,) if width == 1 else (n, width)
    if n is None:
        ok = (a.ndim == 1 and a.shape[0] > 0) if width == 1 else (a.ndim == 2 and a.shape[1] == width and a.shape[0] > 0)
    else:
        ok = a.shape == shape
    if not ok:
        want = "(N,)" if width == 1 else f"(N, {width})"
        raise ValueError(f"{name}: expected shape {want}" + (f" with N = {n}" if n is not None else "") + f", got {a.shape}")
    return a
