"""Force densities, Partial_Stress and the hourglass force of Peridigm's classic correspondence
family (PERIDIGM_CORRESPONDENCE.md §6 step 4, §7), in gather form.

Peridigm scatters: the loop over i adds T(i→j) V_j to f_i and subtracts T(i→j) V_i from f_j. Here
each point sums only its own force density, reading the other ends' per-point data, so the
kernels can run under ``prange``. Incoming bonds come from the transposed bond lists of
:meth:`peridyn.core.bonds.NeighborList.transpose` and :meth:`~peridyn.core.bonds.NeighborList.sources`:
``in_offsets`` (m+1,) int64 and ``in_bonds`` (nb,) int32 (positions b of the bonds into point t
are ``in_bonds[in_offsets[t]:in_offsets[t+1]]``), ``sources`` (nb,) int32 (the row of each bond).
Families may be one-sided (j in i's list without i in j's).

Summation order. For point i the terms are added as Peridigm's serial scatter adds them when the
points are visited in index order: first the reactions of the incoming bonds whose source is
below i, then i's own bonds in list order, then the incoming bonds whose source is above i. With
``in_bonds`` in ascending source order within each target (what ``NeighborList.transpose``
gives) and one block, the result is therefore bit-identical to the scatter; otherwise (another
point order, several blocks summed afterwards, other in-bond orders) the summation order differs
from Peridigm's scatter only by round-off.

Loops: Partial_Stress is the loop law ``PARTIAL_STRESS`` (:mod:`peridyn.core.traversal`, a
:class:`PointSum` of 9 components over i's own bonds); the per-bond physics, :func:`force_state_bond`
(ω (A ξ)) and :func:`hourglass_bond` (M η), is shared with the classic material's ``BOND_STATES``
and the Hourglass_Force_Density output. :func:`force_kernel` and :func:`hourglass_kernel` (tests and
reference: the engine gathers the bond states instead) interleave the incoming bonds with i's own
ones and stay hand-written.

Shapes and units: x, y (n, 3) reference and current (NP1) positions (L); volume (n,) (L^3);
horizon (n,) the Horizon field (L); A (n, 9) = P·K⁻¹ per point (from
:func:`.stress.rotate_piola_kernel`, M L^-6 T^-2); F (n, 9); force densities (n, 3) (M L^-2 T^-2,
force per volume). Arrays are read at the source point of every incoming bond: the caller makes
A, F, horizon, x, y and volume valid for ghost points.
"""
from __future__ import annotations

import math

from numba import njit, prange

from ...core.traversal import PointSum
from ...kernels import default_backend
from ...core.influence import omega

PI = 3.141592653589793  # PeridigmNS::value_of_pi


@njit(cache=True, inline="always")
def force_state_bond(A, p, X0, X1, X2, zeta, delta, omega_kind, omega_table, b):
    """T(p→q) = ω(ζ, δ_p) (A_p ξ) of bond b = p→q with ξ = (X0, X1, X2) = x_q - x_p and
    ζ = sqrt((ξx ξx + ξy ξy) + ξz ξz) (force per volume squared): T_a = w ((A_a0 ξx + A_a1 ξy) + A_a2 ξz)."""
    w = omega(omega_kind, zeta, delta, omega_table, b)
    Tx = w * ((A[p, 0] * X0 + A[p, 1] * X1) + A[p, 2] * X2)
    Ty = w * ((A[p, 3] * X0 + A[p, 4] * X1) + A[p, 5] * X2)
    Tz = w * ((A[p, 6] * X0 + A[p, 7] * X1) + A[p, 8] * X2)
    return Tx, Ty, Tz


@njit(cache=True, inline="always")
def _force_state(A, p, x, q, delta, omega_kind, omega_table, b):
    """:func:`force_state_bond` of bond b = p→q with ξ = x_q - x_p: (Tx, Ty, Tz, ξx, ξy, ξz)."""
    X0 = x[q, 0] - x[p, 0]
    X1 = x[q, 1] - x[p, 1]
    X2 = x[q, 2] - x[p, 2]
    zeta = math.sqrt(X0 * X0 + X1 * X1 + X2 * X2)
    Tx, Ty, Tz = force_state_bond(A, p, X0, X1, X2, zeta, delta, omega_kind, omega_table, b)
    return Tx, Ty, Tz, X0, X1, X2


