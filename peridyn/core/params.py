"""Base class for every plugin's parameters, and shared parameter helpers.

A model's ``Params`` is a frozen pydantic model whose field aliases are Peridigm's deck names
(``"Bulk Modulus"``), with units and meaning in each field's ``description``. Unknown keys are
errors (``extra="forbid"``); keys Peridigm accepts but ignores in that place are listed in
``ignored_keys`` and accepted with one warning.
"""
from __future__ import annotations

import math
import types
import typing
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, ValidationInfo, model_validator

#: deck values are never meant as numbers when they are booleans, and never as deck keys when
#: they are Python attribute names; validation with this context key set enforces both
DECK_CONTEXT = "deck"


def _leaf_types(annotation: Any) -> set[Any]:
    """The scalar types an annotation accepts (``float | str`` -> {float, str}, list[float] -> {list})."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        out: set[Any] = set()
        for arg in typing.get_args(annotation):
            out |= _leaf_types(arg)
        return out
    if origin is typing.Literal:
        return {type(a) for a in typing.get_args(annotation)}
    if origin is typing.Annotated:
        return _leaf_types(typing.get_args(annotation)[0])
    return {origin or annotation}


def _numeric_only(annotation: Any) -> bool:
    kinds = _leaf_types(annotation)
    return bool(kinds & {float, int}) and bool not in kinds


def _bool_for_number(annotation: Any, value: Any) -> bool:
    """A boolean where the annotation wants a number (also inside a list of numbers)."""
    if isinstance(value, bool):
        return _numeric_only(annotation) or _numeric_list(annotation)
    return isinstance(value, (list, tuple)) and any(isinstance(v, bool) for v in value) and _numeric_list(annotation)


def _numeric_list(annotation: Any) -> bool:
    """Whether the annotation (or one of its alternatives) is a list or tuple of numbers."""
    union = typing.get_origin(annotation) in (typing.Union, types.UnionType)
    for alt in typing.get_args(annotation) if union else (annotation,):
        args = [a for a in typing.get_args(alt) if a is not Ellipsis]
        if typing.get_origin(alt) in (list, tuple) and args and all(_numeric_only(a) for a in args):
            return True
    return False


def _non_finite(value: Any) -> bool:
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, (list, tuple)):
        return any(_non_finite(v) for v in value)
    return False


class ModelParams(BaseModel):
    """Base of plugin parameter models: frozen, unknown keys forbidden, Peridigm aliases.

    Subclasses may set ``ignored_keys``: deck keys Peridigm knows but ignores for this model;
    the deck loader drops them with one warning naming them, so Peridigm decks run unchanged.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True, str_strip_whitespace=False, allow_inf_nan=False)

    ignored_keys: ClassVar[frozenset[str]] = frozenset()

    @model_validator(mode="before")
    @classmethod
    def _deck_values(cls, data: Any, info: ValidationInfo) -> Any:
        """Refuse what pydantic's lax mode would take: ``inf``/``nan`` in lists and numbers given
        as booleans (``Density: true``) or as Python attribute names (``density``) in a deck."""
        if not isinstance(data, dict):
            return data
        from_deck = bool(info.context and info.context.get(DECK_CONTEXT))
        problems = []
        for name, f in cls.model_fields.items():
            alias = f.alias or name
            if from_deck and alias != name and name in data and alias not in data:
                problems.append(f"{name!r} is not a deck key: write {alias!r}")
            if alias not in data:
                continue
            value = data[alias]
            if _bool_for_number(f.annotation, value):
                problems.append(f"{alias!r} must be a number, got the boolean {str(value).lower()}")
            elif _non_finite(value):
                problems.append(f"{alias!r} must be finite, got {value!r}")
        if problems:
            raise ValueError("; ".join(problems))
        return data

    def given(self, name: str) -> bool:
        """Whether the field ``name`` (Python name) was given in the deck."""
        return name in self.model_fields_set

    @classmethod
    def deck_names(cls) -> list[str]:
        """The deck names (aliases) of all parameters, in declaration order."""
        return [f.alias or name for name, f in cls.model_fields.items()]


def describe_params(params_cls: type[BaseModel]) -> list[dict[str, Any]]:
    """One dict per parameter: deck name, type, default, required, description (for docs/CLI)."""
    rows = []
    for name, f in params_cls.model_fields.items():
        ann = f.annotation
        type_name = getattr(ann, "__name__", None) or str(ann).replace("typing.", "")
        rows.append(
            {
                "name": f.alias or name,
                "type": type_name,
                "required": f.is_required(),
                "default": None if f.is_required() else f.get_default(call_default_factory=True),
                "description": f.description or "",
            }
        )
    return rows
