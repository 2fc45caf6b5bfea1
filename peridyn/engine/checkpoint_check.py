"""Reading a checkpoint file and checking all of it before the model is touched
(``peridyn run --restart``; docs/restart.md).

:func:`read_checkpoint` reads every member of the ``.npz`` (each one's CRC is verified as it is
read) and the metadata's layout; :func:`check_checkpoint` checks every array the restart will
put into the model (present, dtype, shape, finite where a state cannot be otherwise) against the
freshly set-up model. Both raise :class:`InputError` naming the checkpoint file and
``--restart``. Under MPI :func:`agree` makes every rank refuse with the same line before any
rank starts the restore (whose contact rebuild is collective).
"""
from __future__ import annotations

import json
import math
import zipfile
from pathlib import Path
from typing import Any, Callable, TypeVar

import numpy as np
from numba import njit, uint64

from ..core.errors import InputError
from ..core.fields import Relation, Temporal

#: version of the checkpoint layout
FORMAT = 1

T = TypeVar("T")

#: what a refused checkpoint can do instead
FIX = "restart from an earlier checkpoint (the Restart folder keeps the latest 'Keep' of them) or without --restart"
#: fields that hold positions, motion, forces or geometry: never NaN or inf in a state a run reached
FINITE_FIELDS = frozenset({"Model_Coordinates", "Coordinates", "Displacement", "Velocity", "Force_Density", "Contact_Force_Density",
                           "External_Force_Density", "Volume", "Horizon", "Damage", "Bond_Damage", "Temperature"})
#: floating fields that may hold NaN or inf in a state a run reached. None: no model of peridyn
#: keeps one there (a run that reaches NaN is stopped as unstable before a checkpoint is written,
#: and the NaN that peridyn.testing writes into Force_Density and precompute fields is overwritten
#: within the step), so every floating field, constant or two-step, must be finite.
NONFINITE_FIELDS: frozenset[str] = frozenset()
#: arrays of positions, motion and forces whose magnitude is bounded: beyond what a double can
#: square (kinetic energy, distances) a value is a corrupt checkpoint, not a state of a run
BOUNDED_ARRAYS = FINITE_FIELDS | {"acceleration", "contact/s", "contact/y_build"}
#: the largest magnitude taken in a floating array (its square, 1e300, is still a double); the
#: arrays of BOUNDED_ARRAYS are the ones whose size a run's answer reads first
MAGNITUDE_LIMIT = 1e150
#: the energy monitor's accumulators a continued Verlet section reads (numbers; stored0 may be null)
MONITOR_NUMBERS = ("dt", "dt_estimate", "kinetic0", "shadow0", "shadow", "kinetic", "stored", "external", "constraint", "load_shadow",
                   "max_balance", "max_scale", "floor", "released", "resolution", "max_excess")
MONITOR_FLAGS = ("accounting", "has_prescribed", "start_known", "beyond_limit")
_KINDS = {"point", "bond", "global"}
#: the metadata entries every checkpoint of this layout has
REQUIRED = ("deck", "deck_hash", "ranks", "num_global", "num_bonds_global", "section", "step", "sections", "dt", "time", "time_prev",
            "time_step", "nonlinear_iterations", "fields", "two_step", "writers", "monitor", "contact", "final_time", "relations")


def refusal(path: Path, problem: str, fix: str = FIX) -> InputError:
    """The one line of a checkpoint this run cannot continue."""
    return InputError(problem, file=str(path), path=("--restart",), fix=fix)


def agree(comm, action: Callable[[], T]) -> T:
    """Run ``action`` on every rank; an InputError on any rank is raised on every rank (the
    lowest rank's), so that no rank goes on into a collective the others never reach."""
    result, mine = None, None
    try:
        result = action()
    except InputError as exc:
        mine = (exc.message, exc.file, tuple(exc.path or ()), exc.fix)
    if comm.size == 1:
        if mine is not None:
            raise InputError(mine[0], file=mine[1], path=mine[2], fix=mine[3])
        return result  # type: ignore[return-value]
    found = [m for m in comm.allgather(mine) if m is not None]
    if found:
        message, file, where, fix = found[0]
        raise InputError(message, file=file, path=where, fix=fix)
    return result  # type: ignore[return-value]


