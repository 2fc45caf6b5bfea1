"""Reading and writing Peridigm deck files (Teuchos ParameterLists in YAML or XML).

Both formats load into one *raw tree*: nested ``dict`` objects in deck order whose leaves are
``bool``, ``int``, ``float``, ``str`` or ``list`` (a Teuchos array of ints, floats or strings).
The Python type of a leaf is the Teuchos type Peridigm would see, because Peridigm treats a
double-typed and a string-typed entry differently (PERIDIGM_SEMANTICS.md §1.1, §1.3, §1.4):

* YAML: a quoted scalar is a string; an unquoted one is a bool (``true``/``false``/``yes``/``no``,
  any case), else an int (``[+-]?[0-9]+`` within 32 bits), else a double if it parses entirely as
  a C double (``200e9``, ``.5``, ``5.``, ``inf``, ``nan``), else a string (``1 2 3``). An empty
  value (``Key:``) is an empty parameter list (``{}``). The top key ``Peridigm:`` is optional.
* XML: ``<ParameterList name=..>`` and ``<Parameter name=.. type=.. value=..>`` with the types
  ``double``, ``int``, ``bool``, ``string``, ``Array(double)``, ``Array(int)``, ``Array(string)``.

A name repeated in one list replaces the earlier value in place (Teuchos ``setEntry``): the entry
keeps the position of its first occurrence and the value of its last, with one warning on the
``peridyn.deck`` logger. :func:`dump_yaml` writes a tree back as Peridigm-style YAML that loads to
an identical tree, types included; :func:`convert` is the ``peridyn convert`` command.
"""
from __future__ import annotations

import logging
import numbers
import os
import re
import tempfile
import xml.parsers.expat as expat
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Union

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from peridyn.errors import InputError, format_path

__all__ = [
    "INT_MAX",
    "INT_MIN",
    "XML_SUFFIXES",
    "YAML_SUFFIXES",
    "DeckSource",
    "Leaf",
    "SECTION_NAMES",
    "convert",
    "dump_yaml",
    "infer_scalar",
    "is_section_name",
    "load_deck_file",
    "parse_xml_text",
    "parse_yaml_text",
]

log = logging.getLogger("peridyn.deck")

#: A leaf of the raw tree.
Leaf = Union[bool, int, float, str, list]

YAML_SUFFIXES = (".yaml", ".yml")
XML_SUFFIXES = (".xml",)

#: Teuchos ``int`` is a C ``int``: an unquoted integer outside this range is read as a double.
INT_MIN = -(2**31)
INT_MAX = 2**31 - 1

#: Top-level section names of a Peridigm deck (besides any name containing Solver or Output).
SECTION_NAMES = frozenset(
    {
        "Discretization",
        "Materials",
        "Damage Models",
        "Blocks",
        "Boundary Conditions",
        "Compute Class Parameters",
        "Contact",
        "Data Loader",
        "Restart",
        "Multiphysics",
    }
)

_INT_RE = re.compile(r"[+-]?[0-9]+")
_DOUBLE_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_SPECIAL_DOUBLE_RE = re.compile(r"[+-]?(?:inf|infinity|nan)", re.IGNORECASE)
_TRUE_WORDS = frozenset({"true", "yes"})
_FALSE_WORDS = frozenset({"false", "no"})

# Scalar type ranks, as in Teuchos: a list takes the lowest rank of its items.
_STRING, _DOUBLE, _INT, _BOOL = 0, 1, 2, 3
_KIND_NAMES = {_STRING: "string", _DOUBLE: "double", _INT: "int", _BOOL: "bool"}


# --------------------------------------------------------------------------------------------
# The loaded deck
# --------------------------------------------------------------------------------------------


@dataclass
class DeckSource:
    """A deck file loaded into a raw tree, with where each entry came from.

    Attributes
    ----------
    tree: nested dicts in deck order; leaves are ``bool | int | float | str | list``.
    path: the file (``Path("<string>")`` for text parsed from memory).
    fmt: ``"yaml"`` or ``"xml"``.
    lines: the 1-based line of each key path, e.g.
        ``("Materials", "My Elastic", "Bulk Modulus") -> 17``.
    """

    tree: dict
    path: Path
    fmt: str
    lines: dict[tuple[str, ...], int] = field(default_factory=dict)

    def line_of(self, path: Sequence[str | int]) -> int | None:
        """Line of ``path``, or of its longest prefix that has one; ``None`` if none does."""
        key = tuple(path)
        for n in range(len(key), 0, -1):
            line = self.lines.get(key[:n])  # type: ignore[arg-type]
            if line is not None:
                return line
        return None


