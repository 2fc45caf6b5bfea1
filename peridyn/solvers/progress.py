"""A progress bar with ETA for long runs, and run summaries, through ``logging``."""
from __future__ import annotations

import logging
import os
import sys
import time

log = logging.getLogger("peridyn.progress")


def _fmt_seconds(s: float) -> str:
    if s != s or s == float("inf"):
        return "?"
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m:02d}:{sec:02d}"


class Progress:
    """Shows ``label [#####.....] 45% step 450/1000 ETA 00:12`` on a terminal (stderr), or a log
    line every 10 % otherwise; silent for runs shorter than ``min_seconds``."""

    def __init__(self, total: int, label: str = "", *, enabled: bool = True, min_seconds: float = 2.0, stream=None) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = enabled and os.environ.get("PERIDYN_NO_PROGRESS", "") in ("", "0")
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.last_draw = 0.0
        self.last_decile = -1
        self.min_seconds = min_seconds
        self.shown = False

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        elapsed = now - self.start
        if elapsed < self.min_seconds and done < self.total:
            return
        frac = min(done / self.total, 1.0)
        eta = elapsed * (1.0 - frac) / frac if frac > 0 else float("inf")
        if self.tty:
            if now - self.last_draw < 0.2 and done < self.total:
                return
            self.last_draw = now
            width = 30
            filled = int(width * frac)
            bar = "#" * filled + "." * (width - filled)
            self.stream.write(f"\r{self.label} [{bar}] {frac:4.0%} step {done}/{self.total} ETA {_fmt_seconds(eta)}  ")
            self.stream.flush()
            self.shown = True
        else:
            decile = int(frac * 10)
            if decile > self.last_decile:
                self.last_decile = decile
                log.info("%s %3.0f%% step %d/%d, elapsed %s, ETA %s", self.label, 100 * frac, done, self.total, _fmt_seconds(elapsed), _fmt_seconds(eta))

    def close(self) -> None:
        if self.shown and self.tty:
            self.stream.write("\n")
            self.stream.flush()