# -- reading ---------------------------------------------------------------------------------------
def read_meta(path: Path) -> dict | None:
    """The metadata of checkpoint ``path``, or None when it cannot be read (any reason)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"][()]))
        return meta if isinstance(meta, dict) else None
    except Exception:  # a file of any content: unreadable is the only verdict wanted here
        return None


def read_checkpoint(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """(meta, every array) of checkpoint ``path``; InputError for a file that is missing, not an
    ``.npz``, torn, corrupted (a CRC that does not match) or whose metadata is not a checkpoint's."""
    if not path.is_file():
        raise refusal(path, "no checkpoint: no such file" if not path.exists() else "no checkpoint: not a file",
                      "give a checkpoint file, or --restart alone for the latest of this deck")
    try:
        if not zipfile.is_zipfile(path):
            raise ValueError("not an .npz file")
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: np.asarray(data[key]) for key in data.files}  # reading a member checks its CRC
    except Exception as exc:  # zipfile, numpy's header parser and the OS raise a dozen kinds for a damaged file
        reason = str(exc).strip() or type(exc).__name__
        raise refusal(path, f"not a readable peridyn checkpoint, damaged or cut short ({reason[:100]})") from None
    raw = arrays.pop("meta", None)
    if raw is None or raw.shape != () or raw.dtype.kind != "U":
        raise refusal(path, "holds no metadata ('meta'), so it is not a peridyn checkpoint")
    try:
        meta = json.loads(str(raw[()]))
    except ValueError as exc:
        raise refusal(path, f"its metadata is not valid JSON ({str(exc)[:80]})") from None
    if not isinstance(meta, dict):
        raise refusal(path, "its metadata is not a JSON object")
    _check_meta(path, meta)
    gone = [k for k in meta.get("arrays", ()) if k not in arrays]
    if gone:  # deleted or renamed: what the restart would silently compute afresh instead
        raise refusal(path, f"lacks the array {gone[0]!r} it was written with")
    return meta, arrays


