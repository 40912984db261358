"""Writing a script's measurements into docs/: its rows as CSV, its page as
Markdown (shared by the scripts that generate docs pages)."""

from __future__ import annotations

import csv
import os
from typing import Any, Sequence


def write_csv(path: str, rows: Sequence[dict[str, Any]]) -> None:
    """``rows`` (dicts with the first row's keys) as CSV at ``path``."""
    with open(path, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)


def write_markdown(path: str, lines: Sequence[str]) -> None:
    """``lines`` as a Markdown page at ``path`` (one newline at the end),
    and says so."""
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("wrote", path)
