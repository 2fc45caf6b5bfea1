"""Shape tensor, deformation gradient, velocity gradient and the Flanagan-Taylor rotation update of
Peridigm's classic correspondence family (PERIDIGM_CORRESPONDENCE.md §3, §4), as loop laws
(:mod:`peridyn.core.traversal`) compiled by the run's backend.

Shapes and units of the arguments:

* ``offsets`` (n+1,) int64 and ``neighbors`` (nb,) int32: the CSR bond lists (i's bonds, list order);
* ``x`` (n, 3) reference positions (Model_Coordinates, L); ``y`` (n, 3) current positions
  (NP1 Coordinates, L); ``v`` (n, 3) NP1 velocities (L/T); ``volume`` (n,) (L^3);
* ``horizon`` (n,) the per-point Horizon field δ_i (L): the influence function of bond i->j is
  ω(|ξ|, δ_i) with i's own horizon; ``omega_kind``/``omega_table`` as in
  :func:`peridyn.core.influence.omega` (an empty table unless the deck uses an expression);
* tensors (n, 9), flat row-major: Shape_Tensor_Inverse K⁻¹ (L^-5), Deformation_Gradient F (-),
  Left_Stretch_Tensor V (-), Rotation_Tensor R (-), Unrotated_Rate_Of_Deformation d (1/T).

Per bond, with ξ = x_j - x_i, η = y_j - y_i, Δv = v_j - v_i, ζ = sqrt((ξx ξx + ξy ξy) + ξz ξz) and
w = ((1.0 - 0.0) ω(ζ, δ_i)) V_j (bond damage is ignored by this family; (1.0 - 0.0) ω == ω
exactly): K_ab += (w ξ_a) ξ_b, N_ab += (w η_a) ξ_b, A_ab += (w Δv_a) ξ_b, nine accumulators each,
from 0.0 in list order. Then K⁻¹ = Inv3(K), F = N·K⁻¹, Ḟ = A·K⁻¹, F⁻¹ = Inv3(F), L = Ḟ·F⁻¹ and
FT(L, V_N, R_N, dt). The loops read other points' data only (gather); they never write to a
neighbour.

Loop laws, all run on reference positions (the bond context's (ex, ey, ez) = ξ, L = ζ), each a
:class:`PointSum` whose components are the accumulators above, each summed in bond order, and whose
``finish`` does the point's algebra and writes its rows: ``SHAPE_TENSOR`` (width 18: K, N),
``KINEMATICS`` (width 27: K, N, A) and ``VELOCITY_GRADIENT`` (width 9: A). :func:`shape_tensor_kernel`,
:func:`kinematics_kernel` and :func:`velocity_gradient_kernel` run them on a backend and report the
singular points.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ...core.influence import omega
from ...core.traversal import PointSum
from ...kernels import default_backend
from .tensor import flanagan_taylor, inv3, load9, matmul, store9

EMPTY3 = np.zeros((0, 3))
EMPTY9 = np.zeros((0, 9))


# Loop laws (peridyn.core.traversal), run on reference positions: the bond context's
# (ex, ey, ez) = ξ = x_j - x_i and L = ζ = |ξ| (L). args, the same tuple for the three laws:
# (y (n, 3) L, v (n, 3) L/T, volume (n,) L^3, horizon (n,) L, omega_kind, omega_table (nb,) or
# empty, V_N (n, 9), R_N (n, 9), dt T, Kinv (n, 9) L^-5, F (n, 9), V_NP1 (n, 9), R_NP1 (n, 9),
# d (n, 9) 1/T, L (n, 9) 1/T, status (n,) int8); arrays a law does not read may be empty, the
# outputs are written at [i] by the laws' finish (through the helpers below).
def _weight(i, j, b, zeta, args):
    """w = ω(ζ, δ_i) V_j of bond b = i→j (L^3)."""
    return omega(args[4], zeta, args[3][i], args[5], b) * args[2][j]


def _outer(w, a0, a1, a2, X0, X1, X2):
    """(w a) ⊗ ξ as 9 numbers, row-major: entry ab = (w a_a) ξ_b."""
    return (
        (w * a0) * X0, (w * a0) * X1, (w * a0) * X2,
        (w * a1) * X0, (w * a1) * X1, (w * a1) * X2,
        (w * a2) * X0, (w * a2) * X1, (w * a2) * X2,
    )


def shape_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's terms of K (w ξ ⊗ ξ, L^5) and N (w η ⊗ ξ, L^5): 18 numbers."""
    y = args[0]
    w = _weight(i, j, b, L, args)
    return _outer(w, ex, ey, ez, ex, ey, ez) + _outer(w, y[j, 0] - y[i, 0], y[j, 1] - y[i, 1], y[j, 2] - y[i, 2], ex, ey, ez)


