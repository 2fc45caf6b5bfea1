"""The plugin registry: built-in plugins in-process, third-party ones through entry points.

Built-ins are listed in :data:`BUILTIN_PLUGINS`; third-party packages register modules under
the entry-point group ``peridyn`` (switched off by ``PERIDYN_DISABLE_PLUGIN_AUTOLOAD=1``).
A third-party plugin that fails to import is reported once (a warning) and becomes an error
only when a deck asks for a name nobody else provides.
"""
from __future__ import annotations

import difflib
import importlib
import logging
import os
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import pluggy

from ..core.errors import InputError
from . import hookspecs

log = logging.getLogger("peridyn.plugins")

#: built-in plugin modules, registered in-process (pytest's ``default_plugins`` pattern)
BUILTIN_PLUGINS: tuple[str, ...] = ("peridyn.plugins.builtins",)

ENTRY_POINT_GROUP = "peridyn"
AUTOLOAD_ENV = "PERIDYN_DISABLE_PLUGIN_AUTOLOAD"

#: kind -> (hook name, human name, deck key naming it)
KINDS: dict[str, tuple[str, str, str]] = {
    "material": ("peridyn_materials", "material model", "Material Model"),
    "damage": ("peridyn_damage_models", "damage model", "Damage Model"),
    "contact": ("peridyn_contact_models", "contact model", "Contact Model"),
    "compute": ("peridyn_computes", "compute class", "Compute Class"),
    "solver": ("peridyn_solvers", "solver", "solver method"),
    "discretization": ("peridyn_discretizations", "discretization type", "Type"),
    "boundary_condition": ("peridyn_boundary_conditions", "boundary condition type", "Type"),
    "backend": ("peridyn_backends", "backend", "--backend"),
}


class PluginError(Exception):
    """A plugin set-up problem that is not the deck's fault (two plugins claim one name)."""


@dataclass
class Entry:
    kind: str
    name: str
    target: str  #: "module:Class"
    plugin: str  #: name of the plugin that provides it
    _cls: Any = field(default=None, repr=False)

    def load(self) -> type:
        """The class, imported on first use; TypeError when it does not keep its kind's contract."""
        if self._cls is None:
            module_name, _, attr = self.target.partition(":")
            module = importlib.import_module(module_name)
            cls = getattr(module, attr)
            _check_contract(self.kind, self.target, cls)
            self._cls = cls
        return self._cls


_UNDECLARED = object()


def _check_contract(kind: str, target: str, cls: Any) -> None:
    """A model class subclasses its kind's contract and declares its ``Params`` (the engine reads
    both without probing)."""
    from ..core.conditions import Condition
    from ..core.discretization import DiscretizationReader
    from ..core.interfaces import Compute, ContactModel, DamageModel, Material, Solver
    from ..core.params import ModelParams
    from ..core.traversal import Backend

    contract = {"material": Material, "damage": DamageModel, "contact": ContactModel, "compute": Compute, "solver": Solver,
                "boundary_condition": Condition, "discretization": DiscretizationReader, "backend": Backend}[kind]
    if not (isinstance(cls, type) and issubclass(cls, contract)):
        raise TypeError(f"{target} is not a subclass of {contract.__module__}.{contract.__name__}")
    if kind == "backend":
        return
    params = next((vars(k)["Params"] for k in cls.__mro__ if "Params" in vars(k)), _UNDECLARED)
    keyless = params is None and kind == "compute"
    model = isinstance(params, type) and issubclass(params, ModelParams) and params is not ModelParams
    if not (keyless or model):
        raise TypeError(f"{target} declares no Params, a subclass of peridyn.core.params.ModelParams (the model of its deck keys; "
                        "None for a compute without keys)")