def _integer(value: Any, low: int = 0) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= low


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_meta(path: Path, meta: dict) -> None:
    """Every metadata entry a restart reads, with its type and range."""
    def need(ok: bool, what: str) -> None:
        if not ok:
            raise refusal(path, f"its metadata has {what}")

    if meta.get("format") != FORMAT:
        raise refusal(path, f"layout version {meta.get('format')!r}, this peridyn reads {FORMAT}", "continue it with the peridyn that wrote it")
    lacking = [key for key in REQUIRED if key not in meta]
    if lacking:
        raise refusal(path, f"its metadata lacks {', '.join(map(repr, lacking[:3]))}")
    for key in ("deck", "deck_hash"):
        need(isinstance(meta.get(key), str), f"no {key!r} string")
    for key, low in (("ranks", 1), ("num_global", 0), ("num_bonds_global", 0), ("section", 0), ("step", 0), ("sections", 0),
                     ("nonlinear_iterations", 0)):
        need(_integer(meta.get(key), low), f"{key!r} = {meta.get(key)!r}, not an integer of at least {low}")
    need(meta["section"] <= meta["sections"], f"section {meta['section']} of {meta['sections']}")
    for key in ("time", "time_prev", "time_step"):
        need(_number(meta.get(key)), f"{key!r} = {meta.get(key)!r}, not a finite number")
    need(meta["time_step"] >= 0.0, f"a negative time step {meta['time_step']!r}")
    for key in ("dt", "final_time"):
        need(meta.get(key) is None or _number(meta[key]), f"{key!r} = {meta.get(key)!r}, neither null nor a finite number")
    need(meta["dt"] is None or meta["dt"] > 0.0, f"a time step 'dt' = {meta['dt']!r} that is not positive")
    need(meta["dt"] is not None or meta["step"] == 0, "no time step 'dt' for the step it was written after")
    fields = meta.get("fields")
    need(isinstance(fields, dict) and all(isinstance(k, str) and v in _KINDS for k, v in fields.items()),
         "no 'fields' table of point, bond and global fields")
    two = meta.get("two_step")
    need(isinstance(two, list) and all(isinstance(k, str) and k in fields for k in two), "a 'two_step' list that is not among its fields")
    relations = meta["relations"]
    need(isinstance(relations, dict) and all(isinstance(v, str) for v in relations.values()), "a 'relations' entry that is not a table")
    writers = meta.get("writers")
    need(isinstance(writers, list) and all(isinstance(w, dict) and isinstance(w.get("section"), str) and _integer(w.get("count"))
                                           and _integer(w.get("frames")) and w["frames"] <= w["count"] for w in writers),
         "a 'writers' list whose entries are not (section, count, frames)")
    contact = meta.get("contact")
    need(contact is None or (isinstance(contact, dict) and _integer(contact.get("capacity")) and isinstance(contact.get("stats"), dict)),
         "a 'contact' entry that is neither null nor (capacity, stats)")
    monitor = meta.get("monitor")
    need(monitor is None or isinstance(monitor, dict), "a 'monitor' entry that is neither null nor a table")
    listed = meta.get("arrays", [])
    need(isinstance(listed, list) and all(isinstance(k, str) for k in listed), "an 'arrays' entry that is not a list of names")
    if meta["step"] > 0:  # a Verlet section continued after this step reads the energy monitor
        need(isinstance(monitor, dict), "no energy monitor for the step it was written after")
        for key in MONITOR_NUMBERS:
            need(_number(monitor.get(key)), f"the energy monitor's {key!r} = {monitor.get(key)!r}, not a finite number")
        start = monitor.get("start_energy", "missing")
        need(start is None or _number(start), f"the energy monitor's 'start_energy' = {start!r}, not a finite number or null")
        need(monitor.get("stored0") is None or _number(monitor["stored0"]), "an energy monitor 'stored0' that is not a number")
        for key in MONITOR_FLAGS:
            need(isinstance(monitor.get(key), bool), f"the energy monitor's {key!r} = {monitor.get(key)!r}, not true or false")
        need(_integer(monitor.get("window"), 1), "an energy monitor 'window' that is not a positive integer")
        need(monitor.get("_pending") is None, "an energy monitor with a step half accounted")
        history, fast = monitor.get("history"), monitor.get("fast")
        need(isinstance(history, list) and all(isinstance(h, list) and len(h) == 2 and all(map(_number, h)) for h in history),
             "an energy monitor 'history' that is not pairs of finite numbers")
        need(isinstance(fast, list) and all(map(_number, fast)), "an energy monitor 'fast' list that is not finite numbers")


