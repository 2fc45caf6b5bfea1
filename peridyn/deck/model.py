"""Input decks: load (YAML or Peridigm XML), validate in two phases, return a :class:`Deck`.

Phase 1 checks the core structure (sections, blocks, node sets, boundary conditions, solvers,
outputs). Phase 2 validates every material, damage model, contact model, compute class, solver
and discretization entry with the ``Params`` of the plugin its name selects. Every problem is
collected; all of them are raised together, each naming the file and the deck path.

Peridigm's conventions are honoured: any top-level section whose name contains ``Solver`` is a
solver run in deck order, any containing ``Output`` an output; boundary-condition ``Type`` and
node-set names are matched after "tidying" (upper case, spaces as ``_``); an entry of
``Boundary Conditions`` whose tidied name contains ``NODE_SET`` defines a node set.
"""
from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import Field, field_validator

from ..core.errors import InputError, raise_collected
from ..core.interfaces import Solver
from ..core.params import ModelParams
from ..core.solver_section import SolverSection
from ..plugins.manager import Registry, get_registry
from .boundary import BCEntry, NodeSetEntry, parse_boundary_conditions, tidy
from .source import SECTION_NAMES
from .validation import close_key, ignored_value_problem, suggest as _choices, validate_params

log = logging.getLogger("peridyn.deck")

#: solver methods in the order Peridigm checks them inside a solver section
SOLVER_METHOD_ORDER = ("Verlet", "QuasiStatic", "NOXQuasiStatic", "Implicit", "ImplicitDiffusion")

#: top-level sections (besides names containing Solver or Output), as the file reader knows them
KNOWN_SECTIONS = tuple(sorted(SECTION_NAMES))
#: top-level keys Peridigm reads that change nothing here; accepted with a warning
IGNORED_TOP_LEVEL = {
    "Verbose": "verbosity is set with --verbose/--quiet",
    "Enable Bond-Associated Hypoelastic Model": "no model here reads it",
}
#: top-level key: the seed of ``rnd()`` in expressions (peridyn's; Peridigm has none)
RANDOM_SEED_KEY = "Random Seed"
#: Peridigm sections that peridyn does not implement yet
UNSUPPORTED_SECTIONS: dict[str, str] = {}


# ------------------------------------------------------------------------------------------------
# Core section schemas (phase 1)
# ------------------------------------------------------------------------------------------------
class BlockParams(ModelParams):
    block_names: str = Field(alias="Block Names", description="space-separated block names, e.g. 'block_1 block_2' (or 'default')")
    material: str = Field(alias="Material", description="name of an entry of Materials")
    damage_model: str | None = Field(None, alias="Damage Model", description="name of an entry of Damage Models")
    horizon: float | str | None = Field(
        None,
        alias="Horizon",
        description="horizon (length): a number for a constant horizon, or an expression in x, y, z for a variable one",
    )


class OutputParams(ModelParams):
    output_file_type: str = Field("ExodusII", alias="Output File Type", description="only ExodusII")
    output_format: str = Field("BINARY", alias="Output Format", description="only BINARY")
    output_filename: str = Field("dump", alias="Output Filename", description="base name; '.e' (or '.h') is appended")
    output_frequency: int = Field(-1, alias="Output Frequency", description="write every n-th call (steps); -1 writes nothing")
    initial_output_step: int = Field(1, alias="Initial Output Step", description="first write counter that may write")
    final_output_step: int = Field(2**31 - 2, alias="Final Output Step", description="last write counter that may write (minus one)")
    parallel_write: bool = Field(True, alias="Parallel Write", description="accepted; on several ranks each writes its own piece")
    merge_rank_files: bool = Field(True, alias="Merge Rank Files", description=(
        "on N > 1 ranks: true joins the ranks' pieces into one NAME.e when the run ends; false keeps Peridigm's "
        "NAME.e.N.r pieces ('peridyn merge NAME.e' joins them later)"))
    bond_family: bool = Field(False, alias="Bond Family", description="accepted for compatibility")
    output_variables: dict[str, Any] = Field(default_factory=dict, alias="Output Variables", description="variables to write (values ignored, as in Peridigm)")

    @field_validator("output_filename")
    @classmethod
    def _plain_name(cls, name: str) -> str:
        if not name.strip() or name.strip(".") == "" or any(c in name for c in "/\\") or not name.isprintable():
            raise ValueError(
                f"'Output Filename' must be a plain file name, got {name!r}; "
                "give a name without folders and choose the folder with 'peridyn run --output-dir'"
            )
        return name