def is_section_name(name: str) -> bool:
    """Whether ``name`` is a top-level section of a Peridigm deck (so never a wrapper key)."""
    return name in SECTION_NAMES or "Solver" in name or "Output" in name


# --------------------------------------------------------------------------------------------
# Scalar typing (Teuchos rules)
# --------------------------------------------------------------------------------------------


def _is_int_text(text: str) -> bool:
    return _INT_RE.fullmatch(text) is not None and INT_MIN <= int(text) <= INT_MAX


def _is_double_text(text: str) -> bool:
    return _DOUBLE_RE.fullmatch(text) is not None or _SPECIAL_DOUBLE_RE.fullmatch(text) is not None


def _kind_of_plain(text: str) -> int:
    """Teuchos type rank of an unquoted, untagged scalar."""
    lower = text.lower()
    if lower in _TRUE_WORDS or lower in _FALSE_WORDS:
        return _BOOL
    if _is_int_text(text):
        return _INT
    if _is_double_text(text):
        return _DOUBLE
    return _STRING


def _convert(text: str, kind: int) -> Leaf:
    """``text`` as a value of type ``kind``; raises ``ValueError`` if it is not one."""
    if kind == _STRING:
        return text
    if kind == _BOOL:
        lower = text.lower()
        if lower in _TRUE_WORDS:
            return True
        if lower in _FALSE_WORDS:
            return False
        raise ValueError(f"{text!r} is not a bool (true or false)")
    if kind == _INT:
        if _INT_RE.fullmatch(text) is None:
            raise ValueError(f"{text!r} is not an int")
        value = int(text)
        if not INT_MIN <= value <= INT_MAX:
            raise ValueError(f"{text!r} is outside the range of a 32-bit int")
        return value
    if not _is_double_text(text):
        raise ValueError(f"{text!r} is not a number")
    return float(text)


def infer_scalar(text: str) -> Leaf:
    """The value of an unquoted YAML scalar under Teuchos typing rules.

    ``"1"`` -> ``1``, ``"1.0"`` -> ``1.0``, ``"200e9"`` -> ``2e11``, ``"TRUE"`` -> ``True``,
    ``"1 2 3"`` -> ``"1 2 3"``. Quoted scalars are always strings and never pass through here.
    """
    return _convert(text, _kind_of_plain(text))


# --------------------------------------------------------------------------------------------
# Shared tree building
# --------------------------------------------------------------------------------------------


class _TreeBuilder:
    """Inserts entries into dicts, records their lines, handles repeated names."""

    def __init__(self, filename: str) -> None:
        self.filename = filename
        self.lines: dict[tuple[str, ...], int] = {}

    def prepare(self, mapping: dict, path: tuple[str, ...], line: int) -> None:
        """Call before building the value of ``path``: warn about and forget a repeated name."""
        key = path[-1]
        if key not in mapping:
            return
        old_line = self.lines.get(path)
        earlier = f" (line {old_line})" if old_line else ""
        log.warning(
            "%s:%d: %r is given twice in the same list; this entry replaces the earlier one%s",
            self.filename,
            line,
            format_path(path),
            earlier,
        )
        n = len(path)
        for p in [p for p in self.lines if p[:n] == path]:
            del self.lines[p]

    def put(self, mapping: dict, path: tuple[str, ...], value: Any, line: int) -> None:
        """Store ``value`` (in place of an earlier one of the same name) and its line."""
        mapping[path[-1]] = value
        self.lines[path] = line


# --------------------------------------------------------------------------------------------
# YAML
# --------------------------------------------------------------------------------------------


class _AnchorFound(Exception):
    def __init__(self, mark: yaml.Mark, alias: bool) -> None:
        super().__init__()
        self.mark = mark
        self.alias = alias


class _DeckYamlLoader(yaml.SafeLoader):
    """A composer that records explicit tags and refuses anchors and aliases.

    Only ``compose`` is used; scalars are typed by :func:`_kind_of_plain`, not by YAML resolvers.
    """

    yaml_implicit_resolvers: dict = {}

    def compose_node(self, parent: Node | None, index: Any) -> Node:  # noqa: D102
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            raise _AnchorFound(event.start_mark, isinstance(event, yaml.AliasEvent))
        tag = getattr(event, "tag", None)
        node = super().compose_node(parent, index)
        node.explicit_tag = tag  # type: ignore[attr-defined]
        return node


