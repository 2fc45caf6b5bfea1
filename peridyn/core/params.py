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

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, model_validator

#: deck values are never meant as numbers when they are booleans, and never as deck keys when
#: they are Python attribute names; validation with this context key set enforces both
DECK_CONTEXT = "deck"


def leaf_types(annotation: Any) -> set[Any]:
    """The scalar types an annotation accepts (``float | str`` -> {float, str}, list[float] -> {list})."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        out: set[Any] = set()
        for arg in typing.get_args(annotation):
            out |= leaf_types(arg)
        return out
    if origin is typing.Literal:
        return {type(a) for a in typing.get_args(annotation)}
    if origin is typing.Annotated:
        return leaf_types(typing.get_args(annotation)[0])
    return {origin or annotation}


def _numeric_only(annotation: Any) -> bool:
    kinds = leaf_types(annotation)
    return bool(kinds & {float, int}) and bool not in kinds


def bool_for_number(annotation: Any, value: Any) -> bool:
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


def non_finite(value: Any) -> bool:
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, (list, tuple)):
        return any(non_finite(v) for v in value)
    return False


class ParamKeyError(ValueError):
    """A validator's problem with one deck key (``key``, its alias): the error then names that key's
    deck path and line rather than its section's."""

    def __init__(self, key: str | tuple[str, ...], message: str) -> None:
        super().__init__(message)
        self.key = key


#: the smallest and largest magnitudes whose square is a normal double
SQRT_TINY = math.sqrt(2.2250738585072014e-308)
SQRT_HUGE = math.sqrt(1.7976931348623157e308)
#: a stress this many times below (above) the elastic moduli is not representable in the products
#: a model forms with both (sigma_y^2 / (K delta^5), ...)
STRESS_RATIO_LIMIT = 1.0e100

#: keys whose scale a dedicated check refuses with a clearer message (time steps and times:
#: the step-count limits of peridyn.engine.limits; horizons: peridyn.engine.checks.horizon_scale)
CHECKED_ELSEWHERE = frozenset({"Fixed dt", "Initial Time", "Final Time", "Horizon"})

_BOUND_WORDS = {"gt": "greater than", "ge": "at least", "lt": "less than", "le": "at most"}
_BOUND_TESTS = {"gt": lambda v, b: v > b, "ge": lambda v, b: v >= b, "lt": lambda v, b: v < b, "le": lambda v, b: v <= b}


class UsedWhen:
    """The range of a parameter that Peridigm reads only under some settings: checked only when
    ``test(params)`` is true (``when`` says so in words); unused, any finite value is accepted,
    as Peridigm runs such a deck. Non-finite values are refused always (``allow_inf_nan``)."""

    def __init__(self, test: typing.Callable[[Any], bool], when: str, **bounds: float) -> None:
        self.test, self.when, self.bounds = test, when, bounds

    def problem(self, value: Any) -> str | None:
        if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
            return None
        for kind, bound in self.bounds.items():
            if not _BOUND_TESTS[kind](value, bound):
                return f"must be {_BOUND_WORDS[kind]} {bound:g} (got {value!r}) when {self.when}"
        return None