# not a loop law: sums the incoming bonds' reactions before and after i's own bonds (Peridigm's scatter order), not bond order
@njit(cache=True, error_model="numpy")
def force_point(i, offsets, neighbors, in_offsets, in_bonds, sources, x, volume, horizon, omega_kind, omega_table, A, f):
    """f_i = Σ_{j∈N_i} T(i→j) V_j - Σ_{bonds j→i} T(j→i) V_j into row i of f."""
    fx = 0.0
    fy = 0.0
    fz = 0.0
    k = in_offsets[i]
    k_end = in_offsets[i + 1]
    while k < k_end and sources[in_bonds[k]] < i:  # sources below i: visited before i by the scatter
        b = in_bonds[k]
        j = sources[b]
        Tx, Ty, Tz, _, _, _ = _force_state(A, j, x, i, horizon[j], omega_kind, omega_table, b)
        fx -= Tx * volume[j]
        fy -= Ty * volume[j]
        fz -= Tz * volume[j]
        k += 1
    dI = horizon[i]
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        Tx, Ty, Tz, _, _, _ = _force_state(A, i, x, j, dI, omega_kind, omega_table, b)
        fx += Tx * volume[j]
        fy += Ty * volume[j]
        fz += Tz * volume[j]
    while k < k_end:
        b = in_bonds[k]
        j = sources[b]
        Tx, Ty, Tz, _, _, _ = _force_state(A, j, x, i, horizon[j], omega_kind, omega_table, b)
        fx -= Tx * volume[j]
        fy -= Ty * volume[j]
        fz -= Tz * volume[j]
        k += 1
    f[i, 0] = fx
    f[i, 1] = fy
    f[i, 2] = fz


