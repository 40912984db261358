"""The environment variables hairshade reads, checked at import.

``HAIRSHADE_SIMD`` lowers the vector kernels' instruction set
(``avx512``, ``avx2`` or ``portable``; for measurements and tests). The
kernels read it once; a value they do not know would be ignored
silently, so it is refused here with the values allowed.
"""

from __future__ import annotations

import os

SIMD_LEVELS = ("avx512", "avx2", "portable")


def check_simd(value: str | None) -> None:
    if value is not None and value not in SIMD_LEVELS:
        raise ImportError(f"HAIRSHADE_SIMD: expected 'avx512', 'avx2' or 'portable' (or unset), got {value!r}")


check_simd(os.environ.get("HAIRSHADE_SIMD"))