class DataLoaderParams(ModelParams):
    file_name: str = Field(alias="File Name", description="Exodus file holding the nodal field over time")
    field_name: str = Field(alias="Field Name", description="nodal variable to load")


class ContactSectionParams(ModelParams):
    """The ``Contact`` section's own keys (its ``Models`` are validated by each model)."""

    search_radius: float = Field(alias="Search Radius", gt=0, description="R_s: pairs closer than this at a search are listed (L)")
    search_frequency: int = Field(alias="Search Frequency", ge=1, description="search every this many Verlet steps")
    verbose: bool = Field(False, alias="Verbose", description="accepted; no effect")
    models: dict[str, Any] = Field(alias="Models", description="contact models; the first one acts between all points")
    interactions: dict[str, Any] | None = Field(
        None, alias="Interactions", description="block pairs; Peridigm parses them but contact acts between all blocks"
    )


@dataclass
class ContactEntry:
    """The validated ``Contact`` section: the settings and the one model that acts."""

    params: ContactSectionParams
    model: "ModelEntry"
    path: tuple[str, ...] = ("Contact",)


# ------------------------------------------------------------------------------------------------
# The validated deck
# ------------------------------------------------------------------------------------------------
@dataclass
class ModelEntry:
    """A named entry validated by a plugin (material, damage model, compute class, ...)."""

    name: str  #: the entry's name in the deck ("My Elastic Material"), or the output label
    model: str  #: the plugin name ("Elastic")
    cls: type
    params: Any
    path: tuple[str, ...]


@dataclass
class BlockEntry:
    names: list[str]
    material: str
    damage_model: str | None
    horizon: float | str | None
    path: tuple[str, ...]


@dataclass
class SolverEntry:
    section: str
    method: str
    cls: type[Solver]
    params: SolverSection
    path: tuple[str, ...]


@dataclass
class OutputEntry:
    section: str
    params: OutputParams
    variables: list[str]  #: spaces replaced by "_", deck order
    path: tuple[str, ...]

    @property
    def filename(self) -> str:
        return self.params.output_filename.replace(" ", "_").replace(".", "_")


@dataclass
class DiscretizationEntry:
    type: str
    cls: type
    params: Any
    influence_function: str
    bond_filters: list[tuple[str, dict, tuple[str, ...]]]
    omit_bonds_between_blocks: str
    path: tuple[str, ...]


@dataclass
class Deck:
    """A validated deck. Paths inside it are relative to ``directory``."""

    file: str
    directory: Path
    source: Any  #: the DeckSource (raw tree and line numbers)
    discretization: DiscretizationEntry
    materials: dict[str, ModelEntry]
    damage_models: dict[str, ModelEntry]
    blocks: list[BlockEntry]
    node_sets: dict[str, NodeSetEntry]
    boundary_conditions: list[BCEntry]
    solvers: list[SolverEntry]
    outputs: list[OutputEntry]
    computes: list[ModelEntry]  #: Compute Class Parameters entries, deck order
    data_loader: DataLoaderParams | None
    contact: ContactEntry | None
    registry: Registry = field(repr=False, default=None)
    multiphysics: bool = False  #: top-level ``Multiphysics: 1``: fluid pressure as a 4th dof (PERIDIGM_MODELS.md §7)
    random_seed: int = 0  #: top-level ``Random Seed``: what ``rnd()`` in expressions hashes with each point's global id
    restart: Any = None  #: the ``Restart`` section (:class:`peridyn.deck.restart.RestartParams`), or None

    def line(self, path) -> int | None:
        return self.source.line_of(path) if self.source is not None else None


# ------------------------------------------------------------------------------------------------
# Loading
# ------------------------------------------------------------------------------------------------
def load_deck(path: str | Path, registry: Registry | None = None) -> Deck:
    """Read and validate a deck; raise InputError(s) naming every problem."""
    from .files import load_deck_file

    source = load_deck_file(path)
    return parse_deck(source, registry)


