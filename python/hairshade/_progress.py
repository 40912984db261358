"""Progress bars for sweeps and renders, in one place: tqdm's (``tqdm.auto``:
a widget in Jupyter, text in a terminal) when tqdm is installed
(``pip install 'hairshade[progress]'``), else a text bar on stderr. Both
show the count, the elapsed time, the rate and the ETA.

``enabled``: None shows the bar where it can be seen (a terminal; with tqdm
also a notebook), True forces it, False hides it. Ctrl-C propagates as
KeyboardInterrupt; the bar is closed first.
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import Any, Iterable, Iterator, TypeVar

T = TypeVar("T")


def _tqdm() -> Any:
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm


class Bar:
    """A bar of ``total`` steps (``unit`` per step), advanced with
    :meth:`update_to`; a context manager that closes it."""

    def __init__(self, total: int, desc: str = "", unit: str = "it", enabled: bool | None = None) -> None:
        self.total, self.desc, self.unit = total, desc, unit
        self._start = time.perf_counter()
        self._tq = None
        self._text = False
        if enabled is False:
            return
        tqdm = _tqdm()
        if tqdm is not None:
            # disable=None: tqdm hides the bar on a non-terminal stream, except in a notebook
            self._tq = tqdm(total=total, desc=desc, unit=unit, disable=None if enabled is None else False, leave=True)
        else:
            self._text = bool(enabled) or sys.stderr.isatty()

    def update_to(self, done: int, total: int | None = None) -> None:
        if total is not None:
            self.total = total
        if self._tq is not None:
            if total is not None:
                self._tq.total = total
            self._tq.update(done - self._tq.n)
        elif self._text:
            sys.stderr.write("\r" + text_line(self.desc, done, self.total, time.perf_counter() - self._start, self.unit))
            sys.stderr.flush()

    def close(self) -> None:
        if self._tq is not None:
            self._tq.close()
        elif self._text:
            sys.stderr.write("\n")
            sys.stderr.flush()
        self._tq, self._text = None, False

    def __enter__(self) -> "Bar":
        return self

    def __exit__(self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


def text_line(desc: str, done: int, total: int, elapsed: float, unit: str = "it", width: int = 30) -> str:
    """``desc [#####.....] done/total  elapsed  rate  ETA`` (the text bar)."""
    frac = min(done / total, 1.0) if total else 0.0
    bar = "#" * int(width * frac) + "." * (width - int(width * frac))
    rate = done / elapsed if elapsed > 0 else 0.0
    eta = f"{(total - done) / rate:6.1f}s" if rate > 0 and total else "     ?"
    return f"{desc} [{bar}] {done}/{total or '?'}  {elapsed:6.1f}s  {rate:8.2f} {unit}/s  ETA {eta}"


def progress(items: Iterable[T], total: int | None = None, desc: str = "", enabled: bool | None = True) -> Iterator[T]:
    """Yields ``items`` with a :class:`Bar`. ``enabled``: True (or None)
    shows it where it can be seen, False hides it."""
    if total is None:
        try:
            total = len(items)  # type: ignore[arg-type]
        except TypeError:
            total = 0
    with Bar(total, desc, enabled=None if enabled else False) as bar:
        for k, item in enumerate(items, 1):
            yield item
            bar.update_to(k)