_YAML_HINTS = (
    ("found character '\\t'", "indent with spaces, not tabs"),
    ("mapping values are not allowed", "check indentation, and quote values that contain ': '"),
    ("while scanning a quoted scalar", "check that every quote is closed"),
    ("found unknown escape character", 'in double quotes write a backslash as "\\\\"'),
    ("expected a single document", "a deck is one YAML document: remove the '---' separators"),
)


def _yaml_fix(text: str) -> str:
    for needle, fix in _YAML_HINTS:
        if needle in text:
            return fix
    return "check indentation and that quotes and brackets are closed"


def _tag_kind(tag: str, filename: str, path: tuple[str, ...], line: int) -> int:
    """Teuchos reading of an explicit YAML tag (it looks for bool/int/double/string in it)."""
    if tag == "!":
        return _STRING
    lower = tag.lower()
    if "bool" in lower:
        return _BOOL
    if "int" in lower:
        return _INT
    if "double" in lower or "float" in lower:
        return _DOUBLE
    if "str" in lower:
        return _STRING
    shown = tag.replace("tag:yaml.org,2002:", "!!")
    raise InputError(
        f"unknown type tag {shown!r}",
        file=filename,
        path=path,
        line=line,
        fix="use !!bool, !!int, !!double or !!string, or no tag",
    )


class _YamlReader:
    def __init__(self, filename: str) -> None:
        self.filename = filename
        self.builder = _TreeBuilder(filename)

    def error(
        self, message: str, node: Node, path: tuple[str, ...], fix: str | None = None
    ) -> InputError:
        return InputError(
            message, file=self.filename, path=path, line=node.start_mark.line + 1, fix=fix
        )

    def mapping(self, node: MappingNode, path: tuple[str, ...]) -> dict:
        if getattr(node, "explicit_tag", None) is not None:
            raise self.error("a type tag cannot be put on a list of parameters", node, path)
        result: dict = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, ScalarNode):
                raise self.error("a key must be a name, not a list or a sequence", key_node, path)
            key_path = path + (key_node.value,)
            line = key_node.start_mark.line + 1
            self.builder.prepare(result, key_path, line)
            self.builder.put(result, key_path, self.value(value_node, key_path), line)
        return result

    def value(self, node: Node, path: tuple[str, ...]) -> Any:
        if isinstance(node, MappingNode):
            return self.mapping(node, path)
        if isinstance(node, SequenceNode):
            return self.sequence(node, path)
        assert isinstance(node, ScalarNode)
        if _is_empty_plain(node):
            return {}  # `Key:` with nothing after it is an empty list (Teuchos BVALUE_EMPTY)
        return self.scalar(node, path, None)

    def scalar_kind(self, node: ScalarNode, path: tuple[str, ...]) -> int:
        tag = getattr(node, "explicit_tag", None)
        if tag is not None:
            return _tag_kind(tag, self.filename, path, node.start_mark.line + 1)
        if node.style is not None:
            return _STRING
        return _kind_of_plain(node.value)

    def scalar(self, node: ScalarNode, path: tuple[str, ...], kind: int | None) -> Leaf:
        if kind is None:
            kind = self.scalar_kind(node, path)
        try:
            return _convert(node.value, kind)
        except ValueError as exc:
            fix = "fix the value or remove the type tag"
            raise self.error(str(exc), node, path, fix=fix) from None

    def sequence(self, node: SequenceNode, path: tuple[str, ...]) -> list:
        tag = getattr(node, "explicit_tag", None)
        for item in node.value:
            if isinstance(item, MappingNode):
                raise self.error("a sequence item cannot be a list of parameters", item, path,
                                 fix="turn the sequence into a named list")
            if isinstance(item, SequenceNode):
                raise self.error("nested sequences (2-D arrays) are not supported", item, path)
        items: list[ScalarNode] = node.value
        if tag is not None:
            kind = _tag_kind(tag, self.filename, path, node.start_mark.line + 1)
        else:
            kind = _INT
            for item in items:
                item_kind = self.scalar_kind(item, path)
                if item_kind == _BOOL:
                    raise self.error(
                        "a sequence cannot hold true/false values (Teuchos arrays hold numbers "
                        "or strings)",
                        item,
                        path,
                        fix='quote the values ("true") or use separate parameters',
                    )
                kind = min(kind, item_kind)
        return [self.scalar(item, path, kind) for item in items]


