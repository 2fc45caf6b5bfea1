"""Base class for every plugin's parameters, and shared parameter helpers.

A model's ``Params`` is a frozen pydantic model whose field aliases are Peridigm's deck names
(``"Bulk Modulus"``), with units and meaning in each field's ``description``. Unknown keys are
errors (``extra="forbid"``); keys Peridigm accepts but ignores in that place are listed in
``ignored_keys`` and accepted with one warning.
"""
from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict


class ModelParams(BaseModel):
    """Base of plugin parameter models: frozen, unknown keys forbidden, Peridigm aliases.

    Subclasses may set ``ignored_keys``: deck keys Peridigm knows but ignores for this model;
    the deck loader drops them with one warning naming them, so Peridigm decks run unchanged.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True, str_strip_whitespace=False)

    ignored_keys: ClassVar[frozenset[str]] = frozenset()

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
