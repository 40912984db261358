"""A dependency-free progress bar on stderr for sweeps and renders."""

from __future__ import annotations

import sys
import time
from typing import Iterable, Iterator, TypeVar

T = TypeVar("T")


def progress(items: Iterable[T], total: int | None = None, desc: str = "", enabled: bool = True) -> Iterator[T]:
    """Yields `items`, drawing `desc [#####.....] k/n  elapsed` on stderr
    (only when stderr is a terminal or `enabled` is forced on by the caller).
    Ctrl-C propagates as KeyboardInterrupt; the bar line is closed first."""
    if total is None:
        try:
            total = len(items)  # type: ignore[arg-type]
        except TypeError:
            total = 0
    show = enabled and sys.stderr.isatty()
    start = time.perf_counter()
    width = 30
    k = 0
    try:
        for k, item in enumerate(items, 1):
            yield item
            if show:
                frac = k / total if total else 0.0
                bar = "#" * int(width * frac) + "." * (width - int(width * frac))
                sys.stderr.write(f"\r{desc} [{bar}] {k}/{total or '?'}  {time.perf_counter() - start:5.1f}s")
                sys.stderr.flush()
    finally:
        if show:
            sys.stderr.write("\n")
            sys.stderr.flush()
