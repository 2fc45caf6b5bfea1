"""The ``peridyn`` logger's set-up for the command line: plain lines on stderr, or one JSON object
per line (``--log-json``, for batch systems and log collectors), written around a progress bar
when one is on the terminal."""
from __future__ import annotations

import json
import logging
import sys
import time
from typing import Any

#: whether the command's own messages (errors) are JSON records too
STATE = {"json": False}


class JsonFormatter(logging.Formatter):
    """``{"time": ISO 8601 UTC, "level", "logger", "message", ...}``; a record's ``fields`` extra
    (a dict: progress counts, residuals) is merged in."""

    def format(self, record: logging.LogRecord) -> str:
        out: dict[str, Any] = {
            "time": time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(record.created)) + f".{int(record.msecs):03d}Z",
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        fields = getattr(record, "fields", None)
        if isinstance(fields, dict):
            out.update(fields)
        if record.exc_info:
            out["traceback"] = self.formatException(record.exc_info)
        return json.dumps(out, default=str)


class BarAwareHandler(logging.StreamHandler):
    """A stderr handler that prints above a tqdm bar (``tqdm.write``) while one is shown, so log
    lines and the bar do not overwrite each other."""

    def emit(self, record: logging.LogRecord) -> None:
        tqdm_module = sys.modules.get("tqdm")
        bars = getattr(getattr(tqdm_module, "tqdm", None), "_instances", None) if tqdm_module is not None else None
        if bars:
            try:
                tqdm_module.tqdm.write(self.format(record), file=self.stream)
            except Exception:  # noqa: BLE001 - logging must not raise
                self.handleError(record)
            return
        super().emit(record)


def setup_logging(verbosity: int, rank: int = 0, *, as_json: bool = False) -> None:
    """The ``peridyn`` logger at WARNING (verbosity < 0), INFO (0) or DEBUG (> 0); ranks other
    than 0 report errors only. ``as_json``: one JSON object per record."""
    level = logging.WARNING if verbosity < 0 else logging.INFO if verbosity == 0 else logging.DEBUG
    if rank != 0:
        level = logging.ERROR
    root = logging.getLogger("peridyn")
    root.handlers.clear()
    handler = BarAwareHandler(sys.stderr)
    if as_json:
        handler.setFormatter(JsonFormatter())
    else:
        handler.setFormatter(logging.Formatter("%(message)s" if verbosity <= 0 else "%(levelname)s %(name)s: %(message)s"))
    root.addHandler(handler)
    root.setLevel(level)
    root.propagate = False
    STATE["json"] = as_json


def say(kind: str, text: str, **fields: Any) -> None:
    """A message of the command itself on stderr: ``kind: text`` (error, internal error, ...), or
    a JSON record ``{"level": "error", "event": kind, "message": text, ...}`` with ``--log-json``."""
    if STATE["json"]:
        record = {"time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "level": "error" if "error" in kind else "info",
                  "logger": "peridyn", "event": "error" if kind.startswith("error") else kind.replace(" ", "_") or "message",
                  "message": text, **fields}
        print(json.dumps(record, default=str), file=sys.stderr)
    else:
        print(f"{kind}: {text}" if kind else text, file=sys.stderr)
