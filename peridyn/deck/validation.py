"""Turning pydantic validation errors into one-line, deck-path-named input errors."""
from __future__ import annotations

import difflib
import logging
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from ..core.errors import InputError
from ..core.params import DECK_CONTEXT, IGNORED_KEY_TYPES, ModelParams, bool_for_number, leaf_types, non_finite, reading_field

log = logging.getLogger("peridyn.deck")

P = TypeVar("P", bound=ModelParams)


def _aliases(model: type[BaseModel]) -> list[str]:
    return [f.alias or name for name, f in model.model_fields.items()]


def _submodel(model: type[BaseModel] | None, loc: Sequence[Any]) -> type[BaseModel] | None:
    """The (nested) pydantic model reached by following ``loc`` (aliases) from ``model``."""
    for key in loc:
        if model is None:
            return None
        field = next((f for n, f in model.model_fields.items() if (f.alias or n) == key), None)
        if field is None:
            return None
        ann = field.annotation
        candidates = [ann, *getattr(ann, "__args__", ())]
        model = next((c for c in candidates if isinstance(c, type) and issubclass(c, BaseModel)), None)
    return model


def suggest(name: Any, options: Any) -> str:
    """"did you mean 'x'?" for the option closest to ``name``, else the options defined."""
    options = [str(o) for o in options]
    close = difflib.get_close_matches(str(name), options, n=1, cutoff=0.6)
    if close:
        return f"did you mean {close[0]!r}?"
    return f"defined: {', '.join(options)}" if options else "none is defined"


def close_key(expected: str, raw: Mapping[str, Any], others: Sequence[str] = ()) -> str | None:
    """The key of ``raw`` that is most likely ``expected`` mistyped (another case, spaces, a
    letter off), not one of ``others`` (keys that mean something else there); None if none is."""
    def plain(key: Any) -> str:
        return str(key).lower().replace(" ", "").replace("_", "")

    candidates = [k for k in raw if k != expected and k not in others]
    same = [k for k in candidates if plain(k) == plain(expected)]
    if same:
        return str(same[0])
    close = difflib.get_close_matches(plain(expected), [plain(k) for k in candidates], n=1, cutoff=0.75)
    return next((str(k) for k in candidates if close and plain(k) == close[0]), None)


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _plain(number: Any) -> str:
    return f"{number:g}" if isinstance(number, float) else str(number)


def explain(kind: str, ctx: dict[str, Any], got: Any, msg: str) -> tuple[str, str | None]:
    """(problem, fix) in words for one pydantic error type; pydantic's own text otherwise."""
    shown = f" (got {_describe(got)})" if got is not None and not isinstance(got, Mapping) else ""
    bounds = {
        "greater_than": ("greater than", "gt"),
        "greater_than_equal": ("at least", "ge"),
        "less_than": ("less than", "lt"),
        "less_than_equal": ("at most", "le"),
    }
    if kind in bounds:
        words, key = bounds[kind]
        limit = _plain(ctx.get(key))
        return f"must be {words} {limit}{shown}", f"give a value {words} {limit}"
    if kind == "finite_number":
        return f"must be a finite number{shown}", "give a finite value"
    if kind.startswith(("float_", "int_")):
        whole = kind.startswith("int")
        what = "a whole number" if whole else "a number"
        return f"must be {what}{shown}", ("write an integer below 2^31, such as 10" if whole else "write a number such as 2.5e9")
    if kind in ("bool_parsing", "bool_type"):
        return f"must be true or false{shown}", "write true or false"
    if kind in ("string_type", "string_sub_type"):
        return f"must be a text{shown}", "write a single value (quote it if it contains special characters)"
    if kind == "literal_error":
        expected = str(ctx.get("expected", ""))
        return f"must be one of {expected}{shown}", "choose one of the listed values"
    if kind in ("list_type", "tuple_type"):
        return f"must be a list of values{shown}", "write the values as a list"
    if kind in ("dict_type", "model_type", "model_attributes_type"):
        return f"must be a list of parameters (a mapping){shown}", "give the parameters as keys under it"
    if kind in ("too_short", "too_long"):
        return f"{msg}{shown}", "give the expected number of values"
    return f"{msg}{shown}", None