def parse_deck(source, registry: Registry | None = None) -> Deck:
    """Validate an already-read :class:`~peridyn.deck.source.DeckSource`."""
    registry = registry or get_registry()
    file = str(source.path)
    tree = source.tree
    errors: list[InputError] = []
    lines = source.line_of

    def err(message: str, path=(), fix: str | None = None) -> None:
        errors.append(InputError(message, file=file, path=path, fix=fix, line=lines(path) if path else None))

    def section(name: str) -> dict:
        value = tree.get(name, {})
        if not isinstance(value, Mapping):
            err(f"expected a list of entries, got {value!r}", (name,))
            return {}
        return value

    # -- top level -----------------------------------------------------------------------------
    random_seed = 0
    for key in tree:
        if key == RANDOM_SEED_KEY:  # peridyn's own top-level key (docs/peridigm-differences.md)
            value = tree[key]
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**64:
                err(f"'Random Seed' must be a whole number from 0 to 2^64 - 1, got {value!r}", (key,), "give e.g. 'Random Seed: 1' or remove the key (seed 0)")
            else:
                random_seed = value
            continue
        if key in KNOWN_SECTIONS or "Solver" in key or "Output" in key:
            if key in UNSUPPORTED_SECTIONS:
                err(UNSUPPORTED_SECTIONS[key], (key,), "remove the section")
            continue
        if key in IGNORED_TOP_LEVEL:
            problem = ignored_value_problem(key, tree[key])
            if problem:
                err(problem, (key,), "give a valid value or remove the key")
                continue
            log.warning("%s: %r is ignored (%s)", file, key, IGNORED_TOP_LEVEL[key])
            continue
        import difflib

        close = difflib.get_close_matches(key, list(KNOWN_SECTIONS) + ["Solver", "Output"], n=1, cutoff=0.6)
        err(f"unknown section {key!r}", (key,), f"did you mean {close[0]!r}?" if close else f"known sections: {', '.join(KNOWN_SECTIONS)}, and names containing 'Solver' or 'Output'")
    for required in ("Discretization", "Materials", "Blocks"):
        if required not in tree:
            err(f"missing required section {required!r}", (), f"add a {required} section")

    disc = _parse_discretization(section("Discretization"), registry, file, errors, lines) if "Discretization" in tree else None

    # -- materials and damage models ------------------------------------------------------------
    materials = _parse_models(section("Materials"), "Materials", "material", "Material Model", registry, file, errors, lines)
    damage = _parse_models(section("Damage Models"), "Damage Models", "damage", "Damage Model", registry, file, errors, lines)
    for name, raw in section("Materials").items():
        if isinstance(raw, Mapping) and "Horizon" in raw:
            err("a material may not set 'Horizon'", ("Materials", name, "Horizon"), "set Horizon in the block instead")

    # -- blocks ----------------------------------------------------------------------------------
    blocks: list[BlockEntry] = []
    seen_blocks: dict[str, tuple[str, ...]] = {}
    for name, raw in section("Blocks").items():
        path = ("Blocks", name)
        p = validate_params(BlockParams, raw, path=path, file=file, errors=errors, lines=lines)
        if p is None:
            continue
        names = p.block_names.split()
        if not names:
            err("'Block Names' is empty", path + ("Block Names",), "list block names such as 'block_1 block_2'")
        for b in names:
            if b in seen_blocks:
                err(f"block {b!r} is listed twice (also in {' > '.join(seen_blocks[b])})", path + ("Block Names",))
            seen_blocks[b] = path
        if p.material not in section("Materials"):
            err(f"unknown material {p.material!r}", path + ("Material",), _choices(p.material, section("Materials")))
        if p.damage_model is not None and p.damage_model not in section("Damage Models"):
            err(f"unknown damage model {p.damage_model!r}", path + ("Damage Model",), _choices(p.damage_model, section("Damage Models")))
        horizon = p.horizon
        if horizon is None:
            err("missing required key 'Horizon'", path, "add 'Horizon: <length>'")
        elif isinstance(horizon, float) and not horizon > 0:
            err(f"the horizon must be positive (got {horizon!r})", path + ("Horizon",))
        elif isinstance(horizon, str):
            _check_expression(horizon, ("x", "y", "z"), path + ("Horizon",), file, errors)
        blocks.append(BlockEntry(names, p.material, p.damage_model, horizon, path))

    # -- boundary conditions ----------------------------------------------------------------------
    node_sets, bcs = parse_boundary_conditions(section("Boundary Conditions"), registry, file, errors, lines)

    # -- solvers ---------------------------------------------------------------------------------
    solvers: list[SolverEntry] = []
    for key, raw in tree.items():
        if "Solver" not in key:
            continue
        path = (key,)
        if not isinstance(raw, Mapping):
            err(f"expected a solver section, got {raw!r}", path)
            continue
        methods = [m for m in SOLVER_METHOD_ORDER if m in raw] + [
            m for m in raw if isinstance(raw[m], Mapping) and m not in SOLVER_METHOD_ORDER and registry.has("solver", m)
        ]
        if not methods:
            err("no solver method given", path, f"add one of: {', '.join(registry.names('solver'))}")
            continue
        method = methods[0]
        if not registry.has("solver", method):
            errors.append(registry.unknown("solver", method, path=path + (method,), file=file))
            continue
        cls = registry.get("solver", method, path=path + (method,), file=file)
        params = validate_params(cls.Params, raw, path=path, file=file, errors=errors, lines=lines)
        if params is not None:
            solvers.append(SolverEntry(key, method, cls, params, path))

    # -- compute classes ---------------------------------------------------------------------------
    computes: list[ModelEntry] = []
    for name, raw in section("Compute Class Parameters").items():
        path = ("Compute Class Parameters", name)
        if not isinstance(raw, Mapping) or "Compute Class" not in raw:
            message, fix = _missing_model_key("Compute Class", raw, registry.names("compute"))
            err(message, path, fix)
            continue
        cname = str(raw["Compute Class"]).replace(" ", "_")
        if not registry.has("compute", cname):
            errors.append(registry.unknown("compute", cname, path=path + ("Compute Class",), file=file))
            continue
        cls = registry.get("compute", cname, path=path, file=file)
        if cls.Params is None:
            err(f"compute {cname!r} takes no parameters", path + ("Compute Class",), "list it under Output Variables instead")
            continue
        body = {k: v for k, v in raw.items() if k != "Compute Class"}
        params = validate_params(cls.Params, body, path=path, file=file, errors=errors, lines=lines)
        if params is not None:
            label = cls.output_label(params) or name
            computes.append(ModelEntry(label, cname, cls, params, path))

    # -- outputs -----------------------------------------------------------------------------------
    outputs: list[OutputEntry] = []
    for key, raw in tree.items():
        if "Output" not in key or "Solver" in key:
            continue
        path = (key,)
        p = validate_params(OutputParams, raw, path=path, file=file, errors=errors, lines=lines)
        if p is None:
            continue
        if p.output_file_type != "ExodusII":
            err(f"unsupported Output File Type {p.output_file_type!r}", path + ("Output File Type",), "use 'ExodusII'")
        if p.output_format != "BINARY":
            err(f"unsupported Output Format {p.output_format!r}", path + ("Output Format",), "use 'BINARY'")
        variables = [str(v).replace(" ", "_") for v in p.output_variables]
        outputs.append(OutputEntry(key, p, variables, path))

    # -- data loader, contact -----------------------------------------------------------------------
    loader = None
    if "Data Loader" in tree:
        loader = validate_params(DataLoaderParams, tree["Data Loader"], path=("Data Loader",), file=file, errors=errors, lines=lines)
    contact = None
    if "Contact" in tree:
        contact = _parse_contact(section("Contact"), registry, file, errors, lines)

    restart = None
    if "Restart" in tree:  # Peridigm: the section's presence turns restart on (docs/restart.md)
        from .restart import RestartParams

        raw = tree["Restart"]
        restart = validate_params(RestartParams, raw if isinstance(raw, Mapping) else {}, path=("Restart",), file=file, errors=errors, lines=lines)

    multiphysics = _parse_multiphysics(tree, materials, err)
    raise_collected(errors)
    assert disc is not None
    return Deck(
        file=file,
        directory=Path(source.path).resolve().parent,
        source=source,
        discretization=disc,
        materials=materials,
        damage_models=damage,
        blocks=blocks,
        node_sets=node_sets,
        boundary_conditions=bcs,
        solvers=solvers,
        outputs=outputs,
        computes=computes,
        data_loader=loader,
        contact=contact,
        registry=registry,
        multiphysics=multiphysics,
        random_seed=random_seed,
        restart=restart,
    )


