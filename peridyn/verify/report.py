"""``report.md`` and its figures (error against wall time, log-log, one curve per method) from
the state of a verification run (what ``results.json`` holds)."""
from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from ..io.plot import pyplot
from .fit import fit_rate

log = logging.getLogger("peridyn.verify")

PLOT_HINT = 'pip install "peridyn[plot]"'


def _cell(text: str) -> str:
    """``text`` fit for a markdown table cell (its pipes escaped)."""
    return str(text).replace("|", "\\|")


def _fmt(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return str(value)
        return f"{value:.4g}" if 1e-3 <= abs(value) < 1e5 or value == 0 else f"{value:.3e}"
    return str(value)


def _compare(result: dict[str, Any] | None) -> list[str]:
    """The ``--compare`` section: the points whose error moved beyond their tolerance."""
    if not result:
        return []
    lines = [f"## Compared with {result.get('against')}", "",
             f"{result['compared']} point(s) compared; **{len(result['moved'])} moved beyond their tolerance**"
             if result["moved"] else f"{result['compared']} point(s) compared; none moved beyond its tolerance", ""]
    if result["moved"]:
        lines += ["| problem | method | resolution | error before | error now | why |", "|---|---|---|---|---|---|"]
        lines += [f"| {m['problem']} | {_cell(m['method'])} | {_fmt(m['resolution'])} | {_fmt(m['before'])} | {_fmt(m['now'])} | {_cell(m['why'])} |"
                  for m in result["moved"]]
        lines.append("")
    for key, what in (("only before", "only in the earlier run"), ("only now", "only in this run")):
        if result.get(key):
            lines += [f"Points {what} (not compared): " + ", ".join(f"{p} {m} {r:g}" for p, m, r in result[key][:20])
                      + (" ..." if len(result[key]) > 20 else ""), ""]
    return lines


def _result(check: dict[str, Any]) -> str:
    if check["passed"]:
        return "pass"
    return f"**FAIL** (known: {_cell(check['known'])})" if check.get("known") else "**FAIL**"


def figure(entry: dict[str, Any], path: Path, plt) -> bool:
    """Error (y) against wall time (x), log-log, one curve per method with its fitted rate in
    the legend; False when no method has a point with a positive error and time."""
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    drawn = False
    for method in entry["methods"]:
        pts = [p for p in entry["points"] if p["method"] == method and p.get("error") and p["error"] > 0 and p["wall (s)"] > 0]
        if not pts:
            continue
        rate = entry["rates"].get(method)
        label = f"{method} (rate {rate:.2f} in {entry['size']})" if rate is not None and math.isfinite(rate) else method
        ax.loglog([p["wall (s)"] for p in pts], [p["error"] for p in pts], "o-", label=label)
        for p in pts:
            ax.annotate(f"{p['resolution']:g}", (p["wall (s)"], p["error"]), textcoords="offset points", xytext=(4, 4), fontsize=7)
        drawn = True
    for name, (error_key, wall_key) in entry.get("companions", {}).items():
        for method in entry["methods"]:
            pts = [p for p in entry["points"] if p["method"] == method and "failure" not in p
                   and (p.get("values", {}).get(error_key) or 0) > 0 and (p.get("values", {}).get(wall_key) or 0) > 0]
            if not pts:
                continue
            label = f"{method}: {name}"
            if len(pts) >= 2 and all(p.get("size") for p in pts):
                rate = fit_rate([p["size"] for p in pts], [p["values"][error_key] for p in pts])
                label += f" (rate {rate:.2f} in {entry['size']})" if math.isfinite(rate) else ""
            ax.loglog([p["values"][wall_key] for p in pts], [p["values"][error_key] for p in pts], "s--", label=label)
            drawn = True
    for q in entry.get("peridigm", []):
        if q.get("error") and q["error"] > 0 and q.get("wall (s)", 0) > 0:
            ax.loglog([q["wall (s)"]], [q["error"]], "k*", markersize=11, label=f"Peridigm: {q['method']}")
            drawn = True
    if drawn:
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(entry["error"])
        ax.set_title(f"{entry['name']}: {entry['error']} against wall time\n(labels: {entry['resolution']})", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if len(ax.get_lines()) > 8:  # many curves (rigid-rotation's materials): the legend beside the axes
            fig.set_size_inches(10.0, 4.2)
            ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.02, 1.0), ncol=2)
            fig.subplots_adjust(left=0.1, right=0.55, bottom=0.12, top=0.87)
        else:
            ax.legend(fontsize=8)
            fig.subplots_adjust(left=0.17, right=0.97, bottom=0.12, top=0.87)  # fixed margins: tight_layout doubled each figure's time
        fig.savefig(path, dpi=110)
    plt.close(fig)
    return drawn


