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
#: longest error line after its file name (deck path, message and fix)
MAX_LINE = 380


def sane(text: str, limit: int = MAX_PIECE) -> str:
    """``text`` fit for one terminal line: control characters escaped, at most ``limit``
    characters (the middle elided)."""
    out = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in str(text))
    if len(out) > limit:
        keep = (limit - 5) // 2
        out = f"{out[:keep]} ... {out[-keep:]}"
    return out


def is_file(path: object) -> bool:
    """Whether ``path`` names an existing regular file; False (not an exception) for a name the
    system refuses: too long, NUL bytes, a component that is a file."""
    import os

    try:
        return os.path.isfile(str(path))
    except (OSError, ValueError):
        return False


def missing_file(path: object, what: str) -> str:
    """Why ``path`` cannot be opened as a file: ``"<what> 'x' is a folder, not a file"``, a name
    too long for the file system, or ``"<what> 'x' not found"``."""
    import errno
    import os

    text = str(path)
    try:
        os.stat(text)
        folder = os.path.isdir(text)
    except ValueError:  # NUL bytes
        return f"{what} {text!r} is not a valid file name"
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            return f"{what} name is too long for the file system ({len(os.path.basename(text))} characters)"
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
        """``file:line: deck path: message; fix`` on one line; past the file, at most
        ``MAX_LINE`` characters (the longest pieces, often an echoed value, elided in the middle)."""
        path = sane(format_path(self.path)) if self.path else ""
        message = sane(self.message, 240)
        fix = sane(self.fix) if self.fix else ""
        for piece, floor in (("message", 160), ("fix", 100), ("path", 80)):
            over = len(path) + len(message) + len(fix) + 4 - MAX_LINE
            if over <= 0:
                break
            if piece == "message":
                message = sane(self.message, max(floor, len(message) - over))
            elif piece == "fix" and fix:
                fix = sane(self.fix, max(floor, len(fix) - over))
            elif piece == "path" and path:
                path = sane(format_path(self.path), max(floor, len(path) - over))
        where = []
        if self.file:
            where.append(sane(f"{self.file}:{self.line}" if self.line else self.file))
        if path:
            where.append(path)
        text = ": ".join(where + [message])
        if fix:
            text += f"; {fix}"
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


class OutputWriteError(PeridynError):
    """An output file could not be written (disk full, a file-size limit): the run failed, the
    frames written before stay in ``NAME.partial.e`` and an earlier ``NAME.e`` is untouched."""

    exit_code = ExitCode.UNSTABLE


def raise_collected(errors: list[InputError]) -> None:
    """Raise ``errors`` as one exception, if there are any."""
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise InputErrors(errors)