# -- checking against the model --------------------------------------------------------------------
def check_checkpoint(sim, writers: list, path: Path, meta: dict, arrays: dict[str, np.ndarray], carry: bool,
                     digest: str | None = None) -> None:
    """Every array the restart will read from ``arrays`` into ``sim``: present, of this model's
    dtype and shape, finite where a state cannot be otherwise; the outputs it appends to there
    (``writers``: the run's output files).
    ``carry``: another deck's final state, whose fields this model shares are taken.
    ``digest``: this model's :func:`bond_digest` (computed by every rank before), for a
    checkpoint that holds one instead of bond keys."""
    comm = sim.comm
    n, total, bonds = sim.num_owned, sim.num_global, sim.num_bonds_global
    ghosts = sim.num_local - n
    same = meta["ranks"] == comm.size and comm.size > 1 and not carry
    store = sim.fields

    def array(key: str, shape: tuple, dtype: np.dtype, finite: bool, exact: bool = True) -> np.ndarray:
        """``exact``: this model's dtype and shape; else (another deck's state) numbers with this model's rows."""
        a = arrays.get(key)
        if a is None:
            raise refusal(path, f"lacks the array {key!r}")
        if a.dtype.kind not in "biuf" or (exact and a.dtype != dtype):
            raise refusal(path, f"{key} is {a.dtype}, this model's is {dtype}")
        if a.shape != shape if exact or not shape else a.shape[:1] != shape[:1]:
            raise refusal(path, f"{key} has shape {a.shape}, this model's is {shape}")
        if finite and a.dtype.kind == "f" and not np.isfinite(a).all():
            raise refusal(path, f"{key} holds NaN or inf, which no state of a run has")
        if a.dtype.kind == "f" and a.size:  # every floating array: no field of a run holds 1e150 in any unit system
            largest = float(np.nanmax(np.abs(a)))
            if largest > MAGNITUDE_LIMIT:
                raise refusal(path, f"{key} holds a value of magnitude {largest:.3g}, beyond the {MAGNITUDE_LIMIT:g} of any state "
                                    "of a run (a corrupt checkpoint)")
        return a

    def point(key: str, tail: tuple, dtype: np.dtype, finite: bool, exact: bool = True) -> None:
        array(key, (total,) + tail, dtype, finite, exact)
        if same:
            array(f"r{comm.rank}/{key}", (ghosts,) + tail, dtype, finite, exact)

    declared = {name: store.specs[name] for name in store.names() if name not in store.derived}
    kinds = {name: "bond" if s.relation is Relation.BOND else "global" if s.relation is Relation.GLOBAL else "point"
             for name, s in declared.items()}
    if not carry:
        lacking = sorted(set(declared) - set(meta["fields"]))
        if lacking:
            raise refusal(path, f"lacks fields this model declares ({', '.join(lacking[:4])})", "restart with the deck that wrote it")
    bond_fields = False
    for name, kind in meta["fields"].items():
        if name not in declared:
            continue  # refused by Checkpoints._check unless carried (another deck's field, not taken)
        spec = declared[name]
        if carry and (kind != kinds[name] or meta.get("relations", {}).get(name, spec.relation.name) != spec.relation.name):
            continue
        if kind != kinds[name]:
            raise refusal(path, f"holds {name} as a {kind} field, this model's is a {kinds[name]} field")
        two_step = spec.temporal is Temporal.TWO_STEP
        if not carry and two_step != (name in meta["two_step"]):
            raise refusal(path, f"holds {name} with {'one step' if two_step else 'two steps'}, this model with {'two' if two_step else 'one'}")
        for which in ["np1"] + (["n"] if two_step and name in meta["two_step"] else []):
            key = f"{which}/{name}"
            target = store[name] if which == "np1" else store.n(name)
            tail, finite = tuple(target.shape[1:]), name not in NONFINITE_FIELDS
            if carry and key in arrays and arrays[key].shape[1:] != tail:
                continue  # another deck's field of another length: not taken
            if kind == "point":
                point(key, tail, target.dtype, finite, exact=not carry)
            elif kind == "global":
                array(key, tuple(target.shape), target.dtype, finite, exact=not carry or target.ndim == 0)
            else:
                bond_fields = True
                array(key, (bonds,) + tail, target.dtype, finite, exact=not carry)
    if "bond_digest" in meta and not bond_fields:
        if not carry and meta["bond_digest"] != digest:
            raise refusal(path, "its bonds are not this model's", "restart with the deck and mesh that wrote it")
    elif bond_fields or not carry:
        _check_bond_keys(sim, path, array("bond_keys", (bonds,), np.dtype(np.int64), False))
    if "acceleration" in arrays or (meta["step"] > 0 and not carry):
        point("acceleration", (3,), np.dtype(np.float64), True)
    if carry:
        return
    c = sim.contact
    if c is not None and meta["contact"] is not None:
        array("contact/s", (total,) + tuple(c.s.shape[1:]), np.dtype(np.float64), True)
        if "contact/y_build" in arrays:
            array("contact/y_build", (total, 3), np.dtype(np.float64), True)
    check_outputs(sim, writers, path, meta)


def _check_bond_keys(sim, path: Path, saved: np.ndarray) -> None:
    """The checkpoint's bond keys: sorted, distinct, of this model's points, and every bond of
    this rank among them."""
    total = np.int64(sim.num_global)
    if saved.size and (saved[0] < 0 or saved[-1] >= total * total or (saved.size > 1 and not (np.diff(saved) > 0).all())):
        raise refusal(path, "its bond keys are not sorted keys of this model's points")
    keys = bond_keys(sim)
    idx = np.searchsorted(saved, keys)
    if not (idx < saved.size).all() or not np.array_equal(saved[idx], keys):
        raise refusal(path, "its bonds are not this model's", "restart with the deck and mesh that wrote it")


