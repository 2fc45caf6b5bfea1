"""Mutation testing of the conformance suites: wrong variants of a model, registered in memory,
and a runner that applies a suite's checks to them outside pytest.

A suite is worth what it catches. :func:`material_mutant` derives from any material class a
subclass with one classic bug (doubled modulus, a missing factor of the bond length, a force
scaled point by point, a fixed density, a flipped sign, damage ignored), applied to what the
material writes, so it works on any material without knowing its kernels; :func:`damage_mutant`
does the same for damage models. :class:`ModelPlugin` registers such classes (with
:func:`peridyn.testing.isolated_registry`), and :func:`run_checks` runs every ``test_*`` method
of a suite class and reports each outcome::

    Mutant = material_mutant(MyMaterial, "sign flipped")
    plugin = ModelPlugin(materials={"Mutant": Mutant})
    suite = type("MutantSuite", (MaterialConformance,), {"material": "Mutant", "params": PARAMS, "plugins": (plugin,)})
    results = run_checks(suite)        # {"test_...": Outcome("failed", "AssertionError: ..."), ...}
"""
from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.interfaces import BlockView, DamageModel, Material
from ..plugins.hookspecs import hookimpl

__all__ = [
    "DAMAGE_MUTATIONS",
    "MATERIAL_MUTATIONS",
    "ModelPlugin",
    "Outcome",
    "damage_mutant",
    "material_mutant",
    "point_factor",
    "run_checks",
]

#: the bugs :func:`material_mutant` knows
MATERIAL_MUTATIONS = ("modulus doubled", "bond length missing", "per-point factor", "density ignored", "sign flipped", "damage ignored")
#: the bugs :func:`damage_mutant` knows
DAMAGE_MUTATIONS = ("never breaks", "heals", "breaks half")

#: the density a "density ignored" mutant reports whatever the parameters say (M L^-3)
FIXED_DENSITY = 1000.0


def point_factor(rows: np.ndarray) -> np.ndarray:
    """The per-point factor of the "per-point factor" mutant: 1, 1.25 or 1.5 by point index."""
    return 1.0 + 0.25 * (np.asarray(rows) % 3)


class _FieldsWithout:
    """A FieldStore that hides some fields (``in`` is False, ``[]`` raises KeyError)."""

    def __init__(self, store: Any, hidden: Iterable[str]) -> None:
        self._store = store
        self._hidden = frozenset(hidden)

    def __contains__(self, name: str) -> bool:
        return name not in self._hidden and name in self._store

    def __getitem__(self, name: str) -> np.ndarray:
        if name in self._hidden:
            raise KeyError(name)
        return self._store[name]

    def get(self, name: str, default=None):
        return default if name in self._hidden else self._store.get(name, default)

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._store, attr)


def _bond_rows(block: BlockView) -> tuple[int, int, np.ndarray]:
    """(first bond, end bond, owner point of each bond) of the view's points."""
    offsets = block.bonds.offsets
    lo, hi = int(offsets[block.start]), int(offsets[block.stop])
    rows = np.repeat(np.arange(block.start, block.stop), np.diff(offsets[block.start : block.stop + 1]))
    return lo, hi, rows


def material_mutant(base: type[Material], mutation: str) -> type[Material]:
    """A subclass of ``base`` with one bug (one of :data:`MATERIAL_MUTATIONS`):

    * ``modulus doubled``: force state, fused force density and stored energy times 2 (as if
      the micromodulus were twice the stated one);
    * ``bond length missing``: the force state of bond b times its length |xi_b| (a stretch
      where an extension belongs: units off by a length); the fused path is switched off;
    * ``per-point factor``: the force state of point i's bonds, and the fused force density of
      point i, times :func:`point_factor` (i);
    * ``density ignored``: ``density`` is :data:`FIXED_DENSITY` whatever the parameters say;
    * ``sign flipped``: force state, fused force density and stored energy times -1;
    * ``damage ignored``: the model never sees ``Bond_Damage`` (and adopts no damage rule).
    """
    if mutation not in MATERIAL_MUTATIONS:
        raise ValueError(f"unknown mutation {mutation!r}; known: {', '.join(MATERIAL_MUTATIONS)}")
    scale = {"modulus doubled": 2.0, "sign flipped": -1.0}.get(mutation)
    body: dict[str, Any] = {"__doc__": f"{base.__name__} with a bug: {mutation}.", "__module__": __name__}

    if scale is not None:

        def force_state(self, block, t):
            base.force_state(self, block, t)
            lo, hi, _ = _bond_rows(block)
            t[lo:hi] *= scale

        def force_fused(self, block, force_density):
            done = base.force_fused(self, block, force_density)
            if done:
                force_density[block.start : block.stop] *= scale
            return done

        def stored_energy_density(self, block, out):
            base.stored_energy_density(self, block, out)
            out[block.start : block.stop] *= scale

        body.update(force_state=force_state, force_fused=force_fused, stored_energy_density=stored_energy_density)

    elif mutation == "bond length missing":

        def force_state(self, block, t):
            base.force_state(self, block, t)
            lo, hi, _ = _bond_rows(block)
            t[lo:hi] *= block.fields["Bond_Length"][lo:hi]

        body.update(force_state=force_state, force_fused=lambda self, block, force_density: False, row_local=False)

    elif mutation == "per-point factor":

        def force_state(self, block, t):
            base.force_state(self, block, t)
            lo, hi, rows = _bond_rows(block)
            t[lo:hi] *= point_factor(rows)

        def force_fused(self, block, force_density):
            done = base.force_fused(self, block, force_density)
            if done:
                force_density[block.start : block.stop] *= point_factor(np.arange(block.start, block.stop))[:, None]
            return done

        body.update(force_state=force_state, force_fused=force_fused)

    elif mutation == "density ignored":
        body["density"] = property(lambda self: FIXED_DENSITY)

    else:  # damage ignored

        def hide(method: Callable) -> Callable:
            def wrapped(self, block, *args):
                return method(self, dataclasses.replace(block, fields=_FieldsWithout(block.fields, ("Bond_Damage",))), *args)

            wrapped.__name__ = method.__name__
            return wrapped

        for name in ("initialize", "precompute", "force_state", "force_fused", "stored_energy_density", "tangent"):
            body[name] = hide(getattr(base, name))
        body["adopt_damage"] = lambda self, damage: False

    return type(f"{base.__name__}_{mutation.replace(' ', '_').replace('-', '_')}", (base,), body)


