"""Bond loops as data: what a model hands to a backend instead of writing the loop itself.

A model writes the physics of one bond (and, where it needs them, of one point) as small plain
Python functions at module level, and names them in a *loop law*. A :class:`Backend` turns the
law into a kernel over the bonds of a range of points: numba ``prange`` on CPU threads today,
another compiler through the same seam (``peridyn_backends`` hook). The loop, the bond prelude
(``eta = y_j - y_i``, ``|eta|``), the parallel policy and where the arrays live belong to the
backend; the functions never index the CSR structure themselves.

Every per-bond function receives the same bond context::

    fn(i, j, b, ex, ey, ez, L, z, p, args)

``i`` the point whose bonds are traversed (the loop gathers into ``i``), ``j`` the neighbor,
``b`` the bond's row in bond fields, ``(ex, ey, ez) = y_j - y_i`` and ``L = |y_j - y_i|`` (L),
``z = zeta[b]`` the bond's reference length (L), ``p`` what the law's ``point`` function returned
for ``i`` (0.0 without one), and ``args`` the tuple of arrays and numbers the model passed at the
call (its parameters, fields, outputs written at ``[b]`` or ``[i]``). Functions must be plain
numeric code that numba compiles in nopython mode (``math``, arithmetic, indexing ``args``) and
may call ``@njit`` helpers; they are compiled inline into each kernel, so the arithmetic and its
order are exactly what is written. They must not allocate arrays (``np.zeros``, array
expressions): they are compiled without numba's reference counting, which otherwise costs an
atomic increment and decrement of every array they unpack from ``args`` at every bond (measured
2-4x on the elastic and damage loops). A law whose functions allocate says ``allocates=True``.

Kernel signature for every law with a bond loop: ``kernel(start, stop, offsets, neighbors, zeta, y, args, out)``
with ``offsets`` (n+1,) and ``neighbors`` (nb,) int32 the CSR bonds, ``zeta`` (nb,) reference bond
lengths (L), ``y`` (n, >=3) current positions in columns 0-2 (L; packed records may carry more
columns), ``out`` the law's output (below). Points ``[start, stop)`` are computed. A law with
``z_from_positions=True`` takes instead of ``zeta`` the reference positions (n, >=3) (e.g. columns
of the same packed records as ``y``) and computes z = |x_j - x_i| as the engine computes
``Bond_Length`` (the same bits): no bond-length stream to read, no bond-length field to hold. A
law with ``z_from_codes=True`` takes instead the pair ``(codes, table)`` of
``peridyn.kernels.lengths.coded_lengths`` (a uint8 or uint16 code per bond into a table of the
distinct lengths) and reads z = table[codes[b]], the same bits again, from one or two bytes a bond.

The same seam carries the point loops of a time step: :class:`PointUpdate` (a kick, a drift, a
condition's values written on its node set) and :class:`PointReduction` (the step's energy sums),
so a solver writes its step once and every backend runs it where its arrays live.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Callable, ClassVar


@dataclass(frozen=True)
class PointSum:
    """``out[i] = finish(i, acc, p, args)`` with ``acc = sum_b term(bond context)``; ``out`` (n,).

    Without ``finish``, ``out[i] = acc``. ``gate(i, b, p, args) -> bool``, when given, runs
    before a bond's geometry: False skips the bond (e.g. broken for good). With ``width`` w > 1
    the term returns a w-tuple, summed component by component (each in bond order), ``acc`` is
    a w-tuple, ``finish`` returns a w-tuple, and ``out`` is (n, w).

    ``mirror`` (default True): on one thread a closed block may run the law mirrored
    (``peridyn.kernels.mirror``), applying it from both ends of each bond in one visit. That
    needs what a parallel gather already needs (a point's functions touch only its own entries
    and its own bonds' entries) and one thing more: ``point`` must not write (it is then called
    for a neighbor at each of the neighbor's bonds it visits, not once). A law whose point
    function starts a sum in an array says ``mirror=False``.

    ``both(i, j, b, rb, ex, ey, ez, L, z, p, pj, args) -> (t_i, t_j)``, optional (width 1): the
    term of bond ``b`` seen from i and of its reverse ``rb`` seen from j (eta = -(ex, ey, ez),
    ``pj`` = point(j)) in one call, each the bits ``term`` gives, for mirrored kernels to share
    the work of the two ends (e.g. one stretch test); called where both gates pass.
    """

    term: Callable
    point: Callable | None = None
    finish: Callable | None = None
    gate: Callable | None = None
    width: int = 1
    z_from_positions: bool = False
    z_from_codes: bool = False
    allocates: bool = False
    mirror: bool = True
    both: Callable | None = None


@dataclass(frozen=True)
class BondMap:
    """``out[b] = bond(bond context)`` for every bond of the points; ``out`` (nb,), or (nb, w)
    when ``width`` w > 1 and the function returns a w-tuple (a vector force state: w = 3)."""

    bond: Callable
    point: Callable | None = None
    width: int = 1
    z_from_positions: bool = False
    z_from_codes: bool = False
    allocates: bool = False


@dataclass(frozen=True)
class PairForce:
    """Force density of a pair-wise (fused) force: ``out[i] = sum_b (s / L) eta`` with
    ``s = pair(bond context)`` the magnitude of the bond's force on ``i`` from both ends times
    ``V_j`` (M L^-2 T^-2 times L, i.e. ``(t_ij + t_ji) V_j``); bonds with ``L = 0`` exert none.
    ``out`` (n, 3) force per volume. ``gate``, ``mirror`` and ``both`` (here the two ends'
    ``pair`` values) as in :class:`PointSum`.
    """

    pair: Callable
    point: Callable | None = None
    gate: Callable | None = None
    z_from_positions: bool = False
    z_from_codes: bool = False
    allocates: bool = False
    mirror: bool = True
    both: Callable | None = None


@dataclass(frozen=True)
class PointMap:
    """``out[i] = point(i, args)`` for every point, no bonds: per-point coefficients computed
    where the arrays live (``out`` (n,), or (n, w) when ``width`` w > 1 and the function returns
    a w-tuple). The kernel takes the common signature; ``offsets``, ``neighbors``, ``zeta`` and
    ``y`` are not read."""

    point: Callable
    width: int = 1
    z_from_positions: bool = False
    z_from_codes: bool = False
    allocates: bool = False


@dataclass(frozen=True)
class PointUpdate:
    """``update(i, args)`` for every item ``i`` of ``[start, stop)``, no bonds and no return: the
    function writes item ``i``'s own entries of arrays in ``args`` (a solver's kick or drift of
    point i, a condition's value at entry i of its node set). Items are independent, so a
    backend runs them in any order and on any number of threads. Kernel:
    ``kernel(start, stop, args)``."""

    update: Callable
    allocates: bool = False


@dataclass(frozen=True)
class PointReduction:
    """``out[k] = sum_i term(i, args)[k]`` over the items ``i`` of ``[start, stop)`` (``out``
    (width,) on the backend; ``term`` returns a ``width``-tuple, or a number for width 1): the
    per-step sums of a solver (work, kinetic energy, the largest displacement as a sum's
    partner). Each backend sums in a fixed order that does not depend on its thread count (the
    CPU backends in item order on one thread; a GPU in per-block trees), so a run gives the same
    sums every time and the CPU's bits on every CPU thread count. Kernel:
    ``kernel(start, stop, args, out)``.

    ``combine`` "max" or "min" instead of "sum": the largest or smallest term (-inf or inf
    over no items; a NaN term is passed over, so a term that must count says so itself, e.g.
    as inf), the same on every target and thread count since neither depends on order."""

    term: Callable
    width: int = 1
    allocates: bool = False
    combine: str = "sum"


#: laws with a bond loop (``kernel(start, stop, offsets, neighbors, zeta, y, args, out)``)
BondLaw = PointSum | BondMap | PairForce | PointMap
#: laws over items alone (points, or a node set's entries)
ItemLaw = PointUpdate | PointReduction
Law = BondLaw | ItemLaw


class Backend(ABC):
    """Where arrays live and how bond loops run. One per run, chosen with ``peridyn run
    --backend NAME`` (or the environment variable ``PERIDYN_BACKEND``); packages add backends
    through the ``peridyn_backends`` hook.

    ``kernel(law)`` returns the compiled loop of a law (built once per process and law, and
    cached on disk where the backend can); the arrays it is called with come from ``zeros`` or
    ``asarray`` of the same backend.
    """

    name: ClassVar[str]
    #: one line for ``peridyn plugins`` and the run's log
    description: ClassVar[str] = ""
    #: where the arrays live: "cpu" (numpy arrays, which host-side helper kernels may also read)
    #: or "gpu" (device arrays: only this backend's kernels touch them)
    device: ClassVar[str] = "cpu"

    @abstractmethod
    def kernel(self, law: Law) -> Callable[..., Any]:
        """The loop of ``law``: ``kernel(start, stop, offsets, neighbors, zeta, y, args, out)``
        for a law with a bond loop, ``kernel(start, stop, args)`` for a :class:`PointUpdate` and
        ``kernel(start, stop, args, out)`` for a :class:`PointReduction`."""

    def mirror_kernel(self, law: Law) -> Callable[..., Any] | None:
        """The mirrored loop of ``law`` (``peridyn.kernels.mirror``: each bond once, for both
        ends, the gather's bits), ``mirror_kernel(start, stop, offsets, neighbors, zeta, y, args,
        out, upper, cursor)``, or None: this backend has none (the default), or the law none."""
        return None

    def one_thread(self) -> bool:
        """Whether the loops run on one thread, where a closed block's sums may run mirrored
        (False by default: a backend with ``mirror_kernel`` says when)."""
        return False

    def zeros(self, shape: int | tuple[int, ...], dtype: Any = float) -> Any:
        """A zero-filled array where this backend's kernels read it."""
        import numpy as np

        return np.zeros(shape, dtype=dtype)

    def asarray(self, array: Any) -> Any:
        """``array`` where this backend's kernels read it (no copy when it already is)."""
        return array

    def empty(self, dtype: Any = float) -> Any:
        """A zero-length array ("feature off" in a law's ``args``) where the kernels read it."""
        return self.zeros(0, dtype)

    def resident(self, array: Any) -> Any:
        """``array`` (constant data of a model: an influence table, say) where the kernels read
        it, copied there once per backend and array."""
        return self.asarray(array)

    def to_host(self, array: Any) -> Any:
        """A numpy view or copy of a backend array (output, reductions, checks)."""
        return array

    def synchronize(self) -> None:
        """Wait for every loop launched so far (timings; nothing to wait for on the CPU)."""
