"""``lame-sphere``: correspondence near nu = 0.5 beside LPS against Lamé's pressurised sphere."""
import numpy as np

from peridyn.verify.problems import sphere
from peridyn.verify.problems.lattice import lattice_stiffness
from peridyn.verify.problems.sphere import LameSphere


def test_the_closed_form_is_the_pressurised_sphere():
    a, b, nu = 1.0, 3.0, 0.49
    r = np.array([a, 2.0, b])
    ur, dudr, srr, stt, A = sphere.lame_sphere(r, a, b, nu)
    assert np.allclose(srr[[0, 2]], [-sphere.PRESSURE, 0.0], atol=1e-12 * sphere.PRESSURE)
    # Hooke's law of the displacement: sigma_rr = lambda tr(eps) + 2 G du/dr, sigma_tt = lambda tr(eps) + 2 G u/r
    lam = sphere.lame_bulk_modulus(nu) - 2.0 * sphere.G / 3.0
    eps = 1e-6
    fd = (sphere.lame_sphere(r + eps, a, b, nu)[0] - sphere.lame_sphere(r - eps, a, b, nu)[0]) / (2 * eps)
    assert np.allclose(fd, dudr, rtol=1e-6)
    tr = dudr + 2.0 * ur / r
    assert np.allclose(lam * tr + 2.0 * sphere.G * dudr, srr, rtol=1e-6, atol=1e-9 * sphere.PRESSURE)
    assert np.allclose(lam * tr + 2.0 * sphere.G * ur / r, stt, rtol=1e-6)
    assert np.allclose((srr + 2.0 * stt) / 3.0, A)


def test_the_bond_sum_energy_of_a_homogeneous_strain_is_the_lattice_constants_energy():
    g = (np.arange(-4, 5) + 0.5) * sphere.H
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    eps = 1e-7 * np.array([[1.0, 0.3, -0.2], [0.3, -0.5, 0.4], [-0.2, 0.4, 0.7]])
    inner = np.all(np.abs(x) < 2.0 * sphere.H, axis=1)  # a whole family inside
    K = 3.0 * sphere.G  # 3K != 5G: the dilatation term counts
    w = sphere.lps_energy(x, x @ eps, inner, K)
    v = np.array([eps[0, 0], eps[1, 1], eps[2, 2], 2 * eps[1, 2], 2 * eps[0, 2], 2 * eps[0, 1]])
    expected = 0.5 * v @ lattice_stiffness("Elastic", K, sphere.G, sphere.RATIO) @ v
    assert np.allclose(w, expected, rtol=1e-6)


def points(m):
    return [{"resolution": 6.0, "error": m.error, "size": m.size, "values": m.values}]


def test_correspondence_meets_lame_at_nu_049_and_a_bulk_modulus_5_percent_high_fails_the_mean_stress(monkeypatch):
    problem = LameSphere()
    method = problem.methods[0]
    m = problem.measure(method, 6.0, True)
    checks = problem.checks(method, points(m), True)
    assert len(checks) == 3 and all(c.passed for c in checks), [(c.what, c.value) for c in checks]
    bulk = sphere.bulk_modulus
    monkeypatch.setattr(sphere, "bulk_modulus", lambda nu: 1.05 * bulk(nu))  # the model's K only: Lamé's field keeps nu
    m = problem.measure(method, 6.0, True)
    failed = [c.what for c in problem.checks(method, points(m), True) if not c.passed]
    assert len(failed) == 1 and failed[0].startswith("mean stress"), failed


def test_lps_meets_lame_and_a_shear_modulus_5_percent_high_fails_the_energy(monkeypatch):
    problem = LameSphere()
    method = "Elastic, nu = 0.49"
    m = problem.measure(method, 6.0, True)
    checks = problem.checks(method, points(m), True)
    assert len(checks) == 3 and all(c.passed for c in checks), [(c.what, c.value) for c in checks]
    monkeypatch.setattr(sphere, "shear_modulus", lambda: 1.05 * sphere.G)  # the model's G only
    m = problem.measure(method, 6.0, True)
    failed = [c.what for c in problem.checks(method, points(m), True) if not c.passed]
    assert len(failed) == 1 and failed[0].startswith("stored energy density"), failed


def test_the_mean_stress_and_dilatation_at_nu_0499_are_known_misses_not_failures():
    problem = LameSphere()
    fake = {"Elastic Correspondence, nu = 0.499": {"deviator / Lame": 1.0, "mean stress / Lame": -0.2},
            "Elastic, nu = 0.499": {"dilatation / Lame": -0.08, "energy density / bond-sum Lame": 1.0}}
    for method, values in fake.items():
        checks = problem.checks(method, [{"resolution": 6.0, "error": 0.01, "size": 1 / 6, "values": values}], True)
        failed = [c for c in checks if not c.passed]
        assert len(checks) == 3 and len(failed) == 1 and failed[0].known and not any(c.counts for c in checks)
