"""Errors meant for people, and the program's exit codes.

Every problem with a user's input is an :class:`InputError` that names the file, the deck path
(``Materials > My Material > Bulk Modulus``), what is wrong and how to fix it. The command line
prints it on one line and exits with :attr:`ExitCode.INPUT_ERROR`; no traceback unless
``--debug``.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from enum import IntEnum


class ExitCode(IntEnum):
    """Exit status of the ``peridyn`` command."""

    OK = 0
    FAILURE = 1  #: an internal error (a bug): please report it
    INPUT_ERROR = 2  #: the deck, a mesh or a node-set file is wrong; nothing was run
    UNSTABLE = 3  #: the run became unstable and was stopped; output so far is kept
    INTERRUPTED = 130  #: stopped by the user (Ctrl-C)


#: longest piece (file, path, message, fix) of an error line before it is shortened
MAX_PIECE = 140


def sane(text: str, limit: int = MAX_PIECE) -> str:
    """``text`` fit for one terminal line: control characters escaped, at most ``limit``
    characters (the middle elided)."""
    out = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in str(text))
    if len(out) > limit:
        keep = (limit - 5) // 2
        out = f"{out[:keep]} ... {out[-keep:]}"
    return out


def missing_file(path: object, what: str) -> str:
    """Why ``path`` cannot be opened as a file: ``"<what> 'x' is a folder, not a file"`` or
    ``"<what> 'x' not found"``."""
    import os

    text = str(path)
    try:
        folder = os.path.isdir(text)
    except (OSError, ValueError):  # a name the system refuses
        folder = False
    return f"{what} {text!r} is a folder, not a file" if folder else f"{what} {text!r} not found"


def format_path(path: Sequence[str | int]) -> str:
    """``("Materials", "My Elastic", "Bulk Modulus")`` -> ``Materials > My Elastic > Bulk Modulus``."""
    return " > ".join(str(p) for p in path)


class PeridynError(Exception):
    """Base class of the errors peridyn raises on purpose."""

    exit_code: ExitCode = ExitCode.FAILURE


class InputError(PeridynError):
    """A problem with the user's input.

    Parameters
    ----------
    message: what is wrong, one sentence without a trailing period.
    file: the file the problem is in (deck, mesh, node-set file), if known.
    path: the deck path of the offending entry, outermost first.
    fix: how to fix it, if that is not obvious from the message.
    line: line number in ``file``, if known.
    """

    exit_code = ExitCode.INPUT_ERROR

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        path: Sequence[str | int] = (),
        fix: str | None = None,
        line: int | None = None,
    ) -> None:
        self.message = message
        self.file = file
        self.path = tuple(path)
        self.fix = fix
        self.line = line
        super().__init__(self.one_line())

    def one_line(self) -> str:
        where = []
        if self.file:
            where.append(sane(f"{self.file}:{self.line}" if self.line else self.file))
        if self.path:
            where.append(sane(format_path(self.path)))
        text = ": ".join(where + [sane(self.message, 240)])
        if self.fix:
            text += f"; {sane(self.fix)}"
        return text

    def in_file(self, file: str | None) -> "InputError":
        """This error with ``file`` filled in where it names none (every line of a group)."""
        if self.file or not file:
            return self
        return self.with_context(file=file)

    def with_context(self, *, file: str | None = None, prefix: Sequence[str | int] = ()) -> "InputError":
        """A copy with ``file`` filled in (when missing) and ``prefix`` put before the path."""
        return InputError(
            self.message,
            file=self.file or file,
            path=tuple(prefix) + self.path,
            fix=self.fix,
            line=self.line,
        )


class InputErrors(InputError):
    """Several input problems found in one pass; each is reported on its own line."""

    def __init__(self, errors: Iterable[InputError]) -> None:
        self.errors = list(errors)
        first = self.errors[0]
        super().__init__(first.message, file=first.file, path=first.path, fix=first.fix, line=first.line)

    def in_file(self, file: str | None) -> "InputError":  # noqa: D102 - same contract as the base class
        return InputErrors([e.in_file(file) for e in self.errors])

    def one_line(self) -> str:  # noqa: D102 - same contract as the base class
        if not getattr(self, "errors", None):
            return super().one_line()
        return "\n".join(e.one_line() for e in self.errors)


class InstabilityError(PeridynError):
    """The run went unstable (non-finite values or energy growth); output so far is kept.

    ``collective`` is True when every MPI rank raises it at the same step (the stability
    monitor's reduced sums); False when one rank found it alone (a boundary condition's value
    at its points), so the others must be stopped.
    """

    exit_code = ExitCode.UNSTABLE

    def __init__(self, message: str, *, collective: bool = True) -> None:
        super().__init__(message)
        self.collective = collective


def raise_collected(errors: list[InputError]) -> None:
    """Raise ``errors`` as one exception, if there are any."""
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise InputErrors(errors)