def convert_errors(exc: ValidationError, model: type[BaseModel], *, path: Sequence[str], file: str | None, lines=None) -> list[InputError]:
    """One InputError per pydantic error, with the deck path and a suggestion."""
    out: list[InputError] = []
    for err in exc.errors(include_url=False):
        loc = tuple(str(p) for p in err["loc"])
        kind = err["type"]
        full = tuple(path) + loc
        line = lines(full) if lines else None
        if kind == "extra_forbidden":
            parent = _submodel(model, loc[:-1])
            known = _aliases(parent) if parent else []
            close = difflib.get_close_matches(loc[-1], known, n=1, cutoff=0.6)
            fix = f"did you mean {close[0]!r}?" if close else (f"known keys: {', '.join(known)}" if known else None)
            out.append(InputError(f"unknown key {loc[-1]!r}", file=file, path=full[:-1], fix=fix, line=line))
        elif kind == "missing":
            parent = _submodel(model, loc[:-1])
            field = parent.model_fields.get(loc[-1]) if parent else None
            if field is None and parent is not None:
                field = next((f for n, f in parent.model_fields.items() if f.alias == loc[-1]), None)
            desc = f" ({field.description})" if field is not None and field.description else ""
            out.append(InputError(f"missing required key {loc[-1]!r}{desc}", file=file, path=full[:-1], line=line))
        elif kind in ("value_error", "assertion_error"):
            msg = str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
            cause = (err.get("ctx") or {}).get("error")
            key = getattr(cause, "key", None)
            if isinstance(key, (str, tuple)):  # a validator's problem with one key: name its path
                full = full + ((key,) if isinstance(key, str) else tuple(key))
                line = lines(full) if lines else line
            fix = getattr(cause, "fix", None)
            if isinstance(fix, str) and isinstance(getattr(cause, "message", None), str):
                msg = cause.message  # the validator gave the problem and the fix apart
            else:
                fix = None
            out.append(InputError(msg, file=file, path=full, line=line, fix=fix))
        else:
            msg = str(err["msg"])
            problem, fix = explain(kind, err.get("ctx") or {}, err.get("input"), msg)
            out.append(InputError(problem, file=file, path=full, line=line, fix=fix))
    return out


def validate_params(
    model: type[P],
    data: Mapping[str, Any],
    *,
    path: Sequence[str],
    file: str | None,
    errors: list[InputError],
    lines=None,
    context: dict[str, Any] | None = None,
) -> P | None:
    """Validate ``data`` with ``model``; collect problems into ``errors`` and return None.

    Keys listed in the model's ``ignored_keys`` (Peridigm knows them but ignores them in this
    place) are dropped with one warning each.
    """
    if not isinstance(data, Mapping):
        errors.append(InputError(f"expected a list of parameters, got {_describe(data)}", file=file, path=path))
        return None
    ignored = model.ignored_keys
    clean = {}
    for key, value in data.items():
        if key in ignored:
            problem = ignored_value_problem(key, value)
            if problem:
                errors.append(InputError(problem, file=file, path=(*path, key), line=lines((*path, key)) if lines else None, fix="give a valid value or remove the key"))
                continue
            log.warning("%s: %s: %r is ignored (Peridigm ignores it too)", file, " > ".join(path), key)
            continue
        clean[key] = value
    try:
        return model.model_validate(clean, context={DECK_CONTEXT: True, **(context or {})})
    except ValidationError as exc:
        errors.extend(convert_errors(exc, model, path=path, file=file, lines=lines))
        return None


def ignored_value_problem(key: str, value: Any) -> str | None:
    """Why the value of an ignored deck key is bad input (None when it is fine): ignored keys are
    not read, but a non-finite number, a wrong type or a value outside the key's range where a
    model reads it is a mistake in the deck all the same."""
    from pydantic import TypeAdapter, ValidationError

    annotation = IGNORED_KEY_TYPES.get(key) or reading_field(key)
    if non_finite(value):
        return f"{key!r} must be finite, got {value!r} (the key is ignored here, but its value is still checked)"
    if annotation is None:
        return None
    if bool_for_number(annotation, value):
        return f"{key!r} must be a number, got the boolean {str(value).lower()} (the key is ignored here, but its value is still checked)"
    if bool in leaf_types(annotation) and not isinstance(value, bool):
        return f"{key!r} must be true or false, got {value!r} (the key is ignored here, but its value is still checked)"
    try:
        TypeAdapter(annotation).validate_python(value)
    except ValidationError as exc:
        err = exc.errors(include_url=False)[0]
        problem, _ = explain(err["type"], err.get("ctx") or {}, err.get("input"), str(err["msg"]))
        return f"{key!r} {problem} (the key is ignored here, but its value is still checked)"
    return None
