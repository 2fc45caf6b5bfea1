"""Progress of a solver section: a tqdm bar with its ETA on a terminal, silent elsewhere, and
structured records for batch systems (``peridyn run --log-json``).

A solver counts its steps (``update``) and may report what it is doing inside one (``note``:
the Newton iteration and residual against the tolerance of an implicit load step). On a terminal
the bar shows both; with JSON logging on, a record ``{"event": "progress", ...}`` goes to the
``peridyn.progress`` logger at every tenth of the run (and at its end) with the same fields.
"""
from __future__ import annotations

import logging
import os
import sys
import time
from typing import Any

log = logging.getLogger("peridyn.progress")

#: set by ``peridyn run --log-json``: progress records go to the log (one per tenth of a run)
STRUCTURED = {"on": False}


def structured_progress(on: bool) -> None:
    """Emit progress records through logging (for ``--log-json``) instead of staying silent
    when stderr is not a terminal."""
    STRUCTURED["on"] = bool(on)


class Progress:
    """``total`` steps of a solver section called ``label``; a bar on a terminal once the run
    has lasted ``min_seconds``, nothing (or records, see the module) elsewhere.
    ``enabled=False`` or ``PERIDYN_NO_PROGRESS=1``: nothing at all."""

    def __init__(self, total: int, label: str = "", *, enabled: bool = True, unit: str = "step", min_seconds: float = 2.0,
                 stream=None) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.unit = unit
        self.enabled = enabled and os.environ.get("PERIDYN_NO_PROGRESS", "") in ("", "0")
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.done = 0
        self.status: dict[str, Any] = {}
        self.last_tenth = -1
        self.bar = None
        if self.enabled and self.tty:
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, desc=label, unit=unit, file=self.stream, delay=min_seconds, mininterval=0.2,
                            dynamic_ncols=True, leave=True)

    def update(self, done: int, **status: Any) -> None:
        """``done`` steps of ``total`` finished; ``status``: what to show beside the count."""
        if not self.enabled:
            return
        self.done = done
        if status:
            self.status = status
        if self.bar is not None:
            if status:
                self.bar.set_postfix_str(self._status_text(), refresh=False)
            self.bar.update(done - self.bar.n)
        elif STRUCTURED["on"]:
            tenth = int(10 * min(done / self.total, 1.0))
            if tenth > self.last_tenth:
                self.last_tenth = tenth
                self._record()

    def retotal(self, total: int) -> None:
        """The number of steps changed (a load step cut in two)."""
        self.total = max(int(total), 1)
        if self.bar is not None:
            self.bar.total = self.total
            self.bar.refresh()

    def note(self, **status: Any) -> None:
        """Show ``status`` (e.g. iteration=3, residual=2e-5, tolerance=1e-8) inside a step."""
        if not self.enabled:
            return
        self.status = status
        if self.bar is not None:
            self.bar.set_postfix_str(self._status_text())

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def eta(self) -> float:
        """Seconds left at the mean rate so far (inf before the first step)."""
        elapsed = time.perf_counter() - self.start
        return elapsed * (self.total - self.done) / self.done if self.done > 0 else float("inf")

    def _status_text(self) -> str:
        parts = []
        for k, v in self.status.items():
            parts.append(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}")
        return ", ".join(parts)

    def _record(self) -> None:
        elapsed = time.perf_counter() - self.start
        done = self.done
        eta = self.eta()
        fields = {"event": "progress", "section": self.label, "unit": self.unit, "done": done, "total": self.total,
                  "elapsed_s": round(elapsed, 3), "eta_s": round(eta, 3) if eta != float("inf") else None, **self.status}
        log.info("%s %d/%d %ss, elapsed %.1f s, ETA %s", self.label, done, self.total, self.unit, elapsed,
                 f"{eta:.1f} s" if eta != float("inf") else "?", extra={"fields": fields})