def _parse_multiphysics(tree, materials, err) -> bool:
    """Top-level ``Multiphysics`` (Peridigm: the number of extra dofs, which must be 1); then
    every material must be a multiphysics one (its class declares ``multiphysics = True``), and
    a multiphysics material needs the flag."""
    on = "Multiphysics" in tree
    if on:
        value = tree["Multiphysics"]
        if isinstance(value, bool) or not isinstance(value, int) or value != 1:
            err(f"'Multiphysics' must be 1 (one fluid pressure dof per point), got {value!r}", ("Multiphysics",), "set 'Multiphysics: 1' or remove it")
    for entry in materials.values():  # the material class declares it (Material.multiphysics)
        if on and not entry.cls.multiphysics:
            err(f"material model {entry.model!r} is not multiphysics compatible, and the deck sets 'Multiphysics'", entry.path,
                "use a multiphysics material (e.g. 'Multiphysics Elastic') in every block")
        elif not on and entry.cls.multiphysics:
            err(f"material model {entry.model!r} needs multiphysics enabled at the top level of the deck", entry.path, "add 'Multiphysics: 1' at the top level")
    return on


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def _missing_model_key(key: str, raw: Any, names: list[str]) -> tuple[str, str]:
    """(problem, fix) for an entry without the key that names its model: a mistyped key is named,
    a value that is not a list of parameters is shown."""
    if not isinstance(raw, Mapping):
        return f"expected a list of parameters with {key!r}, got {raw!r}", f"write it as '{key}: <name>' and the model's parameters under the entry"
    typo = close_key(key, raw)
    if typo is not None:
        return f"missing required key {key!r} (the entry has {typo!r})", f"rename {typo!r} to {key!r}"
    shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
    return f"missing required key {key!r}", f"add '{key}: <name>', one of {shown}"


