"""The Young's modulus of an LPS bar with free faces, from the bond sums of its truncated families:
the reference for the surface layer of ``static-modulus``'s LPS bar, computed here and not fitted
to the model's runs.

The bar is a prism of n x n lattice points across (spacing h, infinite along its axis y), the
LPS solid with influence 1 and full point volumes: a point's family is every lattice vector
|xi| <= delta whose end lies in the section, so the points near the faces have truncated
families (their weighted volume m and dilatation theta are sums over what is there). Under the
axial strain eps, the points move in the section plane by (u_x, u_z) of their own, free (the
lateral contraction, the surface layer's relaxation, the edges); the energy per unit length,
minimised over them, is E_bar A eps^2 / 2, A = (n h)^2. Linearised bond extension
e = (eps xi_y^2 + (u(x') - u(x)) . xi) / |xi|; per point
W = K/2 theta^2 + 15 G / (2 m) sum (e - theta |xi| / 3)^2 V, theta = 3 / m sum |xi| e V, so
W = (K - 5 G / 3) theta^2 / 2 + 15 G / (2 m) sum e^2 V. The section may be n x l (a plate of one
layer: l = 1, every family planar), and the model ``Elastic Bond Based`` (plane stress on one
layer: W = c/4 sum e^2 / |xi| V, c = 12 K / (pi t delta^3), t = h). Units: Pa (moduli in,
modulus out)."""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from ...testing.tensile import lattice_family


def prismatic_bar_modulus(bulk: float, shear: float, ratio: float, n: int, layers: int | None = None,
                          model: str = "Elastic") -> float:
    """E_bar (Pa) of the prism of ``n`` x ``layers`` points across (``layers`` = n by default) at
    horizon / spacing ``ratio`` (moduli ``bulk``, ``shear`` in Pa; ``shear`` unused by the
    bond-based plate): the Schur complement of the energy's Hessian in eps after the in-plane
    displacements (2 n l of them; the section's rigid motions by least squares)."""
    if model not in ("Elastic", "Elastic Bond Based"):
        raise ValueError(f"the prism is written for Elastic and the one-layer Elastic Bond Based plate, not {model!r}")
    l = n if layers is None else int(layers)
    if model == "Elastic Bond Based" and l != 1:
        raise ValueError("the bond-based prism is the plane-stress plate of one layer (layers=1)")
    xi, d = lattice_family(ratio)
    a, c = np.rint(xi[:, 0]).astype(int), np.rint(xi[:, 2]).astype(int)
    unknowns = 1 + 2 * n * l  # eps, then (u_x, u_z) of each point, point p = i l + k
    rows, cols, vals, weight = [], [], [], []
    theta_rows, theta_cols, theta_vals = [], [], []
    bond = 0
    for i in range(n):
        for k in range(l):
            ii, kk = i + a, k + c
            ok = (ii >= 0) & (ii < n) & (kk >= 0) & (kk < l)
            x, dd = xi[ok], d[ok]
            p, q = i * l + k, ii[ok] * l + kk[ok]
            nb = len(dd)
            r = bond + np.arange(nb)
            m = float(np.sum(dd * dd))
            for col, v in ((np.zeros(nb, dtype=int), x[:, 1] ** 2 / dd), (1 + 2 * q, x[:, 0] / dd), (2 + 2 * q, x[:, 2] / dd),
                           (np.full(nb, 1 + 2 * p), -x[:, 0] / dd), (np.full(nb, 2 + 2 * p), -x[:, 2] / dd)):
                rows.append(r), cols.append(col), vals.append(v)
            weight.append(np.full(nb, 15.0 * shear / m) if model == "Elastic" else 6.0 * bulk / (math.pi * ratio**3) / dd)
            theta_rows.append(np.full(nb, p)), theta_cols.append(r), theta_vals.append(3.0 * dd / m)
            bond += nb
    B = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(bond, unknowns))
    H = (B.T @ sp.diags(np.concatenate(weight)) @ B).toarray()
    if model == "Elastic":
        T = sp.csr_matrix((np.concatenate(theta_vals), (np.concatenate(theta_rows), np.concatenate(theta_cols))), shape=(n * l, bond)) @ B
        H += (bulk - 5.0 * shear / 3.0) * (T.T @ T).toarray()
    rest, her = H[1:, 1:], H[0, 1:]
    eff = H[0, 0] - her @ np.linalg.lstsq(rest, her, rcond=None)[0]
    return float(eff / (n * l))


def surface_coefficient(bulk: float, shear: float, ratio: float, n: int, modulus: float) -> float:
    """(E_bar - E_lattice) / modulus times the width in horizons, n / ratio: the bar's surface
    stiffening in the form E_lattice + s modulus delta / width (``modulus``: E0, Pa)."""
    from ...testing.tensile import lattice_youngs_modulus

    return (prismatic_bar_modulus(bulk, shear, ratio, n) - lattice_youngs_modulus(bulk, shear, ratio)) / modulus * n / ratio

