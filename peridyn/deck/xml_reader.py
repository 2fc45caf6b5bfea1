"""Reading Peridigm's XML decks (Teuchos ParameterList XML) into the raw tree."""
from __future__ import annotations

import xml.parsers.expat as expat
from pathlib import Path
from typing import Any

from ..core.errors import InputError
from .source import (
    _BOOL,
    _DOUBLE,
    _INT,
    _STRING,
    DeckSource,
    Leaf,
    _convert,
    _TreeBuilder,
    log,
    too_deep,
)

# --------------------------------------------------------------------------------------------
# XML
# --------------------------------------------------------------------------------------------

_XML_SCALAR_TYPES = {"double": _DOUBLE, "int": _INT, "bool": _BOOL, "string": _STRING}
_XML_ARRAY_TYPES = {"array(double)": _DOUBLE, "array(int)": _INT, "array(string)": _STRING}
_XML_TRUE = frozenset({"true", "yes", "1"})
_XML_FALSE = frozenset({"false", "no", "0"})
#: the deepest nesting of elements a deck may have (Peridigm's decks nest a few levels); deeper
#: trees are refused as they are read, before anything walks them recursively
MAX_DEPTH = 64


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
        self.parser.ExternalEntityRefHandler = self.external_entity
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

    def external_entity(self, *_args: Any) -> int:
        raise self.error("external entities are not allowed in a deck", fix="write the value into the deck itself")

    def start(self, tag: str, attrs: dict[str, str]) -> None:
        if len(self.stack) + self.skip_depth >= MAX_DEPTH:
            raise self.error(f"the deck nests its elements more than {MAX_DEPTH} levels deep (<{tag}> at this line)",
                             fix=f"a deck nests a few levels of ParameterLists; close the ones left open or flatten the deck to at most {MAX_DEPTH} levels")
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
        except (LookupError, UnicodeError) as exc:  # an encoding expat and Python do not know
            raise InputError(f"cannot decode the XML deck: {exc}", file=self.filename, line=self.line,
                             fix='save the deck as UTF-8 and declare <?xml version="1.0" encoding="UTF-8"?>') from None
        assert self.root is not None  # expat rejects a document without an element
        return self.root


def _parse_xml(data: str | bytes, filename: str) -> DeckSource:
    reader = _XmlReader(filename)
    try:
        tree = reader.parse(data)
    except RecursionError:
        raise InputError(too_deep(), file=filename, fix="a deck nests a few levels of ParameterLists") from None
    return DeckSource(tree=tree, path=Path(filename), fmt="xml", lines=reader.builder.lines)


def parse_xml_text(text: str, filename: str = "<string>") -> DeckSource:
    """Load a Peridigm XML deck from ``text`` (``filename`` is used in messages and ``path``)."""
    return _parse_xml(text, filename)


