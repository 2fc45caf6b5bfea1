"""The contact partner volume (stable step of contact) as a loop law: max(V_i, sum of V_j over the
bonds shorter than the contact radius), summed in bond order."""
import numpy as np
import pytest

from peridyn.contact.bonds import partner_volume_kernel
from peridyn.testing import build_simulation, cube_deck


@pytest.mark.parametrize("rc", [0.5, 1.01, 2.5])
def test_partner_volume_by_bond_loop(rc):
    sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=4))
    nl, zeta = sim.bonds, sim.fields["Bond_Length"]
    vol = sim.fields["Volume"] * (1.0 + np.random.default_rng(2).random(sim.fields["Volume"].shape))
    n = sim.num_owned
    out = np.empty(n)
    partner_volume_kernel(n, nl.offsets, nl.neighbors, zeta, vol, rc, out)
    want = np.empty(n)
    for i in range(n):
        acc = 0.0
        for b in range(nl.offsets[i], nl.offsets[i + 1]):
            if zeta[b] < rc:
                acc += vol[nl.neighbors[b]]
        want[i] = max(vol[i], acc)
    np.testing.assert_array_equal(out, want)
    if rc < 1.0:
        np.testing.assert_array_equal(out, vol[:n])  # no bond that short: the point's own volume
