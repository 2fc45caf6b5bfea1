"""The files and folders a run writes, checked before any work: the output folder, each output's
``NAME.e`` (or ``NAME.h``), ``NAME.partial.e`` and ``NAME.lock``, the checkpoints' folder and files,
``Interfaces.e``. A name the file system cannot hold, a folder where a file goes, a file where a
folder goes or a place that cannot be written is an InputError naming the deck key or option,
so that a run never computes to fail at its first write or its final rename.
"""
from __future__ import annotations

import errno
import logging
import os
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.errors import InputError, raise_collected
from ..core.services import OutputFiles

if TYPE_CHECKING:  # pragma: no cover
    from ..deck.model import Deck

log = logging.getLogger("peridyn.output")

#: the longest name a run gives an output file: NAME.partial.e (NAME.partial.h is as long)
_LONGEST_SUFFIX = ".partial.e"


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def prepare_output_dir(folder: Path, name: str = "the output folder") -> None:
    """Create the output folder (with its parents) when missing; InputError naming it as ``name``
    (``--output-dir``) when it is a file or cannot be made."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise InputError(f"{name} {str(folder)!r} is a file, not a folder", fix="give a folder for the output files") from None
    except OSError as exc:
        why = _writable_folder(folder) or exc.strerror or str(exc)
        raise InputError(f"{name}: cannot create the output folder {str(folder)!r}: {why}", fix="give a folder you can write to") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{name}: cannot create files in the output folder {str(folder)!r}: this user cannot write it", fix="give a folder you can write to")


def check_output_names(deck: "Deck", folder: Path) -> None:
    """InputError (naming Output > Output Filename) for an output name the file system cannot
    hold in ``folder``: checked before any work, so a run never fails at its first write."""
    errors: list[InputError] = []
    limit = _name_max(folder) if folder.is_dir() else 255
    for out in deck.outputs:
        longest = f"{out.filename}{_LONGEST_SUFFIX}"
        try:
            size = len(os.fsencode(longest))
        except UnicodeError:
            errors.append(InputError(f"'Output Filename' {out.params.output_filename!r} cannot be a file name on this system",
                                     file=deck.file, path=out.path + ("Output Filename",), fix="use plain letters, digits, '-' and '_'"))
            continue
        if size > limit:
            errors.append(InputError(
                f"'Output Filename' is {len(out.params.output_filename)} characters: the file {out.filename[:20]}...{_LONGEST_SUFFIX} "
                f"would have a {size}-byte name, more than the {limit} bytes this file system allows",
                file=deck.file, path=out.path + ("Output Filename",),
                fix=f"give a name of at most {limit - len(_LONGEST_SUFFIX)} bytes"))
    raise_collected(errors)
    for out in deck.outputs:
        if out.filename != out.params.output_filename:
            log.warning("%s: %s: %r is written as %s.e or .h, as Peridigm writes it (every '.' and space in Output Filename becomes '_'); "
                        "give a name without them to have the files named as the deck says", deck.file,
                        " > ".join(out.path + ("Output Filename",)), out.params.output_filename, out.filename)


class OutputLock:
    """An exclusive lock on an output name in a folder (``NAME.lock``, ``fcntl.flock``): a second
    run writing the same files is refused at start. The kernel drops the lock when its process
    ends, however it ends, so a crashed run never blocks the next one; the file is removed when
    the lock is released."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd: int | None = None

    def acquire(self) -> bool:
        """True if taken; False if another live process holds it. OSError for a folder that
        cannot be written."""
        import fcntl

        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    return False
                raise
            try:  # the holder before us may have removed the file after we opened it: retry
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return True

    def holder(self) -> str:
        try:
            return self.path.read_text().strip()
        except OSError:
            return ""

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            os.unlink(self.path)  # while still held: nobody can take a lock on a removed file
        except OSError:
            pass
        os.close(self._fd)
        self._fd = None


def lock_outputs(deck: "Deck", folder: Path) -> list[OutputLock]:
    """Lock every output name of the deck in ``folder`` (rank 0 only: the one that writes).
    InputError for a name another run is writing, or a folder where no file can be created."""
    locks: list[OutputLock] = []
    names: set[str] = set()
    try:
        for out in deck.outputs:
            if out.filename in names:  # one run's NAME.e and NAME.h (a history section) share a name
                continue
            names.add(out.filename)
            lock = OutputLock(folder / f"{out.filename}.lock")
            key = out.path + ("Output Filename",)
            in_the_way = _not_a_file(lock.path)
            if in_the_way:
                raise InputError(f"{str(lock.path)!r}, the lock file of this output, is {in_the_way}", file=deck.file, path=key,
                                 fix="remove or rename it, or give another Output Filename or --output-dir")
            try:
                taken = lock.acquire()
            except OSError as exc:
                if exc.errno == errno.ENAMETOOLONG:
                    raise InputError(f"the output path {str(folder / out.filename)!r} is too long for this file system",
                                     file=deck.file, path=key, fix="give a shorter Output Filename or --output-dir") from None
                raise InputError(f"cannot create files in the output folder {str(folder)!r}: {exc.strerror or exc}",
                                 file=deck.file, path=key, fix="give a folder you can write to (--output-dir)") from None
            if not taken:
                who = lock.holder()
                raise InputError(
                    f"another run{f' (process {who})' if who.isdigit() else ''} is writing {out.filename}.e in {str(folder)!r} "
                    f"(lock {lock.path.name}); two runs writing the same files would destroy each other's output",
                    file=deck.file, path=key, fix="wait for it to end, or give this run another --output-dir or Output Filename")
            locks.append(lock)
    except BaseException:
        release_locks(locks)
        raise
    return locks


