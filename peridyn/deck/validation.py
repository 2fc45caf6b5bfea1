"""Turning pydantic validation errors into one-line, deck-path-named input errors."""
from __future__ import annotations

import difflib
import logging
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from ..core.errors import InputError

log = logging.getLogger("peridyn.deck")

P = TypeVar("P", bound=BaseModel)


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


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


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
        elif kind in ("value_error", "assertion_error") and not loc:
            msg = str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
            out.append(InputError(msg, file=file, path=full, line=line))
        else:
            msg = str(err["msg"]).removeprefix("Value error, ")
            got = err.get("input")
            text = f"{msg} (got {_describe(got)})" if got is not None and not isinstance(got, Mapping) else msg
            out.append(InputError(text, file=file, path=full, line=line))
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
    ignored = getattr(model, "ignored_keys", frozenset())
    clean = {}
    for key, value in data.items():
        if key in ignored:
            log.warning("%s: %s: %r is ignored (Peridigm ignores it too)", file, " > ".join(path), key)
            continue
        clean[key] = value
    try:
        return model.model_validate(clean, context=context)
    except ValidationError as exc:
        errors.extend(convert_errors(exc, model, path=path, file=file, lines=lines))
        return None