# Loop law (peridyn.core.traversal), run on reference positions: the bond context's (ex, ey, ez) =
# ξ = x_j - x_i and L = ζ = |ξ| (L). args (volume (n,) L^3, horizon (n,) L, omega_kind,
# omega_table (nb,) or empty, A (n, 9) M L^-6 T^-2).
def partial_stress_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(T(i→j) ⊗ ξ) V_j of the bond, row-major (M/(L T^2)): entry ab = (T_a ξ_b) V_j."""
    volume, horizon, omega_kind, omega_table, A = args
    Tx, Ty, Tz = force_state_bond(A, i, ex, ey, ez, L, horizon[i], omega_kind, omega_table, b)
    Vj = volume[j]
    return (
        (Tx * ex) * Vj, (Tx * ey) * Vj, (Tx * ez) * Vj,
        (Ty * ex) * Vj, (Ty * ey) * Vj, (Ty * ez) * Vj,
        (Tz * ex) * Vj, (Tz * ey) * Vj, (Tz * ez) * Vj,
    )


#: Partial_Stress_i = Σ_j (T(i→j) ⊗ ξ) V_j over i's own bonds; out (n, 9)
PARTIAL_STRESS = PointSum(partial_stress_term, width=9, z_from_positions=True)


@njit(cache=True, inline="always", error_model="numpy")
def hourglass_bond(p, q, X0, X1, X2, zeta, y, F, c1, delta):
    """(M η_x, M η_y, M η_z) of bond p→q, §7, with ξ = (X0, X1, X2) = x_q - x_p and ζ = |ξ|:
    c_p = c1/(((δ_p δ_p) δ_p) δ_p), e_a = ((y_p,a + F_a0 ξx) + F_a1 ξy) + F_a2 ξz, h = e - y_q,
    dot = -((h·η)), M = ((1.0 - 0.0) c_p (dot/ζ)) (1.0/|η|) with η = y_q - y_p the current bond."""
    c = c1 / (((delta * delta) * delta) * delta)
    E0 = y[q, 0] - y[p, 0]
    E1 = y[q, 1] - y[p, 1]
    E2 = y[q, 2] - y[p, 2]
    length = math.sqrt(E0 * E0 + E1 * E1 + E2 * E2)
    h0 = (((y[p, 0] + F[p, 0] * X0) + F[p, 1] * X1) + F[p, 2] * X2) - y[q, 0]
    h1 = (((y[p, 1] + F[p, 3] * X0) + F[p, 4] * X1) + F[p, 5] * X2) - y[q, 1]
    h2 = (((y[p, 2] + F[p, 6] * X0) + F[p, 7] * X1) + F[p, 8] * X2) - y[q, 2]
    dot = (h0 * E0 + h1 * E1) + h2 * E2
    dot = dot * -1.0
    M = (c * (dot / zeta)) * (1.0 / length)  # (1.0 - 0.0) c == c exactly
    return M * E0, M * E1, M * E2


@njit(cache=True, inline="always", error_model="numpy")
def _hourglass_bond(p, q, x, y, F, c1, delta):
    """:func:`hourglass_bond` of bond p→q with ξ = x_q - x_p."""
    X0 = x[q, 0] - x[p, 0]
    X1 = x[q, 1] - x[p, 1]
    X2 = x[q, 2] - x[p, 2]
    zeta = math.sqrt(X0 * X0 + X1 * X1 + X2 * X2)
    return hourglass_bond(p, q, X0, X1, X2, zeta, y, F, c1, delta)


# not a loop law: sums the incoming bonds' reactions before and after i's own bonds (Peridigm's scatter order), not bond order
@njit(cache=True, error_model="numpy")
def hourglass_point(i, offsets, neighbors, in_offsets, in_bonds, sources, x, y, volume, horizon, F, c1, hg):
    """hg_i = Σ_out (M(i→j) η_ij) V_j - Σ_in (M(j→i) η_ji) V_j into row i of hg."""
    gx = 0.0
    gy = 0.0
    gz = 0.0
    k = in_offsets[i]
    k_end = in_offsets[i + 1]
    while k < k_end and sources[in_bonds[k]] < i:
        j = sources[in_bonds[k]]
        mx, my, mz = _hourglass_bond(j, i, x, y, F, c1, horizon[j])
        gx -= mx * volume[j]
        gy -= my * volume[j]
        gz -= mz * volume[j]
        k += 1
    dI = horizon[i]
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        mx, my, mz = _hourglass_bond(i, j, x, y, F, c1, dI)
        gx += mx * volume[j]
        gy += my * volume[j]
        gz += mz * volume[j]
    while k < k_end:
        j = sources[in_bonds[k]]
        mx, my, mz = _hourglass_bond(j, i, x, y, F, c1, horizon[j])
        gx -= mx * volume[j]
        gy -= my * volume[j]
        gz -= mz * volume[j]
        k += 1
    hg[i, 0] = gx
    hg[i, 1] = gy
    hg[i, 2] = gz


# not a loop law: runs force_point (incoming bonds interleaved with i's own, Peridigm's scatter order)
@njit(cache=True, parallel=True, error_model="numpy")
def force_kernel(start, stop, offsets, neighbors, in_offsets, in_bonds, sources, x, volume, horizon, omega_kind, omega_table, A, f):
    """Force density (§6 step 4) of the points [start, stop) into f (n, 3), overwritten:

        f_i = Σ_{j∈N_i} T(i→j) V_j - Σ_{bonds j→i} T(j→i) V_j,   T(p→q) = ω(ζ, δ_p) (A_p ξ_pq)

    with T_a = w ((A_a0 ξx + A_a1 ξy) + A_a2 ξz), ζ = |ξ| and the influence function at the bond's
    source point's horizon (``omega_table`` indexed by bond). No bond damage. The hourglass force
    (:func:`hourglass_kernel`) is separate: Peridigm adds it afterwards, f + hg. Summation order:
    see the module docstring (bit-identical to Peridigm's serial scatter for source-sorted
    ``in_bonds`` and one block, otherwise the same to round-off)."""
    for i in prange(start, stop):
        force_point(i, offsets, neighbors, in_offsets, in_bonds, sources, x, volume, horizon, omega_kind, omega_table, A, f)


def partial_stress_kernel(start, stop, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, A, S, *, backend=None):
    """Partial_Stress (§6 step 4) of the points [start, stop) into S (n, 9) (M/(L T^2)):
    S_i[a][b] = Σ_{j∈N_i} (T_a ξ_b) V_j over i's own bonds, in list order from 0.0, with T the
    force state of :func:`force_kernel`. Only i's bonds enter, so the order is Peridigm's.
    ``PARTIAL_STRESS`` on ``backend`` (None: the default) over the reference positions x."""
    kernel = (backend or default_backend()).kernel(PARTIAL_STRESS)
    kernel(start, stop, offsets, neighbors, x, x, (volume, horizon, omega_kind, omega_table, A), S)


# not a loop law: runs hourglass_point (incoming bonds interleaved with i's own, Peridigm's scatter order)
@njit(cache=True, parallel=True, error_model="numpy")
def hourglass_kernel(start, stop, offsets, neighbors, in_offsets, in_bonds, sources, x, y, volume, horizon, F, bulk_modulus, coefficient, hg):
    """Hourglass_Force_Density (§7) of the points [start, stop) into hg (n, 3), overwritten:

        hg_i = Σ_out (M(i→j) η_ij) V_j - Σ_in (M(j→i) η_ji) V_j

    with M of bond p→q from the source point's F_p and δ_p: c1 = ((18.0 C) K)/π, c_p =
    c1/(((δ_p δ_p) δ_p) δ_p), e_a = ((y_p,a + F_a0 ξx) + F_a1 ξy) + F_a2 ξz, h = e - y_q,
    dot = ((h_x η_x + h_y η_y) + h_z η_z)·(-1.0), M = (c_p (dot/ζ)) (1.0/|η|). No influence
    function, no damage. C = ``coefficient`` (Hourglass Coefficient, -), K = ``bulk_modulus``
    (M/(L T^2)). F is read at the source of every incoming bond (ghosts included). Summation
    order: see the module docstring (bit-identical to the scatter for source-sorted ``in_bonds``
    and one block, otherwise the same to round-off)."""
    c1 = ((18.0 * coefficient) * bulk_modulus) / PI
    for i in prange(start, stop):
        hourglass_point(i, offsets, neighbors, in_offsets, in_bonds, sources, x, y, volume, horizon, F, c1, hg)
