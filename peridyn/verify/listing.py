"""What ``peridyn verify --help`` lists: every registered problem with its title, read from
:data:`.problems.PROBLEMS` when the help is printed (importing the problems takes about a
second, so the command line's parser does not import them to be built)."""
from __future__ import annotations

import argparse
import textwrap


def problem_listing(width: int = 100) -> str:
    """Every problem ``peridyn verify`` runs, in the order it runs them: its name, kind and title."""
    from .problems import PROBLEMS

    names = list(PROBLEMS)
    pad = max(len(n) for n in names) + 2
    lines = [f"problems ({len(names)}, run in this order; --problems chooses some):"]
    for name, cls in PROBLEMS.items():
        title = f"{cls.title} [{'table' if cls.kind == 'table' else 'curve'}]"
        wrapped = textwrap.wrap(title, width=max(40, width - pad - 2)) or [""]
        lines.append(f"  {name.ljust(pad)}{wrapped[0]}")
        lines += [" " * (pad + 2) + w for w in wrapped[1:]]
    return "\n".join(lines) + "\n"


class ProblemListFormatter(argparse.RawDescriptionHelpFormatter):
    """argparse's formatter with :func:`problem_listing` after the options."""

    def format_help(self) -> str:
        return super().format_help().rstrip("\n") + "\n\n" + problem_listing(self._width) + "\n"