def _check_expression(text: str, variables, path, file, errors) -> None:
    from .expressions import ExpressionError, compile_expression, constant_not_finite

    try:
        problem = constant_not_finite(compile_expression(text, variables))
    except ExpressionError as exc:
        errors.append(InputError(str(exc), file=file, path=path))
        return
    if problem:
        errors.append(InputError(problem, file=file, path=path, fix="give an expression with a finite value"))


def _parse_models(sec, section_name, kind, key, registry, file, errors, lines) -> dict[str, ModelEntry]:
    out: dict[str, ModelEntry] = {}
    for name, raw in sec.items():
        path = (section_name, name)
        if not isinstance(raw, Mapping):
            errors.append(InputError(f"expected a list of parameters, got {raw!r}", file=file, path=path))
            continue
        model = raw.get(key)
        if model is None:
            message, fix = _missing_model_key(key, raw, registry.names(kind))
            errors.append(InputError(message, file=file, path=path, line=lines(path), fix=fix))
            continue
        if not registry.has(kind, model):
            errors.append(registry.unknown(kind, model, path=path + (key,), file=file))
            continue
        try:
            cls = registry.get(kind, model, path=path + (key,), file=file)
        except InputError as exc:
            errors.append(exc)
            continue
        body = {k: v for k, v in raw.items() if k != key and not (section_name == "Materials" and k == "Horizon")}
        params = validate_params(cls.Params, body, path=path, file=file, errors=errors, lines=lines)
        if params is not None:
            out[name] = ModelEntry(name, model, cls, params, path)
    return out


DISCRETIZATION_CORE_KEYS = ("Type", "Influence Function", "Bond Filters", "Omit Bonds Between Blocks")
#: Peridigm discretization options peridyn does not implement yet
DISCRETIZATION_UNSUPPORTED: dict[str, str] = {}  # Construct Interfaces, Element-Horizon ...: Exodus keys now


