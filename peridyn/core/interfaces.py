"""The interfaces every model implements: built-in or third-party, each is a plugin.

A model is one module: a frozen pydantic ``Params`` (aliases = Peridigm's deck names), pure
``@njit(cache=True)`` kernels at module level, and a small class implementing one of the
interfaces below that declares fields and wires arrays to kernels.

Units are whatever consistent system the deck uses (SI in most decks): lengths L, time T, mass M.
Force density is force per unit volume (M L^-2 T^-2), like Peridigm's ``Force_Density``.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, ClassVar, Literal, Protocol

import numpy as np

from .fields import FieldSpec, FieldStore
from .params import ModelParams
from .traversal import Backend
from .conditions import Condition
from .placement import Placement
from .moduli import ElasticModuli  # the plugin API: materials report their constants with it
from .services import (
    Communicator,
    DataLoader,
    DeckEntry,
    DeckView,
    Halo,
    Influence,
    InterfaceOutput,
    Outputs,
    RunServices,
)
from .solver_section import SolverSection
from .state import Clock, SolverState
from .views import BlockView  # the plugin API: what a model works on
from .contact import (  # the plugin API: the contact contract
    VISIT_FROM_PARTNER,
    VISIT_FROM_POINT,
    ContactModel,
    ContactPairs,
    ContactRun,
    ContactState,
)
from .assembly import TangentTarget

from .bonds import NeighborList
from .discretization import Discretization


# ------------------------------------------------------------------------------------------------
# Materials
# ------------------------------------------------------------------------------------------------
#: how a material hands its bond forces to the engine (``Material.force_state_kind``)
ForceStateKind = Literal["scalar", "vector"]
#: which degrees of freedom the tangent of a point's bonds couples (``Material.tangent_coupling``)
TangentCoupling = Literal["family", "pairs"]
#: the stored-energy form of a material's bonds (``Material.bond_energy``)
BondEnergy = Literal["pair", "lps"]
#: the largest bond strain of the linear (small-strain) laws' range (``Material.small_strain_limit``)
SMALL_STRAIN = 0.1


class Material(ABC):
    """A constitutive model for the bonds of one block.

    Force evaluation (Peridigm's ``evalModel``) calls, for every block in block order, the
    damage model first, then ``precompute`` (per-point quantities such as the dilatation, whose
    fields are exchanged to ghosts afterwards), then either ``force_fused`` (when the block is
    closed and the material provides it) or ``force_state``.

    Central-force (ordinary state-based and bond-based) materials write a scalar force state:
    ``t[b]`` is the magnitude of T_i<xi> for the bond b = i->j of one of the block's points, in
    force per volume squared (M L^-5 T^-2 in SI: N/m^6), acting along the deformed bond
    direction (y_j - y_i)/|y_j - y_i|. The engine then gathers, for every point,
    ``f_i = sum_j (t_ij + t_ji) e_ij V_j`` (DESIGN.md decision 6).

    Capabilities are declared here, as class attributes every material has (the engine,
    solvers, damage models and computes read them plainly, never a model's ``name``):
    ``force_state_kind``, ``tangent_coupling``, ``tangent_perturbs_velocity``,
    ``requires_constant_horizon``, ``multiphysics``, ``flow_bond_field``, ``bond_energy``, ``precompute_fields``,
    ``ghost_inputs``, ``row_local``; and elastic constants come from ``elastic_moduli()``.
    """

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]
    #: "scalar": central force states in a per-bond scalar (see above); "vector": the force
    #: state T_i<xi> of bond b = i->j as a vector ``T[b]`` (shape (num_bonds, 3), M L^-5 T^-2,
    #: non-ordinary models such as correspondence), gathered as f_i = sum_j (T_ij - T_ji) V_j
    force_state_kind: ClassVar[ForceStateKind] = "scalar"
    #: the force state depends on the velocities (rate-form models: hypoelastic and classic
    #: correspondence read a velocity gradient): the finite-difference tangent then moves a
    #: point's velocity by probe/dt together with its position, as Peridigm's probe does, and
    #: stiffness estimates probe at the solver's time step
    tangent_perturbs_velocity: ClassVar[bool] = False
    #: the material needs one horizon per block (a number) when the influence function is not
    #: the constant one; False when it reads the per-point ``Horizon`` field (horizon expressions)
    requires_constant_horizon: ClassVar[bool] = True
    #: the material carries the fluid pressure as a fourth degree of freedom per point
    #: (Peridigm's Multiphysics materials): a deck with top-level ``Multiphysics: 1`` needs such
    #: a material in every block, and such a material needs that flag
    multiphysics: ClassVar[bool] = False
    #: solves the nonlocal diffusion equation (``ImplicitDiffusion``): supplies ``flux_jacobian``
    diffusion: ClassVar[bool] = False
    #: a multiphysics material's bond field (``Relation.BOND``, one of its ``fields()``) where
    #: ``force_state`` writes the fluid flow q_b of each of its bonds b = i->j (pressure per time
    #: per volume squared); the coupled solver gathers it into ``Flux_Density`` as
    #: flow_i = sum_(b out of i) q_b V_j - sum_(b into i) q_b V_src(b). None: no fluid flow
    flow_bond_field: ClassVar[str | None] = None
    #: the energy a bond stores, for models that turn a fracture energy into a bond rule
    #: (``Critical Energy``): "pair" (bond-based micropotential w = c s^2 |xi| / 2 per pair, c =
    #: ``elastic_moduli().micromodulus``), "lps" (the linear peridynamic solid, W = K theta^2 / 2
    #: + (15 mu / 2m) sum_j omega (e^d)^2 V_j with K, mu of ``elastic_moduli()``), or None (other)
    bond_energy: ClassVar[BondEnergy | None] = None
    #: point fields ``precompute`` writes that the other end of a bond reads (under MPI they are
    #: exchanged to ghosts after every precompute; other halo fields once, after initialize)
    precompute_fields: ClassVar[tuple[str, ...]] = ()
    #: point fields other than Coordinates whose ghost values the material reads (e.g. the
    #: velocities of a rate-form material): under MPI they are exchanged before every evaluation
    ghost_inputs: ClassVar[tuple[str, ...]] = ()
    #: True promises that ``precompute``, ``precompute_with_damage`` and ``force_fused`` write
    #: only the view's rows ``start:stop`` and read of other points only their positions and
    #: ``precompute_fields`` (and constant fields), and that ``force_fused`` returns True for
    #: every closed view. The engine may then call them on parts of a block: under MPI, first
    #: on the rows without ghost neighbors while the ghosts' values are on their way.
    row_local: ClassVar[bool] = False
    #: where the model computes: "cpu" (the numba backends), and "gpu" when every method the
    #: explicit step calls (``precompute``, ``force_fused``, ``stored_energy_density``) passes
    #: only its view's arrays to compiled loop laws, so the GPU backend runs them on device
    #: arrays. The GPU step computes forces only through ``force_fused`` (it must be overridden
    #: and return True for every closed view); ``peridyn check --device gpu`` refuses a "gpu"
    #: material without it, and the conformance kit compares its device forces with the CPU's
    devices: ClassVar[frozenset[str]] = frozenset({"cpu"})
    #: the range of the law (peridyn.solvers.monitors.model_range warns once when a run leaves it): the
    #: largest strain of an intact bond, and the largest rotation of a family (radians) for a
    #: law whose strain is not rotation invariant; None: no limit (nonlinear, finite-strain laws)
    small_strain_limit: ClassVar[float | None] = None
    small_rotation_limit: ClassVar[float | None] = None

    def __init__(self, params: ModelParams, *, horizon: float | None, options: dict[str, Any] | None = None) -> None:
        self.params = params
        self.horizon = horizon
        self.options = options or {}

    @property
    @abstractmethod
    def density(self) -> float:
        """Mass density (M L^-3)."""

    @property
    @abstractmethod
    def bulk_modulus(self) -> float:
        """Bulk modulus K used by the critical time step estimate (M L^-1 T^-2)."""

    def elastic_moduli(self) -> ElasticModuli | None:
        """The material's small-strain linear elastic constants (see :class:`ElasticModuli`),
        or None for a material without them (default). Models that need a material's
        stiffness ask this method, never the material's name or attributes."""
        return None

    def fields(self) -> list[FieldSpec]:
        """Fields this material reads and writes beyond the ones every run has."""
        return []

    def output_fields(self) -> list[FieldSpec]:
        """Fields this material can fill for an output (e.g. ``Cauchy_Stress``): allocated only
        when an output asks for one; the material fills those present in ``block.fields``."""
        return []

    def initialize(self, block: BlockView) -> None:
        """Once, in the reference configuration (e.g. weighted volume)."""

    def precompute(self, block: BlockView) -> None:
        """Per-point quantities needed by both ends of a bond (e.g. dilatation)."""

    def adopt_damage(self, damage: "DamageModel") -> bool:
        """Offered the block's damage model at set-up: return True to apply its bond rule in
        ``precompute_with_damage`` (the engine then calls that instead of ``damage.update``
        followed by ``precompute``: one bond loop instead of two). Default: no."""
        return False

    def precompute_with_damage(self, block: BlockView) -> None:
        """The adopted damage model's update and ``precompute`` in one pass (see adopt_damage)."""
        raise NotImplementedError

    @abstractmethod
    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        """Write the force state of every bond of the block's points into ``t`` (shape
        (num_bonds,), see class docstring). Bonds of other blocks' points are not touched."""

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        """Optional fast path for closed blocks: write the internal force density of the
        block's points into ``force_density[start:stop]`` (shape (n_local, 3), M L^-2 T^-2),
        both ends of every bond included. Return False when not provided."""
        return False

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        """Stored elastic energy per unit volume of the block's points into ``out[start:stop]``
        (M L^-1 T^-2). Default: zero (Peridigm's base material)."""
        out[block.start : block.stop] = 0.0

    #: which degrees of freedom the tangent of a point's bonds couples: "family" (every pair of
    #: {i} U N_i, e.g. state-based models) or "pairs" (bonded pairs only, bond-based models)
    tangent_coupling: ClassVar[TangentCoupling] = "family"
    #: ``tangent`` computes the tangent from closed-form derivatives (True) rather than by finite
    #: differences of the force (False, the default: the solvers' or the material's own
    #: compiled probes); the wall-time estimate of implicit solvers reads it (peridyn.engine.limits)
    analytic_tangent: ClassVar[bool] = False

    def finite_difference_probe_length(self) -> float | None:
        """The deck's ``Finite Difference Probe Length`` (L) of this material, which takes
        precedence over the solver's; None (the default) where the material sets none."""
        return None

    def tangent(self, block: BlockView, target: TangentTarget) -> bool:
        """Add the tangent d(f V)/dy (force per length) of the block's points' bonds to the
        implicit solvers' matrix ``target`` (a :class:`peridyn.core.assembly.TangentTarget`:
        3x3-block sparse rows in global-id order, see :mod:`peridyn.materials.tangents`) and
        return True; fields are as left by ``precompute`` at the current configuration.

        Default: return False, and the solver builds the tangent by central finite differences
        of ``force_state`` on one point at a time (Peridigm's finite-difference Jacobian)."""
        return False


# ------------------------------------------------------------------------------------------------
# Damage
# ------------------------------------------------------------------------------------------------
class DamageModel(ABC):
    """Decides bond damage (``Bond_Damage``, a two-step bond field in [0, 1]) and the point
    ``Damage`` output. ``update`` runs inside every force evaluation, before the material, at
    the current configuration."""

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]
    #: dtype of Bond_Damage: "uint8" for models whose bond damage is only ever 0 or 1
    bond_damage_dtype: ClassVar[str] = "float64"
    #: True promises that ``update`` writes only the view's rows and their bonds and reads of
    #: other points only their positions (see Material.row_local)
    row_local: ClassVar[bool] = False
    #: where ``update`` runs: "cpu", and "gpu" when it only passes its view's arrays to compiled
    #: loop laws (see Material.devices); ``initialize`` always runs on the CPU
    devices: ClassVar[frozenset[str]] = frozenset({"cpu"})

    def __init__(self, params: ModelParams, *, options: dict[str, Any] | None = None) -> None:
        self.params = params
        self.options = options or {}

    @property
    def symmetric(self) -> bool:
        """True when both ends of every bond always get the same damage (the decision depends
        only on quantities that are bitwise equal from both ends); materials then need not
        look up the reverse bond."""
        return False

    def fields(self) -> list[FieldSpec]:
        from .fields import Relation, Temporal

        return [
            FieldSpec("Bond_Damage", Relation.BOND, 1, Temporal.TWO_STEP, dtype=self.bond_damage_dtype),
            FieldSpec("Damage", Relation.ELEMENT, 1, Temporal.TWO_STEP),
        ]

    def initialize(self, block: BlockView) -> None:
        """Once, before the first force evaluation."""

    def bind_material(self, material: Material) -> None:
        """Once, at set-up, before ``material.adopt_damage``: the block's material, for models
        whose rule depends on its constants (e.g. an energy criterion). Raise ValueError for a
        material the model cannot work with. Default: nothing."""

    def bond_rule(self) -> tuple | None:
        """A description of the bond-breaking rule that a material may apply inside its own
        bond loop instead of calling ``update`` (e.g. ``("critical stretch", s_c, copy)``),
        or None. Materials that do not know the rule ignore it."""
        return None

    def begin_step(self, block: BlockView, time: float) -> None:
        """At the start of every explicit step (Peridigm re-creates damage models there)."""

    @abstractmethod
    def update(self, block: BlockView) -> None:
        """Update ``Bond_Damage`` (NP1) and ``Damage`` (NP1) of the block's points."""


# ------------------------------------------------------------------------------------------------
# What computes, contact models and solvers see of a simulation
# ------------------------------------------------------------------------------------------------
class ModelBlock(Protocol):
    """A block of the model: a contiguous range ``start:stop`` of owned local points with one
    material (and optionally one damage model) and the view its kernels get."""

    index: int  #: position in ``Simulation.blocks``
    name: str
    block_id: int
    material: Material
    damage: DamageModel | None
    horizon: float | None  #: constant horizon (L), or None when it varies in space
    start: int
    stop: int
    fused: bool  #: a fused kernel covers the block (its group's view: ``fused_view``)
    view: BlockView | None
    fused_view: BlockView | None
    path: tuple[str, ...]  #: the block's deck path (messages)


class Simulation(Protocol):
    """The part of the engine's simulation (:class:`peridyn.engine.simulation.Simulation`) that
    computes, contact models and solvers use. Arrays are over local points: owned points
    ``0:num_owned`` first (grouped by block), then ghosts up to ``num_local`` (MPI only).
    """

    fields: FieldStore  #: every allocated field, by name (``fields["Velocity"]``: (num_local, 3))
    bonds: NeighborList  #: CSR bonds over local points
    blocks: list[ModelBlock]  #: blocks in deck order
    comm: Communicator  #: serial or MPI communicator
    num_owned: int
    num_local: int
    num_global: int  #: points in the whole model
    #: the time the fields are at, read-only: the running section's :class:`~peridyn.core.state.SolverState`
    clock: Clock
    time_step: float  #: the step the running solver takes (T; ``set_time_step``), which rate-form models read
    gid: np.ndarray  #: (num_local,) int64 0-based global ids
    stats: dict[str, Any]  #: run statistics a solver records for the end-of-run summary
    deck: DeckView  #: the validated deck (peridyn.deck.model.Deck)
    discretization: Discretization  #: the points as read, in mothership order
    mothership_of_local: np.ndarray  #: (num_local,) int64 mothership index of each local point
    local_of_mothership: np.ndarray  #: (num_global,) int64 local index, -1 where not on this rank
    node_sets: dict[str, np.ndarray]  #: node set name -> mothership indices
    prescribed_dofs: np.ndarray  #: (num_local, 3) bool, components a kinematic condition sets
    prescribed_points: np.ndarray  #: (k,) int64 sorted local points with a prescribed displacement component
    output_dir: Path  #: folder of the output files
    num_bonds_global: int  #: bonds of the whole model (each direction counted)
    block_index: np.ndarray  #: (num_local,) int64 index into ``blocks`` of each local point
    block_index_mothership: np.ndarray  #: (num_global,) int64 block index of each mothership point
    block_specs: list[tuple[str, int, DeckEntry]]  #: (name, block id, the deck's entry) of each block, in the order of ``blocks``
    generic_blocks: list[ModelBlock]  #: blocks no fused kernel covers (force state + gather)
    horizon_local: np.ndarray  #: (num_local,) horizon of each local point (L)
    influence: Influence  #: the influence function (peridyn.geometry.influence.InfluenceFunction)
    owner: np.ndarray  #: (num_local,) int rank that owns each local point
    halo: Halo  #: ghost exchange (a no-op serially)
    precompute_fields: list[str]  #: fields materials precompute and the halo carries before forces
    conditions: list[Condition]  #: boundary and initial conditions bound to this rank's points, deck order
    kinematic: list[Condition]  #: the conditions applied before a step (prescribed displacement, temperature, pressure)
    force_conditions: list[Condition]  #: the conditions that set External_Force_Density (body forces)
    data_loader: DataLoader | None  #: the deck's data loader (fields read from files over time), None without one
    outputs: Outputs  #: what the outputs compute (peridyn.engine.output.OutputManager); the files are the run's
    contact: ContactRun | None  #: the contact manager, None without a Contact section
    interfaces: InterfaceOutput | None  #: block interfaces (``Construct Interfaces``), None otherwise
    element_nodes: np.ndarray | None  #: (n, 8, 3) hexahedron nodes (``Compute Element-Horizon Intersections``), else None
    write_files: bool  #: False for ``peridyn check``: set-up writes nothing
    timers: dict[str, float]  #: wall-time sections (s) for the summary
    backend: Backend  #: where arrays live and bond loops run
    device: str  #: "cpu", or "gpu" for an explicit run on one GPU (``--device``, the solver's ``Device``)
    device_backend: Backend | None  #: the GPU backend of a "gpu" run (set-up stays on ``backend``), else None
    overlap: bool  #: MPI: rows without ghost neighbors computed while halo messages travel

    #: the attributes code outside the engine may assign (the conformance kit: ``overlap``); solvers
    #: write the members of the state they are handed, every other attribute is the engine's
    writable: ClassVar[frozenset[str]] = frozenset({"overlap"})

    def evaluate_forces(self) -> np.ndarray:
        """Internal force density (num_owned, 3) at the current positions (M L^-2 T^-2)."""

    def apply_kinematic(self, t: float, t_prev: float, state: SolverState | None = None) -> None:
        """Apply prescribed displacements and temperatures for the step t_prev -> t; with
        ``state``, they also fill its increments ``delta_u`` / ``delta_p`` where it has them."""

    def host_placement(self, state: SolverState) -> Placement:
        """The step's arrays where this simulation holds them (host memory), with the
        acceleration and increments of ``state``."""

    def show_clock(self, state: SolverState) -> None:
        """From now on ``clock`` reads ``state`` (the engine calls it as a section starts)."""

    def apply_body_forces(self, t: float) -> None:
        """Set the external force density of the body-force conditions at time t."""

    def critical_time_step(self) -> float:
        """The Silling-Askari stable time step of the model (T)."""

    def advance(self) -> None:
        """End of a step: the NP1 state becomes the N state."""

    def begin_step(self, time: float) -> None:
        """Start of a step at ``time``: models that change with time (damage laws of t) update."""

    def plan_solvers(self) -> list[tuple[Solver, int | None, float | None]]:
        """The deck's solvers in order: (solver, planned steps, estimated seconds)."""

    def set_time_step(self, dt: float) -> None:
        """The step the running solver takes (T); rate-form models read it from their views."""

    def load_data(self, t: float) -> None:
        """Read the data loader's field at time t (no-op without a ``Data Loader``)."""

    def check_steps(self, steps: float, path: tuple[str, ...], section: str) -> float:
        """The step count of a solver section, refused (InputError) when zero or beyond limits."""

    def density_per_point(self) -> np.ndarray:
        """(num_local,) mass density of each point's block (M L^-3)."""

    def critical_time_steps(self) -> np.ndarray:
        """(num_owned,) the Silling-Askari stable step of each point (T)."""

    def kinetic_energy(self) -> float:
        """Kinetic energy of the owned points, summed over ranks."""

    def stored_energy(self) -> float:
        """Stored elastic energy, sum of W_i V_i over owned points and ranks."""

    def unit_slip_hint(self) -> str:
        """The model's likely unit slip as a clause for a message ("" when none; collective)."""

    def require(self, spec: FieldSpec) -> np.ndarray:
        """The field of ``spec``, allocated on first request (late declarations of computes)."""

    def exchange_halo_fields(self) -> None:
        """Refresh the ghost copies of the positions and of every halo field (after fields were
        set outside a step: an initial condition, a restart); a no-op serially."""

    def prescribe(self, points: np.ndarray, component: int) -> None:
        """Mark displacement ``component`` (0, 1, 2) of the local ``points`` as prescribed by a
        kinematic condition (``prescribed_dofs``, ``prescribed_points``)."""


# ------------------------------------------------------------------------------------------------
# Computes (output quantities)
# ------------------------------------------------------------------------------------------------
class Compute(ABC):
    """An output quantity computed from the state, run only when an output writes it.

    ``name`` is the output variable (``Kinetic_Energy``) or, for parametrised classes, the
    ``Compute Class`` value (``Block_Data``) in ``Compute Class Parameters``.
    """

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams] | None] = None

    def __init__(self, params: ModelParams | None = None, *, label: str | None = None) -> None:
        self.params = params
        self.label = label

    @classmethod
    def output_label(cls, params: ModelParams) -> str | None:
        """The name the deck's ``Compute Class Parameters`` entry gives its output (``Output
        Label``); None (the default): the entry's own name."""
        return None

    @abstractmethod
    def outputs(self, sim: "Simulation") -> list[FieldSpec]:
        """The fields this compute fills (they are allocated when the compute is used)."""

    def requires(self, sim: "Simulation") -> list[str]:
        """Output variables this compute reads (their computes run first); none by default."""
        return []

    def initialize(self, sim: "Simulation") -> None:
        """Once, after materials and damage models are initialized."""

    @abstractmethod
    def compute(self, sim: "Simulation") -> None:
        """Fill the output fields from the current (NP1) state."""

    def check(self, sim: "Simulation") -> list[str]:
        """Problems that make this compute meaningless for the model (each becomes one input
        error at set-up, naming its Compute Class Parameters entry); none by default."""
        return []