def rate_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's term of A (w Δv ⊗ ξ, L^5/T): 9 numbers."""
    v = args[1]
    w = _weight(i, j, b, L, args)
    return _outer(w, v[j, 0] - v[i, 0], v[j, 1] - v[i, 1], v[j, 2] - v[i, 2], ex, ey, ez)


def kinematics_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's terms of K, N and A: 27 numbers."""
    y, v = args[0], args[1]
    w = _weight(i, j, b, L, args)
    return (
        _outer(w, ex, ey, ez, ex, ey, ez)
        + _outer(w, y[j, 0] - y[i, 0], y[j, 1] - y[i, 1], y[j, 2] - y[i, 2], ex, ey, ez)
        + _outer(w, v[j, 0] - v[i, 0], v[j, 1] - v[i, 1], v[j, 2] - v[i, 2], ex, ey, ez)
    )


def _part(acc, k):
    """Components k..k+8 of a summed tuple: one tensor, row-major."""
    return (acc[k], acc[k + 1], acc[k + 2], acc[k + 3], acc[k + 4], acc[k + 5], acc[k + 6], acc[k + 7], acc[k + 8])


@njit(cache=True, error_model="numpy")
def shape_tensor_rows(i, Km, Nm, Kinv, F, status):
    """K⁻¹ = Inv3(K) and F = N·K⁻¹ into Kinv[i] and F[i]; status[i] = 1 where K is singular
    (K⁻¹ and F written as zeros), else 0."""
    Ki, _, ok = inv3(Km)
    store9(Kinv, i, Ki)
    store9(F, i, matmul(Nm, Ki))
    status[i] = 0 if ok else 1


@njit(cache=True, error_model="numpy")
def kinematics_rows(i, Km, Nm, Am, V_N, R_N, dt, Kinv, F, V_NP1, R_NP1, d, status):
    """K⁻¹, F = N·K⁻¹, Ḟ = A·K⁻¹, F⁻¹, L = Ḟ·F⁻¹ and FT(L, V_N, R_N, dt); writes Kinv, F, V_NP1,
    R_NP1 and d at [i]; status[i] = 1 where K is singular, 2 where F is, else 0."""
    Ki, _, okK = inv3(Km)
    Fi = matmul(Nm, Ki)
    Fdot = matmul(Am, Ki)
    Finv, _, okF = inv3(Fi)
    Li = matmul(Fdot, Finv)
    V1, R1, di = flanagan_taylor(Li, load9(V_N, i), load9(R_N, i), dt)
    store9(Kinv, i, Ki)
    store9(F, i, Fi)
    store9(V_NP1, i, V1)
    store9(R_NP1, i, R1)
    store9(d, i, di)
    status[i] = 1 if not okK else (0 if okF else 2)


@njit(cache=True, error_model="numpy")
def velocity_gradient_row(i, Am, Kinv, F, L, status):
    """L = (A·K⁻¹)·F⁻¹ from the given Kinv[i], F[i] into L[i]; status[i] = 2 where F is
    singular (L written as zeros), else 0."""
    Finv, _, ok = inv3(load9(F, i))
    store9(L, i, matmul(matmul(Am, load9(Kinv, i)), Finv))
    status[i] = 0 if ok else 2


def shape_tensor_finish(i, acc, p, args):
    """acc = (K, N): K⁻¹ and F written (:func:`shape_tensor_rows`); returns acc."""
    shape_tensor_rows(i, _part(acc, 0), _part(acc, 9), args[9], args[10], args[15])
    return acc


def kinematics_finish(i, acc, p, args):
    """acc = (K, N, A): the point's kinematics written (:func:`kinematics_rows`); returns acc."""
    kinematics_rows(i, _part(acc, 0), _part(acc, 9), _part(acc, 18), args[6], args[7], args[8], args[9], args[10], args[11], args[12],
                    args[13], args[15])
    return acc


def velocity_gradient_finish(i, acc, p, args):
    """acc = A: L written (:func:`velocity_gradient_row`); returns acc."""
    velocity_gradient_row(i, acc, args[9], args[10], args[14], args[15])
    return acc