def damage_mutant(base: type[DamageModel], mutation: str) -> type[DamageModel]:
    """A subclass of ``base`` with one bug (one of :data:`DAMAGE_MUTATIONS`): ``never breaks``
    (``update`` leaves every bond intact), ``heals`` (bond damage restarts from zero at every
    update: N is cleared first), ``breaks half`` (the bonds of odd-numbered points stay
    intact). Each also offers materials no bond rule (so they call ``update``)."""
    if mutation not in DAMAGE_MUTATIONS:
        raise ValueError(f"unknown mutation {mutation!r}; known: {', '.join(DAMAGE_MUTATIONS)}")

    def update(self, block):
        s = block.fields
        lo, hi, rows = _bond_rows(block)
        if mutation == "never breaks":
            s["Bond_Damage"][lo:hi] = 0
            s["Damage"][block.start : block.stop] = 0.0
            return
        if mutation == "heals":
            s.n("Bond_Damage")[lo:hi] = 0
        base.update(self, block)
        if mutation == "breaks half":
            s["Bond_Damage"][lo:hi][rows % 2 == 1] = 0

    body = {"__doc__": f"{base.__name__} with a bug: {mutation}.", "__module__": __name__, "update": update, "bond_rule": lambda self: None}
    return type(f"{base.__name__}_{mutation.replace(' ', '_')}", (base,), body)


# ------------------------------------------------------------------------------------------------
# registering classes held in memory
# ------------------------------------------------------------------------------------------------
_HELD: dict[str, type] = {}
_COUNTER = itertools.count()


def __getattr__(name: str) -> type:  # module attribute lookup of the held classes (PEP 562)
    try:
        return _HELD[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None


def _target(cls: type) -> str:
    """A "module:attribute" path the registry imports ``cls`` from."""
    key = f"held_{next(_COUNTER)}_{cls.__name__}"
    _HELD[key] = cls
    return f"{__name__}:{key}"


class ModelPlugin:
    """A plugin providing classes held in memory (mutants, classes defined in a test):
    ``ModelPlugin(materials={"Deck Name": cls}, damage_models={...})``; pass it to
    :func:`peridyn.testing.isolated_registry` or as a suite's ``plugins``."""

    def __init__(self, *, materials: dict[str, type] | None = None, damage_models: dict[str, type] | None = None) -> None:
        self._materials = [(name, _target(cls)) for name, cls in (materials or {}).items()]
        self._damage_models = [(name, _target(cls)) for name, cls in (damage_models or {}).items()]

    @hookimpl
    def peridyn_materials(self) -> list[tuple[str, str]]:
        return list(self._materials)

    @hookimpl
    def peridyn_damage_models(self) -> list[tuple[str, str]]:
        return list(self._damage_models)


# ------------------------------------------------------------------------------------------------
# running a suite outside pytest
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Outcome:
    """The result of one check: ``status`` "passed", "failed" (an assertion failed), "error"
    (another exception: the check could not run) or "skipped"; ``message``: the first line."""

    status: str
    message: str = ""

    @property
    def failed(self) -> bool:
        return self.status == "failed"


def run_checks(suite: type, names: Iterable[str] | None = None, *, stop_at_failure: bool = False) -> dict[str, Outcome]:
    """Run the ``test_*`` methods of the suite class ``suite`` (or ``names``, in that order) on
    a fresh instance each; return name -> :class:`Outcome`. ``stop_at_failure``: stop after the
    first failed assertion."""
    import pytest
    names = list(names) if names is not None else sorted(n for n in dir(suite) if n.startswith("test_"))
    results: dict[str, Outcome] = {}
    for name in names:
        try:
            getattr(suite(), name)()
            results[name] = Outcome("passed")
        except pytest.skip.Exception as exc:
            results[name] = Outcome("skipped", str(exc.msg))
        except (AssertionError, pytest.fail.Exception) as exc:
            results[name] = Outcome("failed", f"{type(exc).__name__}: {_first_line(exc)}")
        except Exception as exc:  # noqa: BLE001 - reported, not raised: the runner surveys
            results[name] = Outcome("error", f"{type(exc).__name__}: {_first_line(exc)}")
        if stop_at_failure and results[name].failed:
            break
    return results


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else ""
