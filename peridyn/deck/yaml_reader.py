"""Reading YAML decks into the raw tree (typed as Teuchos types them; see :mod:`peridyn.deck.source`)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from ..core.errors import InputError
from .source import (
    _BOOL,
    _DOUBLE,
    _INT,
    _STRING,
    DeckSource,
    Leaf,
    _convert,
    _kind_of_plain,
    _TreeBuilder,
    is_section_name,
    too_deep,
)

# --------------------------------------------------------------------------------------------
# YAML
# --------------------------------------------------------------------------------------------


class _AnchorFound(Exception):
    def __init__(self, mark: yaml.Mark, alias: bool) -> None:
        super().__init__()
        self.mark = mark
        self.alias = alias


class _LenientEscapes(dict):
    """YAML's escapes in double-quoted scalars, and any other printable character kept with its
    backslash: Peridigm's decks write ``"if(t <= 0.2)\\{ value = 0.0; \\}"`` (RTCompiler's
    brace escape), which yaml-cpp reads and the expression compiler ignores the backslash of."""

    def __contains__(self, ch: object) -> bool:
        return dict.__contains__(self, ch) or (
            isinstance(ch, str) and ch.isprintable() and ch not in yaml.scanner.Scanner.ESCAPE_CODES
        )

    def __getitem__(self, ch: str) -> str:
        return dict.__getitem__(self, ch) if dict.__contains__(self, ch) else "\\" + ch


class _DeckYamlLoader(yaml.SafeLoader):
    """A composer that records explicit tags and refuses anchors and aliases.

    Only ``compose`` is used; scalars are typed by :func:`_kind_of_plain`, not by YAML resolvers.
    """

    yaml_implicit_resolvers: dict = {}
    ESCAPE_REPLACEMENTS = _LenientEscapes(yaml.SafeLoader.ESCAPE_REPLACEMENTS)

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
    try:
        loader = _DeckYamlLoader(text)
    except yaml.YAMLError as exc:  # a character YAML does not allow (NUL, ESC, ...)
        raise _yaml_error(exc, filename) from None
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
    except RecursionError:
        raise InputError(too_deep(), file=filename, fix="a deck nests a few levels of lists; check the indentation and brackets") from None
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
    try:
        tree = {} if root is None else reader.mapping(root, ())
    except RecursionError:
        raise InputError(too_deep(), file=filename, fix="a deck nests a few levels of lists; check the indentation and brackets") from None
    return DeckSource(tree=tree, path=Path(filename), fmt="yaml", lines=reader.builder.lines)


