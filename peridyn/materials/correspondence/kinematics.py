"""Shape tensor, deformation gradient, velocity gradient and the Flanagan-Taylor rotation update of
Peridigm's classic correspondence family (PERIDIGM_CORRESPONDENCE.md §3, §4), one point per
``prange`` iteration.

Shapes and units of the kernel arguments:

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
FT(L, V_N, R_N, dt). The kernels read other points' data only (gather); they never write to a
neighbour.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...core.influence import omega
from .tensor import flanagan_taylor, inv3, load9, matmul, store9


@njit(cache=True, inline="always")
def _shape_sums(i, offsets, neighbors, x, y, volume, delta, omega_kind, omega_table):
    """(K, N) of point i: the shape tensor and the first term of F, §3 order."""
    K0 = K1 = K2 = K3 = K4 = K5 = K6 = K7 = K8 = 0.0
    N0 = N1 = N2 = N3 = N4 = N5 = N6 = N7 = N8 = 0.0
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    yi0 = y[i, 0]
    yi1 = y[i, 1]
    yi2 = y[i, 2]
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        X0 = x[j, 0] - xi0
        X1 = x[j, 1] - xi1
        X2 = x[j, 2] - xi2
        zeta = math.sqrt(X0 * X0 + X1 * X1 + X2 * X2)
        w = omega(omega_kind, zeta, delta, omega_table, b) * volume[j]
        E0 = y[j, 0] - yi0
        E1 = y[j, 1] - yi1
        E2 = y[j, 2] - yi2
        K0 += (w * X0) * X0
        K1 += (w * X0) * X1
        K2 += (w * X0) * X2
        K3 += (w * X1) * X0
        K4 += (w * X1) * X1
        K5 += (w * X1) * X2
        K6 += (w * X2) * X0
        K7 += (w * X2) * X1
        K8 += (w * X2) * X2
        N0 += (w * E0) * X0
        N1 += (w * E0) * X1
        N2 += (w * E0) * X2
        N3 += (w * E1) * X0
        N4 += (w * E1) * X1
        N5 += (w * E1) * X2
        N6 += (w * E2) * X0
        N7 += (w * E2) * X1
        N8 += (w * E2) * X2
    return (K0, K1, K2, K3, K4, K5, K6, K7, K8), (N0, N1, N2, N3, N4, N5, N6, N7, N8)


@njit(cache=True, inline="always")
def _rate_sums(i, offsets, neighbors, x, v, volume, delta, omega_kind, omega_table):
    """A of point i: the first term of Ḟ, A_ab += (w Δv_a) ξ_b (§4.1, same w as §3)."""
    A0 = A1 = A2 = A3 = A4 = A5 = A6 = A7 = A8 = 0.0
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    vi0 = v[i, 0]
    vi1 = v[i, 1]
    vi2 = v[i, 2]
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        X0 = x[j, 0] - xi0
        X1 = x[j, 1] - xi1
        X2 = x[j, 2] - xi2
        zeta = math.sqrt(X0 * X0 + X1 * X1 + X2 * X2)
        w = omega(omega_kind, zeta, delta, omega_table, b) * volume[j]
        U0 = v[j, 0] - vi0
        U1 = v[j, 1] - vi1
        U2 = v[j, 2] - vi2
        A0 += (w * U0) * X0
        A1 += (w * U0) * X1
        A2 += (w * U0) * X2
        A3 += (w * U1) * X0
        A4 += (w * U1) * X1
        A5 += (w * U1) * X2
        A6 += (w * U2) * X0
        A7 += (w * U2) * X1
        A8 += (w * U2) * X2
    return (A0, A1, A2, A3, A4, A5, A6, A7, A8)


@njit(cache=True)
def _first_flagged(status, start, code):
    """Index (start-based) of the first status entry equal to ``code``, or -1."""
    for k in range(status.shape[0]):
        if status[k] == code:
            return start + k
    return -1


@njit(cache=True, error_model="numpy")
def shape_tensor_point(i, offsets, neighbors, x, y, volume, horizon, omega_kind, omega_table, Kinv, F):
    """K⁻¹ and F of point i into row i of ``Kinv`` and ``F``; returns 1 if K is singular, else 0."""
    Km, Nm = _shape_sums(i, offsets, neighbors, x, y, volume, horizon[i], omega_kind, omega_table)
    Ki, _, ok = inv3(Km)
    store9(Kinv, i, Ki)
    store9(F, i, matmul(Nm, Ki))
    return 0 if ok else 1


@njit(cache=True, error_model="numpy")
def kinematics_point(i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, dt, Kinv, F, V_NP1, R_NP1, d):
    """:func:`kinematics_kernel` for point i; returns 1 if K is singular, 2 if F is, else 0."""
    delta = horizon[i]
    Km, Nm = _shape_sums(i, offsets, neighbors, x, y, volume, delta, omega_kind, omega_table)
    Am = _rate_sums(i, offsets, neighbors, x, v, volume, delta, omega_kind, omega_table)
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
    if not okK:
        return 1
    return 0 if okF else 2


@njit(cache=True, error_model="numpy")
def velocity_gradient_point(i, offsets, neighbors, x, v, volume, horizon, omega_kind, omega_table, Kinv, F, L):
    """L = (A·K⁻¹)·F⁻¹ of point i into row i of ``L``; returns 2 if F is singular, else 0."""
    Am = _rate_sums(i, offsets, neighbors, x, v, volume, horizon[i], omega_kind, omega_table)
    Finv, _, ok = inv3(load9(F, i))
    store9(L, i, matmul(matmul(Am, load9(Kinv, i)), Finv))
    return 0 if ok else 2


# The prange loops only call the per-point functions above: numba's array analysis of parallel
# loops cannot digest the inlined 9-tuples, and a small parallel body also compiles faster.
@njit(cache=True, parallel=True, error_model="numpy")
def shape_tensor_kernel(start, stop, offsets, neighbors, x, y, volume, horizon, omega_kind, omega_table, Kinv, F):
    """K⁻¹ and F = N·K⁻¹ (§3) of the points [start, stop) into ``Kinv`` and ``F`` (n, 9).

    The Deformation_Gradient output path and the material's initialize. Returns the first point
    whose shape tensor is singular (det == 0.0 exactly; its K⁻¹ and F are written as zeros), or -1.
    Peridigm terminates the run in that case ("all nodes must have a minimum of three
    neighbors"); the compute class only warns.
    """
    status = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        status[i - start] = shape_tensor_point(i, offsets, neighbors, x, y, volume, horizon, omega_kind, omega_table, Kinv, F)
    return _first_flagged(status, start, 1)


@njit(cache=True, parallel=True, error_model="numpy")
def kinematics_kernel(
    start, stop, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table,
    V_N, R_N, dt, Kinv, F, V_NP1, R_NP1, d,
):
    """Steps 2-3 of §2.2 for the points [start, stop): K⁻¹, F (§3), Ḟ, F⁻¹, L (§4.1) and the
    Flanagan-Taylor update FT(L, V_N, R_N, dt) (§4.2).

    Inputs: V_N, R_N (n, 9), dt (T). Outputs (n, 9): Kinv, F, V_NP1, R_NP1 and d (the
    Unrotated_Rate_Of_Deformation). Returns ``(first_singular_K, first_singular_F)``: the first
    point whose shape tensor, respectively deformation gradient, has det == 0.0 exactly, or -1.
    A singular K gives K⁻¹ = 0 and F = 0, hence also a singular F. Peridigm terminates the run in
    either case; the caller raises. The outputs of such points are written (zeros where Peridigm
    writes zeros) but are meaningless.
    """
    status = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        status[i - start] = kinematics_point(
            i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, dt, Kinv, F, V_NP1, R_NP1, d
        )
    bad_K = _first_flagged(status, start, 1)
    bad_F = -1
    for k in range(status.shape[0]):
        if status[k] != 0:  # a singular K makes F = 0 singular too
            bad_F = start + k
            break
    return bad_K, bad_F


@njit(cache=True, parallel=True, error_model="numpy")
def velocity_gradient_kernel(start, stop, offsets, neighbors, x, v, volume, horizon, omega_kind, omega_table, Kinv, F, L):
    """L = (A·K⁻¹)·F⁻¹ (§4.1) of the points [start, stop) into ``L`` (n, 9) (1/T), from the given
    K⁻¹ and F (n, 9). Returns the first point with a singular F, or -1 (its L is zero).
    For outputs and tests; :func:`kinematics_kernel` computes the same L internally."""
    status = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        status[i - start] = velocity_gradient_point(i, offsets, neighbors, x, v, volume, horizon, omega_kind, omega_table, Kinv, F, L)
    return _first_flagged(status, start, 2)