def _parse_discretization(raw, registry, file, errors, lines) -> DiscretizationEntry | None:
    path = ("Discretization",)
    if "Horizon" in raw:
        errors.append(InputError("'Horizon' is not allowed here", file=file, path=path + ("Horizon",), fix="set Horizon in each block"))
    dtype = raw.get("Type")
    if dtype is None:
        errors.append(InputError("missing required key 'Type'", file=file, path=path, fix=f"one of: {', '.join(registry.names('discretization'))}"))
        return None
    if not registry.has("discretization", dtype):
        errors.append(registry.unknown("discretization", dtype, path=path + ("Type",), file=file))
        return None
    cls = registry.get("discretization", dtype, path=path + ("Type",), file=file)
    for key, reason in DISCRETIZATION_UNSUPPORTED.items():
        if key in raw:
            errors.append(InputError(f"{key!r}: {reason}", file=file, path=path + (key,), line=lines(path + (key,)), fix="remove the key"))
    body = {k: v for k, v in raw.items() if k not in DISCRETIZATION_CORE_KEYS and k != "Horizon" and k not in DISCRETIZATION_UNSUPPORTED}
    params = validate_params(cls.Params, body, path=path, file=file, errors=errors, lines=lines)
    influence = raw.get("Influence Function", "One")
    if not isinstance(influence, str):
        errors.append(InputError(f"expected a name or an expression, got {influence!r}", file=file, path=path + ("Influence Function",)))
        influence = "One"
    elif influence not in ("One", "Parabolic Decay", "Gaussian"):
        _check_expression(influence, ("zeta", "horizon"), path + ("Influence Function",), file, errors)
    filters = []
    raw_filters = raw.get("Bond Filters", {})
    if raw_filters and not cls.supports_bond_filters:
        errors.append(InputError(f"bond filters cannot be used with {dtype}", file=file, path=path + ("Bond Filters",), fix="use an Exodus or Text File mesh"))
    elif not isinstance(raw_filters, Mapping):
        errors.append(
            InputError(f"'Bond Filters' must be a list of named filters, got {type(raw_filters).__name__} {raw_filters!r:.60}",
                       file=file, path=path + ("Bond Filters",), fix="give each filter as a named sublist with 'Type: Rectangular_Plane'")
        )
    else:
        for fname, fraw in raw_filters.items():
            fpath = path + ("Bond Filters", fname)
            if not isinstance(fraw, Mapping):
                errors.append(InputError(f"expected a bond filter (Type, ...), got {fraw!r}", file=file, path=fpath))
                continue
            filters.append((fname, dict(fraw), fpath))
    omit = raw.get("Omit Bonds Between Blocks", "None")
    if omit not in ("None", "All"):
        errors.append(InputError(f"unknown value {omit!r}", file=file, path=path + ("Omit Bonds Between Blocks",), fix="use 'None' or 'All'"))
    if omit == "All" and not cls.supports_bond_filters:
        errors.append(InputError(f"'Omit Bonds Between Blocks' cannot be used with {dtype}", file=file, path=path + ("Omit Bonds Between Blocks",)))
    if params is None:
        return None
    return DiscretizationEntry(dtype, cls, params, influence, filters, omit, path)


def _parse_contact(raw, registry, file, errors, lines) -> ContactEntry | None:
    """PERIDIGM_CONTACT.md §1: only the first model acts, for every block; ``Interactions`` are
    read but restrict nothing (both accepted with one warning, as Peridigm runs them)."""
    path = ("Contact",)
    p = validate_params(ContactSectionParams, raw, path=path, file=file, errors=errors, lines=lines)
    if p is None:
        return None
    if not p.models:
        errors.append(InputError("'Models' lists no contact model", file=file, path=path + ("Models",), fix="add a model, e.g. 'Contact Model: Short Range Force'"))
        return None
    if p.interactions is not None:
        pairs = [k for k, v in p.interactions.items() if isinstance(v, Mapping)]
        if not pairs:
            errors.append(
                InputError(
                    "'Interactions' lists no interaction (Peridigm hangs on this)",
                    file=file,
                    path=path + ("Interactions",),
                    fix="add an interaction such as 'General Contact: {Contact Model: ...}', or remove 'Interactions'",
                )
            )
            return None
        log.warning(
            "%s: Contact > Interactions is ignored: as in Peridigm, contact acts between all points of all blocks (%s)",
            file, ", ".join(repr(k) for k in pairs[:3]) + (", ..." if len(pairs) > 3 else ""),
        )
    names = list(p.models)
    if len(names) > 1:
        log.warning("%s: Contact > Models: only the first model, %r, is used (as in Peridigm); %s ignored",
                    file, names[0], ", ".join(repr(n) for n in names[1:]))
    name = names[0]
    mraw = p.models[name]
    mpath = path + ("Models", name)
    if not isinstance(mraw, Mapping) or "Contact Model" not in mraw:
        errors.append(InputError("missing required key 'Contact Model'", file=file, path=mpath, fix="give 'Contact Model: Short Range Force'"))
        return None
    model = mraw["Contact Model"]
    if not isinstance(model, str) or not registry.has("contact", model):
        errors.append(registry.unknown("contact", model, path=mpath + ("Contact Model",), file=file))
        return None
    cls = registry.get("contact", model, path=mpath, file=file)
    body = {k: v for k, v in mraw.items() if k != "Contact Model"}
    params = validate_params(cls.Params, body, path=mpath, file=file, errors=errors, lines=lines)
    if params is None:
        return None
    return ContactEntry(p, ModelEntry(name, model, cls, params, mpath), path)