class ModelParams(BaseModel):
    """Base of plugin parameter models: frozen, unknown keys forbidden, Peridigm aliases.

    Subclasses may set ``ignored_keys``: deck keys Peridigm knows but ignores for this model;
    the deck loader drops them with one warning naming them, so Peridigm decks run unchanged.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True, str_strip_whitespace=False, allow_inf_nan=False)

    ignored_keys: ClassVar[frozenset[str]] = frozenset()
    #: Python field name -> :class:`UsedWhen`: ranges that apply only when the settings make the
    #: parameter used (merged along the class hierarchy; a subclass adds or overrides entries)
    used_when: ClassVar[dict[str, UsedWhen]] = {}

    @model_validator(mode="after")
    def _representable(self):
        """A parameter whose square under- or overflows a double (|v| below about 1.5e-154 or above
        1.3e154, zero aside) is refused: the products the models form with it (sigma_y^2, K theta^2,
        rho v^2 ...) would become 0 or inf and the run would stop as unstable or with NaN."""
        for name, field in type(self).model_fields.items():
            value = getattr(self, name, None)
            if isinstance(value, bool) or not isinstance(value, float) or value == 0.0 or not math.isfinite(value):
                continue
            if not self.is_used(name) or (field.alias or name) in CHECKED_ELSEWHERE:
                continue
            if not SQRT_TINY <= abs(value) <= SQRT_HUGE:
                alias = field.alias or name
                what = "underflows to 0" if abs(value) < SQRT_TINY else "overflows to inf"
                raise ParamKeyError(alias, f"{alias!r} = {value!r} cannot be used: its square {what} in double precision, so the "
                                           "products the model forms with it would too and the run would stop as unstable or with NaN; "
                                           "use units in which it lies between 1e-150 and 1e150")
        return self

    @classmethod
    def _used_rules(cls) -> dict[str, UsedWhen]:
        rules: dict[str, UsedWhen] = {}
        for klass in reversed(cls.__mro__):
            rules.update(klass.__dict__.get("used_when", {}))
        return rules

    def is_used(self, name: str) -> bool:
        """Whether the settings make the parameter ``name`` (Python name) used (see ``used_when``)."""
        rule = self._used_rules().get(name)
        return rule is None or bool(rule.test(self))

    @model_validator(mode="after")
    def _used_ranges(self):
        for name, rule in self._used_rules().items():
            field = type(self).model_fields.get(name)
            if field is None or not rule.test(self):
                continue
            problem = rule.problem(getattr(self, name))
            if problem:
                alias = field.alias or name
                raise ParamKeyError(alias, f"{alias!r} {problem}")
        return self

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
            if bool_for_number(f.annotation, value):
                problems.append(f"{alias!r} must be a number, got the boolean {str(value).lower()}")
            elif non_finite(value):
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


#: the type and range of deck keys that some models ignore, where no loaded model reads them (the
#: range is the one the models that read the key give it); an ignored key's value is still checked
IGNORED_KEY_TYPES: dict[str, Any] = {
    "Hourglass Coefficient": typing.Annotated[float, Field(ge=0)],
    "Apply Shear Correction Factor": bool,
    "Apply Automatic Differentiation Jacobian": bool,
    "Verbose": bool,
    "Enable Bond-Associated Hypoelastic Model": bool,
}


def reading_field(key: str) -> Any | None:
    """The annotation (with its constraints) of ``key`` in a loaded model that reads it."""
    stack = list(ModelParams.__subclasses__())
    while stack:
        cls = stack.pop()
        stack.extend(cls.__subclasses__())
        if key in cls.ignored_keys:
            continue
        for name, f in cls.model_fields.items():
            if (f.alias or name) == key:
                return typing.Annotated[f.annotation, *f.metadata] if f.metadata else f.annotation
    return None


def type_text(annotation: Any) -> str:
    """A parameter's type in words: ``float``, ``float or text``, ``one of 'A', 'B'``, ``list of
    float``, ``section`` (a nested list of parameters); None (optional) is left out."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return type_text(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        parts = [type_text(a) for a in typing.get_args(annotation) if a is not type(None)]
        return " or ".join(dict.fromkeys(parts))
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in typing.get_args(annotation))
    if origin in (list, tuple, set, frozenset):
        args = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        return "list of " + (" or ".join(dict.fromkeys(type_text(a) for a in args)) if args else "values")
    if origin in (dict, typing.Mapping) or annotation is dict:
        return "named entries"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "section"
    return {str: "text", float: "number", int: "integer", bool: "true/false"}.get(annotation, getattr(annotation, "__name__", str(annotation)))


def _nested_model(annotation: Any) -> type[BaseModel] | None:
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _nested_model(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return next((m for m in map(_nested_model, typing.get_args(annotation)) if m is not None), None)
    return annotation if isinstance(annotation, type) and issubclass(annotation, BaseModel) else None


def describe_params(params_cls: type[BaseModel], prefix: str = "") -> list[dict[str, Any]]:
    """One dict per parameter: deck name (``Verlet > Safety Factor`` for a nested section's),
    type in words, default, required, description (for docs and ``peridyn plugins``); a nested
    section's own parameters follow its row."""
    rows = []
    for name, f in params_cls.model_fields.items():
        nested = _nested_model(f.annotation)
        rows.append(
            {
                "name": prefix + (f.alias or name),
                "type": type_text(f.annotation),
                "required": f.is_required(),
                "default": None if f.is_required() or nested is not None else f.get_default(call_default_factory=True),
                "description": f.description or "",
            }
        )
        if nested is not None:
            rows.extend(describe_params(nested, prefix + (f.alias or name) + " > "))
    return rows
