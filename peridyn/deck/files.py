"""Deck files: loading by extension, writing Peridigm-style YAML (``peridyn convert``)."""
from __future__ import annotations

import numbers
import os
import re
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..core.errors import InputError, format_path
from .source import (
    _BOOL,
    _DOUBLE,
    _INT,
    _KIND_NAMES,
    _STRING,
    INT_MAX,
    INT_MIN,
    XML_SUFFIXES,
    YAML_SUFFIXES,
    DeckSource,
    _is_double_text,
    _kind_of_plain,
)
from .xml_reader import _parse_xml
from .yaml_reader import parse_yaml_text

# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def _format_of(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix in YAML_SUFFIXES:
        return "yaml"
    if suffix in XML_SUFFIXES:
        return "xml"
    got = f"'{path.suffix}'" if path.suffix else "no extension"
    raise InputError(
        f"cannot tell the deck format from the file name ({got})",
        file=str(path),
        fix="name the deck with .yaml, .yml or .xml",
    )


def load_deck_file(path: str | Path) -> DeckSource:
    """Load a deck file; the extension chooses the format (.yaml/.yml or .xml)."""
    p = Path(path)
    fmt = _format_of(p)
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise InputError(
            "the deck file does not exist", file=str(p), fix="check the path"
        ) from None
    except OSError as exc:
        raise InputError(f"cannot read the deck file: {exc.strerror or exc}", file=str(p)) from None
    if fmt == "xml":
        return _parse_xml(data, str(p))
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            "the file is not valid UTF-8 text",
            file=str(p),
            line=data[: exc.start].count(b"\n") + 1,
            fix="save the deck as UTF-8",
        ) from None
    return parse_yaml_text(text, str(p))


# --------------------------------------------------------------------------------------------
# Writing YAML
# --------------------------------------------------------------------------------------------

# Characters written as themselves inside double quotes; everything else is escaped: the quote,
# the backslash, control characters, YAML line breaks (U+0085, U+2028, U+2029), the BOM and
# characters YAML does not allow in a stream (surrogates, U+FFFE, U+FFFF).
_DQ_CLASS = (
    r"\x20\x21\x23-\x5b\x5d-\x7e\xa0-\u2027\u202a-\ud7ff\ue000-\ufefe\uff00-\ufffd"
    r"\U00010000-\U0010ffff"
)
_DQ_SAFE = re.compile(f"[{_DQ_CLASS}]*")
_DQ_UNSAFE = re.compile(f"[^{_DQ_CLASS}]")
_NAMED_ESCAPES = {'"': '\\"', "\\": "\\\\", "\n": "\\n", "\t": "\\t", "\r": "\\r"}
_PLAIN_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_ .+\-/()]*")
_YAML_KEYWORDS = frozenset({"true", "false", "yes", "no", "on", "off", "y", "n", "null"})
_MAX_KEY_CHARS = 1000  # YAML simple keys are limited to 1024 characters


def _escape_char(match: re.Match[str]) -> str:
    ch = match.group()
    named = _NAMED_ESCAPES.get(ch)
    if named is not None:
        return named
    code = ord(ch)
    if code < 0x100:
        return f"\\x{code:02x}"
    if code < 0x10000:
        return f"\\u{code:04x}"
    return f"\\U{code:08x}"


def _quote(text: str) -> str:
    """``text`` as a YAML double-quoted scalar (escaping only what must be escaped)."""
    if _DQ_SAFE.fullmatch(text):
        return f'"{text}"'
    return '"' + _DQ_UNSAFE.sub(_escape_char, text) + '"'


def _format_key(key: Any) -> str:
    if not isinstance(key, str):
        raise TypeError(f"deck keys must be strings, not {type(key).__name__} ({key!r})")
    if (
        _PLAIN_KEY.fullmatch(key)
        and not key.endswith(" ")
        and key.lower() not in _YAML_KEYWORDS
        and _kind_of_plain(key) == _STRING
    ):
        text = key
    else:
        text = _quote(key)
    if len(text) > _MAX_KEY_CHARS:
        raise ValueError(f"a deck key may be at most {_MAX_KEY_CHARS} characters: {key[:40]!r}...")
    return text


def _format_float(value: float) -> str:
    text = repr(float(value))  # shortest round-tripping form: 2.0, 1e-05, 1e+16, inf, nan
    assert _is_double_text(text), text
    return text