def _is_empty_plain(node: Node) -> bool:
    """Whether ``node`` is the nothing after ``Key:`` (a plain, untagged, empty scalar)."""
    return (
        isinstance(node, ScalarNode)
        and node.style is None
        and node.value == ""
        and getattr(node, "explicit_tag", None) is None
    )


def _yaml_error(exc: yaml.YAMLError, filename: str) -> InputError:
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    line = mark.line + 1 if mark is not None else None
    if isinstance(exc, yaml.reader.ReaderError):
        return InputError(
            f"the file contains a character YAML does not allow (code {exc.character!r})",
            file=filename,
            fix="remove control characters, or quote and escape them",
        )
    problem = getattr(exc, "problem", None) or str(exc)
    context = getattr(exc, "context", None)
    text = f"{context}, {problem}" if context else problem
    message = f"YAML syntax error: {text}"
    return InputError(message, file=filename, line=line, fix=_yaml_fix(text))


def _unwrap(document: MappingNode) -> MappingNode | None:
    """The root list of a deck document: the value of a single wrapper key such as ``Peridigm``.

    ``None`` stands for an empty root (``Peridigm:`` with nothing under it).
    """
    if len(document.value) != 1:
        return document
    key, value = document.value[0]
    if not isinstance(key, ScalarNode) or is_section_name(key.value):
        return document
    if isinstance(value, MappingNode):
        return value
    if _is_empty_plain(value):
        return None
    return document


def parse_yaml_text(text: str, filename: str = "<string>") -> DeckSource:
    """Load a Peridigm YAML deck from ``text`` (``filename`` is used in messages and ``path``)."""
    loader = _DeckYamlLoader(text)
    try:
        document = loader.get_single_node()
    except _AnchorFound as exc:
        what = "aliases (*name)" if exc.alias else "anchors (&name)"
        raise InputError(
            f"YAML {what} are not supported in a deck",
            file=filename,
            line=exc.mark.line + 1,
            fix="write the values out in full",
        ) from None
    except yaml.YAMLError as exc:
        raise _yaml_error(exc, filename) from None
    finally:
        loader.dispose()
    if not isinstance(document, MappingNode):
        line = document.start_mark.line + 1 if document is not None else None
        empty = " but the file is empty" if document is None else ""
        raise InputError(
            f"the deck must be a list of named sections{empty}",
            file=filename,
            line=line,
            fix="start with 'Peridigm:' and indent the sections (Discretization, ...) under it",
        )
    reader = _YamlReader(filename)
    root = _unwrap(document)
    tree = {} if root is None else reader.mapping(root, ())
    return DeckSource(tree=tree, path=Path(filename), fmt="yaml", lines=reader.builder.lines)


# --------------------------------------------------------------------------------------------
# XML
# --------------------------------------------------------------------------------------------

_XML_SCALAR_TYPES = {"double": _DOUBLE, "int": _INT, "bool": _BOOL, "string": _STRING}
_XML_ARRAY_TYPES = {"array(double)": _DOUBLE, "array(int)": _INT, "array(string)": _STRING}
_XML_TRUE = frozenset({"true", "yes", "1"})
_XML_FALSE = frozenset({"false", "no", "0"})


def _xml_scalar(text: str, kind: int) -> Leaf:
    """A Parameter value; raises ``ValueError`` with a short reason if it does not parse."""
    if kind == _STRING:
        return text
    stripped = text.strip()
    if kind == _BOOL:
        lower = stripped.lower()
        if lower in _XML_TRUE:
            return True
        if lower in _XML_FALSE:
            return False
        raise ValueError(f"{text!r} is not a bool (true or false)")
    return _convert(stripped, kind)


def _xml_array(text: str, kind: int) -> list:
    stripped = text.strip()
    if len(stripped) < 2 or stripped[0] != "{" or stripped[-1] != "}":
        raise ValueError(f"{text!r} is not an array; write it as {{1, 2, 3}}")
    inner = stripped[1:-1]
    if not inner.strip():
        return []
    return [_xml_scalar(item.strip(), kind) for item in inner.split(",")]


