"""``density-contrast``: bonded blocks of densities 1e4 apart against the two-segment bar's closed form."""
import math

import numpy as np

from peridyn.engine.simulation import Simulation
from peridyn.verify.problems import contrast
from peridyn.verify.problems.contrast import Chain, DensityContrast, continuum_omega


def test_the_closed_form_tends_to_the_spring_and_mass_as_the_block_gets_short():
    E, L1 = contrast.lattice_modulus(), 0.05
    m_bar = contrast.RHO * L1
    off = []
    for L2 in (1e-3, 1e-4):
        m_block = contrast.CONTRAST * contrast.RHO * L2
        # Rayleigh: a spring of stiffness E / L1 carrying the rigid block and a third of the bar
        off.append(continuum_omega(L1, L2) / math.sqrt(E / L1 / (m_block + m_bar / 3.0)) - 1.0)
    assert -1e-3 < off[1] < 0.0 and 8.0 < off[0] / off[1] < 12.0  # the block's own compliance, first order in L2 / L1


def test_the_chains_verlet_sequence_starts_at_the_initial_velocity_and_tends_to_the_continuous_motion():
    ref = Chain(16, contrast.HEAVY)
    v = ref.verlet(1e-7, 10)
    assert math.isclose(v[0], contrast.V0, rel_tol=1e-12)
    t = ref.quarter()
    assert abs(math.pi / 2 / t / ref.fundamental - 1.0) < 1e-3


def measured(problem, n):
    m = problem.measure(problem.methods[0], n, True)
    return [{"resolution": float(n), "error": m.error, "size": m.size, "values": m.values}]


def test_the_run_follows_the_exact_chain_and_a_heavy_block_10_percent_light_fails(monkeypatch):
    problem = DensityContrast()
    points = measured(problem, 16)
    checks = [c for c in problem.checks(problem.methods[0], points, True) if "finest" not in c.what]  # 1 % from N = 64 on
    assert len(checks) == 2 and all(c.passed for c in checks), [(c.what, c.value) for c in checks]
    assert points[0]["values"]["max |v - v_Verlet exact| / V0"] < 1e-8
    density = Simulation.density_per_point

    def lighter(self):
        rho = np.array(density(self))
        return np.where(rho > contrast.RHO, 0.9 * rho, rho)  # the heavy block's density 10 % low

    monkeypatch.setattr(Simulation, "density_per_point", lighter)
    points = measured(problem, 16)
    failed = {c.what.split(" at ")[0] for c in problem.checks(problem.methods[0], points, True) if not c.passed and "finest" not in c.what}
    assert len(failed) == 2, failed  # the closed form's band and the exact sequence