def _scalar_rank(value: Any) -> int:
    if isinstance(value, bool):
        return _BOOL
    if isinstance(value, numbers.Integral):
        return _INT
    if isinstance(value, numbers.Real):
        return _DOUBLE
    if isinstance(value, str):
        return _STRING
    raise TypeError(
        f"a deck value must be a bool, int, float, str, list or dict, not {type(value).__name__}"
    )


def _format_scalar(value: Any, rank: int) -> str:
    if rank == _BOOL:
        return "true" if value else "false"
    if rank == _INT:
        number = int(value)
        if not INT_MIN <= number <= INT_MAX:
            raise ValueError(f"{number} does not fit a 32-bit int (Teuchos reads it as a double)")
        return str(number)
    if rank == _DOUBLE:
        return _format_float(value)
    return _quote(value)


def _format_value(value: Any, path: tuple[str, ...]) -> str:
    if isinstance(value, (list, tuple)):
        ranks = {_scalar_rank(item) for item in value}
        if _BOOL in ranks or len(ranks) > 1:
            raise ValueError(
                f"{format_path(path)}: a deck list must hold only ints, only floats or only "
                f"strings, not {sorted(_KIND_NAMES[r] for r in ranks)}"
            )
        rank = ranks.pop() if ranks else _STRING
        return "[" + ", ".join(_format_scalar(item, rank) for item in value) + "]"
    return _format_scalar(value, _scalar_rank(value))


def _dump_mapping(mapping: Mapping, level: int, path: tuple[str, ...], out: list[str]) -> None:
    indent = "  " * level
    for key, value in mapping.items():
        key_text = _format_key(key)
        key_path = path + (key,)
        if isinstance(value, Mapping):
            if value:
                out.append(f"{indent}{key_text}:")
                _dump_mapping(value, level + 1, key_path, out)
            else:
                out.append(f"{indent}{key_text}: {{}}")
        else:
            out.append(f"{indent}{key_text}: {_format_value(value, key_path)}")


def dump_yaml(tree: Mapping, top_key: str | None = "Peridigm") -> str:
    """Write ``tree`` as Peridigm-style YAML that loads back to an identical tree.

    Strings are always double-quoted, so their type survives; floats are written with
    ``repr`` (always with a ``.``, an exponent, ``inf`` or ``nan``); ints that do not fit 32 bits,
    lists mixing types and lists of bools raise ``ValueError`` because no deck can hold them.
    With ``top_key=None`` the sections are written at the top level; note that a tree holding
    a single non-section list then loads back unwrapped (as ``Peridigm:`` would be).
    """
    out: list[str] = []
    if top_key is None:
        if not tree:
            return "{}\n"
        _dump_mapping(tree, 0, (), out)
    elif tree:
        out.append(f"{_format_key(top_key)}:")
        _dump_mapping(tree, 1, (), out)
    else:
        out.append(f"{_format_key(top_key)}: {{}}")
    return "\n".join(out) + "\n"


def convert(src: str | Path, dst: str | Path) -> None:
    """Convert a deck (XML or YAML) to Peridigm-style YAML at ``dst`` (``peridyn convert``).

    ``dst`` is replaced atomically: the YAML goes to a temporary file in the same folder which
    is then renamed over ``dst``, so an error leaves an existing ``dst`` untouched. Comments in
    the source are not carried over.
    """
    src_path, dst_path = Path(src), Path(dst)
    if dst_path.suffix.lower() not in YAML_SUFFIXES:
        raise InputError("the converted deck must be a YAML file", file=str(dst_path),
                         fix="name the output file with .yaml")
    source = load_deck_file(src_path)
    text = f"# Converted from {src_path.name} by peridyn convert\n" + dump_yaml(source.tree)
    folder = dst_path.parent
    try:
        mode = dst_path.stat().st_mode & 0o777
    except OSError:
        mode = 0o644
    try:
        fd, tmp_name = tempfile.mkstemp(dir=folder, prefix=f".{dst_path.name}.", suffix=".tmp")
    except OSError as exc:
        raise InputError(
            f"cannot write the converted deck: {exc.strerror or exc}",
            file=str(dst_path),
            fix="check that the folder exists and is writable",
        ) from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp_name, mode)
        os.replace(tmp_name, dst_path)
    except BaseException as exc:
        try:
            os.unlink(tmp_name)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise InputError(f"cannot write the converted deck: {exc.strerror or exc}",
                             file=str(dst_path)) from None
        raise