# ------------------------------------------------------------------------------------------------
# Solvers
# ------------------------------------------------------------------------------------------------
class Solver(ABC):
    """A time integrator or static solver; solver sections run in deck order."""

    name: ClassVar[str]
    #: the section's keys: those of every section, and the method sublist's
    Params: ClassVar[type[SolverSection]]
    #: solves with a tangent (Newton iterations): its wall-time estimate counts the tangent's
    #: entries, not only force evaluations (peridyn.engine.limits)
    implicit: ClassVar[bool] = False

    def __init__(self, params: SolverSection, *, section: str = "Solver") -> None:
        self.params = params
        self.section = section

    @abstractmethod
    def run(self, sim: "Simulation", state: SolverState, run: RunServices) -> SolverState:
        """Advance ``sim`` from the solver's initial to its final time, writing output through
        ``run`` (its files, checkpoints and progress); ``state`` is what the section before left
        (a fresh one for the first section, or a checkpoint's), and what it returns is handed to
        the next section."""

    @classmethod
    def explicit_step(cls, params: SolverSection) -> tuple[float | None, float | None] | None:
        """For an explicit section, whose step is the critical time step estimate unless fixed:
        (the deck's ``Fixed dt`` times its ``Safety Factor``, or None; the ``Safety Factor``, or
        None). None (the default) for a solver that chooses its steps otherwise; the plausibility
        checks of the engine read it."""
        return None

    @classmethod
    def tangent_request(cls, params: SolverSection) -> str | None:
        """The tangent the section asks for: "full" or "block diagonal" when the deck asks for
        one, "default" (full unless another section asks for a block-diagonal one), None (the
        default) for a solver without a tangent."""
        return None

    def planned_time_step(self, sim: "Simulation") -> float | None:
        """The time step (T) the section will take, known before it runs (the API's ``dt``
        before the first step); None for a solver that chooses its steps as it runs."""
        return None

    def planned_steps(self, sim: "Simulation") -> int | None:
        """How many steps (time steps or load steps) ``run`` will take, computed without running
        (None when unknown); ``peridyn check`` reports it and the engine refuses absurd counts."""
        return None
