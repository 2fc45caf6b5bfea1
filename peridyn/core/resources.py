"""What this machine has to give a run, read the same way wherever a size is judged: the cores
and the memory available now, and whether the size limits are switched off
(``PERIDYN_NO_LIMITS=1``, which ``peridyn run --no-limits`` sets)."""
from __future__ import annotations

import math
import os

#: the environment variable that turns the size refusals into warnings
NO_LIMITS_ENV = "PERIDYN_NO_LIMITS"


def limits_off() -> bool:
    """Whether ``PERIDYN_NO_LIMITS`` asks for refusals of size to be warnings."""
    return os.environ.get(NO_LIMITS_ENV, "").strip().lower() not in ("", "0", "false", "no")


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system has one), at least 1."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def available_memory() -> float:
    """Bytes of memory available to this process now (MemAvailable; total memory if unknown)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def human_bytes(n: float) -> str:
    """``n`` bytes as 1.5 GiB and the like."""
    if not math.isfinite(n):
        return "an unbounded amount"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024.0 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024.0
    return f"{n:.3g} PiB"  # pragma: no cover