class Registry:
    """Every model name of every kind, and the class behind it (imported on first use)."""

    def __init__(self, pm: pluggy.PluginManager, failed: dict[str, str]) -> None:
        self.pm = pm
        self.failed = failed  #: plugin name -> one-line import error
        self.entries: dict[str, dict[str, Entry]] = {kind: {} for kind in KINDS}
        problems = []
        for kind, (hook_name, human, _) in KINDS.items():
            hook = getattr(pm.hook, hook_name)
            for impl in hook.get_hookimpls():
                pairs = impl.function() or []
                for name, target in pairs:
                    old = self.entries[kind].get(name)
                    if old is not None and old.plugin != impl.plugin_name:
                        problems.append(
                            f"two plugins provide the {human} {name!r}: {old.plugin!r} ({old.target}) "
                            f"and {impl.plugin_name!r} ({target}); uninstall one of them"
                        )
                        continue
                    self.entries[kind][name] = Entry(kind, name, target, impl.plugin_name)
        if problems:
            raise PluginError("; ".join(problems))

    def names(self, kind: str) -> list[str]:
        return list(self.entries[kind])

    def has(self, kind: str, name: str) -> bool:
        return isinstance(name, str) and name in self.entries[kind]

    def entry(self, kind: str, name: str) -> Entry:
        return self.entries[kind][name]

    def get(self, kind: str, name: str, *, path: tuple[str, ...] = (), file: str | None = None) -> type:
        """The class providing ``name``; InputError (with suggestions) when nobody provides it
        or its module fails to import."""
        entry = self.entries[kind].get(name) if isinstance(name, str) else None
        human = KINDS[kind][1]
        if entry is None:
            raise self.unknown(kind, name, path=path, file=file)
        try:
            return entry.load()
        except Exception as exc:  # a broken plugin is fatal only when used
            raise InputError(
                f"the {human} {name!r} could not be loaded from plugin {entry.plugin!r}: {type(exc).__name__}: {exc}",
                file=file,
                path=path,
                fix="reinstall or fix that plugin",
            ) from exc

    def unknown(self, kind: str, name: str, *, path=(), file=None) -> InputError:
        human = KINDS[kind][1]
        available = self.names(kind)
        if not isinstance(name, str):
            listed = ", ".join(sorted(available)) or "none is installed"
            return InputError(f"expected the name of a {human}, got {name!r}", file=file, path=path,
                              fix=f"write one name (available: {listed})")
        if not available:
            return InputError(f"unknown {human} {name!r}: no {human} is installed", file=file, path=path,
                              fix="remove the entry, or install a plugin that provides it")
        close = difflib.get_close_matches(str(name), available, n=3, cutoff=0.5) or difflib.get_close_matches(
            str(name).upper().strip().replace(" ", "_"), available, n=3, cutoff=0.5)  # names matched as Peridigm tidies them
        hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
        names = sorted(available)
        if len(names) <= 6:
            fix = f"{hint}available: {', '.join(names)}"
        elif hint:
            fix = f"{hint}('peridyn plugins' lists all {len(names)})"
        else:
            fix = f"available: {', '.join(names[:4])}, ... ({len(names)} in all; 'peridyn plugins' lists them)"
        if self.failed:
            fix += "; plugins that failed to import: " + ", ".join(f"{p} ({e})" for p, e in self.failed.items())
        return InputError(f"unknown {human} {name!r}", file=file, path=path, fix=fix)

    def all_classes(self, kind: str) -> dict[str, type | Exception]:
        """Every class of ``kind`` (an exception instead where loading fails)."""
        out: dict[str, type | Exception] = {}
        for name, entry in self.entries[kind].items():
            try:
                out[name] = entry.load()
            except Exception as exc:  # reported by the caller
                out[name] = exc
        return out


def _new_manager() -> pluggy.PluginManager:
    pm = pluggy.PluginManager("peridyn")
    pm.add_hookspecs(hookspecs)
    return pm


def build_registry(*, autoload: bool | None = None, extra_plugins: tuple[Any, ...] = ()) -> Registry:
    """A fresh registry: built-ins, then (unless disabled) entry-point plugins, then
    ``extra_plugins`` (modules or objects with hook implementations; used by tests)."""
    pm = _new_manager()
    for module_name in BUILTIN_PLUGINS:
        pm.register(importlib.import_module(module_name), name=module_name)
    failed: dict[str, str] = {}
    if autoload is None:
        autoload = os.environ.get(AUTOLOAD_ENV, "") in ("", "0")
    if autoload:
        for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
            if pm.has_plugin(ep.name) or pm.is_blocked(ep.name):
                continue
            try:
                plugin = ep.load()
            except Exception as exc:  # report once, fatal only if a deck needs it
                failed[ep.name] = f"{type(exc).__name__}: {exc}"
                log.warning("plugin %r (entry point %s) failed to import: %s", ep.name, ep.value, failed[ep.name])
                continue
            pm.register(plugin, name=ep.name)
    for plugin in extra_plugins:
        if not pm.is_registered(plugin):
            pm.register(plugin)
    pm.check_pending()
    return Registry(pm, failed)


_REGISTRY: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry (built on first use)."""
    global _REGISTRY
    if _REGISTRY is None:
        _REGISTRY = build_registry()
    return _REGISTRY


def reset_registry(registry: Registry | None = None) -> None:
    """Replace (or forget) the process-wide registry; for tests and ``peridyn.testing``."""
    global _REGISTRY
    _REGISTRY = registry