def check_outputs(sim, writers: list, path: Path, meta: dict) -> None:
    """The output files a restart appends to (``writers``): the deck's sections in the
    checkpoint's order and, on rank 0, a file holding the frames written before the checkpoint."""
    if len(meta["writers"]) != len(writers):
        raise refusal(path, "its outputs differ from this deck's", "restart with the deck that wrote it")
    for w, state in zip(writers, meta["writers"]):
        if state["section"] != w.entry.section:
            raise refusal(path, f"its output {state['section']!r} is not this deck's {w.entry.section!r}", "restart with the deck that wrote it")
        if not state["frames"] or not sim.comm.is_root:
            continue
        from .output_pieces import continue_pieces

        continue_pieces(w)  # the pieces a stopped run on several ranks left, joined first
        partial, final = w.partial_path, w.path
        source = partial if partial.is_file() else final if final.is_file() else None
        if source is None:
            raise refusal(path, f"neither {partial.name} nor {final.name} is in {str(partial.parent)!r}: the {state['frames']} frame(s) "
                                "written before the checkpoint are gone", "give the --output-dir of the run that wrote the checkpoint")
        problem = _output_mismatch(w, source, state["frames"], sim.num_global)
        if problem:
            raise refusal(path, f"cannot continue {source.name}: {problem}", "give the --output-dir of the run that wrote the checkpoint")


def _output_mismatch(w, source: Path, frames: int, num_nodes: int) -> str | None:
    """Why the restart cannot append to ``source`` (read only; the writer checks the same when
    it opens the file), or None."""
    import netCDF4

    try:
        with netCDF4.Dataset(str(source)) as ds:
            held = len(ds.dimensions["time_step"])
            if held < frames:
                return f"it holds {held} frame(s), fewer than the {frames} the checkpoint wrote"
            for kind, var, declared in (("nodal", "name_nod_var", w.nodal), ("element", "name_elem_var", w.element),
                                        ("global", "name_glo_var", w.glob)):
                found = [bytes(row).rstrip(b"\0").decode("ascii", "replace") for row in ds[var][:]] if var in ds.variables else []
                if found != [c for _, c, _ in declared]:
                    return f"it holds the {kind} variables {found[:4]}, this deck writes {[c for _, c, _ in declared][:4]}"
            if not w.global_only and int(ds.dimensions["num_nodes"].size) != num_nodes:
                return f"it has {ds.dimensions['num_nodes'].size} nodes, this model {num_nodes}"
    except Exception as exc:  # not netCDF, torn, another program's file
        return f"not a readable Exodus file ({str(exc)[:80] or type(exc).__name__})"
    return None


@njit(cache=True)
def _digest_kernel(n, offsets, neighbors, mothership, total):
    """sum over the bonds of rows 0..n of splitmix64(i * total + j) (mothership indices), mod 2^64."""
    acc = uint64(0)
    for i in range(n):
        row = uint64(mothership[i]) * uint64(total)
        for b in range(offsets[i], offsets[i + 1]):
            z = row + uint64(mothership[neighbors[b]]) + uint64(0x9E3779B97F4A7C15)
            z = (z ^ (z >> uint64(30))) * uint64(0xBF58476D1CE4E5B9)
            z = (z ^ (z >> uint64(27))) * uint64(0x94D049BB133111EB)
            acc += z ^ (z >> uint64(31))
    return acc


def bond_digest(sim) -> str:
    """An order-free digest of the model's bonds, for a checkpoint without bond fields (which
    then needs no bond keys): the sum mod 2^64 of a mixed (splitmix64) hash of every bond's key
    i * num_global + j over every rank, as 16 hex digits; one pass, nothing allocated per bond.
    Collective."""
    nl = sim.bonds
    local = int(_digest_kernel(sim.num_owned, nl.offsets, nl.neighbors, np.ascontiguousarray(sim.mothership_of_local, dtype=np.int64),
                               sim.num_global))
    total = sum(sim.comm.allgather(local)) if sim.comm.size > 1 else local
    return f"{total % (1 << 64):016x}"


def bond_keys(sim) -> np.ndarray:
    """(num_bonds,) int64 key i * num_global + j of every bond of this rank, i and j mothership
    indices (ghosts own no bonds)."""
    nl = sim.bonds
    n = sim.num_owned
    counts = np.diff(nl.offsets[: n + 1])
    rows = np.repeat(np.arange(n, dtype=np.int64), counts)
    m = sim.mothership_of_local.astype(np.int64)
    return m[rows] * np.int64(sim.num_global) + m[nl.neighbors[: nl.offsets[n]].astype(np.int64)]
