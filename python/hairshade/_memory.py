"""Memory the process can still use, for estimates made before large
allocations (procedural hair; the renderer has its own, in Rust)."""

from __future__ import annotations

import resource


def available_bytes() -> int | None:
    """The smaller of the system's available memory (``MemAvailable``) and
    what the address-space limit (``RLIMIT_AS``) leaves; None where
    ``/proc`` cannot be read."""
    try:
        with open("/proc/meminfo") as f:
            info = dict(line.split(":", 1) for line in f if ":" in line)
        avail = int(info["MemAvailable"].split()[0]) * 1024
    except (OSError, KeyError, ValueError):
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        try:
            with open("/proc/self/status") as f:
                used = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))
        except (OSError, StopIteration, ValueError):
            used = 0
        avail = min(avail, max(soft - used, 0))
    return avail


def check(needed: int, what: str, hint: str) -> None:
    """MemoryError naming ``what`` when ``needed`` bytes exceed what is available."""
    avail = available_bytes()
    if avail is not None and needed > avail:
        gib = 1 << 30
        raise MemoryError(f"{what}: needs about {needed / gib:.2f} GiB, more than the {avail / gib:.2f} GiB available; {hint}")