class _XmlReader:
    """Builds the tree from expat callbacks."""

    def __init__(self, filename: str) -> None:
        self.filename = filename
        self.builder = _TreeBuilder(filename)
        self.parser = expat.ParserCreate()
        self.parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
        self.parser.StartElementHandler = self.start
        self.parser.EndElementHandler = self.end
        self.parser.StartDoctypeDeclHandler = self.doctype
        self.parser.EntityDeclHandler = self.entity
        self.root: dict | None = None
        # One entry per open element: (dict of a ParameterList, its path) or None for others.
        self.stack: list[tuple[dict, tuple[str, ...]] | None] = []
        self.skip_depth = 0

    @property
    def line(self) -> int:
        return self.parser.CurrentLineNumber

    def error(self, message: str, path: tuple[str, ...] = (), fix: str | None = None) -> InputError:
        return InputError(message, file=self.filename, path=path, line=self.line, fix=fix)

    def doctype(self, *_args: Any) -> None:
        raise self.error("DOCTYPE declarations are not allowed in a deck",
                         fix="remove the <!DOCTYPE ...> declaration")

    def entity(self, *_args: Any) -> None:
        raise self.error("entity declarations are not allowed in a deck",
                         fix="remove the <!ENTITY ...> declaration")

    def start(self, tag: str, attrs: dict[str, str]) -> None:
        if self.skip_depth:
            self.skip_depth += 1
            return
        if self.root is None:
            if tag != "ParameterList":
                raise self.error(
                    f"the root element must be <ParameterList>, not <{tag}>",
                    fix="put the whole deck inside <ParameterList> ... </ParameterList>",
                )
            self.root = {}
            self.stack.append((self.root, ()))
            return
        top = self.stack[-1]
        if top is None or tag not in ("ParameterList", "Parameter"):
            where = "inside a <Parameter>" if top is None else "in a deck"
            log.warning("%s:%d: ignoring <%s> element %s", self.filename, self.line, tag, where)
            self.skip_depth = 1
            return
        parent, parent_path = top
        name = attrs.get("name")
        if name is None:
            raise self.error(f"<{tag}> has no name attribute", parent_path,
                             fix=f'write <{tag} name="..." ...>')
        path = parent_path + (name,)
        self.builder.prepare(parent, path, self.line)
        if tag == "ParameterList":
            sub: dict = {}
            self.builder.put(parent, path, sub, self.line)
            self.stack.append((sub, path))
        else:
            self.builder.put(parent, path, self.parameter(attrs, path), self.line)
            self.stack.append(None)

    def parameter(self, attrs: dict[str, str], path: tuple[str, ...]) -> Leaf:
        type_name = attrs.get("type")
        if type_name is None:
            raise self.error("<Parameter> has no type attribute", path,
                             fix='add type="double", "int", "bool" or "string"')
        if "value" not in attrs:
            raise self.error("<Parameter> has no value attribute", path, fix='add value="..."')
        text = attrs["value"]
        key = "".join(type_name.split()).lower()
        try:
            if key in _XML_SCALAR_TYPES:
                return _xml_scalar(text, _XML_SCALAR_TYPES[key])
            if key in _XML_ARRAY_TYPES:
                return _xml_array(text, _XML_ARRAY_TYPES[key])
        except ValueError as exc:
            raise self.error(f"bad {type_name} value: {exc}", path,
                             fix=f"give a valid {type_name} or change the type") from None
        raise self.error(
            f"unknown parameter type {type_name!r}",
            path,
            fix="use double, int, bool, string, Array(double), Array(int) or Array(string)",
        )

    def end(self, _tag: str) -> None:
        if self.skip_depth:
            self.skip_depth -= 1
            return
        self.stack.pop()

    def parse(self, data: str | bytes) -> dict:
        try:
            self.parser.Parse(data, True)
        except expat.ExpatError as exc:
            raise InputError(
                f"XML syntax error: {expat.ErrorString(exc.code)}",
                file=self.filename,
                line=exc.lineno,
                fix="check that every tag is closed and every attribute value is quoted",
            ) from None
        assert self.root is not None  # expat rejects a document without an element
        return self.root


def _parse_xml(data: str | bytes, filename: str) -> DeckSource:
    reader = _XmlReader(filename)
    tree = reader.parse(data)
    return DeckSource(tree=tree, path=Path(filename), fmt="xml", lines=reader.builder.lines)


def parse_xml_text(text: str, filename: str = "<string>") -> DeckSource:
    """Load a Peridigm XML deck from ``text`` (``filename`` is used in messages and ``path``)."""
    return _parse_xml(text, filename)


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