def release_locks(locks: list[OutputLock]) -> None:
    for lock in locks:
        lock.release()


def _not_a_file(path: Path) -> str | None:
    """What ``path`` is when something other than a regular file (or a link to one) is there
    ("a folder", ...); None when nothing is there or a file."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return "a broken symbolic link" if path.is_symlink() else None
    except NotADirectoryError:  # under a file: what is wrong is the folder, reported as such
        return None
    except OSError as exc:
        return f"not reachable ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return None
    return "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device, pipe or socket)"


def _writable_folder(folder: Path) -> str | None:
    """Why files cannot be created in ``folder`` (created with its parents when missing), or
    None: the nearest existing one of it and its parents must be a folder this process can write."""
    probe = folder
    while not probe.exists() and not probe.is_symlink() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        return f"{str(probe)!r} is a file, not a folder" if probe.exists() else f"{str(probe)!r} is a broken symbolic link"
    if not os.access(probe, os.W_OK | os.X_OK):
        return f"{str(probe)!r} cannot be written by this user"
    return None


def check_run_paths(sim, files: OutputFiles) -> None:
    """InputError for a file the run will write or rename that cannot be: a folder (or anything
    but a file) at ``NAME.e``, ``NAME.partial.e`` (``.h``), ``Interfaces.e`` or a checkpoint's
    name; a Restart folder that is a file, under one or cannot be written. Called after the
    set-up, before any step (rank 0: the rank that writes)."""
    deck = sim.deck
    errors: list[InputError] = []
    for w in files.writers:
        for path in (w.path, w.partial_path):
            what = _not_a_file(path)
            if what:
                errors.append(InputError(f"{str(path)!r} is {what}, and this output writes the file {path.name} there", file=deck.file,
                                         path=w.entry.path + ("Output Filename",),
                                         fix="remove or rename it, or give another Output Filename or --output-dir"))
    if sim.interfaces is not None:
        from ..io.interfaces import INTERFACES_FILE

        path = Path(sim.output_dir) / INTERFACES_FILE
        what = _not_a_file(path)
        if what:
            errors.append(InputError(f"{str(path)!r} is {what}, and Construct Interfaces writes the file {INTERFACES_FILE} there",
                                     file=deck.file, path=("Discretization", "Construct Interfaces"), fix="remove or rename it, or give another --output-dir"))
    params = deck.restart
    if params is not None:
        errors.extend(_restart_folder_errors(sim, params))
    raise_collected(errors)


def _restart_folder_errors(sim, params) -> list[InputError]:
    from .restart import _NAME

    deck = sim.deck
    folder = Path(sim.output_dir) / params.folder
    key = ("Restart", "Folder")
    fix = "give another Restart > Folder or --output-dir, or remove what is in the way"
    if folder.exists() and not folder.is_dir():
        return [InputError(f"the checkpoints' folder {str(folder)!r} is a file", file=deck.file, path=key, fix=fix)]
    why = _writable_folder(folder)
    if why:
        return [InputError(f"the checkpoints' folder {str(folder)!r} cannot be made or written: {why}", file=deck.file, path=key, fix=fix)]
    stem = Path(deck.file).stem
    errors = []
    if folder.is_dir():
        for entry in sorted(folder.iterdir()):
            m = _NAME.match(entry.name)
            what = _not_a_file(entry) if m and m["stem"] == stem else None
            if what:
                errors.append(InputError(f"{str(entry)!r} is {what}, where this run writes (or removes) a checkpoint file",
                                         file=deck.file, path=key, fix=fix))
    return errors[:1]


# -- files and folders a command writes (peridyn schema -o, convert, fragments --plot, ...) ---------
def check_output_file(path: Path, option: str) -> None:
    """InputError (naming ``option``) unless a file can be written at ``path``: a name the file
    system takes, not a folder or other non-file, in a folder that exists and can be written."""
    try:
        size = len(os.fsencode(path.name))
    except UnicodeError:
        raise InputError(f"{option}: {path.name!r} cannot be a file name on this system", fix="use plain letters, digits, '-', '_' and '.'") from None
    limit = _name_max(path.parent) if path.parent.is_dir() else 255
    if size > limit:
        raise InputError(f"{option}: the name {path.name[:20]!r}... is {size} bytes, this file system takes {limit}", fix="give a shorter name")
    what = _not_a_file(path)
    if what:
        raise InputError(f"{option}: {str(path)!r} is {what}, not a file", fix="give the path of a file (a folder is not replaced)")
    parent = path.parent
    if not parent.is_dir():
        there = "is a file" if parent.exists() else "does not exist"
        raise InputError(f"{option}: the folder {str(parent)!r} of {path.name!r} {there}", fix="create the folder first or give another path")
    why = _writable_folder(parent)
    if why:
        raise InputError(f"{option}: cannot write {str(path)!r}: {why}", fix="give a path in a folder you can write to")


def check_output_folder(folder: Path, option: str) -> None:
    """InputError (naming ``option``) unless ``folder`` is, or can be made as, a folder this user
    writes in."""
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{option}: {str(folder)!r} is a file, not a folder", fix="give a folder (it is created when missing)")
    why = _writable_folder(folder)
    if why:
        raise InputError(f"{option}: cannot create or write the folder {str(folder)!r}: {why}", fix="give a folder you can write to")


def check_output_prefix(prefix: Path, option: str, longest_suffix: int) -> None:
    """InputError (naming ``option``) unless files ``PREFIX_<suffix>`` (suffixes of at most
    ``longest_suffix`` bytes) can be written: the prefix's folder exists (it is not created), this
    user can write in it and the names fit its file-name limit."""
    parent = prefix.parent
    if not parent.is_dir():
        above = next((p for p in (parent, *parent.parents) if p.exists()), None)  # the nearest part that exists
        if above is not None and not above.is_dir():
            raise InputError(f"{option}: {str(above)!r} is a file, not a folder, so the prefix {prefix.name!r} cannot be in it",
                             fix="give a prefix in a folder")
        raise InputError(f"{option}: the folder {str(parent)!r} of the prefix {prefix.name!r} does not exist",
                         fix="create the folder first or give another prefix")
    why = _writable_folder(parent)
    if why:
        raise InputError(f"{option}: cannot write files in {str(parent)!r}: {why}", fix="give a prefix in a folder you can write to")
    size = len(os.fsencode(prefix.name))
    limit = _name_max(parent)
    if size + longest_suffix > limit:
        raise InputError(f"{option} prefix {prefix.name[:40]}... is {size} bytes; the files' names would pass the {limit}-byte limit "
                         "of a file name", fix=f"give a shorter {option} prefix")


def write_text_atomic(path: Path, text: str, option: str) -> None:
    """Write ``text`` to ``path`` through a temporary file beside it, renamed over it: an error
    leaves an existing file as it was and no half-written one. InputError (naming ``option``)
    for a path that cannot be written."""
    check_output_file(path, option)
    replace_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"), option)


def replace_atomic(path: Path, write, option: str) -> None:
    """Call ``write(tmp)`` for a temporary file beside ``path`` (same suffix), then rename it over
    ``path``; the temporary file is removed when anything fails."""
    import tempfile

    try:
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem[:40]}.", suffix=path.suffix)
    except OSError as exc:
        raise InputError(f"{option}: cannot write in {str(path.parent)!r}: {exc.strerror or exc}", fix="give a path in a folder you can write to") from None
    os.close(fd)
    tmp = Path(name)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise InputError(f"{option}: writing {str(path)!r} failed: {exc.strerror or exc}", fix="give a path in a folder you can write to") from None
    finally:
        if tmp.exists():
            tmp.unlink()


#: the path and name arguments of each command: (dest, as the user writes it, what to give instead)
NAMED_ARGUMENTS: dict[str, tuple[tuple[str, str, str], ...]] = {
    "run": (("deck", "DECK", "give a deck file"), ("output_dir", "--output-dir", "give a folder (or leave it out for the current one)"),
            ("restart", "--restart", "give a checkpoint file, or --restart alone for the latest")),
    "check": (("deck", "DECK", "give a deck file"),), "verify": (("out", "--out", "give a folder"),),
    "schema": (("output", "-o", "give a file (or leave it out to print)"), ("reference", "--reference", "give a file")),
    "convert": (("input", "IN", "give the Peridigm XML deck"), ("output", "OUT", "give the YAML file to write")),
    "new-plugin": (("name", "NAME", "give the plugin's package name, e.g. my_material"), ("directory", "--directory", "give a folder")),
    "fragments": (("result", "RESULT", "give an Exodus file a run wrote"), ("plot", "--plot", "give a PNG file")),
    "plot": (("result", "RESULT", "give an Exodus file a run wrote"), ("out", "--out", "give a file name prefix (or leave it out)"),
             ("field", "--field", "give an output variable (or leave it out)")),
}


def refuse_empty_arguments(args: Any) -> None:
    """InputError naming the first argument given as an empty string (``--output-dir ""``), which
    would otherwise mean the current folder or a file named '.'."""
    for dest, shown, fix in NAMED_ARGUMENTS.get(args.command, ()):
        if getattr(args, dest, None) == "":
            raise InputError(f"{shown} is empty", fix=fix)