def _table(entry: dict[str, Any]) -> list[str]:
    extra: list[str] = []
    for p in entry["points"]:
        for k in p.get("values", {}):
            if k not in extra:
                extra.append(k)
    curve = entry["kind"] == "curve"
    head = ["method", entry["resolution"]] + ([entry["size"], entry["error"]] if curve else []) + extra + ["wall (s)", "steps", "peak memory (MiB)"]
    lines = ["| " + " | ".join(_cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    for p in entry["points"]:
        row = [p["method"], _fmt(p["resolution"])] + ([_fmt(p.get("size")), _fmt(p.get("error"))] if curve else [])
        row += [_fmt(p.get("values", {}).get(k)) for k in extra]
        spread = p.get("wall spread (s)")
        wall = _fmt(p["wall (s)"]) + (f" ({_fmt(spread[0])} .. {_fmt(spread[1])}, median of {p['wall runs']})" if spread else "")
        row += [wall, _fmt(p["steps"]), f"{p['peak memory (MiB)']:.0f}"]
        if "failure" in p:
            row[-1] += f" (failed: {p['failure']})"
        lines.append("| " + " | ".join(_cell(c) for c in row) + " |")
    return lines


def write_report(state: dict[str, Any], out: Path, *, figures: bool = True) -> Path:
    """Write ``out/report.md`` (and ``out/<problem>.png`` per plotted problem when matplotlib is
    installed; one log line saying how to get them otherwise). Returns the report's path."""
    out = Path(out)
    plt = pyplot() if figures else None
    if figures and plt is None:
        log.warning("figures skipped: matplotlib is not installed (%s gives them); report.md is written without them", PLOT_HINT)
    m, v = state["machine"], state["peridyn"]
    failed = state.get("failed checks", 0)
    lines = [
        "# peridyn verify",
        "",
        f"- command: `{state['command']}`{' (quick: the coarsest resolutions)' if state['quick'] else ''}",
        f"- status: {state['status']}; {'**' + str(failed) + ' check(s) FAIL**' if failed else 'every check passes'}; "
        f"wall time {state['wall (s)']:.1f} s"
        + (f"; {state['known misses']} known miss(es), shown as FAIL (known: why) and not counted" if state.get("known misses") else ""),
        f"- date: {state['date']}; peridyn {v['version']}" + (f", commit {v['commit']}" if v.get("commit") else "")
        + (f" ({v['commit from']})" if v.get("commit from") else ""),
        f"- machine: {m['cpu']}, {m['cores']} cores ({m['usable cores']} usable, {m['numba threads']} numba threads); {m['platform']}, "
        f"Python {m['python']}" + (f"; GPU: {m['gpu']}" if m.get("gpu") else ""),
        "",
        "Each point runs serially in one process; wall time is the point's own (set-up included unless its problem says "
        "otherwise; a point of a curve under 0.1 s is run up to 5 times and its wall time is the median, the range of the "
        "runs beside it), peak memory the process's peak resident size so far (getrusage)."
        + (f" Run under mpiexec with {state['ranks']} ranks, which shared out the points: each point's time was taken while "
           "the other ranks ran theirs on the same machine." if state.get("ranks", 1) > 1 else ""),
        "",
    ]
    lines += _compare(state.get("compare"))
    for entry in state["problems"]:
        lines += [f"## {entry['name']}: {entry['title']}", "", f"**Computed.** {entry['computes']}", "",
                  f"**Reference.** {entry['reference']}", ""]
        if not entry["points"]:
            lines += ["Not run (the run was interrupted before it)." if state["status"] == "interrupted" else "No points.", ""]
            continue
        lines += _table(entry) + [""]
        for q in entry.get("peridigm", []):
            lines += [f"Peridigm's own point ({q['method']}): {entry['error']} {_fmt(q['error'])} in {_fmt(q['wall (s)'])} s; {q['what']}", ""]
        if entry["kind"] == "curve":
            rates = [f"{meth}: {_fmt(r)}" if r is not None else f"{meth}: not fitted ({entry['unfitted'].get(meth, 'too few points')})"
                     for meth, r in entry["rates"].items()]
            if rates:
                lines += [f"Fitted rate of the {entry['error']} in {entry['size']} (least squares, log-log): " + "; ".join(rates) + ".", ""]
        if plt is not None and entry.get("plotted", entry["kind"] == "curve"):
            png = out / f"{entry['name']}.png"
            if figure(entry, png, plt):
                lines += [f"![{entry['name']}: error against wall time]({png.name})", ""]
        lines += ["| check | method | value | band | result |", "|---|---|---|---|---|"]
        for c in entry["checks"]:
            lines.append(f"| {_cell(c['what'])} | {_cell(c['method'])} | {_cell(c['shown']) if c.get('shown') else _fmt(c['value'])} | {c['band']} | {_result(c)} |")
        lines.append("")
    path = out / "report.md"
    tmp = path.with_name("report.md.tmp")
    tmp.write_text("\n".join(lines), encoding="utf-8")
    tmp.replace(path)
    return path
