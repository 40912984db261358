"""The environment variables hairshade reads, checked at import.

``HAIRSHADE_SIMD`` lowers the vector kernels' instruction set
(``avx512``, ``avx2`` or ``portable``; for measurements and tests). The
kernels read it once; a value they do not know would be ignored
silently, so it is refused here with the values allowed.

``RAYON_NUM_THREADS`` sets the thread pool's size: a whole number from 1
to ``MAX_THREADS``. Anything else (0, negative, not a number, more threads
than a process can reasonably start) is refused here with the range,
instead of being ignored or failing when the pool starts.
"""

from __future__ import annotations

import os

SIMD_LEVELS = ("avx512", "avx2", "portable")

#: The most threads ``RAYON_NUM_THREADS`` may ask for.
MAX_THREADS = 1024


def check_simd(value: str | None) -> None:
    if value is not None and value not in SIMD_LEVELS:
        raise ImportError(f"HAIRSHADE_SIMD: expected 'avx512', 'avx2' or 'portable' (or unset), got {value!r}")


def check_threads(value: str | None) -> None:
    if value is None:
        return
    text = value.strip()
    if not (text.isdigit() and 1 <= int(text) <= MAX_THREADS):
        raise ImportError(f"RAYON_NUM_THREADS: expected a whole number of threads in [1, {MAX_THREADS}] "
                          f"(or unset: one per CPU), got {value!r:.40}")


check_simd(os.environ.get("HAIRSHADE_SIMD"))
check_threads(os.environ.get("RAYON_NUM_THREADS"))