SHAPE_TENSOR = PointSum(shape_term, finish=shape_tensor_finish, width=18, z_from_positions=True)
KINEMATICS = PointSum(kinematics_term, finish=kinematics_finish, width=27, z_from_positions=True)
VELOCITY_GRADIENT = PointSum(rate_term, finish=velocity_gradient_finish, width=9, z_from_positions=True)


def _run(law, backend, start, stop, offsets, neighbors, x, args):
    """Run ``law`` over the points [start, stop) on ``backend`` (None: the default), on the
    reference positions x; the sums go to a scratch (n, width) array."""
    kernel = (backend or default_backend()).kernel(law)
    kernel(start, stop, offsets, neighbors, x, x, args, np.empty((x.shape[0], law.width)))


def _first(flagged, start):
    """start + the index of the first True of ``flagged``, or -1."""
    hits = np.flatnonzero(flagged)
    return start + int(hits[0]) if hits.size else -1


def shape_tensor_kernel(start, stop, offsets, neighbors, x, y, volume, horizon, omega_kind, omega_table, Kinv, F, *, backend=None):
    """K⁻¹ and F = N·K⁻¹ (§3) of the points [start, stop) into ``Kinv`` and ``F`` (n, 9)
    (``SHAPE_TENSOR`` on ``backend``, None: the default).

    The Deformation_Gradient output path and the material's initialize. Returns the first point
    whose shape tensor is singular (det == 0.0 exactly; its K⁻¹ and F are written as zeros), or -1.
    Peridigm terminates the run in that case ("all nodes must have a minimum of three
    neighbors"); the compute class only warns.
    """
    status = np.zeros(x.shape[0], dtype=np.int8)
    args = (y, EMPTY3, volume, horizon, omega_kind, omega_table, EMPTY9, EMPTY9, 0.0, Kinv, F, EMPTY9, EMPTY9, EMPTY9, EMPTY9, status)
    _run(SHAPE_TENSOR, backend, start, stop, offsets, neighbors, x, args)
    return _first(status[start:stop] == 1, start)


def kinematics_kernel(
    start, stop, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table,
    V_N, R_N, dt, Kinv, F, V_NP1, R_NP1, d, *, backend=None,
):
    """Steps 2-3 of §2.2 for the points [start, stop): K⁻¹, F (§3), Ḟ, F⁻¹, L (§4.1) and the
    Flanagan-Taylor update FT(L, V_N, R_N, dt) (§4.2), by ``KINEMATICS`` on ``backend``.

    Inputs: V_N, R_N (n, 9), dt (T). Outputs (n, 9): Kinv, F, V_NP1, R_NP1 and d (the
    Unrotated_Rate_Of_Deformation). Returns ``(first_singular_K, first_singular_F)``: the first
    point whose shape tensor, respectively deformation gradient, has det == 0.0 exactly, or -1.
    A singular K gives K⁻¹ = 0 and F = 0, hence also a singular F. Peridigm terminates the run in
    either case; the caller raises. The outputs of such points are written (zeros where Peridigm
    writes zeros) but are meaningless.
    """
    status = np.zeros(x.shape[0], dtype=np.int8)
    args = (y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, float(dt), Kinv, F, V_NP1, R_NP1, d, EMPTY9, status)
    _run(KINEMATICS, backend, start, stop, offsets, neighbors, x, args)
    flags = status[start:stop]
    return _first(flags == 1, start), _first(flags != 0, start)  # a singular K makes F = 0 singular too


def velocity_gradient_kernel(start, stop, offsets, neighbors, x, v, volume, horizon, omega_kind, omega_table, Kinv, F, L, *, backend=None):
    """L = (A·K⁻¹)·F⁻¹ (§4.1) of the points [start, stop) into ``L`` (n, 9) (1/T), from the given
    K⁻¹ and F (n, 9), by ``VELOCITY_GRADIENT`` on ``backend``. Returns the first point with a
    singular F, or -1 (its L is zero). For outputs and tests; :func:`kinematics_kernel` computes
    the same L internally."""
    status = np.zeros(x.shape[0], dtype=np.int8)
    args = (EMPTY3, v, volume, horizon, omega_kind, omega_table, EMPTY9, EMPTY9, 0.0, Kinv, F, EMPTY9, EMPTY9, EMPTY9, L, status)
    _run(VELOCITY_GRADIENT, backend, start, stop, offsets, neighbors, x, args)
    return _first(status[start:stop] == 2, start)
