"""Verification of Elastic Plastic and Elastic Plastic Hardening against closed forms.

Set-up: a 7^3 lattice (spacing h, horizon 3.015 h); every point follows a prescribed homogeneous
deformation y = F x, and only the centre point, whose family is complete, is measured. Its stress
is the partial stress sigma = sum_j t_j (eta_j / |eta_j|) (x) xi_j V_j (for a homogeneous
deformation the peridynamic stress). Uniaxial stress: for each axial strain the lateral strain is
solved so that sigma_yy = sigma_zz = 0 (Newton), from the converged state of the previous step,
which then becomes the N state (as a quasi-static load step).

Closed forms. For a small deviatoric strain A (traceless) on a family with omega = 1, e^d_j =
zeta_j M_j.A.M_j and, on a cubic lattice, with the moments P = sum zeta^2 M_x^4 V and
Q = sum zeta^2 M_x^2 M_y^2 V, m = sum zeta^2 V:

* theta = tr(eps) exactly, so the mean stress is K tr(eps);
* for a diagonal deviator (uniaxial loading along x): ||t^d||^2 = alpha^2 (P - Q) A:A and
  sigma^d = alpha (P - Q) A, i.e. the shear modulus mu_d = 15 mu (P - Q) / (2 m) and
  sigma_vm^2 = 3 (P - Q) ||t^d||^2 / 2.

Continuum (full sphere, m_c = 4 pi delta^5 / 5, P - Q = 2 m_c / 15): mu_d = mu and, with
Y = 25 sigma_y^2 / (8 pi delta^5), yield at sigma_vm = sigma_y exactly (Mitchell's calibration).

* Perfect plasticity: the stress plateaus at sigma_y (continuum), at sigma_y sqrt(15 (P - Q) /
  (2 m_c)) on the lattice; ||t^d|| = sqrt(2 Y) at every plastic step.
* Hardening (shear correction off): ||t^d||^2 / 2 = Y + H lambda at every plastic step, hence
  sigma_vm^2 = 3 (P - Q)(Y + H lambda) (continuum 3 (P-Q) = 8 pi delta^5 / 25). With
  d eps^p = alpha d lambda A (flow along t^d), the uniaxial plastic strain is
  eps^p = 4 (sigma^3 - sigma_0^3) / (27 (P - Q)^2 H), i.e. the hardening is linear in lambda but
  not in the stress: the slope after yield is d sigma / d eps = E h / (E + h) with
  h(sigma) = 9 (P - Q)^2 H / (4 sigma^2) (continuum: 16 pi^2 delta^10 H / (625 sigma^2)).

Measured on this lattice (delta = 3.015 h): (P - Q) / (2 m_c / 15) = 0.9439, m / m_c = 1.1307, so
mu_d = 0.835 mu and the perfect-plasticity plateau is 0.9715 sigma_y: the lattice quadrature,
not the model, is 2.85 % below the continuum. Tolerances: lattice closed forms 2e-4 (geometric
nonlinearity at strains <= 1e-4 measured 5e-5); continuum plateau 3.5 %.

Stable time step: Peridigm's estimate (SEM §6.1, K only) with Safety Factor 1. Plastic flow
only lowers the deviatoric stiffness (||t^d|| is capped), so the elastic estimate still bounds
the step; a run at the estimate stays bounded while three times the estimate blows up.
"""
import dataclasses
import math

import numba
import numpy as np
import pytest

from peridyn.core.errors import InstabilityError
from peridyn.materials.deviatoric import yield_value
from peridyn.solvers.explicit.verlet import Verlet, VerletSection
from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_section

