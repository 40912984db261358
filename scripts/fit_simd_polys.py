"""Fits the polynomial approximations of the f32 vector kernels (src/simd_math.rs).

Prints the coefficient tables as Rust constants. Each is a least-squares
fit on Chebyshev nodes (close to minimax), in float64, against numpy/scipy:

- ``I0E_LARGE``: ``sqrt(x) * i0e(x)`` for ``x >= I0_SWITCH`` as a polynomial in
  ``u = I0_SWITCH / x`` on (0, 1] (below the switch, ``I0_SMALL``);
- ``ATAN``: ``atan(a) / a`` as a polynomial in ``a^2`` on [0, 1];
- ``I0_SMALL``: ``I0(x)`` for ``x <= I0_SWITCH`` as a polynomial in
  ``q = x^2 / 4`` on [0, I0_SWITCH^2 / 4], fitted in relative error (9 terms
  where the power series needs 12);
- ``EXPM``: ``(e^r - 1 - r) / r^2`` as a polynomial in ``r`` on
  ``|r| <= ln 2 / 2``, fitted in relative error of ``e^r`` (the range
  reduction of the kernels' exponential).

The maximum errors printed are those of the float64 polynomials; the Rust
tests measure the f32 evaluation against the f64 special functions.
Run: ``python scripts/fit_simd_polys.py``.
"""

import math

import numpy as np
from numpy.polynomial import chebyshev as C
from numpy.polynomial import polynomial as P
from scipy.special import i0, i0e

I0_SWITCH = 6.0
I0E_LARGE_DEGREE = 6
ATAN_DEGREE = 8
I0_SMALL_DEGREE = 8
EXPM_DEGREE = 3


def fit(f, degree: int, m: int = 4000) -> np.ndarray:
    """Monomial coefficients (lowest first) of the fit of f on [0, 1]."""
    x = 0.5 + 0.5 * np.cos(np.pi * (np.arange(m) + 0.5) / m)
    return C.cheb2poly(C.chebfit(x, f(x), degree))


def fit_relative(f, lo: float, hi: float, degree: int, weight, m: int = 4000) -> np.ndarray:
    """Monomial coefficients (lowest first) of the least-squares fit of f on
    Chebyshev nodes of [lo, hi], each residual scaled by ``weight``."""
    x = 0.5 * (lo + hi) + 0.5 * (hi - lo) * np.cos(np.pi * (np.arange(m) + 0.5) / m)
    w = weight(x)
    c, *_ = np.linalg.lstsq(np.vander(x, degree + 1, increasing=True) * w[:, None], f(x) * w, rcond=None)
    return c


def series_terms(x: float, rel: float = 2e-8) -> int:
    """Terms k = 0..K of sum (x^2/4)^k / (k!)^2 whose tail is below rel."""
    q = x * x / 4
    t = [q**k / math.factorial(k) ** 2 for k in range(80)]
    return next(K for K in range(80) if sum(t[K + 1:]) / sum(t) < rel)


def rust(name: str, c: np.ndarray) -> str:
    body = ", ".join(repr(float(np.float32(v))) for v in c)
    return f"const {name}: [f32; {len(c)}] = [{body}];"


def main() -> None:
    k = series_terms(I0_SWITCH)
    print(f"// (the power series of I0 below {I0_SWITCH} would need terms k = 0..={k})")
    g = lambda u: np.sqrt(I0_SWITCH / u) * i0e(I0_SWITCH / u)
    u = np.linspace(1e-6, 1.0, 200001)
    p = fit(g, I0E_LARGE_DEGREE)
    print(f"// max rel error {np.max(np.abs(P.polyval(u, p) / g(u) - 1)):.2e}")
    print(rust("I0E_LARGE", p))
    s = np.linspace(1e-12, 1.0, 200001)
    a = np.sqrt(s)
    p = fit(lambda s: np.arctan(np.sqrt(s)) / np.sqrt(s), ATAN_DEGREE)
    print(f"// max abs error {np.max(np.abs(a * P.polyval(s, p) - np.arctan(a))):.2e}")
    print(rust("ATAN", p))
    i0q = lambda q: i0(2 * np.sqrt(q))
    qmax = I0_SWITCH**2 / 4
    p = fit_relative(i0q, 0.0, qmax, I0_SMALL_DEGREE, lambda q: 1 / i0q(q))
    q = np.linspace(0.0, qmax, 200001)
    p32 = p.astype(np.float32).astype(np.float64)
    print(f"// max rel error {np.max(np.abs(P.polyval(q, p32) / i0q(q) - 1)):.2e} (f32 coefficients)")
    print(rust("I0_SMALL", p))
    h = math.log(2) / 2
    expm = lambda r: (np.expm1(r) - r) / r**2
    p = fit_relative(expm, -h, h, EXPM_DEGREE, lambda r: r**2 / np.exp(r))
    r = np.linspace(-h, h, 200001)
    r = r[r != 0]
    p32 = p.astype(np.float32).astype(np.float64)
    print(f"// max rel error {np.max(np.abs((1 + r + r**2 * P.polyval(r, p32)) / np.exp(r) - 1)):.2e} (f32 coefficients)")
    print(rust("EXPM", p))


if __name__ == "__main__":
    main()