H_SPACING = 1.0e-3
K, MU = 160.0e9, 80.0e9
SIGMA_Y = 2.0e6  # yield strain ~1e-5: the geometric nonlinearity stays ~1e-5
EP = {"Material Model": "Elastic Plastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU, "Yield Stress": SIGMA_Y}


@pytest.fixture(autouse=True)
def _threads():
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


class BulkPoint:
    """The centre point of a 7^3 lattice under prescribed homogeneous deformations."""

    def __init__(self, material: dict) -> None:
        numba.set_num_threads(1)  # one point at a time: parallel launches would dominate
        self.sim = build_simulation(cube_deck(material, n=7, spacing=H_SPACING))
        s, nl = self.sim.fields, self.sim.bonds
        self.x = s["Model_Coordinates"]
        self.c = c = int(np.argmin(np.linalg.norm(self.x - self.x.mean(axis=0), axis=1)))
        blk = self.sim.blocks[0]
        self.material = blk.material
        self.view = dataclasses.replace(blk.view, start=c, stop=c + 1)
        self.delta = blk.horizon
        self.b = np.arange(nl.offsets[c], nl.offsets[c + 1])
        self.j = nl.neighbors[self.b]
        self.xi = self.x[self.j] - self.x[c]
        zeta = np.linalg.norm(self.xi, axis=1)
        M = self.xi / zeta[:, None]
        self.V = s["Volume"][self.j]
        assert np.all(np.linalg.norm(self.x[c] - self.x, axis=1)[np.linalg.norm(self.x[c] - self.x, axis=1) <= self.delta].size - 1 == self.b.size)
        self.P = float(np.sum(zeta**2 * M[:, 0] ** 4 * self.V))
        self.Q = float(np.sum(zeta**2 * M[:, 0] ** 2 * M[:, 1] ** 2 * self.V))
        self.m = float(np.sum(zeta**2 * self.V))
        self.m_c = 4.0 * math.pi * self.delta**5 / 5.0
        self.t = np.zeros(nl.num_bonds)
        self.lat = 0.0

    @property
    def mu_d(self) -> float:
        return 15.0 * MU * (self.P - self.Q) / (2.0 * self.m)

    @property
    def E_d(self) -> float:
        return 9.0 * K * self.mu_d / (3.0 * K + self.mu_d)

    def stress(self, F: np.ndarray) -> np.ndarray:
        s = self.sim.fields
        s["Coordinates"][:] = self.x @ F.T
        self.material.precompute(self.view)
        self.material.force_state(self.view, self.t)
        eta = s["Coordinates"][self.j] - s["Coordinates"][self.c]
        L = np.linalg.norm(eta, axis=1)
        return np.einsum("b,bi,bj->ij", self.t[self.b] * self.V / L, eta, self.xi)

    def uniaxial(self, eps: float) -> np.ndarray:
        """sigma at axial strain eps with sigma_yy = sigma_zz = 0 (Newton on the lateral strain)."""
        k = None
        for _ in range(30):
            S = self.stress(np.diag([1 + eps, 1 + self.lat, 1 + self.lat]))
            if abs(S[1, 1]) <= 1e-9 * abs(S[0, 0]):
                break
            if k is None:
                d = 1e-9
                k = (self.stress(np.diag([1 + eps, 1 + self.lat + d, 1 + self.lat + d]))[1, 1] - S[1, 1]) / d
            self.lat -= S[1, 1] / k
        assert abs(S[1, 1]) <= 1e-6 * abs(S[0, 0]) and abs(S[2, 2]) <= 1e-6 * abs(S[0, 0])  # round-off of y = F x
        return S

    def deviatoric_norm(self) -> float:
        """||t^d|| of the centre point (omega = 1, no damage) from the force state just computed."""
        s = self.sim.fields
        zeta = s["Bond_Length"][self.b]
        td = self.t[self.b] - 3.0 * K * s["Dilatation"][self.c] / s["Weighted_Volume"][self.c] * zeta
        return math.sqrt(float(np.sum(td**2 * self.V)))

    def lam(self) -> float:
        return float(self.sim.fields["Lambda"][self.c])

    def advance(self) -> None:
        self.sim.advance()


def test_perfect_plasticity_uniaxial_stress_plateaus_at_the_yield_stress():
    pt = BulkPoint(EP)
    Y = yield_value(SIGMA_Y, pt.delta)
    plateau = SIGMA_Y * math.sqrt(15.0 * (pt.P - pt.Q) / (2.0 * pt.m_c))
    assert plateau / SIGMA_Y == pytest.approx(0.9715, abs=1e-4)  # the lattice's quadrature of the yield condition
    elastic = plastic = 0
    for k in range(1, 61):
        eps = k * 2.0e-6 / 3.0 * 2.5
        S = pt.uniaxial(eps)
        if pt.lam() == 0.0:
            assert S[0, 0] == pytest.approx(pt.E_d * eps, rel=2e-4)
            elastic += 1
        else:
            assert S[0, 0] == pytest.approx(plateau, rel=2e-4)
            assert abs(S[0, 0] / SIGMA_Y - 1.0) < 0.035
            assert pt.deviatoric_norm() == pytest.approx(math.sqrt(2.0 * Y), rel=1e-10)
            plastic += 1
        pt.advance()
    assert elastic >= 5 and plastic >= 40
    # plastic flow is isochoric: eps_lat = -nu sigma / E - (eps - sigma / E) / 2
    nu_d = (3.0 * K - 2.0 * pt.mu_d) / (2.0 * (3.0 * K + pt.mu_d))
    assert pt.lat == pytest.approx(-nu_d * S[0, 0] / pt.E_d - 0.5 * (eps - S[0, 0] / pt.E_d), rel=2e-4)
    # unloading is elastic, with the elastic modulus
    S1 = pt.uniaxial(eps - 2.0e-6)
    assert pt.lam() == pytest.approx(pt.sim.fields.n("Lambda")[pt.c], abs=0)
    assert (S[0, 0] - S1[0, 0]) / 2.0e-6 == pytest.approx(pt.E_d, rel=2e-4)


def test_hardening_uniaxial_stress_follows_the_closed_form():
    pt0 = BulkPoint(EP)
    PQ = pt0.P - pt0.Q
    E_d = pt0.E_d
    h_y = 0.25 * E_d  # hardening modulus at first yield: a quarter of E
    sigma0 = math.sqrt(3.0 * PQ * yield_value(SIGMA_Y, pt0.delta))  # lattice yield stress
    H = h_y * 4.0 * sigma0**2 / (9.0 * PQ**2)
    # the same H in continuum terms: h(sigma) = 16 pi^2 delta^10 H / (625 sigma^2)
    h_c = 16.0 * math.pi**2 * pt0.delta**10 * H / (625.0 * SIGMA_Y**2)
    assert h_c / h_y == pytest.approx((2.0 * pt0.m_c / 15.0 / PQ) ** 2 * (sigma0 / SIGMA_Y) ** 2, rel=1e-12)
    pt = BulkPoint({**EP, "Material Model": "Elastic Plastic Hardening", "Hardening Modulus": H, "Apply Shear Correction Factor": False})
    Y = yield_value(SIGMA_Y, pt.delta)
    de = 1.0e-7
    prev = None
    slopes = []
    for k in range(1, 401):
        eps = k * de
        S = pt.uniaxial(eps)
        sig = S[0, 0]
        if pt.lam() > 0.0:
            # the state is on the hardened yield surface
            assert pt.deviatoric_norm() ** 2 / 2.0 == pytest.approx(Y + H * pt.lam(), rel=1e-9)
            assert sig**2 == pytest.approx(3.0 * PQ * (Y + H * pt.lam()), rel=2e-4)
            if prev is not None and prev[1] > 0.0:
                mid = 0.5 * (sig + prev[0])
                h = 9.0 * PQ**2 * H / (4.0 * mid**2)
                slopes.append(((sig - prev[0]) / de, E_d * h / (E_d + h)))
        else:
            assert sig == pytest.approx(E_d * eps, rel=2e-4)
        prev = (sig, pt.lam())
        pt.advance()
    assert len(slopes) > 250
    measured, expected = np.array(slopes).T
    np.testing.assert_allclose(measured, expected, rtol=2e-3)
    # the whole curve: eps = sigma / E + 4 (sigma^3 - sigma0^3) / (27 (P-Q)^2 H)
    eps_closed = sig / E_d + 4.0 * (sig**3 - sigma0**3) / (27.0 * PQ**2 * H)
    assert eps_closed == pytest.approx(eps, rel=1e-3)
    assert sig > 1.3 * sigma0  # it did harden


@pytest.mark.parametrize(
    "material",
    [EP, {**EP, "Material Model": "Elastic Plastic Hardening", "Hardening Modulus": 1.0e55}],
    ids=["perfect", "hardening"],
)
def test_explicit_run_at_the_stable_time_step_stays_bounded(material):
    def run(factor, steps):
        sim = build_simulation(cube_deck({**material, "Yield Stress": 2.0e8}, n=6, spacing=H_SPACING))
        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][:] = 20.0 * np.sin(np.pi * x[:, [1, 2, 0]] / 6e-3)  # strains ~1e-4 x 20: yields
        ke0 = sim.kinetic_energy()
        dt = factor * sim.critical_time_step()
        section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": steps * dt * (1 + 1e-9), "Verlet": {"Safety Factor": factor}})
        run_section(sim, Verlet(section))
        return sim, ke0

    sim, ke0 = run(1.0, 400)
    assert sim.stats["solvers"][-1]["steps"] == 400
    assert np.isfinite(sim.fields["Displacement"]).all()
    assert sim.kinetic_energy() <= 1.02 * ke0  # no stored energy at t = 0, and plasticity dissipates
    assert (sim.fields["Lambda"] > 0).any()
    with pytest.raises(InstabilityError):
        run(3.0, 400)
